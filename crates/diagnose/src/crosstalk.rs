//! Crosstalk of the tibialis anterior into the triceps electrodes, found in the raw EMG and
//! removed before the model is fitted (docs/diagnosis.md, "EMG crosstalk").
//!
//! Crosstalk cannot be told from the torque alone: a share `f` of the TA's signal in the soleus
//! channel raises the soleus envelope where the TA is active, the model predicts plantarflexor
//! torque that is not there, and the misfit has the shape of the TA's own (antagonist) torque.
//! The raw signals tell them apart, because two muscles' carriers are independent: each
//! triceps channel `x` is band-passed with the envelope's band-pass, as is the TA's, `x_TA`, and
//! the share of `x_TA` in `x` is estimated by least squares weighted by the channel's own
//! power in 100 ms blocks and tested against 0 with a standard error from the block sums
//! ([`signal::crosstalk()`]); `p = erfc(|z|/√2)`. A channel whose evidence `−log10 p` exceeds
//! `crosstalk_threshold` (5 by default: one clean channel in 10⁵ corrected needlessly;
//! strict, because the correction changes the recording, and a share large enough to matter
//! to the torque has `|z|` in the tens) is corrected on the raw signal, `x ← x − f̂·x_TA`, and
//! the whole diagnosis runs on the corrected envelopes. The final model is then fitted again on the uncorrected
//! envelopes, and the held-out deviance and RMS of the two say what the correction is worth
//! ([`EmgCorrection`]). When it is worth more than `min_flexible_gain` the trial is called
//! deficient and `unexplained.depends_on` starts with `activation`: the structure the
//! recording leaves lives in the triceps activation the model was given.

use experiment::Trial;
use muscle_model::TrialInputs;
use serde::Serialize;
use signal::{crosstalk, sosfiltfilt, EnvelopeFilter, EnvelopeSettings};

use crate::baseline;
use crate::fit::{Context, Fit};
use crate::{DiagnoseError, DiagnoseSettings};

/// Length of the blocks whose sums give the share's standard error (s): long against the
/// carriers' correlation time (a few ms at a 10–350 Hz band), short against a trial.
const BLOCK_S: f64 = 0.1;

/// The raw-EMG crosstalk test of one triceps channel against the TA's.
#[derive(Clone, Debug, PartialEq, Serialize)]
#[non_exhaustive]
pub struct CrosstalkCheck {
    /// The triceps channel (`emg_sol`, `emg_gm`, `emg_gl`).
    pub channel: String,
    /// Share of the TA's raw signal in the channel (least squares on the band-passed signals).
    pub fraction: f64,
    /// Its standard error (100 ms block sums).
    pub fraction_se: f64,
    /// `fraction / fraction_se`: standard normal without crosstalk.
    pub z: f64,
    /// Two-sided p-value of `z`.
    pub p_value: f64,
    /// Whether `−log10 p` exceeds the threshold: the channel was corrected.
    pub corrected: bool,
}

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

/// The crosstalk test of each triceps channel of `trial` against its TA channel (module
/// docs); empty when the trial has no TA channel, carries envelopes rather than raw EMG
/// (`settings.input_options.emg_is_envelope`), or `settings.crosstalk_check` is off.
///
/// ```
/// use diagnose::{emg_crosstalk, DiagnoseSettings};
/// use diagnose::scenarios::{uncatalogued_trial, Uncatalogued};
///
/// let t = uncatalogued_trial(Uncatalogued::EmgCrosstalk, 7).unwrap();
/// let checks = emg_crosstalk(&t.hidden.synthetic.trial, &DiagnoseSettings::default()).unwrap();
/// let sol = &checks[0];
/// assert_eq!(sol.channel, "emg_sol");
/// assert!(sol.corrected && (sol.fraction - t.size).abs() < 5.0 * sol.fraction_se);
/// ```
///
/// # Errors
/// The band-pass cannot be designed at the trial's rate, or a channel is too short for it
/// or for ten blocks.
pub fn emg_crosstalk(
    trial: &Trial,
    settings: &DiagnoseSettings,
) -> Result<Vec<CrosstalkCheck>, DiagnoseError> {
    let Some(ta) = trial.emg_ta.as_deref() else {
        return Ok(Vec::new());
    };
    if !settings.crosstalk_check || settings.input_options.emg_is_envelope {
        return Ok(Vec::new());
    }
    let fs = trial.sample_rate_hz();
    let fail = |e: signal::SignalError| DiagnoseError::Recording {
        reason: format!("EMG crosstalk check: {e}"),
    };
    let filter = EnvelopeFilter::new(fs, &EnvelopeSettings::default()).map_err(fail)?;
    let band = |x: &[f64]| sosfiltfilt(filter.bandpass(), x).map_err(fail);
    let ta_bp = band(ta)?;
    let block = ((BLOCK_S * fs).round() as usize).max(1);
    [
        ("emg_sol", &trial.emg_sol),
        ("emg_gm", &trial.emg_gm),
        ("emg_gl", &trial.emg_gl),
    ]
    .into_iter()
    .map(|(name, raw)| {
        let e = crosstalk(&band(raw)?, &ta_bp, block).map_err(fail)?;
        let p_value = numerics::special::erfc(e.z.abs() / std::f64::consts::SQRT_2);
        Ok(CrosstalkCheck {
            channel: name.to_string(),
            fraction: e.fraction,
            fraction_se: e.fraction_se,
            z: e.z,
            p_value,
            corrected: -p_value.max(f64::MIN_POSITIVE).log10() > settings.crosstalk_threshold,
        })
    })
    .collect()
}

/// `trial` with the TA's share removed from the raw signal of every channel `checks`
/// corrected, `x ← x − f̂·x_TA` (`None` when none was, or the trial has no TA channel).
pub fn remove_crosstalk(trial: &Trial, checks: &[CrosstalkCheck]) -> Option<Trial> {
    let ta = trial.emg_ta.as_deref()?;
    if !checks.iter().any(|c| c.corrected) {
        return None;
    }
    let mut out = trial.clone();
    for c in checks.iter().filter(|c| c.corrected) {
        let x = match c.channel.as_str() {
            "emg_sol" => &mut out.emg_sol,
            "emg_gm" => &mut out.emg_gm,
            "emg_gl" => &mut out.emg_gl,
            _ => continue,
        };
        for (v, a) in x.iter_mut().zip(ta) {
            *v -= c.fraction * a;
        }
    }
    Some(out)
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
