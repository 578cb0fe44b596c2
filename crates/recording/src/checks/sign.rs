//! The torque sign check.
//!
//! With a prediction (the model's EMG-driven torque on the same samples, nominal parameters),
//! the Pearson correlation `r` of measured and predicted torque over the samples where both are
//! finite, and the least-squares slope `cov/var(prediction)`. `r < −0.3` is the warning
//! "torque sign looks flipped" (a left leg on a right-leg setting, or a sign convention with
//! plantarflexion < 0): a good trial correlates at `r ≈ 0.9`, and an inverted one at about
//! `−r`; between −0.3 and 0.3 the relation is too weak to tell (a relaxed trial), so it is not
//! flagged. A prediction of another length is not compared (a warning).

use serde::Serialize;

use super::settings::CheckSettings;
use super::values::signed;

/// Torque against the EMG-driven prediction.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct SignCheck {
    /// Number of sample pairs compared (both finite).
    pub samples: usize,
    /// Pearson correlation of measured and predicted torque (`null` when either is constant
    /// or the lengths differ).
    pub correlation: Option<f64>,
    /// Least-squares slope of measured on predicted torque.
    pub slope: Option<f64>,
    /// Correlation below `flipped_max_correlation`.
    pub flipped: bool,
}

pub(super) fn sign_check(
    torque: &[f64],
    prediction: &[f64],
    s: &CheckSettings,
    warnings: &mut Vec<String>,
) -> SignCheck {
    if torque.len() != prediction.len() {
        warnings.push(format!(
            "torque_nm: the prediction has {} samples but the torque has {}: sign not checked",
            prediction.len(),
            torque.len()
        ));
        return SignCheck {
            samples: 0,
            correlation: None,
            slope: None,
            flipped: false,
        };
    }
    let pairs: Vec<(f64, f64)> = torque
        .iter()
        .zip(prediction)
        .filter(|(a, b)| a.is_finite() && b.is_finite())
        .map(|(a, b)| (*a, *b))
        .collect();
    let m = pairs.len();
    let mut out = SignCheck {
        samples: m,
        correlation: None,
        slope: None,
        flipped: false,
    };
    if m < 2 {
        return out;
    }
    let mx = pairs.iter().map(|p| p.0).sum::<f64>() / m as f64;
    let my = pairs.iter().map(|p| p.1).sum::<f64>() / m as f64;
    let (mut sxx, mut syy, mut sxy) = (0.0, 0.0, 0.0);
    for &(x, y) in &pairs {
        sxx += (x - mx) * (x - mx);
        syy += (y - my) * (y - my);
        sxy += (x - mx) * (y - my);
    }
    if syy > 0.0 {
        out.slope = Some(sxy / syy).filter(|v| v.is_finite());
    }
    if sxx > 0.0 && syy > 0.0 {
        let r = (sxy / (sxx.sqrt() * syy.sqrt())).clamp(-1.0, 1.0);
        if r.is_finite() {
            out.correlation = Some(r);
            out.flipped = r < s.flipped_max_correlation;
        }
    }
    if out.flipped {
        warnings.push(format!(
            "torque_nm: torque sign looks flipped: correlation with the EMG-driven prediction r = {} (a flipped leg, or plantarflexion < 0?)",
            signed(out.correlation.unwrap_or(f64::NAN), 2)
        ));
    }
    out
}
