//! What removing the TA's crosstalk from the triceps EMG is worth (docs/diagnosis-method.md, "EMG
//! crosstalk").
//!
//! The crosstalk is tested and removed where the EMG is prepared
//! ([`experiment::emg_crosstalk`], [`experiment::PreparedTrial`]); the whole diagnosis then runs
//! on the corrected envelopes. The final model is fitted again on the uncorrected envelopes,
//! and the held-out deviance and RMS of the two say what the correction is worth
//! ([`EmgCorrection`]). When it is worth more than `min_flexible_gain` the trial is called
//! deficient and `unexplained.depends_on` starts with `activation`: the structure the
//! recording leaves lives in the triceps activation the model was given.

use experiment::CrosstalkCheck;
use muscle_model::TrialInputs;
use serde::Serialize;

use crate::baseline;
use crate::fit::{Context, Fit};
use crate::{DiagnoseError, DiagnoseSettings};

/// The raw-EMG crosstalk tests of a trial and, when a channel was corrected, the model inputs
/// without the correction (what the correction is worth is measured against them).
#[derive(Default)]
pub(crate) struct EmgInputs {
    pub checks: Vec<CrosstalkCheck>,
    pub uncorrected: Option<TrialInputs>,
}

/// What removing the TA's share from the triceps channels is worth: the final model fitted
/// on the corrected and on the uncorrected envelopes, compared on the same folds.
#[derive(Clone, Debug, PartialEq, Serialize)]
#[non_exhaustive]
pub struct EmgCorrection {
    /// The corrected channels.
    pub channels: Vec<String>,
    /// Pooled held-out RMS of the final model on the uncorrected envelopes (N·m).
    pub heldout_rms_uncorrected_nm: f64,
    /// The same on the corrected envelopes (N·m).
    pub heldout_rms_nm: f64,
    /// `100·(1 − corrected/uncorrected)` (%).
    pub heldout_rms_reduction_pct: f64,
    /// Held-out deviance of the uncorrected fit minus the corrected (χ² units).
    pub heldout_deviance_gain: f64,
}

/// The final `model` fitted again on the `uncorrected` envelopes (same torque, noise model,
/// folds and starts as on the corrected ones) and the held-out comparison of the two, with the
/// simulations spent.
///
/// # Errors
/// The refit cannot be simulated.
pub(crate) fn correction_worth(
    ctx: &Context,
    model: &Fit,
    uncorrected: TrialInputs,
    checks: &[CrosstalkCheck],
    settings: &DiagnoseSettings,
) -> Result<(EmgCorrection, usize), DiagnoseError> {
    let raw = ctx.with_inputs(uncorrected);
    let fit = if model.kinds.is_empty() {
        baseline::fit_baseline(&raw, settings)?
    } else {
        raw.fit(&model.kinds, &model.x, true)?
    };
    let correction = EmgCorrection {
        channels: checks
            .iter()
            .filter(|c| c.corrected)
            .map(|c| c.channel.clone())
            .collect(),
        heldout_rms_uncorrected_nm: fit.heldout_rms,
        heldout_rms_nm: model.heldout_rms,
        heldout_rms_reduction_pct: 100.0 * (1.0 - model.heldout_rms / fit.heldout_rms),
        heldout_deviance_gain: fit.heldout_dev - model.heldout_dev,
    };
    Ok((correction, fit.evaluations))
}

/// The terminal summary's crosstalk line (`None` without a TA channel to test against), with
/// what the correction was worth when `correction` is given.
pub fn crosstalk_summary_line(
    checks: &[CrosstalkCheck],
    correction: Option<&EmgCorrection>,
) -> Option<String> {
    if checks.is_empty() {
        return None;
    }
    let fixed: Vec<String> = checks
        .iter()
        .filter(|c| c.corrected)
        .map(|c| {
            format!(
                "{} carried {:.3} ± {:.3} of emg_ta",
                c.channel, c.fraction, c.fraction_se
            )
        })
        .collect();
    if fixed.is_empty() {
        let z = checks.iter().map(|c| c.z.abs()).fold(0.0, f64::max);
        return Some(format!(
            "crosstalk    none from emg_ta in the raw EMG (largest |z| {z:.1})"
        ));
    }
    let worth = correction.map_or(String::new(), |c| {
        format!(
            "; held-out RMS {:.3} N·m uncorrected, {:.3} corrected",
            c.heldout_rms_uncorrected_nm, c.heldout_rms_nm
        )
    });
    Some(format!(
        "crosstalk    {}: removed before fitting{worth}",
        fixed.join(", ")
    ))
}
