//! The defaults of a session recorded without a dynamometer (gait with inverse dynamics, CEINMS
//! trial folders): the parameters calibrated, their bounds and the starts, chosen on held-out
//! real recordings (docs/validation.md); and whether a session of recording maps is read as
//! envelopes.

use super::SessionManifest;
use crate::error::{AppError, AppResult};
use identify_sa::SaIdentifySettings;
use muscle_model::{Effects, ModelParams, ParamId};

/// Annealing chains of a calibration with the recording defaults, before more are added: four
/// run two at a time on two cores.
pub const RECORDING_CHAINS: u32 = 4;

/// Chains added when the best two of the first [`RECORDING_CHAINS`] disagree by more than
/// [`CHAIN_AGREEMENT_REL`]: on CEINMS's four trials the cost has two minima and one start in
/// three reaches the better (docs/real-data.md), so a first batch that splits between them
/// gets four more starts.
pub const RECORDING_EXTRA_CHAINS: u32 = 4;

/// Relative difference of the best two chains' RMS errors below which they agree.
pub const CHAIN_AGREEMENT_REL: f64 = 0.01;

/// Annealing evaluations per chain with the recording defaults (the seed protocol's 6 000
/// searched a cost of 9 parameters on one dynamometer trial; a recording's search set of
/// strides, [`identify_sa::search_set`], is followed by a polish on every sample).
pub const RECORDING_CHAIN_EVALUATIONS: u64 = 3_000;

/// Moves per event of the initial-temperature search with the recording defaults (200 in the
/// seed protocol): the search then costs a tenth of a chain's evaluations, not a third.
pub const RECORDING_T0_EVENT_MOVES: u32 = 100;

/// `settings` with the recording defaults' annealing: [`RECORDING_CHAINS`] chains, four more
/// when the best two disagree, [`RECORDING_CHAIN_EVALUATIONS`] evaluations per chain and
/// [`RECORDING_T0_EVENT_MOVES`] moves per initial-temperature event.
pub fn recording_annealing(settings: SaIdentifySettings) -> SaIdentifySettings {
    let mut s = settings
        .with_chains(RECORDING_CHAINS)
        .with_extra_chains(RECORDING_EXTRA_CHAINS, CHAIN_AGREEMENT_REL)
        .with_chain_evaluations(RECORDING_CHAIN_EVALUATIONS);
    s.annealer.t0_event_moves = RECORDING_T0_EVENT_MOVES;
    s
}

/// The parameters a recording without a dynamometer correction calibrates by default: LST, F0
/// and α0 of the triceps, the activation's shape `A` and one electromechanical delay (the
/// envelopes of a gait lab are already filtered, with a delay of their own).
pub fn recording_free() -> Vec<ParamId> {
    let mut free = ParamId::identified().to_vec();
    free.push(ParamId::parse("activation.shape_a").expect("a catalogued parameter"));
    free.push(ParamId::parse("electromechanical_delay.delay_ms").expect("a catalogued parameter"));
    free
}

/// The recording defaults' bounds around the base value `v`, chosen by held-out prediction on
/// CEINMS's four trials and walk36 split by time (docs/real-data.md):
///
/// * LST ±10 % of `v` (±20 % predicted walk36's later strides better, 9.8 against 10.2 N·m,
///   and CEINMS's left-out trials much worse, 37.6 against 29.2 N·m);
/// * F0 from 0.5 to 10 times `reference_fom_n`, the muscle's force before a CEINMS strength
///   coefficient (else its own F0). F0 here is the force at an envelope of 1, the product of
///   the muscle's strength and its envelope's gain, and a lab's normalisation reference is
///   not the muscle's maximum: walk36's soleus envelope peaks at 0.14 in walking, and its
///   calibrations held F0 at an upper bound of 2.5 and of 5 times;
/// * α0 ±40 % (at least ±2°, never below 0°), the shape `A` over [0, 0.12] (linear to strongly curved) and the delay over
///   0–150 ms (a lab's envelopes are filtered with a delay of their own);
/// * when freed (`--free +curves.e0t`, `validate --extensions`): the tendon strain at F0 from
///   half to three times its value (0.02–0.12 from 0.04: an Achilles tendon stretches by up to
///   about a tenth at maximal force; a wider range let it trade with the delay and predict
///   CEINMS's left-out trials worse, 22.6 against 19.8 N·m), and the eccentric plateau `flen`
///   from 1 (none) to 1.2 times its value;
/// * any other parameter its default range.
pub fn recording_bounds(
    id: ParamId,
    params: &ModelParams,
    effects: &Effects,
    reference_fom_n: [f64; 3],
) -> (f64, f64) {
    use muscle_model::MuscleField;
    let v = id.get(params, effects);
    match id {
        ParamId::Muscle(_, MuscleField::LstM) => (0.9 * v, 1.1 * v),
        ParamId::Muscle(m, MuscleField::FomN) => {
            let f = reference_fom_n[m.index()];
            (0.5 * f, 10.0 * f)
        }
        // at least ±2° (±40 % of 5°), so that a muscle without pennation keeps an interval
        ParamId::Muscle(_, MuscleField::AlphaDeg) if 0.4 * v < 2.0 => ((v - 2.0).max(0.0), v + 2.0),
        ParamId::Muscle(_, MuscleField::AlphaDeg) => (0.6 * v, 1.4 * v),
        ParamId::Activation(2) => (0.0, 0.12),
        ParamId::Effect(muscle_model::EffectKind::ElectromechanicalDelay, _) => (0.0, 150.0),
        // e0t
        ParamId::Curve(5) => (0.5 * v, 3.0 * v),
        // flen
        ParamId::Curve(1) => (1.0, (1.2 * v).max(1.0 + 1e-6)),
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_muscle_without_pennation_keeps_an_interval_in_a_recording() {
        let alpha = ParamId::parse("gl.alpha_deg").unwrap();
        let at = |a: f64| {
            let mut p = ModelParams::nominal();
            p.muscles[2].alpha_deg = a;
            recording_bounds(alpha, &p, &Effects::none(), [3549.0, 1558.0, 683.0])
        };
        assert_eq!(at(0.0), (0.0, 2.0));
        assert_eq!(at(3.0), (1.0, 5.0));
        // from 5° up, ±40 % of the value
        assert_eq!(at(8.0), (0.6 * 8.0, 1.4 * 8.0));
    }
}
