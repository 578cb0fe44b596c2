//! Crosstalk of the tibialis anterior into the triceps electrodes, found in the raw EMG and
//! removed before the envelopes are made (docs/diagnosis-method.md, "EMG crosstalk").
//!
//! Crosstalk cannot be told from the torque alone: a share `f` of the TA's signal in the soleus
//! channel raises the soleus envelope where the TA is active, the model predicts plantarflexor
//! torque that is not there, and the misfit has the shape of the TA's own (antagonist) torque.
//! The raw signals tell them apart, because two muscles' carriers are independent: each
//! triceps channel `x` is band-passed with the envelope's band-pass, as is the TA's, `x_TA`, and
//! the share of `x_TA` in `x` is estimated by least squares weighted by the channel's own
//! power in 100 ms blocks and tested against 0 with a standard error from the block sums
//! ([`signal::crosstalk()`]); `p = erfc(|z|/√2)`. A channel whose evidence `−log10 p` exceeds
//! [`CrosstalkSettings::threshold`] (5 by default: one clean channel in 10⁵ corrected
//! needlessly; strict, because the correction changes the recording, and a share large enough
//! to matter to the torque has `|z|` in the tens) is corrected on the raw signal,
//! `x ← x − f̂·x_TA` ([`remove_crosstalk`]).

use serde::Serialize;
use signal::{crosstalk, sosfiltfilt, EnvelopeFilter, EnvelopeSettings};

use crate::error::{ErrorKind, ExperimentError, Result};
use crate::files::Trial;

/// Length of the blocks whose sums give the share's standard error (s): long against the
/// carriers' correlation time (a few ms at a 10–350 Hz band), short against a trial.
const BLOCK_S: f64 = 0.1;

/// Whether and how strictly the raw triceps EMG is tested for the TA's crosstalk.
#[derive(Clone, Copy, Debug, PartialEq)]
#[non_exhaustive]
pub struct CrosstalkSettings {
    /// Test (and correct) at all.
    pub enabled: bool,
    /// Evidence `−log10 p` above which a channel is corrected.
    pub threshold: f64,
}

impl Default for CrosstalkSettings {
    fn default() -> Self {
        Self {
            enabled: true,
            threshold: 5.0,
        }
    }
}

impl CrosstalkSettings {
    /// Settings that test with evidence threshold `threshold` when `enabled`.
    #[must_use]
    pub fn new(enabled: bool, threshold: f64) -> Self {
        Self { enabled, threshold }
    }

    /// No test: the EMG is taken as recorded.
    #[must_use]
    pub fn off() -> Self {
        Self {
            enabled: false,
            ..Self::default()
        }
    }
}

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

/// The crosstalk test of each triceps channel of `trial` against its TA channel (module
/// docs); empty when the trial has no TA channel, carries envelopes rather than raw EMG
/// (`emg_is_envelope`), or the test is off. `name` names the trial in errors.
///
/// # Errors
/// The band-pass cannot be designed at the trial's rate, or a channel is too short for it
/// or for ten blocks.
pub fn emg_crosstalk(
    trial: &Trial,
    settings: &CrosstalkSettings,
    emg_is_envelope: bool,
    name: &str,
) -> Result<Vec<CrosstalkCheck>> {
    let Some(ta) = trial.emg_ta.as_deref() else {
        return Ok(Vec::new());
    };
    if !settings.enabled || emg_is_envelope {
        return Ok(Vec::new());
    }
    let fs = trial.sample_rate_hz();
    let fail = |e: signal::SignalError| ExperimentError::File {
        path: name.to_string(),
        kind: ErrorKind::InvalidSettings,
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
    .map(|(channel, raw)| {
        let e = crosstalk(&band(raw)?, &ta_bp, block).map_err(fail)?;
        let p_value = numerics::special::erfc(e.z.abs() / std::f64::consts::SQRT_2);
        Ok(CrosstalkCheck {
            channel: channel.to_string(),
            fraction: e.fraction,
            fraction_se: e.fraction_se,
            z: e.z,
            p_value,
            corrected: -p_value.max(f64::MIN_POSITIVE).log10() > settings.threshold,
        })
    })
    .collect()
}

/// `trial` with the TA's share removed from the raw signal of every channel `checks`
/// corrected, `x ← x − f̂·x_TA` (`None` when none was, or the trial has no TA channel).
#[must_use]
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
