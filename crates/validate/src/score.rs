//! How well a prediction matches the measured moment on the samples a fold holds out.

use serde::Serialize;

/// RMS error and coefficient of determination of a prediction over the judged samples.
///
/// With weights `w_i` (a CEINMS trial's moment samples, a fold's mask) over the judged samples,
/// `RMS = √(Σ w_i (y_i − ŷ_i)² / Σ w_i)` and `R² = 1 − Σ w_i (y_i − ŷ_i)² / Σ w_i (y_i − ȳ)²`,
/// `ȳ` the weighted mean of the measured moment.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
#[non_exhaustive]
pub struct FitScore {
    /// RMS error (N·m).
    pub rms_nm: f64,
    /// Coefficient of determination (1 is perfect, 0 is the mean, negative worse than it).
    pub r2: f64,
}

impl FitScore {
    /// The score of `predicted` against `measured` with per-sample weights `weights` (0 leaves
    /// a sample out). NaN when no sample has weight.
    #[must_use]
    pub fn of(measured: &[f64], predicted: &[f64], weights: &[f64]) -> Self {
        let (mut sw, mut swy) = (0.0, 0.0);
        for (y, w) in measured.iter().zip(weights) {
            sw += w;
            swy += w * y;
        }
        if sw <= 0.0 {
            return Self {
                rms_nm: f64::NAN,
                r2: f64::NAN,
            };
        }
        let mean = swy / sw;
        let (mut ss_res, mut ss_tot) = (0.0, 0.0);
        for ((y, p), w) in measured.iter().zip(predicted).zip(weights) {
            ss_res += w * (y - p) * (y - p);
            ss_tot += w * (y - mean) * (y - mean);
        }
        Self {
            rms_nm: (ss_res / sw).sqrt(),
            r2: 1.0 - ss_res / ss_tot,
        }
    }

    /// The mean of several scores (each fold or trial counting once).
    #[must_use]
    pub fn mean(scores: &[FitScore]) -> Self {
        let n = scores.len().max(1) as f64;
        Self {
            rms_nm: scores.iter().map(|s| s.rms_nm).sum::<f64>() / n,
            r2: scores.iter().map(|s| s.r2).sum::<f64>() / n,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_perfect_prediction_scores_zero_and_one_and_the_mean_scores_zero() {
        let y = [1.0, 2.0, 3.0, 4.0];
        let w = [1.0; 4];
        let s = FitScore::of(&y, &y, &w);
        assert_eq!(s.rms_nm, 0.0);
        assert_eq!(s.r2, 1.0);
        let m = FitScore::of(&y, &[2.5; 4], &w);
        assert!(m.r2.abs() < 1e-12);
        assert!((m.rms_nm - 1.25f64.sqrt()).abs() < 1e-12);
    }

    #[test]
    fn weight_zero_leaves_a_sample_out() {
        let y = [1.0, 2.0, 100.0];
        let p = [1.0, 2.0, 0.0];
        let s = FitScore::of(&y, &p, &[1.0, 1.0, 0.0]);
        assert_eq!(s.rms_nm, 0.0);
        assert!(FitScore::of(&y, &p, &[0.0; 3]).rms_nm.is_nan());
    }
}
