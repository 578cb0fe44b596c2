//! The EMG-driven Hill-type triceps-surae model, its optional effects, trial simulation, the
//! identification problem and the sensitivity sweep (all described in `docs/model.md`).
//!
//! The model's muscles are sol, gm and gl (identified) and any further muscles crossing the
//! ankle with fixed parameters ([`ModelParams::fixed`], e.g. a tibialis anterior `ta`), each
//! driven by its own envelope channel. Per muscle `j` the state is `[a, F̃T, LM, LMT]` (plus
//! `∫â dt`, used only by the `fatigue` effect):
//!
//! ```text
//! ȧ    = (u − a)(k1·u + k2),             k2 = 1/τdeact, k1 = 1/τact − 1/τdeact
//! â    = f_A(a)                           (Manal–Buchanan A-model)
//! sin α = LOM·sin α0 / LM                  (α ≤ 84°)
//! F̃T/cos α = â·fl(LM/LOM)·fv(ṽ) + fpe(LM/LOM) + β·ṽ      → ṽ (unique, closed form)
//! L̇M   = vM = ṽ·vmax,                     vmax = 10·LOM /s
//! LMT  = P(q) − r_knee·k,                 P cubic (gait2392), k = knee flexion
//! L̇MT  = vMT = r(q)·q̇ − r_knee·k̇,         r = dP/dq (the ankle moment arm)
//! dF̃T/dt = fT'(ε)/LST · (vMT − vM/cos α),  ε = (LMT − LM·cos α − LST)/LST
//! τ    = Σ_j F̃T_j·F0_j·r_j                (+ effects; r_j < 0 for a dorsiflexor)
//! ```
//!
//! A trial may instead give a muscle's `LMT(t)` and `r(t)` as series
//! ([`TrialInputs::with_geometry`]), interpolated linearly in time; the polynomial and the
//! knee term are then unused for it. The knee angle comes with the trial
//! ([`TrialInputs::with_knee_angle`]; without it the knee is extended).
//!
//! Each muscle is integrated on its own with Dormand–Prince 5(4), with dense output at the
//! sample times. By default ([`Formulation::Fast`]) `a`, `â`, the fatigue factor and
//! `LMT(t)` are computed once per trial at the samples (they do not depend on LST, F0, α0)
//! and only `LM` is integrated; `F̃T = fT(ε)` comes from the invariant. A [`Workspace`] keeps
//! each muscle's result for its two latest parameter sets, so a move of one muscle's
//! parameters integrates one muscle and a move of `F0` alone integrates none; the fixed
//! muscles' torque is kept for as long as their inputs do not change.
//! [`Formulation::Reduced`] integrates `a` and `LM` (used by [`SimSettings::tight`]);
//! [`Formulation::FourState`] integrates the four states above as written. The initial state is
//! the static equilibrium (`ṽ = 0`) at `a = u(0)`.
//!
//! ```
//! use muscle_model::{simulate, synthetic, Effects, ModelParams, SimSettings};
//!
//! let trial = synthetic::seed_like_trial(512.0).unwrap();
//! let params = ModelParams::from_json_str(r#"{"muscles": {"sol": {"lst_m": 0.255}}}"#).unwrap();
//! let effects = Effects::from_json_str(r#"{"torque_offset": {"offset_nm": -1.5}}"#).unwrap();
//! let out = simulate(&trial, &params, &effects, &SimSettings::default()).unwrap();
//! assert_eq!(out.torque.len(), trial.len());
//! let peak = out.torque.iter().cloned().fold(f64::MIN, f64::max);
//! assert!(peak > 50.0 && peak < 400.0, "peak plantarflexion torque {peak}");
//! ```
//!
//! A model of four muscles: the triceps surae and a tibialis anterior with fixed (nominal)
//! parameters, driven by its own envelope, on a trial with the knee flexed to 30°:
//!
//! ```
//! use muscle_model::{simulate, Effects, ModelParams, MuscleParams, SimSettings, TrialInputs};
//!
//! let n = 1000; // 1 s at 1 kHz
//! let fs = 1000.0;
//! let angle: Vec<f64> = (0..n).map(|i| (10.0 * (i as f64 / fs)).to_radians()).collect();
//! let drive = |level: f64| -> Vec<f64> {
//!     (0..n).map(|i| if i > 200 && i < 700 { level } else { 0.02 }).collect()
//! };
//! let ta_envelope: Vec<f64> = (0..n).map(|i| if i > 400 { 0.5 } else { 0.05 }).collect();
//! let trial = TrialInputs::new(fs, 0.0, angle, [drive(0.8), drive(0.7), drive(0.6)], None)
//!     .unwrap()
//!     .with_envelope("ta", ta_envelope)
//!     .unwrap()
//!     .with_knee_angle(vec![30f64.to_radians(); n])
//!     .unwrap();
//!
//! let mut params = ModelParams::nominal();
//! params.fixed.insert("ta", MuscleParams::nominal_ta()).unwrap();
//! let out = simulate(&trial, &params, &Effects::none(), &SimSettings::default()).unwrap();
//!
//! let names: Vec<&str> = out.muscles.iter().map(|m| m.name).collect();
//! assert_eq!(names, ["sol", "gm", "gl", "ta"]);
//! let ta = out.muscle_named("ta").unwrap();
//! // a dorsiflexor: its torque is negative, and it is part of the joint torque
//! assert!(ta.torque[900] < -5.0);
//! let triceps: f64 = out.muscles[..3].iter().map(|m| m.torque[900]).sum();
//! assert!((out.torque[900] - (triceps + ta.torque[900])).abs() < 1e-9);
//! ```
//!
//! The same model from a parameters JSON: a muscle other than sol, gm and gl is a fixed one,
//! e.g. `{"muscles": {"ta": {"fom_n": 905, "lom_m": 0.098, "lst_m": 0.223, "alpha_deg": 5,
//! "lmt_poly_m": [0.321, -0.036, 0.003, 0]}}}`; without `lmt_poly_m` its geometry must come
//! with each trial as series.

pub mod activation;
pub mod curves;
pub mod derivatives;
pub mod effects;
pub mod error;
mod fast_simulation;
pub mod geometry;
pub mod inputs;
mod interp;
mod joint_effects;
pub mod likelihood;
mod muscle_torque;
pub mod musculotendon;
pub mod noise;
pub mod params;
mod path;
pub mod problem;
pub mod problem_set;
pub mod sensitivity;
pub mod settings;
pub mod simulate;
pub mod stats;
pub mod synthetic;
pub mod workspace;

pub use derivatives::{exact_derivative_available, exact_torque_jacobian};
pub use effects::{EffectKind, Effects, ParamSpec};
pub use error::ModelError;
pub use inputs::{GeometrySeries, TrialInputs};
pub use likelihood::{Ar1Gaussian, GaussianIid, NoiseLikelihood};
pub use musculotendon::{MuscleUnit, STATE_DIM};
pub use noise::{Ar1White, MomentFit, WhitenPlan};
pub use params::{
    ActivationParams, CurveParams, FixedMuscle, FixedMuscles, ModelParams, Muscle, MuscleParams,
};
pub use problem::{MuscleField, ParamId, Problem, ProblemWorkspace};
pub use problem_set::{ProblemSet, ProblemSetWorkspace};
pub use sensitivity::{
    sensitivity, SensitivityRank, SensitivityRow, SensitivitySettings, SensitivityTable,
};
pub use settings::{Formulation, SimSettings};
pub use simulate::{simulate, simulate_into, MuscleOutput, SimOutput};
pub use stats::SimStats;
pub use workspace::Workspace;
