//! Scores stride by stride inside a held-out part: a part's single RMS error hides whether the
//! model misses every stride a little or a few strides badly (a stride the recording checks
//! flag, a stumble), and which strides those are.
//!
//! A stride `k` runs from its foot strike `start_k` to the next, `end_k` (exclusive), as in
//! `experiment::Stride`. It is scored when it lies wholly inside the held-out samples; its
//! score is [`FitScore::of`] with the part's judged weights on `start_k..end_k` and 0 elsewhere
//! (the same weights the part is judged by, so the strides' scores add up to the part's).

use std::collections::BTreeMap;
use std::ops::Range;

use serde::Serialize;

use crate::score::FitScore;
use crate::ValidationTrial;

/// One stride of a held-out part, scored.
#[derive(Clone, Debug, PartialEq, Serialize)]
#[non_exhaustive]
pub struct StrideScore {
    /// The stride's index among the trial's strides.
    pub stride: usize,
    /// Time of its foot strike (s).
    pub start_s: f64,
    /// Time of the next foot strike, where it ends (s).
    pub end_s: f64,
    /// Whether the recording checks flagged it as implausible (`checks.strides.flagged`).
    pub flagged: bool,
    /// Samples judged in it (positive weight).
    pub samples: usize,
    /// The calibrated model.
    pub model: FitScore,
    /// The linear baseline.
    pub linear: FitScore,
    /// Each peer, by name.
    pub peers: BTreeMap<String, FitScore>,
    /// Its samples (indices into the trial).
    #[serde(skip)]
    pub samples_range: Range<usize>,
}

/// The trial's strides as `(start, end, flagged)`: `end` from `stride_ends`, else the next
/// stride's start (so without `stride_ends` the last stride, whose end is unknown, is left
/// out).
pub(crate) fn stride_spans(trial: &ValidationTrial<'_>) -> Vec<(usize, usize, bool)> {
    let Some(starts) = trial.stride_starts else {
        return Vec::new();
    };
    starts
        .iter()
        .enumerate()
        .filter_map(|(k, &start)| {
            let end = match trial.stride_ends {
                Some(ends) => ends.get(k).copied(),
                None => starts.get(k + 1).copied(),
            }?;
            let flagged = trial
                .stride_flagged
                .and_then(|f| f.get(k).copied())
                .unwrap_or(false);
            Some((start, end, flagged))
        })
        .collect()
}

/// The scores of every stride of `trial` wholly inside `part` (its samples), `weights` the
/// part's judged weights over the whole trial, and `model`, `linear` and each peer's
/// predictions over the whole trial.
pub(crate) fn stride_scores(
    trial: &ValidationTrial<'_>,
    part: &Range<usize>,
    weights: &[f64],
    model: &[f64],
    linear: &[f64],
    peers: &[(&str, &[f64])],
) -> Vec<StrideScore> {
    let y = trial.problem.measured();
    let times = trial.problem.inputs().times();
    let n = y.len();
    // the next strike of the last stride may be one sample past the trial: its time is
    // extrapolated by one sampling interval, as the recording checks do
    let dt = if n >= 2 { times[1] - times[0] } else { 0.0 };
    let time_at = |i: usize| {
        times
            .get(i)
            .copied()
            .unwrap_or_else(|| times[n - 1] + (i + 1 - n) as f64 * dt)
    };
    stride_spans(trial)
        .into_iter()
        .enumerate()
        .filter(|(_, (a, b, _))| a < b && *a >= part.start && *b <= part.end && *b <= n)
        .map(|(k, (a, b, flagged))| {
            let w = &weights[a..b];
            let score = |p: &[f64]| FitScore::of(&y[a..b], &p[a..b], w);
            StrideScore {
                stride: k,
                start_s: time_at(a),
                end_s: time_at(b),
                flagged,
                samples: w.iter().filter(|v| **v > 0.0).count(),
                model: score(model),
                linear: score(linear),
                peers: peers
                    .iter()
                    .map(|(name, p)| ((*name).to_string(), score(p)))
                    .collect(),
                samples_range: a..b,
            }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use muscle_model::Problem;

    fn problem() -> Problem {
        let syn =
            experiment::synthesize(&experiment::SynthConfig::new(experiment::Protocol::Seed, 3))
                .unwrap();
        Problem::standard(syn.inputs.clone(), syn.model_torque.clone()).unwrap()
    }

    fn trial<'a>(
        p: &'a Problem,
        starts: &'a [usize],
        ends: Option<&'a [usize]>,
        flagged: Option<&'a [bool]>,
    ) -> ValidationTrial<'a> {
        ValidationTrial {
            name: "t",
            condition: None,
            problem: p,
            stride_starts: Some(starts),
            stride_ends: ends,
            stride_flagged: flagged,
        }
    }

    #[test]
    fn only_strides_inside_the_part_are_scored_and_their_scores_add_up_to_the_parts() {
        let p = problem();
        let n = p.measured().len();
        assert!(n > 400, "{n}");
        let starts = [0, 100, 200, 300];
        let ends = [100, 200, 300, 400];
        let flagged = [false, false, true, false];
        let t = trial(&p, &starts, Some(&ends), Some(&flagged));
        // a prediction off by a stride-dependent offset: the per-stride RMS is the offset
        let offset = |i: usize| (i / 100) as f64 + 1.0;
        let model: Vec<f64> = p
            .measured()
            .iter()
            .enumerate()
            .map(|(i, y)| y + offset(i))
            .collect();
        let part = 100..400;
        let w: Vec<f64> = (0..n)
            .map(|i| if part.contains(&i) { 1.0 } else { 0.0 })
            .collect();
        let s = stride_scores(&t, &part, &w, &model, p.measured(), &[("peer", &model)]);
        assert_eq!(
            s.iter().map(|x| x.stride).collect::<Vec<_>>(),
            vec![1, 2, 3]
        );
        assert_eq!(
            s.iter().map(|x| x.flagged).collect::<Vec<_>>(),
            vec![false, true, false]
        );
        let times = p.inputs().times();
        assert_eq!(s[0].start_s, times[100]);
        assert_eq!(s[0].end_s, times[200]);
        for x in &s {
            assert_eq!(x.samples, 100);
            assert!((x.model.rms_nm - offset(x.samples_range.start)).abs() < 1e-9);
            assert_eq!(x.linear.rms_nm, 0.0);
            assert_eq!(x.peers["peer"], x.model);
        }
        // the strides tile the part: their weighted mean square is the part's
        let part_score = FitScore::of(p.measured(), &model, &w);
        let ms: f64 = s.iter().map(|x| x.model.rms_nm.powi(2)).sum::<f64>() / 3.0;
        assert!((ms.sqrt() - part_score.rms_nm).abs() < 1e-9);
    }

    #[test]
    fn without_ends_a_stride_ends_at_the_next_start_and_the_last_is_left_out() {
        let p = problem();
        let starts = [10, 50, 90];
        let t = trial(&p, &starts, None, None);
        assert_eq!(stride_spans(&t), vec![(10, 50, false), (50, 90, false)]);
        let no = ValidationTrial {
            stride_starts: None,
            ..t
        };
        assert!(stride_spans(&no).is_empty());
    }

    #[test]
    fn a_stride_past_the_trial_is_not_scored_and_one_ending_at_it_has_an_extrapolated_end() {
        let p = problem();
        let n = p.measured().len();
        let starts = [n - 50, n];
        let ends = [n, n + 40];
        let t = trial(&p, &starts, Some(&ends), None);
        let w = vec![1.0; n];
        let y = p.measured();
        let s = stride_scores(&t, &(0..n), &w, y, y, &[]);
        assert_eq!(s.len(), 1);
        let times = p.inputs().times();
        let dt = times[1] - times[0];
        assert!((s[0].end_s - (times[n - 1] + dt)).abs() < 1e-12);
    }
}
