//! Flexible terms: what a structure no catalogued effect explains depends on, and a model
//! extended with it (docs/diagnosis.md, "Beyond the catalogue").
//!
//! A flexible term in a state variable `v` adds to the model torque
//!
//! ```text
//! τ += Σ_j β_j h_j(v(t))
//! ```
//!
//! with piecewise-linear hat functions `h_j` on knots spread uniformly over the observed range
//! of `v` (five; four for the TA; about every 2 s in time), or, for `direction`, the single
//! column `sign(q̇)` (0 while the joint is still). Time is also tried with a step `1{t ≥ τ}`
//! added at the residual's most likely change point (`with_step`), and direction as
//! `tanh(q̇/w)` with the transition width `w` searched on the residual (`with_width`); the
//! better of the two forms (held-out gain in the ranking, BIC in the review) stands for the
//! variable, a searched value counting as one parameter in the BIC. Columns are centred on
//! their mean over the trial except in time (a constant is a function of time only). The vocabulary: `angle` (°),
//! `velocity` (°/s), `direction`, `acceleration` (°/s²), `time` (s), `activation` (the mean
//! normalised triceps surae envelope) and `activation_ta` (the normalised tibialis anterior
//! envelope).
//!
//! **Fit.** The term is linear in `β`, so it is fitted by variable projection: for muscle
//! (and effect) parameters `x` the whitened residual `w(x) = W(y − τ̂(x))` is projected off the
//! whitened basis `WB` (`β̂(x)` by least squares, rank-revealing), and the bounded
//! Levenberg–Marquardt of the catalogued effects refits `x` on `‖(I − UUᵀ)w(x)‖²`, `U` the
//! left singular vectors of `WB`. The noise model and the whitening are those of the
//! catalogued effects, and so are the cross-validation folds, except for a term in time,
//! cross-validated on 0.5 s blocks in 5 folds (`time_folds`) and compared with the final
//! model on the same blocks. In each fold the basis is whitened over the training samples
//! only and the held-out samples are predicted by `τ̂(x_f) + Bβ̂_f`.
//!
//! **Ranking.** When the residual keeps structure, every variable's term is added to the
//! final model and ranked by its held-out deviance gain `G_v = D(model) − D(model + term)`;
//! `depends_on` holds the best variable whose `G_v` exceeds
//! [`DiagnoseSettings::min_flexible_gain`](crate::DiagnoseSettings::min_flexible_gain)
//! (`direction` before `velocity` when it reaches 80 % of the velocity term's gain), and the
//! next when adding it to the first gains that much again.
//!
//! **No false story.** A named catalogued effect `e` stays named only when the model with it
//! beats, by [`DiagnoseSettings::flexible_margin_bic`](crate::DiagnoseSettings::flexible_margin_bic)
//! in BIC, the model without it but with a flexible term in each variable its shape lives in
//! ([`StateVariable::of_effect`]), in time also a ramp (`simplest_in_time`: twelve hats
//! would cost eleven parameters more than fatigue's rate);
//! otherwise the flexible term is reported instead. Once the
//! extension is known the review runs again with the extension's terms added to both sides,
//! and the extension alone (the model without the effect and with no other term) is one more
//! alternative: a cause that only helps the extension along is not named.
//!
//! **Band.** The term's uncertainty is from the Gauss–Newton covariance of the full problem
//! `r(x, β) = w(x) − WBβ`: `Cov = s²(JᵀJ)⁺`, `J = [J_w, −WB]`, `s² = max(1, ‖r‖²/(n − k))`;
//! the band is ±1.96 standard errors of the term at each reported point.

use muscle_model::{EffectKind, Muscle, ParamId};
use nalgebra::{DMatrix, DVector};
use rayon::prelude::*;
use serde::Serialize;

use crate::fit::{minimise_fold, minimise_model, pool_heldout, Context, Fit};
use crate::DiagnoseError;

/// A state variable of the flexible terms' vocabulary.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum StateVariable {
    /// Ankle angle (°).
    Angle,
    /// Angular velocity (°/s).
    Velocity,
    /// Sign of the angular velocity.
    Direction,
    /// Angular acceleration (°/s²).
    Acceleration,
    /// Time since the start of the trial (s).
    Time,
    /// Mean normalised triceps surae envelope.
    Activation,
    /// Normalised tibialis anterior envelope.
    ActivationTa,
}

impl StateVariable {
    /// The vocabulary, in report order.
    pub const ALL: [StateVariable; 7] = [
        StateVariable::Angle,
        StateVariable::Velocity,
        StateVariable::Direction,
        StateVariable::Acceleration,
        StateVariable::Time,
        StateVariable::Activation,
        StateVariable::ActivationTa,
    ];

    /// Name in `diagnosis.json`.
    pub fn name(self) -> &'static str {
        match self {
            StateVariable::Angle => "angle",
            StateVariable::Velocity => "velocity",
            StateVariable::Direction => "direction",
            StateVariable::Acceleration => "acceleration",
            StateVariable::Time => "time",
            StateVariable::Activation => "activation",
            StateVariable::ActivationTa => "activation_ta",
        }
    }

    /// Unit of the variable's values (empty: dimensionless).
    pub fn unit(self) -> &'static str {
        match self {
            StateVariable::Angle => "°",
            StateVariable::Velocity => "°/s",
            StateVariable::Acceleration => "°/s²",
            StateVariable::Time => "s",
            StateVariable::Direction | StateVariable::Activation | StateVariable::ActivationTa => {
                ""
            }
        }
    }

    /// The variables a catalogued effect's torque is a function of, which its flexible
    /// alternatives are drawn from: an offset is a constant of time, fatigue a decay over time
    /// that scales the active force, an antagonist term follows the TA, eccentric enhancement
    /// and damping follow the velocity and its sign, inertia the acceleration, the passive
    /// torque and gravity the angle, and a delay shifts the activation.
    pub fn of_effect(kind: EffectKind) -> &'static [StateVariable] {
        use StateVariable as V;
        match kind {
            EffectKind::TorqueOffset => &[V::Time],
            EffectKind::PassiveJointTorque | EffectKind::Gravity => &[V::Angle],
            EffectKind::ElectromechanicalDelay => &[V::Activation],
            EffectKind::Fatigue => &[V::Time, V::Activation],
            EffectKind::AntagonistCoactivation => &[V::ActivationTa],
            EffectKind::EccentricEnhancement | EffectKind::ViscousDamping => {
                &[V::Velocity, V::Direction]
            }
            EffectKind::Inertia => &[V::Acceleration],
        }
    }
}

impl Serialize for StateVariable {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_str(self.name())
    }
}

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
}

/// Fraction of the largest speed below which the joint counts as still for `direction`.
const STILL_FRACTION: f64 = 0.05;

/// Spacing of the time knots (s).
const TIME_KNOT_S: f64 = 2.0;

/// Block length (s) and folds of the cross-validation of a term in time.
const TIME_BLOCKS: (f64, usize) = (0.5, 5);

/// The folds of a term in time: 0.5 s blocks in 5 folds (a term in time is predicted in a
/// block from its neighbours; a whole cycle held out can only be extrapolated into).
pub(crate) fn time_folds(ctx: &Context) -> Folds {
    let n = ctx.y.len();
    let folds = crate::CvFolds::Blocks {
        block_s: TIME_BLOCKS.0,
        folds: TIME_BLOCKS.1,
    };
    folds
        .held_out_masks(n, ctx.inputs.fs(), &ctx.seg.cycle)
        .into_iter()
        .map(|mut held| {
            for (i, h) in held.iter_mut().enumerate() {
                *h = *h && ctx.is_observed(i);
            }
            let train: Vec<bool> = (0..n).map(|i| !held[i] && ctx.is_observed(i)).collect();
            let plan = ctx.noise.plan(n, Some(&train));
            (held, plan)
        })
        .collect()
}

/// Knots of the hat bases (the TA's range is narrower: four).
fn knot_count(v: StateVariable) -> usize {
    match v {
        StateVariable::ActivationTa => 4,
        _ => 5,
    }
}

/// The variable per sample, `None` when the recording has no such variable (no TA channel)
/// or it does not change over the compared samples (no joint angle).
fn series(ctx: &Context, v: StateVariable) -> Option<Vec<f64>> {
    let inp = &ctx.inputs;
    let n = inp.len();
    let deg = |x: &[f64]| x.iter().map(|a| a.to_degrees()).collect::<Vec<f64>>();
    let s = match v {
        StateVariable::Angle => deg(inp.angle()),
        StateVariable::Velocity | StateVariable::Direction => deg(inp.velocity()),
        StateVariable::Acceleration => deg(inp.acceleration()),
        StateVariable::Time => inp.times().to_vec(),
        StateVariable::Activation => (0..n)
            .map(|i| Muscle::ALL.iter().map(|m| inp.envelope(*m)[i]).sum::<f64>() / 3.0)
            .collect(),
        StateVariable::ActivationTa => inp.envelope_ta()?.to_vec(),
    };
    let (lo, hi) = observed_range(ctx, &s)?;
    (hi - lo > 1e-9 * (1.0 + hi.abs().max(lo.abs()))).then_some(s)
}

/// Smallest and largest value over the compared samples.
fn observed_range(ctx: &Context, x: &[f64]) -> Option<(f64, f64)> {
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
enum Functions {
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

    fn eval(&self, v: f64) -> Vec<f64> {
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
/// is predicted from its neighbours; [`with_step`] adds a step).
pub(crate) fn basis(ctx: &Context, v: StateVariable) -> Option<FlexBasis> {
    let s = series(ctx, v)?;
    let (lo, hi) = observed_range(ctx, &s)?;
    let (funcs, points) = match v {
        StateVariable::Direction => {
            let still = STILL_FRACTION * lo.abs().max(hi.abs());
            (Functions::Sign { still }, vec![-1.0, 1.0])
        }
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

/// The basis of `v` (series `s`, largest magnitude `amax`) made of `funcs`, its shape reported
/// at `points` (for direction the two signs).
fn from_functions(
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
    }
}

/// Shortest time (s) between a change point in time and either end of the trial.
const STEP_MARGIN_S: f64 = 0.5;

/// The time basis `b` with a step `1{t ≥ τ}` added at the most likely change point of
/// `residual` (`y − τ̂` of the model the term will extend, N·m): the residual is projected
/// off the time hats over the compared samples, and `τ` maximises its standardised cumulative
/// sum `|S_k − (k/m)S_m| / √(k(m−k)/m)` over the samples at least 0.5 s from either end.
/// A hat every 2 s only ramps through a jump (a strap that slips, a re-zeroed amplifier); the
/// step costs one coefficient and its searched `τ` one more parameter in the BIC, and the
/// cross-validation and the BIC judge it like any other term.
/// Its shape is reported at the knots and on both sides of `τ`. Any other basis is returned
/// unchanged.
pub(crate) fn with_step(
    ctx: &Context,
    b: FlexBasis,
    residual: &[f64],
    jac: Option<&DMatrix<f64>>,
) -> FlexBasis {
    if b.variable != StateVariable::Time {
        return b;
    }
    let found = match jac {
        Some(j) => change_point(ctx, &b.cols, residual, j),
        None => change_point_cusum(ctx, &b.cols, residual),
    };
    let Some(tau) = found else {
        return b;
    };
    let t = ctx.inputs.times();
    let mut out = b;
    out.cols.push(
        t.iter()
            .map(|&x| if x >= tau { 1.0 } else { 0.0 })
            .collect(),
    );
    // the knots with the step's column, and both sides of the step
    let hats = Functions::Hats(out.points.clone());
    let mut shape: Vec<(f64, Vec<f64>)> = out
        .points
        .iter()
        .zip(&out.rows)
        .map(|(p, row)| {
            let mut row = row.clone();
            row.push(if *p >= tau { 1.0 } else { 0.0 });
            (*p, row)
        })
        .collect();
    for side in [0.0, 1.0] {
        let mut row = hats.eval(tau);
        row.push(side);
        shape.push((tau, row));
    }
    // stable: the knot rows before the two sides at τ, the side before the step first
    shape.sort_by(|a, b| a.0.total_cmp(&b.0));
    out.points = shape.iter().map(|(p, _)| *p).collect();
    out.rows = shape.into_iter().map(|(_, r)| r).collect();
    out.searched.push(SearchedValue {
        name: "change_point".into(),
        value: tau,
        unit: "s".into(),
    });
    out
}

/// The most likely change point (s) of `residual` (N·m, one value per sample) beside the time
/// hats `cols` and the parameters of the model that left it (`jac`, its whitened Jacobian,
/// one row per sample): the `τ` whose step `1{t ≥ τ}` explains most of the whitened residual
/// once both are projected off the whitened hats and the Jacobian's columns,
/// `(cᵀP⊥r)²/(cᵀP⊥c)` — the score test for a step at `τ` under the trial's noise model, with
/// the model's parameters free to move as in the refit that follows. `τ` runs over every
/// compared sample at least 0.5 s from either end (`None` on a recording too short for one):
/// a whitened step is mostly the innovation at its onset, so the score peaks within a sample
/// or two of a true jump.
///
/// Unwhitened, the noise's slow AR(1) part dominates: the cumulative sum of
/// [`change_point_cusum`] put a slip of +3.73 N·m at 5.217 s (trial 20 254 127) at 8.2 s, the
/// edge of the range, where that part's standardised sum is largest; this scan puts it at
/// 5.217 s. The characterisation places its step so: it ranks the terms by their held-out
/// gain, where a step on a spike of the noise gains nothing.
fn change_point(
    ctx: &Context,
    cols: &[Vec<f64>],
    residual: &[f64],
    jac: &DMatrix<f64>,
) -> Option<f64> {
    let t = ctx.inputs.times();
    let n = t.len();
    if residual.len() != n {
        return None;
    }
    let (t0, t1) = observed_range(ctx, t)?;
    let whiten = |x: &[f64]| {
        let mut w = vec![0.0; n];
        ctx.plan.whiten(x, &mut w);
        w
    };
    let mut h: Vec<Vec<f64>> = cols.iter().map(|c| whiten(c)).collect();
    if jac.nrows() == n {
        h.extend(
            jac.column_iter()
                .map(|c| c.iter().copied().collect::<Vec<f64>>()),
        );
    }
    let k = h.len();
    let dot = |a: &[f64], b: &[f64]| a.iter().zip(b).map(|(x, y)| x * y).sum::<f64>();
    let gram = DMatrix::from_fn(k, k, |a, b| dot(&h[a], &h[b]));
    let svd = gram.svd(true, true);
    // (HᵀH)⁻¹Hᵀv by the pseudo-inverse: hats over unobserved stretches may be degenerate
    let mut wr = whiten(residual);
    let coef = svd
        .solve(
            &DVector::from_iterator(k, h.iter().map(|c| dot(c, &wr))),
            1e-12,
        )
        .ok()?;
    for (a, c) in coef.iter().zip(&h) {
        for (r, x) in wr.iter_mut().zip(c) {
            *r -= a * x;
        }
    }
    // Backwards over the onsets: the whitened step at s is the one at s + 1 plus the whitened
    // impulse at s, so its products with the residual and the projection's columns, and its
    // squared norm, are suffix sums over the impulse's support.
    let ginv = svd.pseudo_inverse(1e-12).ok()?;
    let mut wc = vec![0.0; n];
    let (mut a, mut q) = (0.0, 0.0);
    let mut hc = DVector::<f64>::zeros(k);
    let mut best: Option<(usize, f64)> = None;
    let mut d = Vec::new();
    for s in (0..n).rev() {
        ctx.plan.whitened_impulse(s, 1e-12, &mut d);
        for (o, &di) in d.iter().enumerate() {
            let i = s + o;
            q += di * (2.0 * wc[i] + di);
            a += di * wr[i];
            for (hj, c) in hc.iter_mut().zip(&h) {
                *hj += di * c[i];
            }
            wc[i] += di;
        }
        if !(ctx.is_observed(s) && t[s] - t0 >= STEP_MARGIN_S && t1 - t[s] >= STEP_MARGIN_S) {
            continue;
        }
        let rest = q - hc.dot(&(&ginv * &hc));
        let score = if rest > 1e-12 * q { a * a / rest } else { 0.0 };
        // ≥: of equal scores the earliest onset
        if best.is_none_or(|(_, b)| score >= b) {
            best = Some((s, score));
        }
    }
    best.map(|(s, _)| t[s])
}

/// The change point (s) of `residual` (N·m, one value per sample) by a cumulative sum, once
/// projected off the time hats `cols` by least squares over the compared samples: the time
/// maximising the standardised cumulative sum `|S_k − (k/m)S_m| / √(k(m−k)/m)` over the
/// samples at least 0.5 s from either end (`None` on a recording too short for one).
///
/// The review places its step so. It decides by BIC, which charges the searched point one
/// parameter (ln n ≈ 10), while the scan of [`change_point`] takes the largest of one χ²₁
/// score per onset, nearly independent for spike-like whitened steps: for N independent ones
/// that is about 2 ln N − ln(π ln N) ≈ 16 for the ≈ 16 000 onsets of a relaxed+2 trial without
/// any step. In the review a step on a spike of the noise would compete with a catalogued
/// cause.
/// A spike barely moves the unwhitened sum, though the noise's slow part can (the slip above
/// comes out at 8.2 s).
fn change_point_cusum(ctx: &Context, cols: &[Vec<f64>], residual: &[f64]) -> Option<f64> {
    let t = ctx.inputs.times();
    let idx: Vec<usize> = (0..t.len()).filter(|&i| ctx.is_observed(i)).collect();
    let m = idx.len();
    if m < 4 || residual.len() != t.len() {
        return None;
    }
    let y = DVector::from_iterator(m, idx.iter().map(|&i| residual[i]));
    let h = DMatrix::from_fn(m, cols.len(), |r, c| cols[c][idx[r]]);
    let coef = h.clone().svd(true, true).solve(&y, 1e-12).ok()?;
    let r = y - h * coef;
    let (t0, t1) = (t[idx[0]], t[idx[m - 1]]);
    let mut best: Option<(f64, f64)> = None;
    let total = r.sum();
    let mut cum = 0.0;
    for j in 1..m {
        cum += r[j - 1];
        let at = t[idx[j]];
        if at - t0 < STEP_MARGIN_S || t1 - at < STEP_MARGIN_S {
            continue;
        }
        let (jf, mf) = (j as f64, m as f64);
        let stat = (cum - jf / mf * total).abs() / (jf * (mf - jf) / mf).sqrt();
        if best.is_none_or(|(_, s)| stat > s) {
            best = Some((at, stat));
        }
    }
    best.map(|(at, _)| at)
}

/// The ramp `t − t₀` (s) from the first compared sample, one value per sample: the review's
/// one-coefficient shape in time, which the detection limits of the effects that live in
/// time are computed against (`None` without a compared sample).
pub(crate) fn ramp_column(ctx: &Context) -> Option<Vec<f64>> {
    let t = ctx.inputs.times();
    let (t0, _) = observed_range(ctx, t)?;
    Some(t.iter().map(|x| x - t0).collect())
}

/// The simplest shape in time, for the review of a named cause that lives in time (an
/// offset, fatigue): a ramp `t − t₀` from the first compared sample, one coefficient like
/// the rate it is compared with (a torque cell that drifts from its zero). Twelve hats cost
/// eleven parameters more than fatigue's rate, so without it a drift the rate mimics in part
/// kept the name fatigue. A step alone at a searched change point is not offered: on fatigue
/// hidden at its detection limit it took the fatigue's place by fitting the noise's slow
/// part as well (trial 61 003: ΔBIC 2.3 in the step's favour, with one parameter counted for
/// its change point).
fn simplest_in_time(ctx: &Context) -> Vec<FlexBasis> {
    let t = ctx.inputs.times();
    let (Some((t0, t1)), Some(ramp)) = (observed_range(ctx, t), ramp_column(ctx)) else {
        return Vec::new();
    };
    vec![FlexBasis {
        variable: StateVariable::Time,
        points: vec![t0, t1],
        rows: vec![vec![0.0], vec![t1 - t0]],
        cols: vec![ramp],
        searched: Vec::new(),
    }]
}

/// Candidate transition widths of the direction term, as fractions of the largest speed: a
/// geometric grid from a pure sign (the first sample off zero speed) to the still band.
const WIDTH_GRID: (f64, f64, usize) = (1e-3, STILL_FRACTION, 24);

/// The direction basis `b` with `sign(q̇)` replaced by `tanh(q̇/w)`, the width `w` searched on
/// `residual` (`y − τ̂` of the model the term will extend, N·m): the `w` of the grid
/// [`WIDTH_GRID`] whose whitened, centred column explains most of the whitened residual,
/// `(cᵀr)²/(cᵀc)`. The whitening of a slowly correlated noise weighs a jump by its timing
/// within a sample or two, so a friction that sets in below the still band is missed by the
/// fixed `sign` at every start and stop of a movement while viscous damping's ramp is not
/// (trial 9 500 000: the still band cost 63 in BIC against damping, the searched width wins).
/// The width is a searched value like a step's change point (one parameter in the BIC). Any
/// other basis is returned unchanged.
fn with_width(ctx: &Context, b: FlexBasis, residual: &[f64]) -> FlexBasis {
    if b.variable != StateVariable::Direction || residual.len() != ctx.y.len() {
        return b;
    }
    let Some(s) = series(ctx, StateVariable::Direction) else {
        return b;
    };
    let Some((lo, hi)) = observed_range(ctx, &s) else {
        return b;
    };
    let amax = lo.abs().max(hi.abs());
    let n = s.len();
    let mut wr = vec![0.0; n];
    ctx.plan.whiten(residual, &mut wr);
    let mut wc = vec![0.0; n];
    let (f0, f1, count) = WIDTH_GRID;
    let mut best: Option<(FlexBasis, f64, f64)> = None;
    for j in 0..count {
        let width = amax * f0 * (f1 / f0).powf(j as f64 / (count - 1) as f64);
        let cand = from_functions(
            ctx,
            StateVariable::Direction,
            &s,
            &Functions::Tanh { width },
            b.points.clone(),
            amax,
        );
        ctx.plan.whiten(&cand.cols[0], &mut wc);
        let cc: f64 = wc.iter().map(|x| x * x).sum();
        let cr: f64 = wc.iter().zip(&wr).map(|(a, b)| a * b).sum();
        let score = if cc > 0.0 { cr * cr / cc } else { 0.0 };
        if best.as_ref().is_none_or(|(_, s, _)| score > *s) {
            best = Some((cand, score, width));
        }
    }
    let Some((mut out, _, width)) = best else {
        return b;
    };
    out.searched = b.searched;
    out.searched.push(SearchedValue {
        name: "transition_width".into(),
        value: width,
        unit: StateVariable::Velocity.unit().into(),
    });
    out
}

/// `b`, and also `b` with its searched form when it has one (time: with its step,
/// [`with_step`]; direction: with its transition width, [`with_width`]): both are fitted,
/// and the better one (held-out gain in the ranking, BIC in the review) stands for the
/// variable.
///
/// A step is placed by the scan of [`change_point`] beside the parameters of the model that
/// left `residual` (`jac`, its whitened Jacobian) in the characterisation, by the cumulative
/// sum of [`change_point_cusum`] in the review (`None`).
fn with_searched_forms(
    ctx: &Context,
    b: FlexBasis,
    residual: &[f64],
    jac: Option<&DMatrix<f64>>,
) -> Vec<FlexBasis> {
    if residual.is_empty() {
        return vec![b];
    }
    match b.variable {
        StateVariable::Time => vec![b.clone(), with_step(ctx, b, residual, jac)],
        StateVariable::Direction => vec![b.clone(), with_width(ctx, b, residual)],
        _ => vec![b],
    }
}

/// Least squares on a whitened basis: `β = V Σ⁻¹ Uᵀ w` over the singular values above
/// `10⁻⁹` of the largest (columns without a training sample drop out, `β` = 0 along them).
struct Projector {
    u: DMatrix<f64>,
    solve: DMatrix<f64>,
}

impl Projector {
    fn new(plan: &muscle_model::WhitenPlan, cols: &[&Vec<f64>], n: usize) -> Projector {
        let mut wb = DMatrix::zeros(n, cols.len());
        let mut w = vec![0.0; n];
        for (j, c) in cols.iter().enumerate() {
            plan.whiten(c, &mut w);
            wb.set_column(j, &DVector::from_column_slice(&w));
        }
        if cols.is_empty() {
            return Projector {
                u: DMatrix::zeros(n, 0),
                solve: DMatrix::zeros(0, 0),
            };
        }
        let svd = wb.svd(true, true);
        let (u, vt) = (svd.u.expect("u"), svd.v_t.expect("v_t"));
        let smax = svd.singular_values.max();
        let keep: Vec<usize> = (0..svd.singular_values.len())
            .filter(|&i| svd.singular_values[i] > 1e-9 * smax && smax > 0.0)
            .collect();
        let mut uk = DMatrix::zeros(n, keep.len());
        let mut solve = DMatrix::zeros(cols.len(), keep.len());
        for (c, &i) in keep.iter().enumerate() {
            uk.set_column(c, &u.column(i));
            let s = svd.singular_values[i];
            for r in 0..cols.len() {
                solve[(r, c)] = vt[(i, r)] / s;
            }
        }
        Projector { u: uk, solve }
    }

    fn rank(&self) -> usize {
        self.u.ncols()
    }

    /// `Uᵀw`.
    fn coords(&self, w: &[f64]) -> DVector<f64> {
        self.u.tr_mul(&DVector::from_column_slice(w))
    }

    /// `(I − UUᵀ)w`.
    fn residual(&self, w: &[f64]) -> Vec<f64> {
        let c = self.coords(w);
        let p = &self.u * c;
        w.iter().zip(p.iter()).map(|(a, b)| a - b).collect()
    }

    /// `β̂` for the whitened residual `w`.
    fn beta(&self, w: &[f64]) -> Vec<f64> {
        (&self.solve * self.coords(w)).iter().copied().collect()
    }
}

/// `Σ_j β_j col_j`.
fn combine(cols: &[&Vec<f64>], beta: &[f64], n: usize) -> Vec<f64> {
    let mut t = vec![0.0; n];
    for (c, b) in cols.iter().zip(beta) {
        for (ti, ci) in t.iter_mut().zip(c.iter()) {
            *ti += b * ci;
        }
    }
    t
}

/// A model with flexible terms: the catalogued part `model` (its `pred` without the terms,
/// its `white`, `white_ss`, `loglik`, `rms` and held-out errors with them), the terms'
/// coefficients and, when asked for, their covariance.
#[derive(Clone, Debug)]
pub(crate) struct FlexFit {
    pub model: Fit,
    pub bases: Vec<FlexBasis>,
    pub beta: Vec<f64>,
    /// Covariance of `beta` (empty unless the band was asked for).
    pub beta_cov: Option<DMatrix<f64>>,
    /// Independent coefficients (the rank of the whitened basis).
    pub rank: usize,
}

impl FlexFit {
    pub fn k(&self) -> usize {
        self.model.k() + self.rank + self.bases.iter().map(|b| b.searched.len()).sum::<usize>()
    }

    pub fn bic(&self, n: usize) -> f64 {
        -2.0 * self.model.loglik + self.k() as f64 * (n as f64).ln()
    }

    pub fn variables(&self) -> Vec<StateVariable> {
        self.bases.iter().map(|b| b.variable).collect()
    }
}

/// Share of the velocity term's held-out gain the direction term must reach to be reported
/// before it.
const COARSER_SHARE: f64 = 0.8;

/// Levenberg–Marquardt iterations of a flexible fit from the current model (it starts next to
/// its optimum: the terms are linear and profiled out).
const FLEX_ITERATIONS: usize = 12;

/// Cross-validation folds: held-out mask and the whitening plan of the training samples.
pub(crate) type Folds = Vec<(Vec<bool>, muscle_model::WhitenPlan)>;

/// Fits the catalogued effects `kinds` (from `x0`) plus flexible terms in `bases`, with the
/// cross-validation over `folds` when given; `band`: also the coefficients' covariance
/// (module docs).
pub(crate) fn fit_flexible(
    ctx: &Context,
    kinds: &[EffectKind],
    x0: &[f64],
    bases: &[FlexBasis],
    folds: Option<&Folds>,
    band: bool,
) -> Result<FlexFit, DiagnoseError> {
    let problem = ctx.problem(kinds)?;
    let bounds = problem.bounds().to_vec();
    let cols: Vec<&Vec<f64>> = bases.iter().flat_map(|b| b.cols.iter()).collect();
    let n = ctx.y.len();
    let proj = Projector::new(&ctx.plan, &cols, n);
    let f = ctx.residual_fn(&problem, &ctx.plan);
    let g = |x: &[f64]| f(x).map(|w| proj.residual(&w));
    let name = || {
        let vars: Vec<&str> = bases.iter().map(|b| b.variable.name()).collect();
        format!(
            "{}+flexible({})",
            crate::fit::model_name(kinds),
            vars.join(",")
        )
    };
    let lm = numerics::LevenbergMarquardtSettings {
        max_iterations: ctx.lm.max_iterations.min(FLEX_ITERATIONS),
        ..ctx.lm
    };
    let out =
        minimise_model(problem.free(), &g, x0, &bounds, &lm).ok_or_else(|| DiagnoseError::Fit {
            model: name(),
            reason: "the model cannot be simulated at the start point".into(),
        })?;
    let mut evaluations = out.evaluations;
    let w = f(&out.x).ok_or_else(|| DiagnoseError::Fit {
        model: name(),
        reason: "the model cannot be simulated at the fitted point".into(),
    })?;
    let beta = proj.beta(&w);
    let pred = problem.predict(&out.x)?;
    let term = combine(&cols, &beta, n);
    let total: Vec<f64> = pred.iter().zip(&term).map(|(a, b)| a + b).collect();
    let rms = ctx.observed_rms(&ctx.y, &total);
    let k = out.x.len() + proj.rank();

    // Gauss–Newton covariance of (x, β): J = [J_w, −WB]; J_w by forward differences
    let beta_cov = if band {
        evaluations += out.x.len();
        crate::fit::whitened_jacobian(ctx, &problem, &out.x, &w, &bounds, &ctx.lm).and_then(|jw| {
            let p = out.x.len();
            let m = cols.len();
            let mut jac = DMatrix::zeros(n, p + m);
            jac.columns_mut(0, p).copy_from(&jw);
            let mut wc = vec![0.0; n];
            for (j, c) in cols.iter().enumerate() {
                ctx.plan.whiten(c, &mut wc);
                for (i, v) in wc.iter().enumerate() {
                    jac[(i, p + j)] = -v;
                }
            }
            let ss: f64 = out.residual.iter().map(|v| v * v).sum();
            let s2 = (ss / ctx.plan.n_obs().saturating_sub(k).max(1) as f64).max(1.0);
            let jtj = jac.tr_mul(&jac);
            let eps = 1e-12 * jtj.norm();
            let cov = jtj.pseudo_inverse(eps).ok()?;
            Some(cov.view((p, p), (m, m)).into_owned() * s2)
        })
    } else {
        None
    };
    let (heldout_rms, heldout_dev, ev) = match folds {
        Some(folds) => cross_validate(ctx, folds, &problem, &out.x, &cols),
        None => (f64::NAN, f64::NAN, 0),
    };
    evaluations += ev;
    let model = Fit {
        kinds: kinds.to_vec(),
        free: problem.free().to_vec(),
        x: out.x,
        pred,
        white: out.residual,
        white_ss: out.cost,
        loglik: ctx.plan.log_likelihood(out.cost),
        rms,
        jac: out.jacobian,
        heldout_rms,
        heldout_dev,
        evaluations,
    };
    Ok(FlexFit {
        model,
        bases: bases.to_vec(),
        beta,
        beta_cov,
        rank: proj.rank(),
    })
}

/// Cross-validation of a model with flexible terms (none: the catalogued model alone) over
/// `folds`: pooled held-out RMS, held-out deviance and the simulations.
pub(crate) fn cross_validate(
    ctx: &Context,
    folds: &Folds,
    problem: &muscle_model::Problem,
    x: &[f64],
    cols: &[&Vec<f64>],
) -> (f64, f64, usize) {
    let bounds = problem.bounds();
    let n = ctx.y.len();
    let res: Vec<((f64, f64, usize), usize)> = folds
        .par_iter()
        .map(|(held, plan)| {
            let proj = Projector::new(plan, cols, n);
            let f = ctx.residual_fn(problem, plan);
            let g = |x: &[f64]| f(x).map(|w| proj.residual(&w));
            let (xf, ev) = minimise_fold(problem.free(), &g, x, bounds, &ctx.cv_lm)
                .unwrap_or_else(|| (x.to_vec(), 0));
            let beta = f(&xf)
                .map(|w| proj.beta(&w))
                .unwrap_or_else(|| vec![0.0; cols.len()]);
            let term = combine(cols, &beta, n);
            let pred = problem.predict(&xf).unwrap_or_else(|_| vec![0.0; n]);
            let e: Vec<f64> = (0..n).map(|i| ctx.y[i] - pred[i] - term[i]).collect();
            (ctx.heldout_sums(held, &e), ev)
        })
        .collect();
    pool_heldout(&res)
}

/// `fit`'s effects and parameter vector without the effects `drop`.
pub(crate) fn without_effects(fit: &Fit, drop: &[EffectKind]) -> (Vec<EffectKind>, Vec<f64>) {
    let kinds: Vec<EffectKind> = fit
        .kinds
        .iter()
        .copied()
        .filter(|k| !drop.contains(k))
        .collect();
    let x: Vec<f64> = fit
        .free
        .iter()
        .zip(&fit.x)
        .filter(|(id, _)| !matches!(id, ParamId::Effect(k, _) if drop.contains(k)))
        .map(|(_, v)| *v)
        .collect();
    (kinds, x)
}

// ---------------------------------------------------------------------------------------
// Report

/// A variable's flexible term added to the final model.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct VariableGain {
    /// State variable.
    pub variable: StateVariable,
    /// Held-out deviance of the final model minus that of the model with the term (χ² units;
    /// positive: the term predicts held-out data better).
    pub heldout_deviance_gain: f64,
    /// Pooled held-out RMS with the term (N·m).
    pub heldout_rms_nm: f64,
    /// BIC with the term minus the final model's.
    pub delta_bic: f64,
    /// Independent coefficients of the term.
    pub parameters: usize,
}

/// The fitted shape of one flexible term: its value at points of its variable with a 95 %
/// band. The term is centred: its mean over the trial is zero.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct FlexibleTerm {
    /// State variable.
    pub variable: StateVariable,
    /// Unit of `points` (empty: dimensionless).
    pub unit: String,
    /// Points of the variable (for `direction`: −1 and +1, the sign of the velocity).
    pub points: Vec<f64>,
    /// Term at each point (N·m).
    pub value_nm: Vec<f64>,
    /// Half-width of the 95 % band at each point (N·m; NaN when not computed).
    pub band_nm: Vec<f64>,
    /// The term's values searched on the data rather than fitted: a step's `change_point`
    /// (s) in time, the `transition_width` (°/s) of `tanh(q̇/w)` in direction, the speed at
    /// which the term reaches 76 % of its level.
    pub searched: Vec<SearchedValue>,
}

/// A value of a flexible term's shape searched on the data (a grid or a scan), not fitted as
/// a coefficient; it counts as one parameter in the BIC.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct SearchedValue {
    /// `change_point` or `transition_width`.
    pub name: String,
    /// The value found.
    pub value: f64,
    /// Its unit.
    pub unit: String,
}

/// The final model extended with the flexible terms of `depends_on`.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct FlexibleExtension {
    /// The variables of its terms.
    pub variables: Vec<StateVariable>,
    /// Pooled held-out RMS (N·m).
    pub heldout_rms_nm: f64,
    /// Reduction of the held-out RMS against the final catalogued model (%).
    pub heldout_rms_reduction_pct: f64,
    /// Held-out deviance gain against the final catalogued model.
    pub heldout_deviance_gain: f64,
    /// In-sample RMS (N·m).
    pub rms_nm: f64,
    /// BIC against the final catalogued model.
    pub delta_bic: f64,
    /// The terms' shapes.
    pub terms: Vec<FlexibleTerm>,
    /// Per-sample torque of the terms (N·m; not serialised; for the figures).
    #[serde(skip)]
    pub term_nm: Vec<f64>,
}

/// A catalogued effect the selection found that a flexible term in its own variable explains
/// better: not named.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Replacement {
    /// Effect.
    pub effect: String,
    /// The variable whose flexible term explains its share better.
    pub variable: StateVariable,
    /// BIC of the model with the effect minus that with the flexible term instead (above
    /// `−margin`: not named).
    pub delta_bic: f64,
}

/// What the unexplained structure depends on (`unexplained` in `diagnosis.json`).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Unexplained {
    /// The best one or two variables (empty: none of the vocabulary explains it).
    pub depends_on: Vec<StateVariable>,
    /// Every variable's term added to the final model, best held-out gain first.
    pub ranking: Vec<VariableGain>,
    /// The model extended with the terms of `depends_on`.
    pub extension: Option<FlexibleExtension>,
    /// A catalogued effect not named whose shape, added to the final model, explains the
    /// structure as well as the flexible term in the best variable (by the margin).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub catalogued_shape: Option<String>,
    /// Catalogued effects the selection found that a flexible term explains better.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub replaced: Vec<Replacement>,
}

impl Unexplained {
    /// Lines of the terminal summary.
    pub fn summary_lines(&self) -> Vec<String> {
        let mut l = Vec::new();
        for r in &self.replaced {
            l.push(format!(
                "not named    {}: a flexible term in {} explains its share better (ΔBIC {:+.1})",
                r.effect,
                r.variable.name(),
                -r.delta_bic
            ));
        }
        match (&self.depends_on[..], &self.extension) {
            ([], _) | (_, None) => l.push(
                "depends on   none of angle, velocity, direction, acceleration, time, \
                 activation, activation_ta"
                    .to_string(),
            ),
            (vars, Some(e)) => {
                let names: Vec<&str> = vars.iter().map(|v| v.name()).collect();
                l.push(format!(
                    "depends on   {}: a flexible term lowers the held-out RMS to {:.2} N·m \
                     (−{:.1} %, held-out deviance −{:.0})",
                    names.join(" and "),
                    e.heldout_rms_nm,
                    e.heldout_rms_reduction_pct,
                    e.heldout_deviance_gain
                ));
            }
        }
        for t in self.extension.iter().flat_map(|e| &e.terms) {
            for v in &t.searched {
                l.push(format!(
                    "searched     {}: {} {:.3} {}",
                    t.variable.name(),
                    v.name.replace('_', " "),
                    v.value,
                    v.unit
                ));
            }
        }
        if let Some(k) = &self.catalogued_shape {
            l.push(format!(
                "shape        that of {k} after all (its term explains the structure as well)"
            ));
        }
        l
    }
}

/// The shapes of a flexible fit's terms.
fn terms_of(ff: &FlexFit) -> Vec<FlexibleTerm> {
    let mut out = Vec::new();
    let mut j = 0;
    for b in &ff.bases {
        let m = b.cols.len();
        let beta = &ff.beta[j..j + m];
        let (value_nm, band_nm) = b
            .rows
            .iter()
            .map(|row| {
                let v: f64 = row.iter().zip(beta).map(|(a, c)| a * c).sum();
                let var = ff.beta_cov.as_ref().map_or(f64::NAN, |cov| {
                    let mut q = 0.0;
                    for (r, a) in row.iter().enumerate() {
                        for (c, bb) in row.iter().enumerate() {
                            q += a * cov[(j + r, j + c)] * bb;
                        }
                    }
                    q
                });
                (v, 1.96 * var.max(0.0).sqrt())
            })
            .unzip();
        out.push(FlexibleTerm {
            variable: b.variable,
            unit: b.variable.unit().to_string(),
            points: b.points.clone(),
            value_nm,
            band_nm,
            searched: b.searched.clone(),
        });
        j += m;
    }
    out
}

/// For each effect of `model` (or only those in `only`), the model without it plus a flexible
/// term in each of `vars(effect)` (or `extra` added to every model, and `extra` alone as one
/// more alternative). Returns the effects a
/// flexible alternative beats (`BIC(with) > BIC(without + term) − margin`) and the
/// simulations spent. `reference` is the model they are compared with (its BIC).
fn review(
    ctx: &Context,
    model: &Fit,
    reference_bic: f64,
    extra: &[FlexBasis],
    margin_bic: f64,
    nobs: usize,
) -> Result<(Vec<Replacement>, usize), DiagnoseError> {
    let mut out = Vec::new();
    let mut evaluations = 0;
    for &kind in &model.kinds {
        let (kinds, x) = without_effects(model, &[kind]);
        // a step in time, or the width of a change of direction, is searched on what the
        // model without the effect leaves
        let searched = [StateVariable::Time, StateVariable::Direction];
        let resid: Vec<f64> = if StateVariable::of_effect(kind)
            .iter()
            .any(|v| searched.contains(v))
        {
            let pred = ctx.problem(&kinds)?.predict(&x)?;
            ctx.y.iter().zip(&pred).map(|(a, b)| a - b).collect()
        } else {
            Vec::new()
        };
        // each of its own variables' terms, beside the extension's (when not among them)
        let mut alternatives: Vec<Vec<FlexBasis>> = StateVariable::of_effect(kind)
            .iter()
            .filter_map(|v| basis(ctx, *v))
            .flat_map(|b| {
                // the extension's own term stands for its variable
                if extra.iter().any(|e| e.variable == b.variable) {
                    vec![b]
                } else if b.variable == StateVariable::Time {
                    let mut v = simplest_in_time(ctx);
                    v.extend(with_searched_forms(ctx, b, &resid, None));
                    v
                } else {
                    with_searched_forms(ctx, b, &resid, None)
                }
            })
            .map(|b| {
                let mut set = extra.to_vec();
                if !set.iter().any(|e| e.variable == b.variable) {
                    set.push(b);
                }
                set
            })
            .collect();
        // the extension alone, without the effect: a cause that only helps the extension's
        // term along is not needed (an electromechanical delay beside a slipping strap's term
        // in time, trial 9 503 010: the extension alone is 2.9 in BIC better)
        if !extra.is_empty() && !alternatives.iter().any(|a| a.len() == extra.len()) {
            alternatives.push(extra.to_vec());
        }
        let fits: Vec<Result<FlexFit, DiagnoseError>> = alternatives
            .par_iter()
            .map(|b| fit_flexible(ctx, &kinds, &x, b, None, false))
            .collect();
        let mut best: Option<(StateVariable, f64)> = None;
        // an alternative that cannot be fitted does not replace anything
        for f in fits.into_iter().flatten() {
            evaluations += f.model.evaluations;
            let d = reference_bic - f.bic(nobs);
            if best.is_none_or(|(_, b)| d > b) {
                best = Some((f.bases.last().expect("a term").variable, d));
            }
        }
        if let Some((variable, d)) = best {
            // named only when BIC(with the effect) ≤ BIC(flexible instead) − margin
            if d > -margin_bic {
                out.push(Replacement {
                    effect: kind.name().to_string(),
                    variable,
                    delta_bic: d,
                });
            }
        }
    }
    Ok((out, evaluations))
}

/// The no-false-story review of the selected causes (module docs): for each named effect, the
/// model without it plus a flexible term in each of its own variables.
pub(crate) fn review_causes(
    ctx: &Context,
    model: &Fit,
    margin_bic: f64,
    nobs: usize,
) -> Result<(Vec<Replacement>, usize), DiagnoseError> {
    review(ctx, model, model.bic(nobs), &[], margin_bic, nobs)
}

/// The ranking of the vocabulary on the final model `fin` and its extension (module docs).
pub(crate) struct Characterisation {
    pub unexplained: Unexplained,
    /// Named causes that the extension makes unnecessary (to be dropped by the caller, who
    /// then characterises the smaller model again).
    pub unneeded: Vec<Replacement>,
    pub evaluations: usize,
}

/// Ranks the vocabulary's flexible terms on the final model `fin` and extends it with the best
/// one or two (module docs); `catalogued` are the effects eligible on this trial.
pub(crate) fn characterise(
    ctx: &Context,
    fin: &Fit,
    catalogued: &[EffectKind],
    replaced: Vec<Replacement>,
    min_gain: f64,
    margin_bic: f64,
    nobs: usize,
) -> Result<Characterisation, DiagnoseError> {
    let mut evaluations = 0;
    let resid: Vec<f64> = ctx.y.iter().zip(&fin.pred).map(|(a, b)| a - b).collect();
    let bases: Vec<FlexBasis> = StateVariable::ALL
        .iter()
        .filter_map(|v| basis(ctx, *v))
        .flat_map(|b| with_searched_forms(ctx, b, &resid, Some(&fin.jac)))
        .collect();
    // the final model's held-out errors under each fold scheme: a term in time is compared on
    // the time blocks, every other term on the trial's own folds
    let blocks = time_folds(ctx);
    let problem = ctx.problem(&fin.kinds)?;
    let (block_rms, block_dev, ev) = cross_validate(ctx, &blocks, &problem, &fin.x, &[]);
    evaluations += ev;
    let uses_time = |b: &[FlexBasis]| b.iter().any(|x| x.variable == StateVariable::Time);
    let folds_of = |b: &[FlexBasis]| if uses_time(b) { &blocks } else { &ctx.folds };
    let reference = |b: &[FlexBasis]| {
        if uses_time(b) {
            (block_rms, block_dev)
        } else {
            (fin.heldout_rms, fin.heldout_dev)
        }
    };
    let fits: Vec<Result<FlexFit, DiagnoseError>> = bases
        .par_iter()
        .map(|b| {
            let one = std::slice::from_ref(b);
            fit_flexible(ctx, &fin.kinds, &fin.x, one, Some(folds_of(one)), false)
        })
        .collect();
    // a variable whose term cannot be fitted (the model fails to simulate) is left out
    let mut fits: Vec<FlexFit> = fits.into_iter().flatten().collect();
    evaluations += fits.iter().map(|f| f.model.evaluations).sum::<usize>();
    let gain = |f: &FlexFit| reference(&f.bases).1 - f.model.heldout_dev;
    fits.sort_by(|a, b| gain(b).total_cmp(&gain(a)));
    // time with and without its step, direction with and without its searched width: the
    // better of the two stands for the variable
    let mut seen = Vec::new();
    fits.retain(|f| {
        let v = f.bases[0].variable;
        let first = !seen.contains(&v);
        seen.push(v);
        first
    });
    let ranking: Vec<VariableGain> = fits
        .iter()
        .map(|f| VariableGain {
            variable: f.bases[0].variable,
            heldout_deviance_gain: gain(f),
            heldout_rms_nm: f.model.heldout_rms,
            delta_bic: f.bic(nobs) - fin.bic(nobs),
            parameters: f.rank,
        })
        .collect();
    // The terms that generalise (held-out gain above the threshold), best first; the sign of
    // the velocity before a function of the velocity that gains at most a fifth more (the
    // coarser explanation, module docs).
    let mut eligible: Vec<&FlexFit> = fits.iter().filter(|f| gain(f) > min_gain).collect();
    let at = |v: StateVariable, e: &[&FlexFit]| e.iter().position(|f| f.bases[0].variable == v);
    if let (Some(iv), Some(id)) = (
        at(StateVariable::Velocity, &eligible),
        at(StateVariable::Direction, &eligible),
    ) {
        if iv < id && gain(eligible[id]) >= COARSER_SHARE * gain(eligible[iv]) {
            let d = eligible.remove(id);
            eligible.insert(iv, d);
        }
    }
    let mut chosen: Option<Vec<FlexBasis>> = None;
    if let Some(first) = eligible.first() {
        chosen = Some(first.bases.clone());
        if let Some(second) = eligible.get(1) {
            let pair = vec![first.bases[0].clone(), second.bases[0].clone()];
            let both = fit_flexible(
                ctx,
                &fin.kinds,
                &first.model.x,
                &pair,
                Some(folds_of(&pair)),
                false,
            );
            // the pair's gain over the first alone, on the same folds
            let first_dev = if uses_time(&pair) && !uses_time(&first.bases) {
                fit_flexible(
                    ctx,
                    &fin.kinds,
                    &first.model.x,
                    &first.bases,
                    Some(&blocks),
                    false,
                )
                .map(|again| {
                    evaluations += again.model.evaluations;
                    again.model.heldout_dev
                })
                .unwrap_or(f64::NAN)
            } else {
                first.model.heldout_dev
            };
            if let Ok(both) = both {
                evaluations += both.model.evaluations;
                if first_dev - both.model.heldout_dev > min_gain {
                    chosen = Some(pair);
                }
            }
        }
    }
    let mut catalogued_shape = None;
    let mut unneeded = Vec::new();
    let extension = match &chosen {
        None => None,
        Some(chosen) => {
            let ff = fit_flexible(
                ctx,
                &fin.kinds,
                &fin.x,
                chosen,
                Some(folds_of(chosen)),
                true,
            )?;
            evaluations += ff.model.evaluations;
            // a named cause the extension makes unnecessary is not named either
            if let Ok((u, ev)) = review(ctx, &ff.model, ff.bic(nobs), chosen, margin_bic, nobs) {
                evaluations += ev;
                unneeded = u;
            }
            // a catalogued effect of the best variable that explains it as well after all: by
            // the naming rule, its BIC beats a flexible term in each of its own variables by
            // the margin (an effect already replaced lost that comparison)
            let top = chosen[0].variable;
            let single_bic = |v: StateVariable| {
                fits.iter()
                    .find(|f| f.bases[0].variable == v)
                    .map(|f| f.bic(nobs))
            };
            let mut best: Option<(EffectKind, f64)> = None;
            for &k in catalogued.iter().filter(|k| {
                !fin.kinds.contains(k)
                    && !replaced.iter().any(|r| r.effect == k.name())
                    && StateVariable::of_effect(**k).contains(&top)
            }) {
                let mut kinds = fin.kinds.clone();
                kinds.push(k);
                let mut x0 = fin.x.clone();
                x0.extend(k.null_values().iter().take(k.params().len()));
                if let Ok(cf) = ctx.fit(&kinds, &x0, false) {
                    evaluations += cf.evaluations;
                    let d = StateVariable::of_effect(k)
                        .iter()
                        .filter_map(|v| single_bic(*v))
                        .fold(f64::INFINITY, f64::min)
                        - cf.bic(nobs);
                    if d >= margin_bic && best.is_none_or(|(_, b)| d > b) {
                        best = Some((k, d));
                    }
                }
            }
            catalogued_shape = best.map(|(k, _)| k.name().to_string());
            let cols: Vec<&Vec<f64>> = ff.bases.iter().flat_map(|b| b.cols.iter()).collect();
            Some(FlexibleExtension {
                variables: ff.variables(),
                heldout_rms_nm: ff.model.heldout_rms,
                heldout_rms_reduction_pct: 100.0
                    * (1.0 - ff.model.heldout_rms / reference(&ff.bases).0),
                heldout_deviance_gain: gain(&ff),
                rms_nm: ff.model.rms,
                delta_bic: ff.bic(nobs) - fin.bic(nobs),
                terms: terms_of(&ff),
                term_nm: combine(&cols, &ff.beta, ctx.y.len()),
            })
        }
    };
    Ok(Characterisation {
        unexplained: Unexplained {
            depends_on: chosen
                .map(|c| c.iter().map(|b| b.variable).collect())
                .unwrap_or_default(),
            ranking,
            extension,
            catalogued_shape,
            replaced,
        },
        unneeded,
        evaluations,
    })
}

#[cfg(test)]
mod tests {
    use super::Functions;

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
