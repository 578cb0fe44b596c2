//! Whether a residual keeps a shape locked to the motion's cycle (a stride, a stance, a
//! dynamometer cycle) — tested against the scatter of the data themselves, never against a
//! noise model fitted to the same residual.
//!
//! A *segment* is one cycle's residual, its judged samples in time order. [`PhaseShape::of`]
//! cuts it into `B` equal parts of its judged span (phase `0…1`) and keeps each part's mean
//! `m_b`. A model that is adequate leaves segments whose phase means scatter around zero
//! independently from cycle to cycle; a missing mechanism leaves the same shape in every one.
//! Two tests ask that question with different references:
//!
//! * **Across cycles** ([`sign_flip_test`]), for `K` segments of one recording: the statistic
//!   `T = Σ_b (Σ_k m_kb)²` is the squared size of the cycles' summed shape. Under the null
//!   hypothesis (every segment's shape symmetric about zero and independent of the others)
//!   each sign pattern `s ∈ {±1}^K` of `T(s) = Σ_b (Σ_k s_k m_kb)²` is equally likely, so
//!   `p = #{s : T(s) ≥ T(1)} / #s` over every pattern (`K ≤ 16`) or over `1 + draws` seeded
//!   patterns, the observed one among them. The reference is the cycle-to-cycle scatter at
//!   matched phase: no noise model, no assumption about correlation within a cycle.
//!   The smallest attainable `p` is `2/2^K`.
//! * **Against a template** ([`template_test`]), a held-out shape `m` against the shape `t`
//!   the model left elsewhere (its training data, the other trials): the least-squares factor
//!   `β̂ = Σ m_b t_b / Σ t_b²`, its residual `e = m − β̂ t`, `s² = Σ e_b² / (B' − 1)` over the
//!   `B'` phases both have, and `t = β̂ √(Σ t_b²) / s` against Student's t with `B' − 1`
//!   degrees of freedom, one-sided (the same shape, not its mirror). The reference is how far
//!   the held-out shape departs from the template, phase by phase.
//!
//! ```
//! use numerics::cycle_shape::{sign_flip_test, template_test, PhaseShape};
//! // ten cycles that all keep a bump at mid-phase, with scatter
//! let cycles: Vec<PhaseShape> = (0..10)
//!     .map(|k| {
//!         let r: Vec<f64> = (0..100)
//!             .map(|i| {
//!                 let ph = i as f64 / 100.0;
//!                 5.0 * (-(ph - 0.5f64).powi(2) / 0.01).exp() + ((k * 7 + i) % 5) as f64 - 2.0
//!             })
//!             .collect();
//!         PhaseShape::of(&r, None, 10)
//!     })
//!     .collect();
//! let across = sign_flip_test(&cycles, 9_999, 1).unwrap();
//! assert!(across.p_value < 0.01);
//! let held = PhaseShape::mean(&cycles[5..]).unwrap();
//! let template = PhaseShape::mean(&cycles[..5]).unwrap();
//! assert!(template_test(&held, &template).unwrap().p_value < 1e-3);
//! ```

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use crate::special::t_survival;

/// The phase means of one segment (or the mean of several): `B` values, NaN where no judged
/// sample fell in the phase.
#[derive(Clone, Debug, PartialEq)]
pub struct PhaseShape {
    /// Mean residual per phase bin (NaN for an empty bin).
    pub means: Vec<f64>,
}

impl PhaseShape {
    /// The shape of one segment: `values` in time order, `weights` (`None`: all judged) leave
    /// out the samples of weight `≤ 0`; the judged span, from the first to the last judged
    /// sample, is cut into `bins` equal phases by sample position.
    pub fn of(values: &[f64], weights: Option<&[f64]>, bins: usize) -> Self {
        let judged = |i: usize| weights.is_none_or(|w| w.get(i).is_some_and(|v| *v > 0.0));
        let first = (0..values.len()).find(|&i| judged(i));
        let last = (0..values.len()).rev().find(|&i| judged(i));
        let mut sum = vec![0.0; bins];
        let mut count = vec![0usize; bins];
        if let (Some(a), Some(b)) = (first, last) {
            let span = (b + 1 - a) as f64;
            for (i, v) in values.iter().enumerate().take(b + 1).skip(a) {
                if judged(i) && v.is_finite() {
                    let k = (((i - a) as f64 / span) * bins as f64) as usize;
                    let k = k.min(bins - 1);
                    sum[k] += v;
                    count[k] += 1;
                }
            }
        }
        PhaseShape {
            means: sum
                .iter()
                .zip(&count)
                .map(|(s, c)| if *c > 0 { s / *c as f64 } else { f64::NAN })
                .collect(),
        }
    }

    /// The phase-by-phase mean of several shapes of the same length (each counting once; a
    /// phase empty in one shape is averaged over the others). `None` for no shape or shapes
    /// of different lengths.
    pub fn mean(shapes: &[PhaseShape]) -> Option<Self> {
        let b = shapes.first()?.means.len();
        if shapes.iter().any(|s| s.means.len() != b) {
            return None;
        }
        let means = (0..b)
            .map(|j| {
                let v: Vec<f64> = shapes
                    .iter()
                    .map(|s| s.means[j])
                    .filter(|v| v.is_finite())
                    .collect();
                if v.is_empty() {
                    f64::NAN
                } else {
                    v.iter().sum::<f64>() / v.len() as f64
                }
            })
            .collect();
        Some(PhaseShape { means })
    }

    /// The number of phases.
    pub fn bins(&self) -> usize {
        self.means.len()
    }
}

/// The outcome of a shape test.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize))]
pub struct ShapeTestOutcome {
    /// The test statistic (`T` in N·m² for the sign-flip test, Student's `t` for the template).
    pub statistic: f64,
    /// One-sided p-value.
    pub p_value: f64,
    /// The segments (sign-flip) or phases (template) the test used.
    pub used: usize,
}

/// The sign-flip test across cycles (module docs): the phases every shape has are used, the
/// patterns are enumerated for up to 16 shapes and otherwise drawn (`draws` of them, from
/// `ChaCha8Rng::seed_from_u64(seed)`). `None` for fewer than 2 shapes, shapes of different
/// lengths or no phase common to all.
pub fn sign_flip_test(shapes: &[PhaseShape], draws: usize, seed: u64) -> Option<ShapeTestOutcome> {
    let k = shapes.len();
    let b = shapes.first()?.means.len();
    if k < 2 || shapes.iter().any(|s| s.means.len() != b) {
        return None;
    }
    let phases: Vec<usize> = (0..b)
        .filter(|&j| shapes.iter().all(|s| s.means[j].is_finite()))
        .collect();
    if phases.is_empty() {
        return None;
    }
    let stat = |signs: &dyn Fn(usize) -> f64| -> f64 {
        phases
            .iter()
            .map(|&j| {
                let s: f64 = (0..k).map(|c| signs(c) * shapes[c].means[j]).sum();
                s * s
            })
            .sum()
    };
    let observed = stat(&|_| 1.0);
    // a pattern and its mirror give the same T: count each pair once
    let tol = 1e-12 * observed.abs();
    let (hits, total) = if k <= 16 {
        let mut hits = 0usize;
        let patterns = 1usize << (k - 1);
        for bits in 0..patterns {
            let t = stat(&|c| if (bits >> c) & 1 == 1 { -1.0 } else { 1.0 });
            if t >= observed - tol {
                hits += 1;
            }
        }
        (hits, patterns)
    } else {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let mut signs = vec![1.0; k];
        let mut hits = 1usize;
        for _ in 0..draws {
            for s in signs.iter_mut() {
                *s = if rng.random::<bool>() { 1.0 } else { -1.0 };
            }
            if stat(&|c| signs[c]) >= observed - tol {
                hits += 1;
            }
        }
        (hits, draws + 1)
    };
    Some(ShapeTestOutcome {
        statistic: observed,
        p_value: hits as f64 / total as f64,
        used: k,
    })
}

/// The template test (module docs) of `held` against `template`. `None` for shapes of
/// different lengths, fewer than 3 phases both have, or a template of zero size.
pub fn template_test(held: &PhaseShape, template: &PhaseShape) -> Option<ShapeTestOutcome> {
    if held.means.len() != template.means.len() {
        return None;
    }
    let pairs: Vec<(f64, f64)> = held
        .means
        .iter()
        .zip(&template.means)
        .filter(|(m, t)| m.is_finite() && t.is_finite())
        .map(|(m, t)| (*m, *t))
        .collect();
    let n = pairs.len();
    let tt: f64 = pairs.iter().map(|(_, t)| t * t).sum();
    if n < 3 || tt.is_nan() || tt <= 0.0 {
        return None;
    }
    let beta = pairs.iter().map(|(m, t)| m * t).sum::<f64>() / tt;
    let ss: f64 = pairs.iter().map(|(m, t)| (m - beta * t).powi(2)).sum();
    let df = (n - 1) as f64;
    let s = (ss / df).sqrt();
    let statistic = if s > 0.0 {
        beta * tt.sqrt() / s
    } else if beta > 0.0 {
        f64::INFINITY
    } else {
        f64::NEG_INFINITY
    };
    let p_value = if statistic.is_infinite() {
        if statistic > 0.0 {
            0.0
        } else {
            1.0
        }
    } else {
        t_survival(statistic, df)
    };
    Some(ShapeTestOutcome {
        statistic,
        p_value,
        used: n,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::Rng;

    fn noise_cycles(k: usize, seed: u64, bump: f64) -> Vec<PhaseShape> {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        (0..k)
            .map(|_| {
                let r: Vec<f64> = (0..200)
                    .map(|i| {
                        let ph = i as f64 / 200.0;
                        let z: f64 = (0..12).map(|_| rng.random::<f64>()).sum::<f64>() - 6.0;
                        bump * (std::f64::consts::TAU * ph).sin() + 3.0 * z
                    })
                    .collect();
                PhaseShape::of(&r, None, 10)
            })
            .collect()
    }

    #[test]
    fn phases_use_judged_samples_only() {
        let v = [9.0, 1.0, 2.0, 9.0, 3.0, 4.0, 9.0];
        let w = [0.0, 1.0, 1.0, 0.0, 1.0, 1.0, 0.0];
        // judged span 1..=5 (5 samples) in 2 phases: samples 1, 2 | 4, 5 (3 is not judged)
        let s = PhaseShape::of(&v, Some(&w), 2);
        assert_eq!(s.means, vec![1.5, 3.5]);
        let empty = PhaseShape::of(&v, Some(&[0.0; 7]), 3);
        assert!(empty.means.iter().all(|m| m.is_nan()));
    }

    #[test]
    fn sign_flip_is_uniform_under_the_null() {
        // 200 sets of 8 pure-noise cycles: p ≤ 0.05 in about 5 % of them (binomial band)
        let mut small = 0;
        for seed in 0..200 {
            let p = sign_flip_test(&noise_cycles(8, 1000 + seed, 0.0), 0, 0)
                .unwrap()
                .p_value;
            if p <= 0.05 {
                small += 1;
            }
        }
        assert!((2..=20).contains(&small), "{small} of 200 below 0.05");
    }

    #[test]
    fn sign_flip_finds_a_shared_shape() {
        let with = sign_flip_test(&noise_cycles(12, 7, 3.0), 0, 0).unwrap();
        assert!(with.p_value < 1e-3, "{with:?}");
        // more than 16 cycles: drawn patterns, reproducible by seed
        let many = noise_cycles(30, 8, 3.0);
        let a = sign_flip_test(&many, 4_999, 11).unwrap();
        assert_eq!(a, sign_flip_test(&many, 4_999, 11).unwrap());
        assert!(a.p_value <= 1e-3 && a.p_value >= 1.0 / 5_000.0, "{a:?}");
        assert!(sign_flip_test(&many[..1], 10, 0).is_none());
    }

    #[test]
    fn template_test_tells_the_same_shape_from_another() {
        let train = PhaseShape::mean(&noise_cycles(10, 21, 4.0)).unwrap();
        let held = PhaseShape::mean(&noise_cycles(10, 22, 4.0)).unwrap();
        assert!(template_test(&held, &train).unwrap().p_value < 1e-3);
        // the mirror shape is not "kept"
        let mirror = PhaseShape {
            means: held.means.iter().map(|v| -v).collect(),
        };
        assert!(template_test(&mirror, &train).unwrap().p_value > 0.5);
        // null: held-out noise against a template, p ≤ 0.05 in about 5 % of 200 trials
        let mut small = 0;
        for seed in 0..200 {
            let h = PhaseShape::mean(&noise_cycles(3, 5000 + seed, 0.0)).unwrap();
            if template_test(&h, &train).unwrap().p_value <= 0.05 {
                small += 1;
            }
        }
        assert!((2..=20).contains(&small), "{small} of 200 below 0.05");
    }
}
