//! A session trial's strides: from its vertical ground force, the ones its recording checks
//! flag, and their exclusion from the session's fits when the manifest asks for it.

use super::SessionTrial;
use crate::error::{AppError, AppResult};
use std::path::Path;

impl SessionTrial {
    /// The trial's strides from its vertical ground force (stance while it exceeds
    /// [`experiment::STANCE_THRESHOLD_N`]); `None` without one. A stride the force cannot make
    /// (shorter than 0.2 s) is an error naming the file and column the force came from.
    pub fn strides(&self) -> AppResult<Option<experiment::Strides>> {
        let Some(trial) = self.prepared.as_ref().map(|p| &p.trial) else {
            return Ok(None);
        };
        let Some(force) = trial.grf_vertical_n.as_deref() else {
            return Ok(None);
        };
        experiment::strides_from_ground_force(
            force,
            trial.sample_rate_hz(),
            experiment::STANCE_THRESHOLD_N,
        )
        .map(Some)
        .map_err(|e| {
            // name the force's own file and column, as the map gives them
            let place = recording::read_map(Path::new(&self.source))
                .ok()
                .and_then(|m| {
                    let c = m.channels.get("grf_vertical_n")?;
                    let file = c.file.clone().or(m.file.clone())?;
                    Some(format!("{file}: column {}", c.column))
                })
                .unwrap_or_else(|| self.source.clone());
            AppError::bad(format!("{}: {place}: {e}", self.source))
        })
    }

    /// Where the trial's strides start (samples); see [`SessionTrial::strides`].
    pub fn stride_starts(&self) -> AppResult<Option<Vec<usize>>> {
        Ok(self
            .strides()?
            .map(|s| s.strides.iter().map(|x| x.start).collect()))
    }

    /// The scale of `prediction` (the model's moment on the trial's grid) that the trial asks
    /// for, judged by predicting one half of it from the other (`validate`'s
    /// [`validate::MomentScale`]): its unflagged strides dealt into the halves, or ten blocks
    /// of a trial without usable strides; the trial's own weights judge.
    pub fn moment_scale(&self, prediction: &[f64]) -> Option<validate::MomentScale> {
        let n = self.problem.inputs().len();
        // a ground force that makes no usable stride leaves the whole trial, cut into blocks:
        // the scale is a report, and the strides' own errors belong to the jobs that use them
        let mut segments: Vec<std::ops::Range<usize>> = match self.strides() {
            Ok(Some(s)) => {
                let flags = self.stride_flags(&s);
                s.strides
                    .iter()
                    .zip(flags)
                    .filter(|(x, flagged)| !flagged && x.start < x.end && x.end <= n)
                    .map(|(x, _)| x.start..x.end)
                    .collect()
            }
            Ok(None) | Err(_) => Vec::new(),
        };
        if segments.is_empty() {
            segments.push(0..n);
        }
        let ones;
        let weights = match self.problem.weights() {
            Some(w) => w,
            None => {
                ones = vec![1.0; n];
                &ones
            }
        };
        validate::moment_scale(self.problem.measured(), prediction, weights, &segments)
    }

    /// Which of `strides` (this trial's) the recording checks flagged, matched by time: the
    /// checks find their strides in the trial as recorded.
    pub fn stride_flags(&self, strides: &experiment::Strides) -> Vec<bool> {
        let flags = self
            .checks
            .as_ref()
            .and_then(|c| c.strides.as_ref())
            .map_or(&[][..], |g| g.flagged.as_slice());
        let time = self
            .prepared
            .as_ref()
            .map_or(self.problem.inputs().times(), |p| p.trial.time_s.as_slice());
        strides
            .strides
            .iter()
            .map(|x| flagged_by_checks(time, x.start, x.end, flags))
            .collect()
    }
}

/// Whether the stride `start..end` (samples of `time_s`) is one the recording checks flagged:
/// a flagged stride's span holds its middle. The checks find their strides in the trial as
/// recorded, so they are matched by time, not by index.
fn flagged_by_checks(
    time_s: &[f64],
    start: usize,
    end: usize,
    flags: &[recording::checks::StrideFlag],
) -> bool {
    let (Some(&a), Some(&last)) = (time_s.get(start), time_s.last()) else {
        return false;
    };
    let b = time_s.get(end).copied().unwrap_or(last);
    let mid = 0.5 * (a + b);
    flags.iter().any(|f| f.start_s <= mid && mid < f.end_s)
}

/// `t`'s problem with the samples of every stride its recording checks flag weighted 0, so that
/// no fit and no score of the session sees them (the manifest's `exclude_flagged_strides`).
pub(super) fn exclude_flagged_strides(t: &mut SessionTrial) -> AppResult {
    let Some(g) = t.checks.as_ref().and_then(|c| c.strides.as_ref()) else {
        return Ok(());
    };
    if g.flagged.is_empty() {
        return Ok(());
    }
    let times = t.problem.inputs().times();
    let weights: Vec<f64> = times
        .iter()
        .enumerate()
        .map(|(i, &ti)| {
            if g.flagged.iter().any(|f| f.start_s <= ti && ti < f.end_s) {
                0.0
            } else {
                t.problem.weights().map_or(1.0, |w| w[i])
            }
        })
        .collect();
    t.problem = t
        .problem
        .clone()
        .with_weights(weights)
        .map_err(|e| AppError::bad(format!("{}: exclude_flagged_strides: {e}", t.source)))?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::flagged_by_checks;
    use recording::checks::StrideFlag;

    fn flag(start_s: f64, end_s: f64) -> StrideFlag {
        StrideFlag {
            stride: 0,
            start_s,
            end_s,
            reasons: Vec::new(),
        }
    }

    #[test]
    fn a_stride_is_flagged_when_a_flagged_span_holds_its_middle() {
        let time: Vec<f64> = (0..500).map(|i| 10.0 + 0.01 * f64::from(i)).collect();
        // samples 100..220: 11.00 s to 12.20 s, its middle at 11.60 s
        assert!(flagged_by_checks(&time, 100, 220, &[flag(11.0, 12.2)]));
        assert!(flagged_by_checks(&time, 100, 220, &[flag(11.5, 11.7)]));
        assert!(!flagged_by_checks(&time, 100, 220, &[flag(12.2, 13.4)]));
        assert!(!flagged_by_checks(&time, 100, 220, &[flag(9.8, 11.0)]));
        assert!(!flagged_by_checks(&time, 100, 220, &[]));
        // a stride ending one past the last sample still has a middle
        assert!(flagged_by_checks(&time, 400, 500, &[flag(14.0, 15.0)]));
        assert!(!flagged_by_checks(&time, 600, 700, &[flag(0.0, 100.0)]));
    }
}
