//! The fit of a model with flexible terms and its cross-validation.
//!
//! The term is linear in `β`, so it is fitted by variable projection: for muscle
//! (and effect) parameters `x` the whitened residual `w(x) = W(y − τ̂(x))` is projected off the
//! whitened basis `WB` (`β̂(x)` by least squares, rank-revealing), and the bounded
//! Levenberg–Marquardt of the catalogued effects refits `x` on `‖(I − UUᵀ)w(x)‖²`, `U` the
//! left singular vectors of `WB`. The noise model and the whitening are those of the
//! catalogued effects, and so are the cross-validation folds, except for a term in time,
//! cross-validated on 0.5 s blocks in 5 folds (`time_folds`) and compared with the final
//! model on the same blocks. In each fold the basis is whitened over the training samples
//! only and the held-out samples are predicted by `τ̂(x_f) + Bβ̂_f`, `β̂_f` along the
//! directions the training samples fix at least half as well as the fit on all the samples
//! fixes its least determined one (`HELDOUT_MIN_SINGULAR_FRACTION`).
//!
//! The term's uncertainty is from the Gauss–Newton covariance of the full problem
//! `r(x, β) = w(x) − WBβ`: `Cov = s²(JᵀJ)⁺`, `J = [J_w, −WB]`, `s² = max(1, ‖r‖²/(n − k))`;
//! the band is ±1.96 standard errors of the term at each reported point.

use muscle_model::{EffectKind, ParamId};
use nalgebra::{DMatrix, DVector};
use rayon::prelude::*;

use crate::fit::{minimise_fold, minimise_model, pool_heldout, Context, Fit};
use crate::DiagnoseError;

use super::basis::{variables_of, FlexBasis};
use super::report::FlexibleTerm;
use super::variable::StateVariable;

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

/// The least singular value of a fold's whitened training basis along which a term is carried
/// into the held-out samples, as a fraction of the least singular value of the basis whitened
/// over all the samples.
///
/// The whitened residual has unit variance, so the coefficient along a right singular vector
/// of singular value `s` has the standard error `1/s`. A fold that holds out a fifth of the
/// samples spread over the whole range of the variable sees every direction a little less
/// well than the full fit (`s` about √0.8 ≈ 0.89 of it). Where a variable reaches part of its
/// range only inside the held-out samples (the activation around a recruitment level, reached
/// in one contraction) the training samples leave a combination of the columns they hardly
/// see, and its coefficient, multiplied by the held-out samples' large values of the same
/// columns, predicted them worse than no term at all (generated trial 83 242 660, a step of
/// the activation with its level searched: held-out deviance gain −1.7·10⁷ on the time
/// blocks). A direction the fold fixes less than half as well as the full fit fixes its least
/// determined one is left out of the fold's prediction. The bound is relative because the
/// whitened scale is the noise's: an absolute one (a standard error of 1 N·m) dropped every
/// term on a CEINMS stance whose noise is tens of newton-metres.
const HELDOUT_MIN_SINGULAR_FRACTION: f64 = 0.5;

/// Least squares on a whitened basis: `β = V Σ⁻¹ Uᵀ w` over the singular values above
/// `10⁻⁹` of the largest and above `min_singular` (columns without a training sample drop
/// out, `β` = 0 along them).
struct WhitenedBasisProjector {
    u: DMatrix<f64>,
    solve: DMatrix<f64>,
    /// The least singular value kept (0 when none is).
    smallest: f64,
}

impl WhitenedBasisProjector {
    fn new(
        plan: &muscle_model::WhitenPlan,
        cols: &[&Vec<f64>],
        n: usize,
        min_singular: f64,
    ) -> WhitenedBasisProjector {
        let mut wb = DMatrix::zeros(n, cols.len());
        for (j, c) in cols.iter().enumerate() {
            // a column of the column-major matrix is one contiguous run of samples
            plan.whiten(c, wb.column_mut(j).as_mut_slice());
        }
        if cols.is_empty() {
            return WhitenedBasisProjector {
                u: DMatrix::zeros(n, 0),
                solve: DMatrix::zeros(0, 0),
                smallest: 0.0,
            };
        }
        let svd = wb.svd(true, true);
        let (u, vt) = (svd.u.expect("u"), svd.v_t.expect("v_t"));
        let smax = svd.singular_values.max();
        let keep: Vec<usize> = (0..svd.singular_values.len())
            .filter(|&i| {
                let sv = svd.singular_values[i];
                sv > 1e-9 * smax && smax > 0.0 && sv >= min_singular
            })
            .collect();
        let smallest = keep
            .iter()
            .map(|&i| svd.singular_values[i])
            .fold(f64::INFINITY, f64::min);
        let mut uk = DMatrix::zeros(n, keep.len());
        let mut solve = DMatrix::zeros(cols.len(), keep.len());
        for (c, &i) in keep.iter().enumerate() {
            uk.set_column(c, &u.column(i));
            let s = svd.singular_values[i];
            for r in 0..cols.len() {
                solve[(r, c)] = vt[(i, r)] / s;
            }
        }
        WhitenedBasisProjector {
            u: uk,
            solve,
            smallest: if smallest.is_finite() { smallest } else { 0.0 },
        }
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
pub(super) fn combine(cols: &[&Vec<f64>], beta: &[f64], n: usize) -> Vec<f64> {
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
        variables_of(&self.bases)
    }
}

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
    let proj = WhitenedBasisProjector::new(&ctx.plan, &cols, n, 0.0);
    let f = ctx.residual_fn(&problem, &ctx.plan);
    let g = ctx
        .model_residuals(&problem, &ctx.plan)
        .then(|w: &[f64], out: &mut [f64]| out.copy_from_slice(&proj.residual(w)));
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

    // Gauss–Newton covariance of (x, β): J = [J_w, −WB]; J_w exact where the model has it
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
        Some(folds) => cross_validate(ctx, folds, &problem, &out.x, &cols, proj.smallest),
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
/// `folds`: pooled held-out RMS, held-out deviance and the simulations. `full_smallest`: the
/// least singular value the fit on all samples keeps of the whitened `cols` (0 without
/// columns), from which a fold's floor is set (`HELDOUT_MIN_SINGULAR_FRACTION`).
pub(crate) fn cross_validate(
    ctx: &Context,
    folds: &Folds,
    problem: &muscle_model::Problem,
    x: &[f64],
    cols: &[&Vec<f64>],
    full_smallest: f64,
) -> (f64, f64, usize) {
    let bounds = problem.bounds();
    let n = ctx.y.len();
    let floor = HELDOUT_MIN_SINGULAR_FRACTION * full_smallest;
    let res: Vec<((f64, f64, usize), usize)> = folds
        .par_iter()
        .map(|(held, plan)| {
            let proj = WhitenedBasisProjector::new(plan, cols, n, floor);
            let f = ctx.residual_fn(problem, plan);
            let g = ctx
                .model_residuals(problem, plan)
                .then(|w: &[f64], out: &mut [f64]| out.copy_from_slice(&proj.residual(w)));
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

/// The shapes of a flexible fit's terms.
pub(super) fn terms_of(ff: &FlexFit) -> Vec<FlexibleTerm> {
    let mut out = Vec::new();
    let mut j = 0;
    for b in &ff.bases {
        let m = b.cols.len();
        let beta = &ff.beta[j..j + m];
        let (value_nm, band_nm): (Vec<f64>, Vec<f64>) = b
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
        let term = |range: std::ops::Range<usize>, direction: Option<f64>| FlexibleTerm {
            variable: b.variable,
            direction,
            unit: b.variable.unit().to_string(),
            points: b.points[range.clone()].to_vec(),
            value_nm: value_nm[range.clone()].to_vec(),
            band_nm: band_nm[range].to_vec(),
            searched: b.searched.clone(),
        };
        if b.by_direction {
            // the points are the knots twice: while q̇ < 0, then while q̇ > 0
            let half = b.points.len() / 2;
            out.push(term(0..half, Some(-1.0)));
            out.push(term(half..b.points.len(), Some(1.0)));
        } else {
            out.push(term(0..b.points.len(), None));
        }
        j += m;
    }
    out
}
