//! The defaults of a session recorded without a dynamometer (gait with inverse dynamics, CEINMS
//! trial folders): the parameters calibrated, their bounds and the starts, chosen on held-out
//! real recordings (docs/validation.md); and whether a session of recording maps is read as
//! envelopes.

use super::SessionManifest;
use crate::error::{AppError, AppResult};
use muscle_model::{Effects, ModelParams, ParamId};

/// Annealing chains of a calibration with the recording defaults: on CEINMS's four trials the
/// cost has two minima and one start in three reaches the better (docs/real-data.md).
pub const RECORDING_CHAINS: u32 = 8;

/// The parameters a recording without a dynamometer correction calibrates by default: LST, F0
/// and α0 of the triceps, the activation's shape `A` and one electromechanical delay (the
/// envelopes of a gait lab are already filtered, with a delay of their own).
pub fn recording_free() -> Vec<ParamId> {
    let mut free = ParamId::identified().to_vec();
    free.push(ParamId::parse("activation.shape_a").expect("a catalogued parameter"));
    free.push(ParamId::parse("electromechanical_delay.delay_ms").expect("a catalogued parameter"));
    free
}

/// The recording defaults' bounds around the base value `v`: LST ±10 % (a subject's tendon is
/// not the model's to within 5 %), F0 from 0.5 to 2.5 times (the specific tension of muscle
/// ranges over about a factor of five), α0 ±40 %, the shape `A` over [0, 0.12] (linear to
/// strongly curved) and the delay over 0–150 ms; any other parameter its default range.
pub fn recording_bounds(id: ParamId, params: &ModelParams, effects: &Effects) -> (f64, f64) {
    use muscle_model::MuscleField;
    let v = id.get(params, effects);
    match id {
        ParamId::Muscle(_, MuscleField::LstM) => (0.9 * v, 1.1 * v),
        ParamId::Muscle(_, MuscleField::FomN) => (0.5 * v, 2.5 * v),
        ParamId::Muscle(_, MuscleField::AlphaDeg) => (0.6 * v, 1.4 * v),
        ParamId::Activation(2) => (0.0, 0.12),
        ParamId::Effect(muscle_model::EffectKind::ElectromechanicalDelay, _) => (0.0, 150.0),
        _ => id.default_bounds(params, effects),
    }
}

/// Whether every trial of `manifest` is a recording map that says its EMG is envelopes already
/// (then the session reads every trial's EMG as envelopes, as `--emg-is-envelope` asks).
pub(super) fn maps_say_envelopes(manifest: &SessionManifest) -> AppResult<bool> {
    let mut all = !manifest.trials.is_empty();
    for t in &manifest.trials {
        let p = t.source.path();
        if p.is_dir() || recording::file_kind(p) != recording::FileKind::Map {
            return Ok(false);
        }
        all &= recording::read_map(p)
            .map_err(AppError::bad)?
            .emg_is_envelope;
    }
    Ok(all)
}
