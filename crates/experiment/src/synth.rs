//! A complete synthetic experiment in memory (docs/formats.md, "Synthetic trials"): trial with "measured" torque, unloaded run, truth.
//!
//! [`synthesize`] does what `cargo xtask gen-fixtures` writes to disk, and what the
//! identification and diagnosis tests use to make trials with known (random) parameters:
//!
//! 1. sample the protocol ([`Protocol::trace`]);
//! 2. synthesise raw EMG ([`synthetic_emg_at_knee`] at the configured knee angle, which lowers
//!    the gastrocnemii's drive when the knee is flexed; `emg_ta` too when the effects need it
//!    or the true model has a fixed muscle `ta`, which that channel then drives);
//! 3. round every raw EMG sample to `emg_decimals` decimals (`k / 10^d`, so the file holds
//!    at most `d` decimals: short lines, small fixtures; the default 4 decimals = 1e-4 in the
//!    EMG unit, a rounding noise of 3e-5 RMS against a rest-level RMS of 3e-3 to 1e-2, which
//!    changes the normalised envelopes by well under 1 %) and the angle to `angle_decimals` decimals of a
//!    degree (7: 1e-7°);
//! 4. build the [`Trial`] (torque zeros; a `knee_angle_deg` column holding the knee angle when
//!    it is not 0) and turn it into model inputs with
//!    [`model_inputs`], so the truth is computed from exactly what a user's program reads;
//! 5. simulate the true parameters and effects ([`muscle_model::simulate()`]);
//! 6. add the dynamometer error ([`dynamometer_error`], [`Recording::Trial`] streams of the
//!    seed) and quantise with the 12-bit ADC: the trial's torque;
//! 7. the unloaded run: [`crate::unloaded_run`] at the trial's speed ([`unloaded_run_with`]) with
//!    the same seed (independent noise streams).
//!
//! Everything is sequential and seeded: the result depends only on the configuration.
//!
//! ```
//! use experiment::{random_params, synthesize, Protocol, SynthConfig};
//! use muscle_model::ModelParams;
//! use rand::SeedableRng;
//!
//! let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(1);
//! let truth = random_params(&mut rng, &ModelParams::nominal());
//! let syn = synthesize(&SynthConfig::new(Protocol::Seed, 42).with_params(truth))?;
//! let residual: Vec<f64> = syn.trial.torque_nm.iter().zip(&syn.model_torque)
//!     .map(|(m, t)| m - t).collect();
//! let mean = residual.iter().sum::<f64>() / residual.len() as f64;
//! assert!(mean > -4.0 && mean < 1.0); // the −1.5 N·m dynamometer offset
//! assert_eq!(syn.truth_json["seed"], 42);
//! # Ok::<(), experiment::ExperimentError>(())
//! ```

use muscle_model::{simulate, Effects, ModelParams, ParamId, SimSettings, TrialInputs};
use rand::Rng;
use serde_json::{json, Map, Value};

use crate::dynamometer::{
    dynamometer_error, quantise_in_place, unloaded_run_with, DynamometerSettings, Recording,
};
use crate::emg::{synthetic_emg_at_knee, EmgSettings};
use crate::error::{ErrorKind, ExperimentError, Result};
use crate::files::{Trial, Unloaded};
use crate::model_inputs::{model_inputs, model_inputs_referenced, EmgReferences, InputOptions};
use crate::protocol::{Protocol, ProtocolTrace, SynthProtocol, NOMINAL_SPEED_DEG_S};

/// Decimals of the raw EMG columns written by the synthesis (1e-4 in the EMG unit).
pub const DEFAULT_EMG_DECIMALS: u32 = 4;
/// Decimals of a degree of the angle column written by the synthesis (1e-7°).
pub const DEFAULT_ANGLE_DECIMALS: u32 = 7;

/// Everything that defines a synthetic experiment.
#[derive(Clone, Debug, PartialEq)]
pub struct SynthConfig {
    /// The protocol of the trial (the unloaded run is always [`Protocol::unloaded`]).
    pub protocol: Protocol,
    /// Knee flexion throughout the trial (degrees; 0 extended). When it is not 0 the trial has
    /// a `knee_angle_deg` column and the gastrocnemii's drive is lowered
    /// ([`crate::gastrocnemius_drive_factor`]).
    pub knee_angle_deg: f64,
    /// Cruise speed of the sweeps (°/s; 30 nominal). The unloaded run moves at the same speed.
    pub speed_deg_s: f64,
    /// The true model parameters. Besides sol, gm and gl they may hold one fixed muscle, `ta`
    /// (with its length polynomial), driven by the synthetic `emg_ta`.
    pub params: ModelParams,
    /// The true model extensions (docs/formats.md, "Effects JSON").
    pub effects: Effects,
    /// The dynamometer error (docs/dynamometer.md).
    pub dynamometer: DynamometerSettings,
    /// The synthetic EMG. `include_ta` is forced on when `antagonist_coactivation` is present.
    pub emg: EmgSettings,
    /// The seed of every random part (EMG carriers and wobble, dynamometer noise).
    pub seed: u64,
    /// Raw EMG is rounded to this many decimals (in its own unit). At most 15.
    pub emg_decimals: u32,
    /// The angle is rounded to this many decimals of a degree. At most 15.
    pub angle_decimals: u32,
    /// Integration settings of the true simulation.
    pub sim: SimSettings,
}

impl SynthConfig {
    /// Nominal parameters, no effect, nominal dynamometer error, default EMG, default rounding,
    /// [`SimSettings::tight`] (the "true" torque is the model solved to rtol 1e-10, so it does
    /// not move when the fast default integration settings are tuned).
    #[must_use]
    pub fn new(protocol: Protocol, seed: u64) -> Self {
        Self {
            protocol,
            knee_angle_deg: 0.0,
            speed_deg_s: NOMINAL_SPEED_DEG_S,
            params: ModelParams::nominal(),
            effects: Effects::none(),
            dynamometer: DynamometerSettings::default(),
            emg: EmgSettings::default(),
            seed,
            emg_decimals: DEFAULT_EMG_DECIMALS,
            angle_decimals: DEFAULT_ANGLE_DECIMALS,
            sim: SimSettings::tight(),
        }
    }

    /// A configuration for a protocol with its knee angle and speed (otherwise as
    /// [`SynthConfig::new`]).
    #[must_use]
    pub fn for_protocol(protocol: SynthProtocol, seed: u64) -> Self {
        let mut cfg =
            Self::new(protocol.protocol, seed).with_knee_angle_deg(protocol.knee_angle_deg);
        cfg.speed_deg_s = protocol.speed_deg_s;
        cfg
    }

    /// The same configuration with the knee flexed by `deg` degrees throughout.
    #[must_use]
    pub fn with_knee_angle_deg(mut self, deg: f64) -> Self {
        self.knee_angle_deg = deg;
        self
    }

    /// The protocol with its knee angle (`knee90`, `relaxed+2@knee90`, or the bare protocol for
    /// the extended knee; `knee0@60` at another speed).
    #[must_use]
    pub fn synth_protocol(&self) -> SynthProtocol {
        SynthProtocol {
            protocol: self.protocol,
            knee_angle_deg: self.knee_angle_deg,
            speed_deg_s: self.speed_deg_s,
        }
    }

    /// The same configuration with other true parameters.
    #[must_use]
    pub fn with_params(mut self, params: ModelParams) -> Self {
        self.params = params;
        self
    }

    /// The same configuration with other true effects.
    #[must_use]
    pub fn with_effects(mut self, effects: Effects) -> Self {
        self.effects = effects;
        self
    }

    /// The EMG settings actually used: `include_ta` forced on when the effects need `emg_ta` or
    /// the true model has a fixed muscle `ta`.
    #[must_use]
    pub fn effective_emg(&self) -> EmgSettings {
        let mut e = self.emg;
        if needs_ta(&self.effects) || self.params.fixed.get("ta").is_some() {
            e.include_ta = true;
        }
        e
    }

    /// The truth as JSON (keys sorted at every level):
    /// `{"angle_decimals", "dynamometer", "effects", "emg", "emg_decimals", "params",
    /// "protocol", "seed", "sim"}` with `params` the full parameters JSON and
    /// `effects` the effects JSON (both in docs/formats.md); `"knee_angle_deg"` too when the
    /// knee is flexed (absent for the extended knee), and `"speed_deg_s"` when the speed is not
    /// the nominal 30 °/s.
    #[must_use]
    pub fn truth_json(&self) -> Value {
        let mut v = json!({
            "params": self.params.to_json_value(),
            "effects": self.effects.to_json_value(),
            "protocol": self.protocol.to_string(),
            "dynamometer": serde_json::to_value(self.dynamometer).unwrap_or(Value::Null),
            "emg": serde_json::to_value(self.effective_emg()).unwrap_or(Value::Null),
            "seed": self.seed,
            "emg_decimals": self.emg_decimals,
            "angle_decimals": self.angle_decimals,
            "sim": serde_json::to_value(self.sim).unwrap_or(Value::Null),
        });
        if self.knee_angle_deg != 0.0 {
            if let Value::Object(m) = &mut v {
                m.insert("knee_angle_deg".into(), json!(self.knee_angle_deg));
            }
        }
        if self.speed_deg_s != NOMINAL_SPEED_DEG_S {
            if let Value::Object(m) = &mut v {
                m.insert("speed_deg_s".into(), json!(self.speed_deg_s));
            }
        }
        sorted_json(&v)
    }
}

fn needs_ta(effects: &Effects) -> bool {
    effects.antagonist_coactivation.is_some()
}

/// A synthetic experiment.
#[derive(Clone, Debug, PartialEq)]
pub struct Synthetic {
    /// The trial: rounded raw EMG, rounded angle, measured (quantised) torque. No comments.
    pub trial: Trial,
    /// The unloaded run (3 cycles), quantised dynamometer error. No comments.
    pub unloaded: Unloaded,
    /// The noise-free torque of the true model on the trial's own inputs (N·m).
    pub model_torque: Vec<f64>,
    /// The model inputs of the trial (what [`model_inputs`] gives with default options).
    pub inputs: TrialInputs,
    /// [`SynthConfig::truth_json`].
    pub truth_json: Value,
}

/// `x` rounded to `d` decimals as `round(x·10^d)/10^d`: the nearest `f64` to a number with at
/// most `d` decimals, so it prints with at most `d` decimals.
#[must_use]
pub fn round_decimals(x: f64, d: u32) -> f64 {
    let s = 10f64.powi(d as i32);
    let r = (x * s).round() / s;
    if r == 0.0 {
        0.0 // no "-0" in the files
    } else {
        r
    }
}

/// Generates the experiment described by `cfg` (see the module documentation).
///
/// # Errors
/// Invalid protocol, EMG or dynamometer settings, more than 15 decimals, invalid parameters or
/// effects, or a failed simulation ([`ErrorKind::InvalidSettings`], naming the cause).
pub fn synthesize(cfg: &SynthConfig) -> Result<Synthetic> {
    let (trace, trial) = synthetic_recording(cfg)?;
    let inputs = model_inputs(&trial, &InputOptions::default())?;
    finish(cfg, &trace, trial, inputs)
}

/// [`synthesize`] with the EMG normalised by given references (one per channel, e.g. the
/// largest envelope over a session's trials, [`crate::synth_session`]) instead of the trial's
/// own maxima: the true torque is computed from the envelopes a session-wide normalisation
/// gives, so that identifying the session recovers the truth.
///
/// # Errors
/// As [`synthesize`]; a reference that is not finite and > 0.
pub fn synthesize_referenced(cfg: &SynthConfig, refs: &EmgReferences) -> Result<Synthetic> {
    let (trace, trial) = synthetic_recording(cfg)?;
    let inputs = model_inputs_referenced(&trial, &InputOptions::default(), refs, "<trial>")?;
    finish(cfg, &trace, trial, inputs)
}

/// The trial as recorded before its torque: protocol trace, rounded raw EMG and angle, knee
/// column (steps 1–4 of the module documentation; the torque is zeros).
///
/// # Errors
/// As [`synthesize`].
pub fn synthetic_recording(cfg: &SynthConfig) -> Result<(ProtocolTrace, Trial)> {
    if cfg.emg_decimals > 15 || cfg.angle_decimals > 15 {
        return Err(ExperimentError::invalid(
            "synthesis settings",
            ErrorKind::InvalidSettings,
            "emg_decimals and angle_decimals must be at most 15",
        ));
    }
    check_fixed_muscles(&cfg.params)?;
    let trace = cfg.synth_protocol().trace()?;
    let emg = synthetic_emg_at_knee(&trace, &cfg.effective_emg(), cfg.seed, cfg.knee_angle_deg)?;
    let mut emg = emg;
    for ch in &mut emg.channels {
        for x in &mut ch.raw {
            *x = round_decimals(*x, cfg.emg_decimals);
        }
    }
    let mut trial = emg.to_trial(&trace, vec![0.0; trace.len()])?;
    for a in &mut trial.ankle_angle_deg {
        *a = round_decimals(*a, cfg.angle_decimals);
    }
    if cfg.knee_angle_deg != 0.0 {
        trial.knee_angle_deg = Some(vec![cfg.knee_angle_deg; trial.len()]);
    }
    Ok((trace, trial))
}

/// Steps 5–7: the true torque on `inputs`, the dynamometer error, the unloaded run.
fn finish(
    cfg: &SynthConfig,
    trace: &ProtocolTrace,
    mut trial: Trial,
    inputs: TrialInputs,
) -> Result<Synthetic> {
    let out = simulate(&inputs, &cfg.params, &cfg.effects, &cfg.sim).map_err(|e| {
        ExperimentError::invalid(
            "true model",
            ErrorKind::InvalidSettings,
            format!("the simulation of the truth failed: {e}"),
        )
    })?;
    let model_torque = out.torque;
    let mut torque = dynamometer_error(trace, &cfg.dynamometer, cfg.seed, Recording::Trial)?;
    for (t, m) in torque.iter_mut().zip(&model_torque) {
        *t += m;
    }
    quantise_in_place(&mut torque, &cfg.dynamometer);
    trial.torque_nm = torque;
    trial.validate("<synthetic trial>")?;
    let mut unloaded =
        unloaded_run_with(&cfg.dynamometer, cfg.seed, &cfg.synth_protocol().motion())?;
    for a in &mut unloaded.ankle_angle_deg {
        *a = round_decimals(*a, cfg.angle_decimals);
    }
    Ok(Synthetic {
        trial,
        unloaded,
        model_torque,
        inputs,
        truth_json: cfg.truth_json(),
    })
}

/// The synthetic subject has EMG for sol, gm, gl and ta only, and a synthetic trial carries no
/// geometry series: a fixed muscle must be `ta` with a length polynomial.
fn check_fixed_muscles(params: &ModelParams) -> Result<()> {
    for f in params.fixed.iter() {
        let reason = if f.name != "ta" {
            format!(
                "fixed muscle '{}': the synthetic subject has EMG for sol, gm, gl and ta only",
                f.name
            )
        } else if f.params.geometry_from_trial() {
            "fixed muscle 'ta' needs its lmt_poly_m: a synthetic trial has no geometry series"
                .to_string()
        } else {
            continue;
        };
        return Err(ExperimentError::invalid(
            "true model",
            ErrorKind::InvalidSettings,
            reason,
        ));
    }
    Ok(())
}

/// Draws the 9 identified parameters (LST, F0, α0 of each muscle) uniformly inside
/// their bounds around `nominal` (LST ±5 %, F0 ±20 %, α0 ±20 %, the bounds of
/// [`ParamId::default_bounds`]); every other parameter is `nominal`'s.
pub fn random_params(rng: &mut impl Rng, nominal: &ModelParams) -> ModelParams {
    let mut p = *nominal;
    let mut effects = Effects::none();
    for id in ParamId::identified() {
        let (lo, hi) = id.default_bounds(nominal, &Effects::none());
        let u: f64 = rng.random();
        id.set(&mut p, &mut effects, lo + (hi - lo) * u);
    }
    p
}

/// A copy of `v` whose objects are rebuilt with their keys in sorted order, at every level
/// (stable output whether or not `serde_json` keeps insertion order).
#[must_use]
pub fn sorted_json(v: &Value) -> Value {
    match v {
        Value::Object(m) => {
            let mut keys: Vec<&String> = m.keys().collect();
            keys.sort();
            let mut out = Map::new();
            for k in keys {
                out.insert(k.clone(), sorted_json(&m[k]));
            }
            Value::Object(out)
        }
        Value::Array(a) => Value::Array(a.iter().map(sorted_json).collect()),
        other => other.clone(),
    }
}
