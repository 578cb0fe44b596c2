//! The EMG-driven Hill-type triceps-surae model, its optional effects, trial simulation, the
//! identification problem and the sensitivity sweep (all described in `docs/model.md`).
//!
//! Per muscle `j ∈ {sol, gm, gl}` the state is `[a, F̃T, LM, LMT]` (plus `∫â dt`, used only by
//! the `fatigue` effect):
//!
//! ```text
//! ȧ    = (u − a)(k1·u + k2),             k2 = 1/τdeact, k1 = 1/τact − 1/τdeact
//! â    = f_A(a)                           (Manal–Buchanan A-model)
//! sin α = LOM·sin α0 / LM                  (α ≤ 84°)
//! F̃T/cos α = â·fl(LM/LOM)·fv(ṽ) + fpe(LM/LOM) + β·ṽ      → ṽ (unique, closed form)
//! L̇M   = vM = ṽ·vmax,                     vmax = 10·LOM /s
//! L̇MT  = vMT = r(q)·q̇,                    r = dLMT/dq, LMT(q) cubic (gait2392)
//! dF̃T/dt = fT'(ε)/LST · (vMT − vM/cos α),  ε = (LMT − LM·cos α − LST)/LST
//! τ    = Σ_j F̃T_j·F0_j·r_j(q)             (+ effects)
//! ```
//!
//! Each muscle is integrated on its own with Dormand–Prince 5(4), with dense output at the
//! sample times. By default ([`Formulation::Fast`]) `a`, `â`, the fatigue factor and
//! `LMT(q)` are computed once per trial at the samples (they do not depend on LST, F0, α0)
//! and only `LM` is integrated; `F̃T = fT(ε)` comes from the invariant. A [`Workspace`] keeps
//! each muscle's result for its two latest parameter sets, so a move of one muscle's
//! parameters integrates one muscle and a move of `F0` alone integrates none.
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

pub mod activation;
pub mod curves;
pub mod effects;
pub mod error;
mod fast_simulation;
pub mod geometry;
pub mod inputs;
mod joint_effects;
pub mod likelihood;
mod muscle_torque;
pub mod musculotendon;
pub mod noise;
pub mod params;
mod path;
pub mod problem;
pub mod sensitivity;
pub mod settings;
pub mod simulate;
pub mod stats;
pub mod synthetic;
pub mod workspace;

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
pub use sensitivity::{
    sensitivity, SensitivityRank, SensitivityRow, SensitivitySettings, SensitivityTable,
};
pub use settings::{Formulation, SimSettings};
pub use simulate::{simulate, simulate_into, MuscleOutput, SimOutput};
pub use stats::SimStats;
pub use workspace::Workspace;
