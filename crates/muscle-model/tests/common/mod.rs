//! Helpers shared by the integration tests.
#![allow(dead_code)]

use muscle_model::{Muscle, ParamId};
use rand::Rng;

/// RMS of `a − b`.
#[allow(unused_imports)] // not every test binary uses it
pub use numerics::rms_diff;

/// Max of `|a − b|`.
pub fn max_diff(a: &[f64], b: &[f64]) -> f64 {
    a.iter()
        .zip(b)
        .map(|(x, y)| (x - y).abs())
        .fold(0.0, f64::max)
}

/// Random values of the 9 identified parameters, uniform in the identification bounds box
/// (LST ±5 %, F0 and α0 ±20 %) scaled by `scale` (1 = the bounds, 2 = twice the bounds box)
/// around nominal.
pub fn random_identified(rng: &mut impl Rng, scale: f64) -> muscle_model::ModelParams {
    let mut p = muscle_model::ModelParams::nominal();
    let mut e = muscle_model::Effects::none();
    for id in ParamId::identified() {
        let (lo, hi) = id.default_bounds(&muscle_model::ModelParams::nominal(), &e);
        let mid = 0.5 * (lo + hi);
        let half = 0.5 * (hi - lo) * scale;
        let v = rng.random_range(mid - half..=mid + half);
        id.set(&mut p, &mut e, v);
    }
    p
}

/// Index of the sample closest to time `t` (uniform grid from 0).
pub fn idx(fs: f64, t: f64) -> usize {
    (t * fs).round() as usize
}

pub const MUSCLES: [Muscle; 3] = Muscle::ALL;
pub mod spec_model;
