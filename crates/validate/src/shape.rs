//! Whether a held-out part's residual keeps a reproducible shape: the test of adequacy that
//! does not grade the model with a noise model fitted to its own residual
//! ([`numerics::cycle_shape`]).
//!
//! A part's *segments* are its strides that lie wholly inside it, or, for a trial without
//! strides (a CEINMS stance), the part itself. Each segment's residual `y − ŷ` over its judged
//! samples is cut into [`SHAPE_BINS`] phases. Two tests, each against the data's own scatter:
//!
//! * **across strides**: the sign-flip test over the held-out part's own strides (at least
//!   [`MIN_STRIDES`] of them) — does every stride miss in the same way?
//! * **against training**: the held-out shape (the mean over its segments) against the shape
//!   the calibration left in its training parts (the mean over their segments), by Student's
//!   t — does the residual the model could not remove where it was fitted come back where it
//!   was not?
//!
//! The part's p-value is the Bonferroni minimum of the tests it has; the residual *keeps a
//! reproducible shape* when `p < 10^−SHAPE_EVIDENCE`, the diagnosis's threshold for structure
//! (a false alarm in 10³ adequate models).

use std::ops::Range;

use numerics::cycle_shape::{sign_flip_test, template_test, PhaseShape, ShapeTestOutcome};
use serde::Serialize;

/// Phases a segment is cut into.
pub const SHAPE_BINS: usize = 10;
/// Strides a held-out part needs for the test across strides (the smallest p it can reach is
/// `2/2^K`: 1/512 for 10).
pub const MIN_STRIDES: usize = 10;
/// `−log10 p` above which a residual keeps a reproducible shape.
pub const SHAPE_EVIDENCE: f64 = 3.0;
/// Sign patterns drawn when a part has more than 16 strides.
const SIGN_FLIP_DRAWS: usize = 19_999;
/// Seed of the drawn sign patterns (results do not depend on the thread count).
const SIGN_FLIP_SEED: u64 = 0x5eed_5a9e;

/// The shape test of one held-out part (module docs).
#[derive(Clone, Debug, PartialEq, Serialize)]
#[non_exhaustive]
pub struct HeldOutShape {
    /// Segments of the held-out part (its strides, or 1).
    pub segments: usize,
    /// Segments of the training parts the template was taken from.
    pub training_segments: usize,
    /// The sign-flip test across the part's strides (`None` below [`MIN_STRIDES`]).
    pub across_strides: Option<ShapeTestOutcome>,
    /// The test of the held-out shape against the training residual's (`None` when either
    /// has no phase).
    pub against_training: Option<ShapeTestOutcome>,
    /// Bonferroni p-value of the tests run (1 when none could run).
    pub p_value: f64,
    /// Whether the residual keeps a reproducible shape (`p < 10^−3`).
    pub reproducible: bool,
    /// The held-out residual's mean phase shape (N·m, one value per phase; `null` for an
    /// empty phase).
    pub held_out_shape_nm: Vec<Option<f64>>,
    /// The training residual's mean phase shape (N·m).
    pub training_shape_nm: Vec<Option<f64>>,
}

/// The residual of one part: `measured − predicted` over the trial, the part's judged
/// `weights` over the trial, and the part's segments (sample ranges).
pub(crate) struct PartResidual<'a> {
    pub measured: &'a [f64],
    pub predicted: &'a [f64],
    pub weights: &'a [f64],
    pub segments: Vec<Range<usize>>,
}

impl PartResidual<'_> {
    fn shapes(&self) -> Vec<PhaseShape> {
        self.segments
            .iter()
            .map(|r| {
                let e: Vec<f64> = r
                    .clone()
                    .map(|i| self.measured[i] - self.predicted[i])
                    .collect();
                PhaseShape::of(&e, Some(&self.weights[r.clone()]), SHAPE_BINS)
            })
            .filter(|s| s.means.iter().any(|v| v.is_finite()))
            .collect()
    }
}

/// The shape test of `held` against the training parts `training` (module docs).
pub(crate) fn held_out_shape(
    held: &PartResidual<'_>,
    training: &[PartResidual<'_>],
) -> HeldOutShape {
    let held_shapes = held.shapes();
    let train_shapes: Vec<PhaseShape> = training.iter().flat_map(|t| t.shapes()).collect();
    let across_strides = if held.segments.len() >= MIN_STRIDES {
        sign_flip_test(&held_shapes, SIGN_FLIP_DRAWS, SIGN_FLIP_SEED)
    } else {
        None
    };
    let held_mean = PhaseShape::mean(&held_shapes);
    let train_mean = PhaseShape::mean(&train_shapes);
    let against_training = match (&held_mean, &train_mean) {
        (Some(h), Some(t)) => template_test(h, t),
        _ => None,
    };
    let tests: Vec<f64> = [across_strides, against_training]
        .iter()
        .flatten()
        .map(|t| t.p_value)
        .collect();
    let p_value = if tests.is_empty() {
        1.0
    } else {
        (tests.iter().fold(1.0f64, |a, b| a.min(*b)) * tests.len() as f64).min(1.0)
    };
    let finite = |s: Option<&PhaseShape>| -> Vec<Option<f64>> {
        s.map_or_else(
            || vec![None; SHAPE_BINS],
            |s| {
                s.means
                    .iter()
                    .map(|v| v.is_finite().then_some(*v))
                    .collect()
            },
        )
    };
    HeldOutShape {
        segments: held_shapes.len(),
        training_segments: train_shapes.len(),
        across_strides,
        against_training,
        p_value,
        reproducible: -p_value.max(1e-300).log10() > SHAPE_EVIDENCE,
        held_out_shape_nm: finite(held_mean.as_ref()),
        training_shape_nm: finite(train_mean.as_ref()),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A trial of `k` strides of 100 samples whose residual is `bump·sin` plus seeded noise
    /// that changes from stride to stride.
    fn trial(k: usize, bump: f64) -> (Vec<f64>, Vec<f64>, Vec<Range<usize>>) {
        use rand::{Rng, SeedableRng};
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(42);
        let n = 100 * k;
        let y: Vec<f64> = (0..n)
            .map(|i| {
                let ph = (i % 100) as f64 / 100.0;
                bump * (std::f64::consts::TAU * ph).sin() + rng.random_range(-2.0..2.0)
            })
            .collect();
        let segs = (0..k).map(|s| s * 100..(s + 1) * 100).collect();
        (y, vec![0.0; n], segs)
    }

    #[test]
    fn a_kept_shape_is_reproducible_and_noise_is_not() {
        for (bump, kept) in [(3.0, true), (0.0, false)] {
            let (y, pred, segs) = trial(24, bump);
            let w = vec![1.0; y.len()];
            let held = PartResidual {
                measured: &y,
                predicted: &pred,
                weights: &w,
                segments: segs[12..].to_vec(),
            };
            let train = PartResidual {
                measured: &y,
                predicted: &pred,
                weights: &w,
                segments: segs[..12].to_vec(),
            };
            let s = held_out_shape(&held, &[train]);
            assert_eq!(s.segments, 12);
            assert_eq!(s.training_segments, 12);
            assert!(s.across_strides.is_some() && s.against_training.is_some());
            assert_eq!(s.reproducible, kept, "{s:?}");
        }
    }

    #[test]
    fn one_stance_is_tested_against_training_only() {
        let (y, pred, _) = trial(2, 4.0);
        let w = vec![1.0; y.len()];
        let part = |r: Range<usize>| PartResidual {
            measured: &y,
            predicted: &pred,
            weights: &w,
            segments: vec![r],
        };
        let s = held_out_shape(&part(100..200), &[part(0..100)]);
        assert!(s.across_strides.is_none());
        assert!(
            s.against_training.is_some_and(|t| t.p_value < 1e-3),
            "{s:?}"
        );
        assert!(s.reproducible);
        // no training segment: nothing to test, not reproducible
        let alone = held_out_shape(&part(100..200), &[]);
        assert_eq!((alone.p_value, alone.reproducible), (1.0, false));
    }
}
