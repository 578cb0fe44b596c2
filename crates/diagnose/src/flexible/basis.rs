//! The basis of one variable's flexible term (module `flexible`): piecewise-linear hats on
//! knots spread uniformly over the observed range of the variable (five; four for the TA;
//! about every 2 s in time), or `sign(q̇)` for direction, each column centred on its mean over
//! the compared samples except in time.

use crate::fit::Context;

use super::report::SearchedValue;
use super::variable::StateVariable;

/// The basis of one variable's flexible term: its columns, each centred on its mean over the
/// compared samples except in time (a constant is a function of time only: the catalogued
/// offset lives there), and the points at which its shape is reported with the basis row at
/// each.
#[derive(Clone, Debug)]
pub(crate) struct FlexBasis {
    pub variable: StateVariable,
    /// Points of the reported shape (variable units).
    pub points: Vec<f64>,
    /// Basis row (centred) at each point.
    pub rows: Vec<Vec<f64>>,
    /// Columns, one value per sample.
    pub cols: Vec<Vec<f64>>,
    /// Values found by searching the data rather than fitted as coefficients (a step's
    /// change point, a change of direction's width), each counted as a parameter in the BIC.
    pub searched: Vec<SearchedValue>,
    /// The hats fitted separately in the two directions of motion ([`by_direction`]): the
    /// points are the knots twice, first while `q̇ < 0`, then while `q̇ > 0`.
    pub by_direction: bool,
}

impl FlexBasis {
    /// The variables the term is a function of: its own, and the direction when it is
    /// fitted separately in each direction of motion.
    pub fn variables(&self) -> Vec<StateVariable> {
        if self.by_direction {
            vec![self.variable, StateVariable::Direction]
        } else {
            vec![self.variable]
        }
    }
}

/// The variables of the terms `b`, each once, in the terms' order.
pub(super) fn variables_of(b: &[FlexBasis]) -> Vec<StateVariable> {
    let mut out: Vec<StateVariable> = Vec::new();
    for v in b.iter().flat_map(FlexBasis::variables) {
        if !out.contains(&v) {
            out.push(v);
        }
    }
    out
}

/// Fraction of the largest speed below which the joint counts as still for `direction`.
pub(super) const STILL_FRACTION: f64 = 0.05;

/// Spacing of the time knots (s).
const TIME_KNOT_S: f64 = 2.0;

/// Knots of the hat bases (the TA's range is narrower: four).
fn knot_count(v: StateVariable) -> usize {
    match v {
        StateVariable::ActivationTa => 4,
        _ => 5,
    }
}

/// The variable per sample, `None` when the recording has no such variable (no TA channel)
/// or it does not change over the compared samples (no joint angle).
pub(super) fn series(ctx: &Context, v: StateVariable) -> Option<Vec<f64>> {
    let s = v.samples(&ctx.inputs)?;
    let (lo, hi) = observed_range(ctx, &s)?;
    (hi - lo > 1e-9 * (1.0 + hi.abs().max(lo.abs()))).then_some(s)
}

/// Smallest and largest value over the compared samples.
pub(super) fn observed_range(ctx: &Context, x: &[f64]) -> Option<(f64, f64)> {
    let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
    for (i, v) in x.iter().enumerate() {
        if ctx.is_observed(i) && v.is_finite() {
            lo = lo.min(*v);
            hi = hi.max(*v);
        }
    }
    (lo <= hi).then_some((lo, hi))
}

/// The uncentred basis functions of a variable at value `v`.
pub(super) enum Functions {
    /// Hat functions on uniform knots, constant beyond the ends.
    Hats(Vec<f64>),
    /// `sign(v)` outside `±still`, 0 inside: Coulomb friction's shape, one level for both
    /// directions (as parsimonious as viscous damping's `b·q̇`, which it is compared with).
    Sign { still: f64 },
    /// `tanh(v/width)`: the same shape with a transition `width` wide through zero speed.
    Tanh { width: f64 },
}

impl Functions {
    fn len(&self) -> usize {
        match self {
            Functions::Hats(knots) => knots.len(),
            Functions::Sign { .. } | Functions::Tanh { .. } => 1,
        }
    }

    pub(super) fn eval(&self, v: f64) -> Vec<f64> {
        if !v.is_finite() {
            // a sample without the variable gets no term
            return vec![0.0; self.len()];
        }
        match self {
            Functions::Hats(knots) => {
                let k = knots.len();
                let (lo, hi) = (knots[0], knots[k - 1]);
                let h = (hi - lo) / (k - 1) as f64;
                let u = ((v.clamp(lo, hi) - lo) / h).min((k - 1) as f64);
                let j = (u.floor() as usize).min(k - 2);
                let f = u - j as f64;
                let mut row = vec![0.0; k];
                row[j] = 1.0 - f;
                row[j + 1] = f;
                row
            }
            Functions::Sign { still } => vec![if v > *still {
                1.0
            } else if v < -*still {
                -1.0
            } else {
                0.0
            }],
            Functions::Tanh { width } => vec![(v / width).tanh()],
        }
    }
}

/// The flexible basis of `v` on this recording (module docs), `None` when it has no such
/// variable: hats for angle, velocity, acceleration and the activations, `sign(q̇)` for
/// direction, and hats about every 2 s for time (cross-validated on 0.5 s blocks, so a hat
/// is predicted from its neighbours; [`with_step`](super::forms::with_step) adds a step).
pub(crate) fn basis(ctx: &Context, v: StateVariable) -> Option<FlexBasis> {
    let s = series(ctx, v)?;
    let (lo, hi) = observed_range(ctx, &s)?;
    let (funcs, points) = match v {
        StateVariable::Direction => (sign_of_motion(lo, hi), vec![-1.0, 1.0]),
        StateVariable::Time => {
            // a knot every 2 s or so: local enough for a step, smooth over a 0.5 s block
            let k = (((hi - lo) / TIME_KNOT_S).round() as usize + 1).clamp(3, 12);
            let knots: Vec<f64> = (0..k)
                .map(|j| lo + (hi - lo) * j as f64 / (k - 1) as f64)
                .collect();
            (Functions::Hats(knots.clone()), knots)
        }
        _ => {
            let k = knot_count(v);
            let knots: Vec<f64> = (0..k)
                .map(|j| lo + (hi - lo) * j as f64 / (k - 1) as f64)
                .collect();
            (Functions::Hats(knots.clone()), knots)
        }
    };
    Some(from_functions(
        ctx,
        v,
        &s,
        &funcs,
        points,
        lo.abs().max(hi.abs()),
    ))
}

/// The variables whose basis the vocabulary test also splits by the direction of motion: a
/// moment that depends on the angle, the acceleration or the activation differently while the
/// ankle plantarflexes and while it dorsiflexes (a product of the direction with one of them)
/// is odd in the direction, so each variable's own hats, which are even in it, miss it.
/// The velocity's hats already tell the two directions apart, and time is not a state of the
/// motion.
pub(crate) const SPLIT_BY_DIRECTION: [StateVariable; 3] = [
    StateVariable::Angle,
    StateVariable::Acceleration,
    StateVariable::Activation,
];

/// `sign(q̇)` outside the still band of a velocity observed over `[lo, hi]`, 0 inside it.
fn sign_of_motion(lo: f64, hi: f64) -> Functions {
    Functions::Sign {
        still: STILL_FRACTION * lo.abs().max(hi.abs()),
    }
}

/// The direction of motion at every sample (`sign(q̇)`, 0 while the joint is still, as the
/// direction's own term), `None` when the recording has no motion.
pub(crate) fn direction_signs(ctx: &Context) -> Option<Vec<f64>> {
    let q = series(ctx, StateVariable::Direction)?;
    let (lo, hi) = observed_range(ctx, &q)?;
    let sign = sign_of_motion(lo, hi);
    Some(q.iter().map(|x| sign.eval(*x)[0]).collect())
}

/// The columns of a basis split by the direction of motion `d` ([`direction_signs`]): each
/// centred column times `d`. The direction's own column is not among them (the hats, centred,
/// sum to zero), so a test on them sees how the function differs between the directions
/// beyond a constant shift, which the direction's term tests.
pub(crate) fn split_by_direction(b: &FlexBasis, d: &[f64]) -> Vec<Vec<f64>> {
    b.cols
        .iter()
        .map(|c| c.iter().zip(d).map(|(a, s)| a * s).collect())
        .collect()
}

/// The basis `b` of a variable in [`SPLIT_BY_DIRECTION`] fitted separately in the two
/// directions of motion: its centred columns `h_j` and the same times the direction `d`
/// ([`split_by_direction`]), so that the term is `Σ_j (β_j + d γ_j) h_j(v)`, a function of
/// the variable while plantarflexing and another while dorsiflexing (while the joint is still,
/// `d = 0`, their mean). A product of the direction with the variable lives here and in
/// neither variable's own term. `None` for another variable, a form already searched (a
/// level step) or a recording without motion.
pub(crate) fn by_direction(ctx: &Context, b: &FlexBasis) -> Option<FlexBasis> {
    if !SPLIT_BY_DIRECTION.contains(&b.variable) || b.by_direction || !b.searched.is_empty() {
        return None;
    }
    let d = direction_signs(ctx)?;
    let mut cols = b.cols.clone();
    cols.extend(split_by_direction(b, &d));
    let mut points = b.points.clone();
    points.extend(b.points.iter().copied());
    let rows = [-1.0, 1.0]
        .iter()
        .flat_map(|s| {
            b.rows.iter().map(move |r| {
                let mut row = r.clone();
                row.extend(r.iter().map(|x| s * x));
                row
            })
        })
        .collect();
    Some(FlexBasis {
        variable: b.variable,
        points,
        rows,
        cols,
        searched: Vec::new(),
        by_direction: true,
    })
}

/// The basis of `v` (series `s`, largest magnitude `amax`) made of `funcs`, its shape reported
/// at `points` (for direction the two signs).
pub(super) fn from_functions(
    ctx: &Context,
    v: StateVariable,
    s: &[f64],
    funcs: &Functions,
    points: Vec<f64>,
    amax: f64,
) -> FlexBasis {
    let m = funcs.len();
    let mut cols = vec![vec![0.0; s.len()]; m];
    let (mut mean, mut cnt) = (vec![0.0; m], 0usize);
    for (i, x) in s.iter().enumerate() {
        let row = funcs.eval(*x);
        for j in 0..m {
            cols[j][i] = row[j];
        }
        if ctx.is_observed(i) {
            for j in 0..m {
                mean[j] += row[j];
            }
            cnt += 1;
        }
    }
    // centred, except in time: a constant is a function of time (the catalogued offset lives
    // there), and of no other variable
    for j in 0..m {
        mean[j] = if v == StateVariable::Time {
            0.0
        } else {
            mean[j] / cnt.max(1) as f64
        };
        cols[j].iter_mut().for_each(|c| *c -= mean[j]);
    }
    let rows = points
        .iter()
        .map(|p| {
            // for direction the points are the two signs themselves
            let at = if v == StateVariable::Direction {
                p * (1.0 + amax)
            } else {
                *p
            };
            funcs
                .eval(at)
                .iter()
                .zip(&mean)
                .map(|(a, b)| a - b)
                .collect()
        })
        .collect();
    FlexBasis {
        variable: v,
        points,
        rows,
        cols,
        searched: Vec::new(),
        by_direction: false,
    }
}

#[cfg(test)]
mod tests {
    use super::{basis, by_direction, direction_signs, Functions};
    use crate::flexible::{seed_context, StateVariable};

    #[test]
    fn a_basis_by_direction_adds_its_hats_times_the_direction_and_reports_both_shapes() {
        let ctx = seed_context();
        let d = direction_signs(&ctx).unwrap();
        assert!(d.contains(&1.0) && d.contains(&-1.0) && d.contains(&0.0));
        let b = basis(&ctx, StateVariable::Acceleration).unwrap();
        let s = by_direction(&ctx, &b).unwrap();
        let k = b.cols.len();
        assert!(s.by_direction && s.variable == StateVariable::Acceleration);
        assert_eq!(
            s.variables(),
            [StateVariable::Acceleration, StateVariable::Direction]
        );
        assert_eq!(s.cols.len(), 2 * k);
        for j in 0..k {
            assert_eq!(s.cols[j], b.cols[j]);
            for i in 0..d.len() {
                assert_eq!(s.cols[k + j][i], b.cols[j][i] * d[i]);
            }
        }
        // the knots twice: the row while plantarflexing, then while dorsiflexing
        let m = b.points.len();
        assert_eq!(s.points.len(), 2 * m);
        for p in 0..m {
            assert_eq!(s.points[p], b.points[p]);
            assert_eq!(s.points[m + p], b.points[p]);
            for j in 0..k {
                assert_eq!(s.rows[p][j], b.rows[p][j]);
                assert_eq!(s.rows[p][k + j], -b.rows[p][j]);
                assert_eq!(s.rows[m + p][k + j], b.rows[p][j]);
            }
        }
        // neither the velocity, nor time, nor a basis already split
        for v in [
            StateVariable::Velocity,
            StateVariable::Time,
            StateVariable::Direction,
        ] {
            assert!(
                by_direction(&ctx, &basis(&ctx, v).unwrap()).is_none(),
                "{v:?}"
            );
        }
        assert!(by_direction(&ctx, &s).is_none());
    }

    #[test]
    fn hats_interpolate_their_knot_values() {
        let f = Functions::Hats(vec![0.0, 1.0, 2.0, 3.0]);
        let beta = [2.0, -1.0, 4.0, 0.5];
        let want = |v: f64| {
            // the piecewise-linear interpolant of beta, constant beyond the ends
            let u = v.clamp(0.0, 3.0);
            let j = (u.floor() as usize).min(2);
            beta[j] + (beta[j + 1] - beta[j]) * (u - j as f64)
        };
        for v in [-1.0, 0.0, 0.25, 1.5, 3.0, 4.0] {
            let row = f.eval(v);
            let s: f64 = row.iter().zip(beta).map(|(a, b)| a * b).sum();
            assert!((s - want(v)).abs() < 1e-12, "at {v}: {s} vs {}", want(v));
            assert!((row.iter().sum::<f64>() - 1.0).abs() < 1e-12);
        }
    }

    #[test]
    fn sign_rows() {
        let s = Functions::Sign { still: 1.5 };
        assert_eq!(s.eval(30.0), vec![1.0]);
        assert_eq!(s.eval(-2.0), vec![-1.0]);
        assert_eq!(s.eval(1.0), vec![0.0]);
    }
}
