//! The folds of a validation: which samples of which trials calibrate the model and which are
//! predicted.
//!
//! * **Leave one trial out**: one fold per trial; the others calibrate, it is predicted whole.
//! * **Later strides**: one fold; the first `fraction` of every trial calibrates (cut at the
//!   start of the stride nearest to it when the trial's strides are known, so no stride is
//!   split), the rest of every trial is predicted. It asks whether a calibration carries forward
//!   in time on the same subject and task.
//! * **Leave one condition out**: one fold per `condition` label; the trials of the other
//!   conditions calibrate, the trials of this one are predicted (e.g. a calibration on slow
//!   walking predicting fast walking).

use std::ops::Range;

use serde::Serialize;

use crate::{ValidateError, ValidationTrial};

/// How a fold splits the session.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
#[non_exhaustive]
pub enum FoldScheme {
    /// Each trial predicted from the others.
    LeaveOneTrialOut,
    /// The later part of every trial predicted from the earlier parts.
    LaterStrides,
    /// Each condition's trials predicted from the other conditions'.
    LeaveOneConditionOut,
}

impl FoldScheme {
    /// Every scheme, in the order a report lists them.
    pub const ALL: [FoldScheme; 3] = [
        FoldScheme::LeaveOneTrialOut,
        FoldScheme::LaterStrides,
        FoldScheme::LeaveOneConditionOut,
    ];

    /// The scheme's name (`leave_one_trial_out`, `later_strides`, `leave_one_condition_out`).
    #[must_use]
    pub fn name(self) -> &'static str {
        match self {
            FoldScheme::LeaveOneTrialOut => "leave_one_trial_out",
            FoldScheme::LaterStrides => "later_strides",
            FoldScheme::LeaveOneConditionOut => "leave_one_condition_out",
        }
    }

    /// The scheme named `s` (its [`FoldScheme::name`], or `trial`, `strides`, `condition`).
    #[must_use]
    pub fn parse(s: &str) -> Option<Self> {
        match s {
            "leave_one_trial_out" | "trial" => Some(FoldScheme::LeaveOneTrialOut),
            "later_strides" | "strides" => Some(FoldScheme::LaterStrides),
            "leave_one_condition_out" | "condition" => Some(FoldScheme::LeaveOneConditionOut),
            _ => None,
        }
    }
}

/// The samples `samples` of trial `trial` (an index into the session's trials).
#[derive(Clone, Debug, PartialEq, Eq, Serialize)]
pub struct TrialPart {
    /// The trial's index.
    pub trial: usize,
    /// Its samples.
    pub samples: Range<usize>,
}

/// One fold: the parts that calibrate and the parts predicted.
#[derive(Clone, Debug, PartialEq, Serialize)]
#[non_exhaustive]
pub struct Fold {
    /// Its scheme.
    pub scheme: FoldScheme,
    /// Its name: the trial or condition held out, or `later_strides`.
    pub name: String,
    /// What calibrates.
    pub train: Vec<TrialPart>,
    /// What is predicted.
    pub test: Vec<TrialPart>,
}

/// The folds of `scheme` over `trials`; `fraction` is the calibrated share of each trial for
/// [`FoldScheme::LaterStrides`].
///
/// # Errors
/// Leave one trial out with fewer than two trials; leave one condition out with a trial that
/// has no condition label or with fewer than two conditions; a `fraction` outside (0, 1), or a
/// trial too short to split at it.
pub fn folds(
    scheme: FoldScheme,
    trials: &[ValidationTrial<'_>],
    fraction: f64,
) -> Result<Vec<Fold>, ValidateError> {
    let whole = |k: usize| TrialPart {
        trial: k,
        samples: 0..trials[k].problem.inputs().len(),
    };
    match scheme {
        FoldScheme::LeaveOneTrialOut => {
            if trials.len() < 2 {
                return Err(ValidateError::invalid(
                    "leave_one_trial_out",
                    "needs at least two trials",
                ));
            }
            Ok((0..trials.len())
                .map(|k| Fold {
                    scheme,
                    name: trials[k].name.to_string(),
                    train: (0..trials.len()).filter(|&j| j != k).map(whole).collect(),
                    test: vec![whole(k)],
                })
                .collect())
        }
        FoldScheme::LaterStrides => {
            if !(fraction > 0.0 && fraction < 1.0) {
                return Err(ValidateError::invalid(
                    "later_strides",
                    format!("the calibrated fraction {fraction} is not within (0, 1)"),
                ));
            }
            let mut train = Vec::with_capacity(trials.len());
            let mut test = Vec::with_capacity(trials.len());
            for (k, t) in trials.iter().enumerate() {
                let n = t.problem.inputs().len();
                let cut = split_at(n, fraction, t.stride_starts);
                if cut == 0 || cut >= n {
                    return Err(ValidateError::invalid(
                        t.name,
                        format!(
                            "too short to split at {:.0} % of its samples",
                            100.0 * fraction
                        ),
                    ));
                }
                train.push(TrialPart {
                    trial: k,
                    samples: 0..cut,
                });
                test.push(TrialPart {
                    trial: k,
                    samples: cut..n,
                });
            }
            Ok(vec![Fold {
                scheme,
                name: "later_strides".into(),
                train,
                test,
            }])
        }
        FoldScheme::LeaveOneConditionOut => {
            let mut conditions: Vec<&str> = Vec::new();
            for t in trials {
                let c = t.condition.ok_or_else(|| {
                    ValidateError::invalid(
                        t.name,
                        "has no condition label (\"condition\" in the session manifest)",
                    )
                })?;
                if !conditions.contains(&c) {
                    conditions.push(c);
                }
            }
            if conditions.len() < 2 {
                return Err(ValidateError::invalid(
                    "leave_one_condition_out",
                    format!(
                        "needs trials of at least two conditions (all are {})",
                        conditions.first().copied().unwrap_or("unlabelled")
                    ),
                ));
            }
            Ok(conditions
                .iter()
                .map(|c| Fold {
                    scheme,
                    name: (*c).to_string(),
                    train: (0..trials.len())
                        .filter(|&j| trials[j].condition != Some(c))
                        .map(whole)
                        .collect(),
                    test: (0..trials.len())
                        .filter(|&j| trials[j].condition == Some(c))
                        .map(whole)
                        .collect(),
                })
                .collect())
        }
    }
}

/// The sample at which a trial of `n` samples is split: `fraction·n`, moved to the nearest
/// stride start when the strides are known (a stride is never split between the parts).
fn split_at(n: usize, fraction: f64, stride_starts: Option<&[usize]>) -> usize {
    let target = (fraction * n as f64).round() as usize;
    match stride_starts {
        Some(starts) if !starts.is_empty() => *starts
            .iter()
            .min_by_key(|&&s| s.abs_diff(target))
            .unwrap_or(&target),
        _ => target,
    }
}

#[cfg(test)]
mod tests {
    use super::split_at;

    #[test]
    fn a_split_moves_to_the_nearest_stride_start() {
        assert_eq!(split_at(1000, 0.5, None), 500);
        assert_eq!(split_at(1000, 0.5, Some(&[100, 480, 560, 900])), 480);
        assert_eq!(split_at(1000, 0.5, Some(&[])), 500);
    }
}
