//! The searched forms of a flexible term: time with a step `1{t ≥ τ}` at the residual's most
//! likely change point or with a sinusoid at its strongest frequency, direction as
//! `tanh(q̇/w)` with its transition width searched on the residual, and the simplest shape in
//! time (a ramp) for the review of a cause in time. A searched value counts as one parameter
//! in the BIC.

use nalgebra::{DMatrix, DVector};

use crate::fit::Context;

use super::basis::{from_functions, observed_range, series, FlexBasis, Functions, STILL_FRACTION};
use super::report::SearchedValue;
use super::variable::StateVariable;

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
    let hats = Functions::Hats(out.points.clone()).eval(tau);
    add_step_to_shape(
        &mut out,
        tau,
        Some(hats),
        |p| if p >= tau { 1.0 } else { 0.0 },
        SearchedValue {
            name: "change_point".into(),
            value: tau,
            unit: "s".into(),
        },
    );
    out
}

/// The reported shape of `out` with a step at `at` added as its last column: each point's row
/// gains the step's value there (`step`), and two points at `at` carry the hats' row there
/// (`hats_at`) with the step's values below and above it; `searched` records where the step
/// was found.
fn add_step_to_shape(
    out: &mut FlexBasis,
    at: f64,
    hats_at: Option<Vec<f64>>,
    step: impl Fn(f64) -> f64,
    searched: SearchedValue,
) {
    let mut shape: Vec<(f64, Vec<f64>)> = out
        .points
        .iter()
        .zip(&out.rows)
        .map(|(p, row)| {
            let mut row = row.clone();
            row.push(step(*p));
            (*p, row)
        })
        .collect();
    if let Some(hats) = hats_at {
        // the side below first: the sort below is stable
        for side in [step(f64::NEG_INFINITY), step(f64::INFINITY)] {
            let mut row = hats.clone();
            row.push(side);
            shape.push((at, row));
        }
    }
    // stable: the knot rows before the two sides at `at`, the side below before the side above
    shape.sort_by(|a, b| a.0.total_cmp(&b.0));
    out.points = shape.iter().map(|(p, _)| *p).collect();
    out.rows = shape.into_iter().map(|(_, r)| r).collect();
    out.searched.push(searched);
}

/// The score test of a step column against a residual, the column grown a sample at a time:
/// the whitened residual `r̃` and the whitened column `c̃` projected off the columns `H` (the
/// whitened term's columns, a constant `with_constant`, the model's whitened Jacobian), and the
/// score `(c̃ᵀP⊥r̃)²/(c̃ᵀP⊥c̃)`. Adding sample `s` to the column adds its whitened impulse, so
/// `c̃ᵀr̃`, `Hᵀc̃` and `c̃ᵀc̃` grow by sums over the impulse's support.
struct StepScan {
    h: Vec<Vec<f64>>,
    ginv: DMatrix<f64>,
    /// `P⊥r̃`.
    wr: Vec<f64>,
    /// `c̃`.
    wc: Vec<f64>,
    /// `c̃ᵀP⊥r̃`, `c̃ᵀc̃`, `Hᵀc̃`.
    a: f64,
    q: f64,
    hc: DVector<f64>,
    impulse: Vec<f64>,
}

impl StepScan {
    /// `None` when `residual` or `jac` (when it has rows) is not one value per sample, or the
    /// projection cannot be formed.
    fn new(
        ctx: &Context,
        cols: &[Vec<f64>],
        with_constant: bool,
        jac: &DMatrix<f64>,
        residual: &[f64],
    ) -> Option<Self> {
        let n = ctx.y.len();
        if residual.len() != n {
            return None;
        }
        let whiten = |x: &[f64]| {
            let mut w = vec![0.0; n];
            ctx.plan.whiten(x, &mut w);
            w
        };
        let mut h: Vec<Vec<f64>> = cols.iter().map(|c| whiten(c)).collect();
        if with_constant {
            h.push(whiten(&vec![1.0; n]));
        }
        if jac.nrows() == n {
            h.extend(
                jac.column_iter()
                    .map(|c| c.iter().copied().collect::<Vec<f64>>()),
            );
        }
        let k = h.len();
        let gram = DMatrix::from_fn(k, k, |a, b| dot(&h[a], &h[b]));
        let svd = gram.svd(true, true);
        // (HᵀH)⁻¹Hᵀv by the pseudo-inverse: hats over unobserved stretches, or over a range the
        // compared samples do not fill, may be degenerate
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
        let ginv = svd.pseudo_inverse(1e-12).ok()?;
        Some(StepScan {
            h,
            ginv,
            wr,
            wc: vec![0.0; n],
            a: 0.0,
            q: 0.0,
            hc: DVector::zeros(k),
            impulse: Vec::new(),
        })
    }

    /// Adds sample `s` to the step column.
    fn add(&mut self, ctx: &Context, s: usize) {
        ctx.plan.whitened_impulse(s, 1e-12, &mut self.impulse);
        for (o, &di) in self.impulse.iter().enumerate() {
            let i = s + o;
            self.q += di * (2.0 * self.wc[i] + di);
            self.a += di * self.wr[i];
            for (hj, c) in self.hc.iter_mut().zip(&self.h) {
                *hj += di * c[i];
            }
            self.wc[i] += di;
        }
    }

    /// The score of the column as it stands (0 when the projection leaves nothing of it).
    fn score(&self) -> f64 {
        let rest = self.q - self.hc.dot(&(&self.ginv * &self.hc));
        if rest > 1e-12 * self.q {
            self.a * self.a / rest
        } else {
            0.0
        }
    }
}

fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
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
pub(super) fn change_point(
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
    let mut scan = StepScan::new(ctx, cols, false, jac, residual)?;
    // Backwards over the onsets: the whitened step at s is the one at s + 1 plus the whitened
    // impulse at s.
    let mut best: Option<(usize, f64)> = None;
    for s in (0..n).rev() {
        scan.add(ctx, s);
        if !(ctx.is_observed(s) && t[s] - t0 >= STEP_MARGIN_S && t1 - t[s] >= STEP_MARGIN_S) {
            continue;
        }
        let score = scan.score();
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
pub(super) fn simplest_in_time(ctx: &Context) -> Vec<FlexBasis> {
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
        by_direction: false,
    }]
}

/// Smallest share of the compared samples on either side of a step in a hat variable: a step
/// that a few samples carry is a spike of the noise, not a level the torque changes at.
const LEVEL_STEP_MIN_SHARE: f64 = 0.02;

/// The hat basis `b` of the angle or an activation with a step `1{v ≥ c}` added (centred, as
/// the hats are), the level `c` searched on `residual` (`y − τ̂` of the model the term will
/// extend, N·m) beside the hats and the parameters of that model (`jac`, its whitened
/// Jacobian): the `c` among the variable's values between its 5 % and 95 % quantiles whose
/// whitened step column, projected off the whitened hats, a constant and the Jacobian,
/// explains most of the whitened residual, `(cᵀP⊥r)²/(cᵀP⊥c)` (the score test of
/// [`change_point`] with a level in place of a time).
///
/// Every value is a candidate, not a grid: a whitened step is mostly the innovations at the
/// samples where the variable crosses the level, so the score falls off within a sample or two
/// of the true crossings (a grid of 40 levels over the seed trial's angle put a 2 N·m step at
/// −7.75° at −3.76°). As the level falls past a value, the samples holding it enter the
/// column, and the whitened column, its products with the residual and the projection's
/// columns, and its squared norm grow by those samples' whitened impulses.
///
/// Five hats uniform over the range only ramp through a jump of the torque at one level of the
/// variable (a contact that closes at an angle, a recruitment threshold in the activation).
/// `None` for any other variable, when no level leaves [`LEVEL_STEP_MIN_SHARE`] of the samples
/// on both sides, or when the projection cannot be formed.
pub(super) fn with_level_step(
    ctx: &Context,
    b: &FlexBasis,
    residual: &[f64],
    jac: &DMatrix<f64>,
) -> Option<FlexBasis> {
    let hat_variables = [
        StateVariable::Angle,
        StateVariable::Activation,
        StateVariable::ActivationTa,
    ];
    let n = ctx.y.len();
    if !hat_variables.contains(&b.variable) || residual.len() != n || jac.nrows() != n {
        return None;
    }
    let s = series(ctx, b.variable)?;
    // every sample with a value, highest first; the shares count the compared ones
    let mut order: Vec<usize> = (0..n).filter(|i| s[*i].is_finite()).collect();
    order.sort_by(|a, b| s[*b].total_cmp(&s[*a]));
    let m = order.iter().filter(|i| ctx.is_observed(**i)).count();
    if m < 4 {
        return None;
    }
    let descending: Vec<f64> = order
        .iter()
        .filter(|i| ctx.is_observed(**i))
        .map(|i| s[*i])
        .collect();
    // the nearest-rank quantile q, counted from the top
    let at = |q: f64| descending[m - 1 - ((q * (m - 1) as f64).round() as usize).min(m - 1)];
    let (lo, hi) = (at(0.05), at(0.95));
    if hi <= lo {
        return None;
    }
    let mut scan = StepScan::new(ctx, &b.cols, true, jac, residual)?;
    let min_side = (LEVEL_STEP_MIN_SHARE * m as f64).ceil() as usize;
    let mut above = 0usize;
    // (level, score, compared samples at or above it)
    let mut best: Option<(f64, f64, usize)> = None;
    let mut j = 0;
    while j < order.len() {
        // the samples holding the next value down enter the column together
        let level = s[order[j]];
        while j < order.len() && s[order[j]] == level {
            above += usize::from(ctx.is_observed(order[j]));
            scan.add(ctx, order[j]);
            j += 1;
        }
        if level > hi || level < lo || above < min_side || m - above < min_side {
            continue;
        }
        let score = scan.score();
        if best.is_none_or(|(_, b, _)| score > b) {
            best = Some((level, score, above));
        }
    }
    let (level, _, above) = best?;
    let share = above as f64 / m as f64;
    let step = |v: f64| if v >= level { 1.0 - share } else { -share };
    let mut out = b.clone();
    out.cols.push(
        s.iter()
            .map(|v| if v.is_finite() { step(*v) } else { 0.0 })
            .collect(),
    );
    // the hats interpolated at the level (exact: the centred hats are linear between knots)
    let hats = interpolated_row(&b.points, &b.rows, level);
    add_step_to_shape(
        &mut out,
        level,
        hats,
        step,
        SearchedValue {
            name: "step_level".into(),
            value: level,
            unit: b.variable.unit().into(),
        },
    );
    Some(out)
}

/// The hat rows `rows` (one per knot in `points`, ascending) interpolated linearly at `v`.
fn interpolated_row(points: &[f64], rows: &[Vec<f64>], v: f64) -> Option<Vec<f64>> {
    let j = points.windows(2).position(|w| w[0] <= v && v <= w[1])?;
    let (a, b) = (points[j], points[j + 1]);
    let f = if b > a { (v - a) / (b - a) } else { 0.0 };
    Some(
        rows[j]
            .iter()
            .zip(&rows[j + 1])
            .map(|(x, y)| x + f * (y - x))
            .collect(),
    )
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
pub(super) fn with_width(ctx: &Context, b: FlexBasis, residual: &[f64]) -> FlexBasis {
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

/// Lowest frequency of the periodic form in time, in periods over the compared span: slower
/// changes are what the time hats and the ramp describe.
const PERIOD_MIN_CYCLES: f64 = 2.0;

/// Highest frequency (Hz) of the periodic form in time: a mains hum or a motor's ripple
/// above it is the noise model's, and the torque of a triceps does not follow it.
const PERIOD_MAX_HZ: f64 = 5.0;

/// Frequencies scanned per unit of the Fourier resolution `1/span`.
const PERIOD_OVERSAMPLING: f64 = 4.0;

/// The time basis `b` with a sinusoid `sin(2πft)`, `cos(2πft)` added at the frequency `f`
/// that explains most of the whitened `residual` (`y − τ̂` of the model the term will extend,
/// N·m): the largest `r̃ᵀP_f r̃` over a grid from [`PERIOD_MIN_CYCLES`] periods in the
/// compared span to [`PERIOD_MAX_HZ`] at a quarter of the Fourier resolution, `P_f` the
/// projection onto the whitened pair, `r̃` the whitened residual.
///
/// A disturbance periodic in time but not locked to the motion (a fan, a treadmill belt's
/// joint, a strap that creaks at its own rate) has no term in the hats every 2 s, which only
/// follow changes slower than a period of 4 s; the characterisation then put such a term on
/// the velocity or on no variable at all (docs/studies/uncatalogued.md). The frequency is a
/// searched value (one parameter in the BIC), the pair two coefficients; the shape is
/// reported at the knots. Any other basis is returned unchanged.
pub(super) fn with_period(ctx: &Context, b: FlexBasis, residual: &[f64]) -> FlexBasis {
    let t = ctx.inputs.times();
    let n = t.len();
    if b.variable != StateVariable::Time || residual.len() != n {
        return b;
    }
    let Some((t0, t1)) = observed_range(ctx, t) else {
        return b;
    };
    let span = t1 - t0;
    let (f_lo, f_hi) = (
        PERIOD_MIN_CYCLES / span,
        PERIOD_MAX_HZ.min(0.5 * ctx.inputs.fs()),
    );
    if !(span > 0.0 && f_lo < f_hi) {
        return b;
    }
    let mut wr = vec![0.0; n];
    ctx.plan.whiten(residual, &mut wr);
    let (mut ws, mut wc) = (vec![0.0; n], vec![0.0; n]);
    let (mut sin, mut cos) = (vec![0.0; n], vec![0.0; n]);
    let step = 1.0 / (PERIOD_OVERSAMPLING * span);
    let mut best: Option<(f64, f64)> = None;
    let mut f = f_lo;
    while f <= f_hi {
        let w = std::f64::consts::TAU * f;
        for (i, &ti) in t.iter().enumerate() {
            (sin[i], cos[i]) = (w * (ti - t0)).sin_cos();
        }
        ctx.plan.whiten(&sin, &mut ws);
        ctx.plan.whiten(&cos, &mut wc);
        // r̃ᵀP r̃ for the pair: (g⁻¹ of the 2×2 Gram) applied to the products with r̃
        let (ss, sc, cc) = (dot(&ws, &ws), dot(&ws, &wc), dot(&wc, &wc));
        let (rs, rc) = (dot(&ws, &wr), dot(&wc, &wr));
        let det = ss * cc - sc * sc;
        if det > 1e-12 * ss * cc {
            let score = (cc * rs * rs - 2.0 * sc * rs * rc + ss * rc * rc) / det;
            if best.is_none_or(|(_, s)| score > s) {
                best = Some((f, score));
            }
        }
        f += step;
    }
    let Some((f, _)) = best else {
        return b;
    };
    let w = std::f64::consts::TAU * f;
    let mut out = b;
    out.cols
        .push(t.iter().map(|&x| (w * (x - t0)).sin()).collect());
    out.cols
        .push(t.iter().map(|&x| (w * (x - t0)).cos()).collect());
    for (p, row) in out.points.iter().zip(out.rows.iter_mut()) {
        let (s, c) = (w * (p - t0)).sin_cos();
        row.push(s);
        row.push(c);
    }
    out.searched.push(SearchedValue {
        name: "frequency".into(),
        value: f,
        unit: "Hz".into(),
    });
    out
}

/// `b`, and also `b` with its searched forms when it has them (time: with its step,
/// [`with_step`], and with a sinusoid, [`with_period`]; direction: with its transition width,
/// [`with_width`]): all are fitted, and the best one (held-out gain in the ranking, BIC in
/// the review) stands for the variable.
///
/// A step is placed by the scan of [`change_point`] beside the parameters of the model that
/// left `residual` (`jac`, its whitened Jacobian) in the characterisation, by the cumulative
/// sum of [`change_point_cusum`] in the review (`None`).
pub(super) fn with_searched_forms(
    ctx: &Context,
    b: FlexBasis,
    residual: &[f64],
    jac: Option<&DMatrix<f64>>,
) -> Vec<FlexBasis> {
    if residual.is_empty() {
        return vec![b];
    }
    match b.variable {
        StateVariable::Time => vec![
            b.clone(),
            with_period(ctx, b.clone(), residual),
            with_step(ctx, b, residual, jac),
        ],
        StateVariable::Direction => vec![b.clone(), with_width(ctx, b, residual)],
        _ => {
            let stepped = jac.and_then(|j| with_level_step(ctx, &b, residual, j));
            std::iter::once(b).chain(stepped).collect()
        }
    }
}

#[cfg(test)]
mod tests {
    use super::{with_level_step, with_period, FlexBasis};
    use crate::flexible::basis::{basis, series};
    use crate::flexible::{seed_context, StateVariable};
    use nalgebra::DMatrix;

    fn empty_time_basis() -> FlexBasis {
        FlexBasis {
            variable: StateVariable::Time,
            points: vec![0.0, 1.0],
            rows: vec![vec![], vec![]],
            cols: Vec::new(),
            searched: Vec::new(),
            by_direction: false,
        }
    }

    #[test]
    fn the_periodic_form_finds_the_frequency_of_a_sinusoid_in_the_residual() {
        let ctx = seed_context();
        let t = ctx.inputs.times().to_vec();
        let span = t[t.len() - 1] - t[0];
        for f_true in [0.61, 1.37, 3.9] {
            // 2 N·m at f_true beside a ramp of 0.3 N·m over the trial
            let residual: Vec<f64> = t
                .iter()
                .map(|x| 2.0 * (std::f64::consts::TAU * f_true * x + 0.4).sin() + 0.3 * x / span)
                .collect();
            let b = with_period(&ctx, empty_time_basis(), &residual);
            assert_eq!(b.cols.len(), 2, "a sine and a cosine column");
            assert_eq!(b.rows.iter().map(Vec::len).collect::<Vec<_>>(), vec![2, 2]);
            let found = b.searched.last().expect("a searched frequency");
            assert_eq!(found.name, "frequency");
            assert!(
                (found.value - f_true).abs() <= 0.5 / span,
                "found {} Hz for {f_true} Hz (trial of {span:.1} s)",
                found.value
            );
        }
    }

    #[test]
    fn the_periodic_form_leaves_other_variables_alone() {
        let ctx = seed_context();
        let mut b = empty_time_basis();
        b.variable = StateVariable::Angle;
        let residual = vec![1.0; ctx.inputs.len()];
        let out = with_period(&ctx, b, &residual);
        assert!(out.cols.is_empty() && out.searched.is_empty());
    }

    #[test]
    fn the_level_step_finds_a_jump_of_the_torque_at_one_angle() {
        let ctx = seed_context();
        let angle = series(&ctx, StateVariable::Angle).expect("the seed trial moves");
        let (lo, hi) = angle
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| {
                (a.min(*v), b.max(*v))
            });
        let hats = basis(&ctx, StateVariable::Angle).unwrap();
        let no_model = DMatrix::<f64>::zeros(ctx.y.len(), 0);
        for frac in [0.35, 0.5, 0.62] {
            let level = lo + frac * (hi - lo);
            // 2 N·m above the level, beside a smooth 1 N·m function the hats follow
            let residual: Vec<f64> = angle
                .iter()
                .map(|a| 2.0 * f64::from(u8::from(*a >= level)) + ((a - lo) / (hi - lo)).powi(2))
                .collect();
            let b = with_level_step(&ctx, &hats, &residual, &no_model).expect("a step");
            assert_eq!(b.cols.len(), hats.cols.len() + 1);
            let found = b.searched.last().expect("a searched level");
            assert_eq!(found.name, "step_level");
            // at the level, to the angle's rounding
            assert!(
                (found.value - level).abs() <= 0.05,
                "found {:.2}° for {level:.2}° (range {lo:.1}–{hi:.1}°)",
                found.value
            );
            // the shape is reported on both sides of the level, in ascending order
            assert!(b.points.windows(2).all(|w| w[0] <= w[1]));
            assert_eq!(b.points.iter().filter(|p| **p == found.value).count(), 2);
            assert!(b.rows.iter().all(|r| r.len() == b.cols.len()));
        }
        // no level step in time or direction, whose searched forms are their own
        for v in [StateVariable::Time, StateVariable::Direction] {
            let b = basis(&ctx, v).unwrap();
            assert!(with_level_step(&ctx, &b, &vec![0.0; ctx.y.len()], &no_model).is_none());
        }
    }
}
