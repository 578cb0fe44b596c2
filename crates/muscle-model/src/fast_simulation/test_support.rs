//! What the tests of the fast simulation share.

use crate::effects::Effects;
use crate::inputs::TrialInputs;
use crate::musculotendon::MuscleUnit;
use crate::params::{ModelParams, Muscle};
use crate::path::MusclePath;
use std::sync::Arc;

/// The channel of `unit` (sol, gm or gl) on `tr` with delay `d` (s), found or built.
pub(super) fn test_channel(tr: &TrialInputs, unit: &MuscleUnit, d: f64) -> Arc<super::Channel> {
    let env = tr.envelope(unit.muscle().unwrap());
    let path = MusclePath::new(unit, tr).unwrap();
    super::channel_for(None, tr, unit, env, &path, d)
}

/// The seed-like synthetic trial (512 Hz) and the three muscles' units at nominal parameters
/// with an electromechanical delay of `delay_ms` and an optional fatigue rate; the delay in
/// seconds.
pub(super) fn test_units(
    fatigue: Option<f64>,
    delay_ms: f64,
) -> (TrialInputs, [MuscleUnit; 3], f64) {
    let tr = crate::synthetic::seed_like_trial(512.0).unwrap();
    let mut json = format!(r#"{{"electromechanical_delay": {{"delay_ms": {delay_ms}}}"#);
    if let Some(k) = fatigue {
        json += &format!(r#", "fatigue": {{"rate_per_s": {k}}}"#);
    }
    json += "}";
    let e = Effects::from_json_str(&json).unwrap();
    let p = ModelParams::nominal();
    let u = Muscle::ALL.map(|m| MuscleUnit::new(&p, m, &e));
    (tr, u, delay_ms * 1e-3)
}
