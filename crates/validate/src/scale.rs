//! Does a held-out part ask for another EMG-to-moment gain than the calibration's?
//!
//! The envelopes of a trial recorded on another day, at another speed or after the electrodes
//! moved reach the moment with another gain, and a calibration carried there predicts the right
//! shape at the wrong size. The part's own best scale of the model's moment,
//!
//! ```text
//! k̂ = Σ w_i y_i ŷ_i / Σ w_i ŷ_i²
//! ```
//!
//! (weighted least squares of the measured moment `y` on the predicted `ŷ`), says how much; its
//! gain is judged out of sample within the part: the part's segments (its strides, or
//! [`SCALE_BLOCKS`] equal blocks of its judged samples when it has fewer than two) are dealt
//! alternately into two halves, `k̂` of one half scales the prediction of the other, and the
//! scaled RMS over both is compared with the unscaled one over the same samples,
//!
//! ```text
//! gain % = 100 · (RMS − RMS_scaled) / RMS.
//! ```
//!
//! The part asks for another gain when that cross-validated gain reaches [`SCALE_MIN_GAIN_PCT`]
//! (the diagnosis's margin for a held-out tie): one number fitted on half the part that
//! predicts the other half better by that much is a difference of gain, not of shape.

use serde::Serialize;

/// Blocks a part without strides is cut into for the cross-validation.
pub const SCALE_BLOCKS: usize = 10;

/// Cross-validated gain (%) at and above which a part asks for another gain.
pub const SCALE_MIN_GAIN_PCT: f64 = 2.0;

/// The scale of the model's moment a held-out part asks for.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
#[non_exhaustive]
pub struct MomentScale {
    /// `k̂` over the whole part (1: the calibration's gain fits).
    pub factor: f64,
    /// The unscaled prediction's RMS error (N·m) over the same samples (the part's judged
    /// samples inside its unflagged strides, or all of them).
    pub rms_nm: f64,
    /// The RMS error (N·m) of the prediction scaled by the other half's `k̂`, over the part.
    pub cross_validated_rms_nm: f64,
    /// `100 · (RMS − cross_validated_rms_nm) / RMS`: positive when the scale predicts better.
    pub cross_validated_gain_pct: f64,
    /// `cross_validated_gain_pct ≥` [`SCALE_MIN_GAIN_PCT`].
    pub differs: bool,
}

/// `Σ w y ŷ / Σ w ŷ²` over `idx`, or `None` when the prediction is zero there.
fn best_scale(y: &[f64], p: &[f64], w: &[f64], idx: &[usize]) -> Option<f64> {
    let (mut num, mut den) = (0.0, 0.0);
    for &i in idx {
        num += w[i] * y[i] * p[i];
        den += w[i] * p[i] * p[i];
    }
    (den > 0.0).then(|| num / den)
}

/// The scale a part asks for (module documentation): `segments` are its strides (or the part
/// itself), every index inside `measured`, `predicted` and `weights`. `None` when no sample of
/// the part has weight or the prediction is zero on a half.
#[must_use]
pub fn moment_scale(
    measured: &[f64],
    predicted: &[f64],
    weights: &[f64],
    segments: &[std::ops::Range<usize>],
) -> Option<MomentScale> {
    let judged = |r: &std::ops::Range<usize>| -> Vec<usize> {
        r.clone().filter(|&i| weights[i] > 0.0).collect()
    };
    let mut pieces: Vec<Vec<usize>> = segments.iter().map(judged).collect();
    pieces.retain(|p| !p.is_empty());
    if pieces.len() < 2 {
        let all: Vec<usize> = pieces.concat();
        let len = all.len().div_ceil(SCALE_BLOCKS).max(1);
        pieces = all.chunks(len).map(<[usize]>::to_vec).collect();
    }
    if pieces.len() < 2 {
        return None;
    }
    let half = |h: usize| -> Vec<usize> {
        pieces
            .iter()
            .enumerate()
            .filter(|(k, _)| k % 2 == h)
            .flat_map(|(_, p)| p.iter().copied())
            .collect()
    };
    let halves = [half(0), half(1)];
    let all: Vec<usize> = halves.concat();
    let factor = best_scale(measured, predicted, weights, &all)?;
    let k = [
        best_scale(measured, predicted, weights, &halves[1])?,
        best_scale(measured, predicted, weights, &halves[0])?,
    ];
    let (mut sw, mut ss, mut ss_scaled) = (0.0, 0.0, 0.0);
    for (h, idx) in halves.iter().enumerate() {
        for &i in idx {
            let (y, p, w) = (measured[i], predicted[i], weights[i]);
            sw += w;
            ss += w * (y - p) * (y - p);
            ss_scaled += w * (y - k[h] * p) * (y - k[h] * p);
        }
    }
    let rms = (ss / sw).sqrt();
    let scaled = (ss_scaled / sw).sqrt();
    // a prediction without error leaves nothing for a scale to gain
    let gain = if rms > 0.0 {
        100.0 * (rms - scaled) / rms
    } else {
        0.0
    };
    Some(MomentScale {
        factor,
        rms_nm: rms,
        cross_validated_rms_nm: scaled,
        cross_validated_gain_pct: gain,
        differs: gain >= SCALE_MIN_GAIN_PCT,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn wave(n: usize) -> Vec<f64> {
        (0..n)
            .map(|i| 40.0 * (i as f64 * 0.05).sin().max(0.0) + 2.0)
            .collect()
    }

    #[test]
    fn a_moment_at_another_gain_asks_for_that_gain() {
        let p = wave(400);
        // measured at 0.6 times the model's gain, with a small deterministic ripple
        let y: Vec<f64> = p
            .iter()
            .enumerate()
            .map(|(i, v)| 0.6 * v + 0.3 * (i as f64 * 1.7).sin())
            .collect();
        let w = vec![1.0; 400];
        let strides: Vec<_> = (0..4).map(|s| s * 100..(s + 1) * 100).collect();
        let s = moment_scale(&y, &p, &w, &strides).unwrap();
        assert!((s.factor - 0.6).abs() < 0.01, "{s:?}");
        assert!(s.cross_validated_gain_pct > 80.0, "{s:?}");
        assert!(s.differs);
    }

    #[test]
    fn the_right_gain_is_not_called_different() {
        let p = wave(400);
        let y: Vec<f64> = p
            .iter()
            .enumerate()
            .map(|(i, v)| v + 3.0 * (i as f64 * 0.31).cos())
            .collect();
        let w = vec![1.0; 400];
        // one segment: cut into blocks
        let s = moment_scale(&y, &p, &w, std::slice::from_ref(&(0..400))).unwrap();
        assert!((s.factor - 1.0).abs() < 0.05, "{s:?}");
        assert!(s.cross_validated_gain_pct < SCALE_MIN_GAIN_PCT, "{s:?}");
        assert!(!s.differs);
    }

    #[test]
    fn samples_without_weight_are_left_out_and_an_empty_part_has_no_scale() {
        let p = wave(200);
        let mut y: Vec<f64> = p.iter().map(|v| 0.8 * v).collect();
        let mut w = vec![1.0; 200];
        for i in 150..200 {
            y[i] = 1e6;
            w[i] = 0.0;
        }
        let s = moment_scale(&y, &p, &w, std::slice::from_ref(&(0..200))).unwrap();
        assert!((s.factor - 0.8).abs() < 1e-12, "{s:?}");
        assert!(moment_scale(&y, &p, &[0.0; 200], std::slice::from_ref(&(0..200))).is_none());
    }

    #[test]
    fn a_prediction_without_error_gains_nothing_from_a_scale() {
        let p = wave(100);
        let s = moment_scale(&p, &p, &[1.0; 100], std::slice::from_ref(&(0..100))).unwrap();
        assert_eq!(s.factor, 1.0);
        assert_eq!(s.cross_validated_gain_pct, 0.0);
        assert!(!s.differs);
    }
}
