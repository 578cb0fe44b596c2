//! The search set of a calibration on long recordings: windows of strides spread evenly over
//! the judged samples of every trial, each after a lead-in, for [`crate::identify_set_with_search`].
//!
//! A chain's annealing evaluates the model thousands of times, and each evaluation costs what
//! the integrated length costs; on 60 s of steady walking most strides repeat what the others
//! say. With the judged length `T` of the set and the search's length `S`
//! ([`SearchSettings::judged_s`], 5 s: two or three windows of two strides of walking), a set
//! with `T ≤ 1.5·S` is searched as it is; a longer one by `k = ⌈S / d̄⌉` of its `N` candidate
//! windows (runs of [`SearchSettings::strides_per_window`] strides, else chunks of
//! [`SearchSettings::chunk_s`]; `d̄` their mean duration), window `⌊(j + ½)·N/k⌋` for
//! `j = 0…k−1` in trial order, so that every part of
//! every trial is represented. A window is integrated from [`SearchSettings::lead_in_s`] before
//! its start (weighted 0), which covers the longest electromechanical delay (150 ms) and lets
//! activation (τ ≤ 50 ms) and fibres forget the equilibrium start.

use muscle_model::{Problem, ProblemSet};
use serde::{Deserialize, Serialize};

use crate::Error;

/// How a long set's search windows are chosen.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct SearchSettings {
    /// Judged seconds of the search set (5).
    pub judged_s: f64,
    /// Lead-in integrated before each window, weighted 0 (0.4 s).
    pub lead_in_s: f64,
    /// Consecutive strides in one window (2): a window's lead-in and the integrator's first
    /// steps are a cost per window, not per stride.
    pub strides_per_window: usize,
    /// Length of a window where a trial has no strides (2.4 s, about two strides of walking).
    pub chunk_s: f64,
}

impl Default for SearchSettings {
    fn default() -> Self {
        SearchSettings {
            judged_s: 5.0,
            lead_in_s: 0.4,
            strides_per_window: 2,
            chunk_s: 2.4,
        }
    }
}

/// The search set of `set`, whose trial `i` has its strides starting at the samples
/// `cycles[i]` (`None`: no strides known); `None` when `set` is short enough to search as it
/// is (module doc). Only windows whose every sample is judged (weight > 0) are candidates, so
/// held-out samples never enter the search.
///
/// # Errors
/// [`Error::Search`] for `cycles` of another length than the set or a setting that is not
/// positive; [`Error::Model`] when a window cannot be cut.
pub fn search_set(
    set: &ProblemSet,
    cycles: &[Option<&[usize]>],
    s: &SearchSettings,
) -> Result<Option<ProblemSet>, Error> {
    if cycles.len() != set.len() {
        return Err(Error::Search(
            "one list of stride starts per trial is needed",
        ));
    }
    if !(s.judged_s > 0.0 && s.lead_in_s >= 0.0 && s.chunk_s > 0.0 && s.strides_per_window > 0) {
        return Err(Error::Search("its lengths must be positive"));
    }
    let mut judged_s = 0.0;
    let mut candidates: Vec<(usize, std::ops::Range<usize>)> = Vec::new();
    for (i, p) in set.problems().iter().enumerate() {
        let fs = p.inputs().fs();
        let judged: Vec<bool> = (0..p.inputs().len())
            .map(|k| p.weights().is_none_or(|w| w[k] > 0.0))
            .collect();
        judged_s += judged.iter().filter(|&&j| j).count() as f64 / fs;
        let all_judged =
            |r: &std::ops::Range<usize>| r.len() >= 2 && judged[r.clone()].iter().all(|&j| j);
        match cycles[i] {
            Some(starts) => {
                let per = s.strides_per_window;
                let mut k = 0;
                while k + per < starts.len() {
                    let r = starts[k]..starts[k + per].min(judged.len());
                    if all_judged(&r) {
                        candidates.push((i, r));
                        k += per;
                    } else {
                        k += 1;
                    }
                }
            }
            None => {
                let len = ((s.chunk_s * fs).round() as usize).max(2);
                let mut k = 0;
                while k + len <= judged.len() {
                    let r = k..k + len;
                    if all_judged(&r) {
                        candidates.push((i, r));
                        k += len;
                    } else {
                        k += 1;
                    }
                }
            }
        }
    }
    if judged_s <= 1.5 * s.judged_s || candidates.is_empty() {
        return Ok(None);
    }
    let seconds = |(i, r): &(usize, std::ops::Range<usize>)| {
        r.len() as f64 / set.problems()[*i].inputs().fs()
    };
    let mean_s = candidates.iter().map(seconds).sum::<f64>() / candidates.len() as f64;
    let n = candidates.len();
    let k = ((s.judged_s / mean_s).ceil() as usize).clamp(1, n);
    let windows = (0..k)
        .map(|j| {
            let (i, r) = &candidates[((j as f64 + 0.5) * n as f64 / k as f64) as usize];
            let p: &Problem = &set.problems()[*i];
            let lead = (s.lead_in_s * p.inputs().fs()).round() as usize;
            p.window(r.clone(), lead)
        })
        .collect::<Result<Vec<_>, _>>()?;
    Ok(Some(ProblemSet::new(windows)?))
}

#[cfg(test)]
mod tests {
    use super::*;
    use muscle_model::synthetic;

    fn problem(seconds: f64) -> Problem {
        let tr = synthetic::gait_like_trial(100.0, seconds).unwrap();
        let n = tr.len();
        Problem::standard(tr, vec![1.0; n]).unwrap()
    }

    #[test]
    fn a_short_set_is_searched_as_it_is() {
        let set = ProblemSet::single(problem(7.0));
        assert!(search_set(&set, &[None], &SearchSettings::default())
            .unwrap()
            .is_none());
    }

    #[test]
    fn strides_spread_over_the_trial_make_the_search_and_held_out_samples_never_do() {
        let p = problem(60.0);
        let n = p.inputs().len();
        // strides of 1.15 s; the later half held out
        let starts: Vec<usize> = (0..).map(|k| 50 + k * 115).take_while(|&s| s < n).collect();
        let held_out = n / 2;
        let w: Vec<f64> = (0..n)
            .map(|k| if k < held_out { 1.0 } else { 0.0 })
            .collect();
        let set = ProblemSet::single(p.with_weights(w).unwrap());
        let s = SearchSettings::default();
        let search = search_set(&set, &[Some(&starts)], &s).unwrap().unwrap();
        // ⌈5 / 2.3⌉ = 3 windows of two strides, each after a 0.4 s lead-in
        assert_eq!(search.len(), 3);
        let mut last_t0 = f64::NEG_INFINITY;
        for w in search.problems() {
            assert_eq!(w.inputs().len(), 230 + 40);
            let t0 = w.inputs().t0();
            assert!(t0 > last_t0);
            last_t0 = t0;
            let end_s = t0 + (w.inputs().len() - 1) as f64 / 100.0;
            assert!(
                end_s < held_out as f64 / 100.0,
                "a window reaches the held-out half"
            );
        }
        let judged = search.weight_sum() / 100.0;
        assert!((judged - 3.0 * 2.3).abs() < 1e-9, "{judged}");
        // spread: the first window in the first sixth, the last in the last quarter of the half
        let t0s: Vec<f64> = search
            .problems()
            .iter()
            .map(|w| w.inputs().t0() + 0.4)
            .collect();
        assert!(t0s[0] < 6.0 && t0s[2] > 20.0, "{t0s:?}");
    }

    #[test]
    fn without_strides_the_search_takes_chunks_and_bad_arguments_are_errors() {
        let set = ProblemSet::single(problem(30.0));
        let s = SearchSettings::default();
        let search = search_set(&set, &[None], &s).unwrap().unwrap();
        assert_eq!(search.len(), 3, "⌈5 / 2.4⌉ chunks");
        assert!(search_set(&set, &[], &s).is_err());
        let bad = SearchSettings { judged_s: 0.0, ..s };
        assert!(search_set(&set, &[None], &bad).is_err());
    }
}
