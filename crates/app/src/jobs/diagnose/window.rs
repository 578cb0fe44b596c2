//! The part of a long gait trial the diagnosis fits.
//!
//! A diagnosis refits the model hundreds of times (the baseline's starts, every round's
//! leaders, the flexible terms, the detection limits, the profiles), and each simulation costs
//! what the integrated length costs: on 60 s of walking a diagnosis took minutes where a
//! calibration, which searches a few windows of strides (`identify_sa::search_set`), takes
//! seconds. A trial with strides and no unloaded run longer than `1.5·W`
//! ([`DIAGNOSIS_WINDOW_S`]) is therefore diagnosed on a run of whole strides of about `W`
//! seconds at its middle, integrated from [`LEAD_IN_S`] before the window's first foot strike
//! (those samples weighted 0, as the calibration's windows are). Steady walking repeats itself
//! from stride to stride, so the window sees the shapes the whole trial has; what the
//! calibration leaves on the rest of the trial is judged by `validate`'s folds over every
//! sample ([`super::session_run`]). The window is diagnosed from the session's prepared inputs
//! (with any crosstalk correction the session applied), so the diagnosis does not report what
//! that correction was worth, as it does for a trial diagnosed whole.

use std::ops::Range;

use crate::error::AppResult;
use crate::jobs::session::SessionTrial;

/// Seconds of strides a long trial's diagnosis fits.
pub const DIAGNOSIS_WINDOW_S: f64 = 6.0;
/// Integrated before the window's first foot strike and not judged (s): covers the longest
/// electromechanical delay (150 ms) and lets activation and fibres forget the start.
pub const LEAD_IN_S: f64 = 0.4;

/// The window of a long trial (module docs).
#[derive(Debug, Clone, PartialEq)]
pub(super) struct DiagnosisWindow {
    /// Samples integrated, lead-in included.
    pub range: Range<usize>,
    /// The first judged sample, inside `range`.
    pub first_judged: usize,
    /// Strides judged.
    pub strides: usize,
    /// Strides of the whole trial.
    pub of_strides: usize,
}

impl DiagnosisWindow {
    /// The trial's weights over the window: 0 in the lead-in, the trial's own after.
    pub fn weights(&self, trial_weights: Option<&[f64]>) -> Vec<f64> {
        self.range
            .clone()
            .map(|i| {
                if i < self.first_judged {
                    0.0
                } else {
                    trial_weights.map_or(1.0, |w| w[i])
                }
            })
            .collect()
    }

    /// What the terminal and the report say about it.
    pub fn describe(&self, fs: f64) -> String {
        format!(
            "diagnosed on {} of its {} strides ({:.1}–{:.1} s, after a {:.1} s lead-in); its held-out residual is judged on every sample",
            self.strides,
            self.of_strides,
            self.first_judged as f64 / fs,
            self.range.end as f64 / fs,
            LEAD_IN_S
        )
    }
}

/// The window of `trial`, or `None` when it is diagnosed whole: it has an unloaded run, no
/// strides, or is at most `1.5·W` long.
pub(super) fn diagnosis_window(trial: &SessionTrial) -> AppResult<Option<DiagnosisWindow>> {
    if trial.correction().is_some() || trial.ceinms.is_some() {
        return Ok(None);
    }
    let Some(strides) = trial.strides()? else {
        return Ok(None);
    };
    let inputs = trial.problem.inputs();
    let fs = inputs.fs();
    Ok(window_of(
        &strides
            .strides
            .iter()
            .map(|s| (s.start, s.end))
            .collect::<Vec<_>>(),
        inputs.len(),
        fs,
    ))
}

/// The window over strides `(start, end)` (samples) of a trial of `n` samples at `fs`.
fn window_of(strides: &[(usize, usize)], n: usize, fs: f64) -> Option<DiagnosisWindow> {
    if (n as f64) / fs <= 1.5 * DIAGNOSIS_WINDOW_S || strides.is_empty() {
        return None;
    }
    let lead = (LEAD_IN_S * fs).round() as usize;
    let mean_s =
        strides.iter().map(|(a, b)| (b - a) as f64).sum::<f64>() / fs / strides.len() as f64;
    let k = ((DIAGNOSIS_WINDOW_S / mean_s).round() as usize).clamp(1, strides.len());
    // centred, and never starting before the lead-in can be integrated
    let mut first = (strides.len() - k) / 2;
    while first + k < strides.len() && strides[first].0 < lead {
        first += 1;
    }
    let start = strides[first].0;
    let end = strides[first + k - 1].1.min(n);
    if start < lead || end <= start {
        return None;
    }
    Some(DiagnosisWindow {
        range: start - lead..end,
        first_judged: start,
        strides: k,
        of_strides: strides.len(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_long_trial_is_diagnosed_on_strides_at_its_middle() {
        // 60 s at 100 Hz, strides of 1.1 s from 0.5 s
        let strides: Vec<(usize, usize)> = (0..50).map(|k| (50 + 110 * k, 160 + 110 * k)).collect();
        let w = window_of(&strides, 6000, 100.0).unwrap();
        assert_eq!(w.strides, 5, "6 s of 1.1 s strides");
        assert_eq!(w.of_strides, 50);
        // centred: strides 22…26
        assert_eq!(w.first_judged, strides[22].0);
        assert_eq!(w.range, strides[22].0 - 40..strides[26].1);
        let weights = w.weights(None);
        assert_eq!(weights.len(), w.range.len());
        assert!(weights[..40].iter().all(|v| *v == 0.0));
        assert!(weights[40..].iter().all(|v| *v == 1.0));
    }

    #[test]
    fn a_short_trial_is_diagnosed_whole() {
        let strides: Vec<(usize, usize)> = (0..7).map(|k| (50 + 110 * k, 160 + 110 * k)).collect();
        assert_eq!(window_of(&strides, 900, 100.0), None);
        assert_eq!(window_of(&[], 6000, 100.0), None);
    }
}
