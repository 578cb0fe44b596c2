//! The sampling coordinates: no walls, F0 on its exact truncated Gaussian conditional, the rest
//! on the logit scale and whitened by a Laplace fit.
//!
//! The joint torque is linear in every muscle's F0 (the normalised tendon force does not depend
//! on it): `τ = Σ_j F0_j·g_j(t; θ) + c(t; θ)`, `θ` the other parameters. With the whitening
//! filter `W` of the noise model, `ỹ = W(y − c)`, `G̃ = W[g_j]`, `A = G̃ᵀG̃ = RRᵀ`,
//! `f̂ = A⁻¹G̃ᵀỹ`, `RSS = ỹᵀỹ − ỹᵀG̃f̂`:
//!
//! `ℓ(θ, f) = N(θ) − ½·RSS(θ) − ½·(f − f̂)ᵀA(f − f̂)`,
//!
//! so `f | θ ~ N(f̂, Σ)`, `Σ = A⁻¹ = LLᵀ`, truncated to the F0 box.
//!
//! **θ** (LST and α0 of every muscle): `θ_i = lo_i + w_i·σ(φ_i)`, `σ` the logistic function,
//! `φ = φ_c + L_φ·z` with `L_φ` the Laplace factor of the best mode carried to the logit scale
//! ([`Conditional::with_chol_logit`]); the Jacobian `Σ ln(w_i σ(1 − σ))` is added.
//!
//! **f** (F0): `f = f̂ + L·ω`, where `ω` comes from `u ∈ ℝ^p` by the GHK map (Geweke,
//! Hajivassiliou, Keane): in turn for `k = 1..p`, `ω_k` is the standard normal truncated to the
//! interval `[l_k, h_k]` that keeps `f_k` in its bounds given `ω_1..ω_{k−1}`, taken at probability
//! level `Φ(u_k)`: `ω_k = Φ⁻¹(Φ(l_k) + Φ(u_k)·(Φ(h_k) − Φ(l_k)))`. The map is a bijection of
//! `ℝ^p` onto the part of the F0 box, and its Jacobian gives
//!
//! `log π(z, u) = N − ½RSS − ln det R + Σ_k ln(Φ(h_k) − Φ(l_k)) − ½|u|² + Σ ln(w_i σ(1 − σ))`.
//!
//! Without truncation `u` is exactly standard normal and independent of θ; with it, the mass
//! terms make the density smooth where the box cuts the conditional. Either way the sampler
//! sees no hard wall: the uniform prior's box is the image of the whole space. Why not
//! the simpler choice: sampling θ linearly with F0 at `f̂` clamped plus `R⁻ᵀu` puts about 28 %
//! of the random-walk proposals outside the box, and on random truths its chains mix five to
//! ten times more slowly.

//!
//! **Sessions.** Several trials sharing the parameters contribute independent likelihood terms:
//! `A`, `f̂`'s right-hand side, `ỹᵀỹ` and `N` are sums over the trials of their own Gram
//! quantities (module `trial_term`), each with its own whitening filter and offset nuisance; the
//! rest of the conditional is unchanged. The trials are evaluated one after the other inside
//! one log density, not in parallel: the 4 chains already keep 2 cores busy, and splitting a
//! 3-trial evaluation over the trials (rayon, summed in trial order) gave the same draws for
//! more CPU time and 2.1–2.4× the wall time on two synthetic knee0@30 + knee90@30 + knee0@60
//! sessions (35 against 30 CPU-s, 38 against 16 s; 60 against 57 CPU-s, 162 against 79 s on a
//! busier machine).

use std::cell::RefCell;

use muscle_model::{MuscleField, ParamId, ProblemWorkspace, Workspace};

use numerics::cholesky::{
    cholesky, solve_lower_in_place, solve_lower_transpose_in_place, spd_inverse,
};
use numerics::special::{normal_cdf, normal_quantile};

use crate::transform::{logistic_log_jacobian, logistic_map};
use crate::trial_term::{TrialModel, TrialTerm};
use crate::LogDensity;

/// Largest dimension handled with stack buffers.
const STACK_DIM: usize = 32;

#[derive(Default)]
struct Scratch {
    ws: Workspace,
    total: Vec<f64>,
}

thread_local! {
    static SCRATCH: RefCell<Scratch> = RefCell::new(Scratch::default());
}

/// A model evaluation in sampling coordinates.
pub(crate) struct Point {
    /// The log target `log π(v)` (with the Jacobian term).
    pub log_target: f64,
    /// The log-likelihood `ℓ(x)`.
    pub log_likelihood: f64,
}

/// The posterior in `(z, u)` coordinates (see the module documentation).
pub(crate) struct Conditional<'a> {
    /// The trials (at least one; shared free parameters and bounds).
    trials: Vec<TrialTerm<'a>>,
    /// The model's bounds (the uniform prior).
    model_bounds: Vec<(f64, f64)>,
    /// Free-parameter indices of the nonlinear parameters θ.
    nl: Vec<usize>,
    /// `(free index, muscle index)` of the F0 parameters.
    lin: Vec<(usize, usize)>,
    center: Vec<f64>,
    /// Whether the nonlinear parameters are sampled on the logit scale (see
    /// [`Conditional::with_chol_logit`]).
    logit: bool,
    /// Centre of the logit-scale coordinates `φ` (one per nonlinear parameter).
    phi_center: Vec<f64>,
    /// Lower Cholesky factor of θ's Laplace covariance, row-major |nl|×|nl|.
    chol_nl: Vec<f64>,
    zbounds: Vec<(f64, f64)>,
}

impl<'a> Conditional<'a> {
    /// Build the target around `center` (inside the bounds) with box half-width `k`.
    /// Returns the target and the simulations used for the Laplace factor.
    pub fn new(trials: &[TrialModel<'a>], center: &[f64], k: f64) -> (Self, u64) {
        let mut target = Self::build(trials, center, k);
        let (chol, sims) = target.laplace_at(center);
        target.chol_nl = chol;
        (target, sims)
    }

    /// Everything but the scaling (`chol_nl` left empty). `trials` is not empty and its
    /// problems share free parameters and bounds (checked by the caller).
    fn build(trials: &[TrialModel<'a>], center: &[f64], k: f64) -> Self {
        let problem = trials[0].problem;
        let mut nl = Vec::new();
        let mut lin = Vec::new();
        for (i, id) in problem.free().iter().enumerate() {
            match id {
                ParamId::Muscle(m, MuscleField::FomN) if problem.bounds()[i].0 > 0.0 => {
                    lin.push((i, m.index()))
                }
                _ => nl.push(i),
            }
        }
        let d = center.len();
        Self {
            trials: trials.iter().map(TrialTerm::new).collect(),
            model_bounds: problem.bounds().to_vec(),
            nl,
            lin,
            center: center.to_vec(),
            logit: false,
            phi_center: Vec::new(),
            chol_nl: Vec::new(),
            zbounds: vec![(-k, k); d],
        }
    }

    /// The target on the logit scale: every nonlinear parameter `θ_i ∈ (lo_i, hi_i)` is
    /// `θ_i = lo_i + w_i·σ(φ_i)`, `σ` the logistic function, and `φ = φ_c + L_φ·z` with
    /// `φ_c` the logit of `center` (each fraction clamped into [0.03, 0.97]) and
    /// `L_φ = D⁻¹·chol_nl`, `D = diag(w_i·σ(1 − σ))` at `φ_c` (the Laplace factor carried
    /// to the new scale). The log target gains the Jacobian `Σ ln(w_i·σ(φ_i)(1 − σ(φ_i)))`,
    /// so the posterior is the same, but the prior box has no walls for `θ`: a uniform prior
    /// becomes a smooth logistic density, and a random walk no longer wastes proposals
    /// outside the box in the directions the data do not constrain.
    pub fn with_chol_logit(
        trials: &[TrialModel<'a>],
        center: &[f64],
        chol_nl: &[f64],
        k: f64,
    ) -> Self {
        let mut t = Self::build(trials, center, k);
        t.phi_center =
            t.nl.iter()
                .map(|&i| {
                    let (lo, hi) = t.model_bounds[i];
                    let f = ((center[i] - lo) / (hi - lo)).clamp(0.03, 0.97);
                    (f / (1.0 - f)).ln()
                })
                .collect();
        t.chol_nl = t.phi_factor(center, chol_nl);
        t.logit = true;
        t
    }

    /// A factor `L` of θ's covariance at `x` carried to the logit scale: `D⁻¹L`,
    /// `D = diag(w_i·f_i(1 − f_i))`, `f_i` the fraction of θ_i in its bounds clamped into
    /// [0.03, 0.97].
    pub fn phi_factor(&self, x: &[f64], chol_nl: &[f64]) -> Vec<f64> {
        let m = self.nl.len();
        let mut out = chol_nl.to_vec();
        for (a, &i) in self.nl.iter().enumerate() {
            let (lo, hi) = self.model_bounds[i];
            let f = ((x[i] - lo) / (hi - lo)).clamp(0.03, 0.97);
            let dd = (hi - lo) * f * (1.0 - f);
            for v in &mut out[a * m..(a + 1) * m] {
                *v /= dd;
            }
        }
        out
    }

    /// The target without a Laplace factor: `θ = mid + diag(w/2)·z`, `mid` the middle of the
    /// bounds and `w` their widths, so `z ∈ [−1, 1]` spans the box (the scout of the mode
    /// search).
    pub fn box_scaled(trials: &[TrialModel<'a>]) -> Self {
        let center: Vec<f64> = trials[0]
            .problem
            .bounds()
            .iter()
            .map(|(lo, hi)| 0.5 * (lo + hi))
            .collect();
        let mut t = Self::build(trials, &center, 1.0);
        let m = t.nl.len();
        let mut chol = vec![0.0; m * m];
        for (a, &i) in t.nl.iter().enumerate() {
            let (lo, hi) = t.model_bounds[i];
            chol[a * m + a] = 0.5 * (hi - lo);
        }
        t.chol_nl = chol;
        t
    }

    /// Free-parameter indices of the nonlinear parameters (sampled in whitened coordinates).
    pub fn nl(&self) -> &[usize] {
        &self.nl
    }

    /// The lower Cholesky factor of the nonlinear parameters' scaling.
    pub fn chol_nl(&self) -> &[f64] {
        &self.chol_nl
    }

    /// Whitened coordinates of the nonlinear parameters of `x` (model vector):
    /// `z = L⁻¹(θ − θ_centre)`, or `L⁻¹(φ(θ) − φ_c)` on the logit scale.
    pub fn z_of(&self, x: &[f64]) -> Vec<f64> {
        let mut z: Vec<f64> = self
            .nl
            .iter()
            .enumerate()
            .map(|(a, &i)| {
                if self.logit {
                    let (lo, hi) = self.model_bounds[i];
                    let f = ((x[i] - lo) / (hi - lo)).clamp(1e-12, 1.0 - 1e-12);
                    (f / (1.0 - f)).ln() - self.phi_center[a]
                } else {
                    x[i] - self.center[i]
                }
            })
            .collect();
        solve_lower_in_place(&self.chol_nl, &mut z);
        z
    }

    /// Cholesky factor of θ's block of `(Jᵀ_w J_w + diag(12/w²))⁻¹` at `x` (a model vector):
    /// `J_w` the whitened Jacobian of the predicted torque, the trials' whitened columns
    /// stacked (the model's exact Jacobian where it has one; otherwise central differences of
    /// step `10⁻³·w`, one-sided at a bound), `diag(12/w²)` the precision of a Gaussian with the
    /// uniform prior's variance. The prior's diagonal if a simulation or a factorisation fails.
    pub fn laplace_at(&self, x: &[f64]) -> (Vec<f64>, u64) {
        let x = &x.to_vec();
        let d = x.len();
        let bounds = &self.model_bounds;
        let widths: Vec<f64> = bounds.iter().map(|(lo, hi)| hi - lo).collect();
        let m = self.nl.len();
        let prior_diag = || {
            let mut l = vec![0.0; m * m];
            for (a, &i) in self.nl.iter().enumerate() {
                l[a * m + a] = widths[i] / 12f64.sqrt();
            }
            l
        };
        let mut sims = 0u64;
        let mut cols: Vec<Vec<f64>> = Vec::with_capacity(d);
        if let Some((exact, evaluations)) = self.exact_whitened_columns(x) {
            sims += evaluations;
            cols = exact;
        }
        for i in cols.len()..d {
            let h = 1e-3 * widths[i];
            let (lo, hi) = bounds[i];
            let (a, b) = ((x[i] - h).max(lo), (x[i] + h).min(hi));
            let mut xa = x.clone();
            let mut xb = x.clone();
            xa[i] = a;
            xb[i] = b;
            let mut w = Vec::new();
            for t in &self.trials {
                sims += 2;
                let (Ok(pa), Ok(pb)) = (t.problem.predict(&xa), t.problem.predict(&xb)) else {
                    return (prior_diag(), sims);
                };
                let diff: Vec<f64> = pb.iter().zip(&pa).map(|(p, q)| (p - q) / (b - a)).collect();
                t.whiten_append(&diff, &mut w);
            }
            cols.push(w);
        }
        let mut h = vec![0.0; d * d];
        for i in 0..d {
            for j in 0..=i {
                let v: f64 = cols[i].iter().zip(&cols[j]).map(|(p, q)| p * q).sum();
                h[i * d + j] = v;
                h[j * d + i] = v;
            }
            h[i * d + i] += 12.0 / (widths[i] * widths[i]);
        }
        let Ok(cov) = spd_inverse(&h, d) else {
            return (prior_diag(), sims);
        };
        let mut block = vec![0.0; m * m];
        for (a, &i) in self.nl.iter().enumerate() {
            for (b, &j) in self.nl.iter().enumerate() {
                block[a * m + b] = cov[i * d + j];
            }
        }
        (cholesky(&block, m).unwrap_or_else(|_| prior_diag()), sims)
    }

    /// The whitened columns of `J_w` (as [`Conditional::laplace_at`]) from the model's exact
    /// Jacobian, one per free parameter, and the Jacobians taken; `None` when a trial's model
    /// has no exact derivative for a free parameter or its evaluation fails (the caller then
    /// differences). Differences at the default settings miss the α0 columns by 24–56 %
    /// (docs/model.md, "Integration jitter"), which skews the sampling coordinates' scaling.
    fn exact_whitened_columns(&self, x: &[f64]) -> Option<(Vec<Vec<f64>>, u64)> {
        let d = x.len();
        let mut cols: Vec<Vec<f64>> = vec![Vec::new(); d];
        let mut ws = ProblemWorkspace::new();
        let mut jac = Vec::new();
        let mut evaluations = 0;
        for t in &self.trials {
            t.problem.exact_jacobian_available().ok()?;
            evaluations += 1;
            t.problem.jacobian_with(x, &mut ws, &mut jac).ok()?;
            let n = t.problem.measured().len();
            for (i, col) in cols.iter_mut().enumerate() {
                t.whiten_append(&jac[i * n..(i + 1) * n], col);
            }
        }
        Some((cols, evaluations))
    }

    /// The summed Gram quantities of every trial at `x` (module `trial_term`): `A`, `b`,
    /// `yᵀy` and `N`. `None`: a simulation failed.
    fn session_gram(&self, x: &[f64]) -> Option<([f64; 9], [f64; 3], f64, f64)> {
        let p = self.lin.len();
        let mut a = [0.0; 9];
        let mut b = [0.0; 3];
        let mut yy = 0.0;
        let mut norm = 0.0;
        for t in &self.trials {
            let g = SCRATCH.with(|cell| {
                let s = &mut *cell.borrow_mut();
                t.gram(x, &self.lin, &mut s.ws, &mut s.total)
            })?;
            for (s, v) in a[..p * p].iter_mut().zip(&g.a) {
                *s += v;
            }
            for (s, v) in b[..p].iter_mut().zip(&g.b) {
                *s += v;
            }
            yy += g.yy;
            norm += g.norm;
        }
        Some((a, b, yy, norm))
    }

    /// Evaluate at `v`, writing the model parameters into `x`. `None`: failed simulation;
    /// `log_target = −∞`: outside the bounds.
    pub fn eval(&self, v: &[f64], x: &mut [f64]) -> Option<Point> {
        let outside = Some(Point {
            log_target: f64::NEG_INFINITY,
            log_likelihood: f64::NEG_INFINITY,
        });
        let m = self.nl.len();
        x.copy_from_slice(&self.center);
        let mut log_jac = 0.0;
        for (a, &i) in self.nl.iter().enumerate() {
            let row = &self.chol_nl[a * m..=a * m + a];
            let lz = row
                .iter()
                .zip(&self.nl)
                .map(|(l, &j)| l * v[j])
                .sum::<f64>();
            let (lo, hi) = self.model_bounds[i];
            if self.logit {
                // θ = lo + w·σ(φ); ln σ = −softplus(−φ), ln(1 − σ) = −softplus(φ).
                let phi = self.phi_center[a] + lz;
                x[i] = logistic_map(lo, hi - lo, phi);
                log_jac += logistic_log_jacobian(hi - lo, phi);
                if !(x[i] > lo && x[i] < hi) {
                    return outside;
                }
            } else {
                x[i] += lz;
                if !(x[i] >= lo && x[i] <= hi) {
                    return outside;
                }
            }
        }
        let p = self.lin.len();
        let (a, b, yy, norm) = self.session_gram(x)?;
        let r = cholesky(&a[..p * p], p).ok()?;
        // f̂ = A⁻¹b via R w = b, Rᵀ f̂ = w; RSS = yy − |w|².
        let mut w = [0.0; 3];
        for k in 0..p {
            let mut acc = b[k];
            for l in 0..k {
                acc -= r[k * p + l] * w[l];
            }
            w[k] = acc / r[k * p + k];
        }
        let rss = yy - w[..p].iter().map(|v| v * v).sum::<f64>();
        // f̂ from Rᵀ f̂ = w. The conditional f | θ is N(f̂, Σ), Σ = A⁻¹ = L Lᵀ, truncated to
        // the box; f = f̂ + L ω with ω from the GHK map of u (module documentation).
        let mut fh = [0.0; 3];
        fh[..p].copy_from_slice(&w[..p]);
        solve_lower_transpose_in_place(&r, &mut fh[..p]);
        let sigma_l = conditional_factor(&r, p)?;
        let mut omega = [0.0; 3];
        let mut log_mass = 0.0;
        let mut uu = 0.0;
        for (k, &(i, _)) in self.lin.iter().enumerate() {
            let (lo, hi) = self.model_bounds[i];
            let shift: f64 = fh[k] + (0..k).map(|j| sigma_l[k * p + j] * omega[j]).sum::<f64>();
            let lkk = sigma_l[k * p + k];
            let (wl, wh) = ((lo - shift) / lkk, (hi - shift) / lkk);
            let u = v[i];
            uu += u * u;
            let (om, lm) = ghk_step(wl, wh, normal_cdf(u))?;
            omega[k] = om;
            log_mass += lm;
            x[i] = (shift + lkk * om).clamp(lo, hi);
        }
        let ww: f64 = omega[..p].iter().map(|v| v * v).sum();
        let log_det_r: f64 = (0..p).map(|k| r[k * p + k].ln()).sum();
        let ll = norm - 0.5 * (rss.max(0.0) + ww);
        let log_target = norm - 0.5 * rss.max(0.0) - log_det_r + log_mass - 0.5 * uu + log_jac;
        (ll.is_finite() && !log_target.is_nan()).then_some(Point {
            log_target,
            log_likelihood: ll,
        })
    }
}

impl LogDensity for Conditional<'_> {
    fn dim(&self) -> usize {
        self.center.len()
    }
    fn bounds(&self) -> &[(f64, f64)] {
        &self.zbounds
    }
    fn log_density(&self, v: &[f64]) -> Option<f64> {
        let d = v.len();
        let r = if d <= STACK_DIM {
            let mut buf = [0.0; STACK_DIM];
            self.eval(v, &mut buf[..d])
        } else {
            let mut buf = vec![0.0; d];
            self.eval(v, &mut buf)
        };
        r.map(|p| p.log_target)
    }
    /// The model's bounds: the reported coordinates are the model's parameters.
    fn report_bounds(&self) -> &[(f64, f64)] {
        &self.model_bounds
    }
    /// `log π(v)`, the model parameters at `v` and the log-likelihood `ℓ(x)` stored with a draw.
    fn evaluate(&self, v: &[f64], report: &mut [f64]) -> Option<(f64, f64)> {
        self.eval(v, report)
            .map(|p| (p.log_target, p.log_likelihood))
    }
}

/// The lower Cholesky factor `L` of `Σ = A⁻¹` for `A = R Rᵀ` (`R` lower triangular, row-major
/// `p×p`, `p ≤ 3`): `Σ = R⁻ᵀ R⁻¹`, then its Cholesky factor. `None` if not positive definite.
fn conditional_factor(r: &[f64], p: usize) -> Option<[f64; 9]> {
    // R⁻¹ (lower triangular) by forward substitution on the identity.
    let mut ri = [0.0; 9];
    for col in 0..p {
        for row in col..p {
            let mut acc = if row == col { 1.0 } else { 0.0 };
            for k in col..row {
                acc -= r[row * p + k] * ri[k * p + col];
            }
            ri[row * p + col] = acc / r[row * p + row];
        }
    }
    let mut sigma = [0.0; 9];
    for i in 0..p {
        for j in 0..p {
            sigma[i * p + j] = (0..p).map(|k| ri[k * p + i] * ri[k * p + j]).sum();
        }
    }
    let l = cholesky(&sigma[..p * p], p).ok()?;
    let mut out = [0.0; 9];
    out[..p * p].copy_from_slice(&l);
    Some(out)
}

/// `ln Q(x)`, `Q(x) = 1 − Φ(x)` the upper tail: from `erfc` below 30, above by the asymptotic
/// series `Q(x) = φ(x)/x·(1 − 1/x² + 3/x⁴ − 15/x⁶ + 105/x⁸)` (relative error < 10⁻¹¹ there),
/// which never underflows.
fn ln_upper_tail(x: f64) -> f64 {
    if x < 30.0 {
        normal_cdf(-x).ln()
    } else {
        let r = 1.0 / (x * x);
        let series = 1.0 - r * (1.0 - r * (3.0 - r * (15.0 - 105.0 * r)));
        -0.5 * x * x - x.ln() - 0.5 * (2.0 * std::f64::consts::PI).ln() + series.ln()
    }
}

/// The `w ≥ 0` with `ln Q(w) = target`, by Newton's method on `ln Q` (its slope is
/// `−φ(w)/Q(w)`), started from `w₀ = max(start, √(−2·target) − 1)`.
fn upper_tail_quantile(target: f64, start: f64) -> f64 {
    if target > (1e-300f64).ln() + 10.0 {
        return -normal_quantile(target.exp());
    }
    let mut w = start.max((-2.0 * target).sqrt() - 1.0);
    for _ in 0..50 {
        let lq = ln_upper_tail(w);
        let ln_phi = -0.5 * w * w - 0.5 * (2.0 * std::f64::consts::PI).ln();
        let slope = -(ln_phi - lq).exp();
        let step = (lq - target) / slope;
        w -= step;
        if step.abs() <= 1e-12 * w.abs().max(1.0) {
            break;
        }
    }
    w
}

/// One step of the GHK map: the standard normal truncated to `[lo, hi]` at probability level
/// `q ∈ (0, 1)`, and the log of the interval's mass `Φ(hi) − Φ(lo)`. Intervals in a tail are
/// computed on that tail in log space, so that an interval many standard deviations out keeps
/// a finite (very negative) log mass instead of underflowing. `None` only for an empty or
/// non-finite interval.
fn ghk_step(lo: f64, hi: f64, q: f64) -> Option<(f64, f64)> {
    if lo.is_nan() || hi.is_nan() || lo >= hi {
        return None;
    }
    if lo > 5.0 || hi < -5.0 {
        // Work on the upper tail (mirror a lower-tail interval): Q(w) = Q(a) − q'·(Q(a) − Q(b)).
        let (a, b, qq, sign) = if lo > 5.0 {
            (lo, hi, q, 1.0)
        } else {
            (-hi, -lo, 1.0 - q, -1.0)
        };
        let la = ln_upper_tail(a);
        let lb = if b.is_finite() {
            ln_upper_tail(b)
        } else {
            f64::NEG_INFINITY
        };
        let ratio = (lb - la).exp(); // Q(b)/Q(a) < 1
        let log_mass = la + (-ratio).ln_1p();
        let target = la + (-qq * (1.0 - ratio)).ln_1p();
        let w = upper_tail_quantile(target, a);
        return (log_mass.is_finite() && w.is_finite())
            .then_some(((sign * w).clamp(lo, hi), log_mass));
    }
    let (pl, ph) = (normal_cdf(lo), normal_cdf(hi));
    let mass = ph - pl;
    let w = normal_quantile(pl + q * mass);
    (mass > 0.0 && w.is_finite()).then_some((w.clamp(lo, hi), mass.ln()))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn upper_tail_series_joins_erfc() {
        // Both forms at x = 29.9 (erfc is still accurate there).
        let x = 29.9f64;
        let direct = normal_cdf(-x).ln();
        let r = 1.0 / (x * x);
        let series = 1.0 - r * (1.0 - r * (3.0 - r * (15.0 - 105.0 * r)));
        let asym = -0.5 * x * x - x.ln() - 0.5 * (2.0 * std::f64::consts::PI).ln() + series.ln();
        assert!(
            (direct - asym).abs() < 1e-9 * direct.abs(),
            "{direct} vs {asym}"
        );
        assert!(ln_upper_tail(60.0).is_finite() && ln_upper_tail(60.0) < -1800.0);
    }

    #[test]
    fn ghk_step_matches_the_truncated_normal() {
        // Central interval: w is the q-quantile of N(0, 1) truncated to [lo, hi].
        for &(lo, hi) in &[(-1.0, 2.0), (-0.5, 0.5), (3.0, 4.5), (-4.9, -2.0)] {
            for &q in &[0.01, 0.3, 0.5, 0.9] {
                let (w, lm) = ghk_step(lo, hi, q).unwrap();
                let mass = normal_cdf(hi) - normal_cdf(lo);
                assert!((lm - mass.ln()).abs() < 1e-12);
                assert!(
                    ((normal_cdf(w) - normal_cdf(lo)) / mass - q).abs() < 1e-9,
                    "{lo} {hi} {q}"
                );
            }
        }
        // The tail form (|x| > 5) against upper-tail probabilities Q(x) = Φ(−x).
        for &q in &[0.05, 0.5, 0.95] {
            let (w, lm) = ghk_step(5.5, 6.0, q).unwrap();
            let mass = normal_cdf(-5.5) - normal_cdf(-6.0);
            assert!((lm - mass.ln()).abs() < 1e-10);
            assert!(
                ((normal_cdf(-5.5) - normal_cdf(-w)) / mass - q).abs() < 1e-9,
                "{q}"
            );
        }
        // Far tails: finite log mass, w inside, monotone in q; mirrored intervals agree.
        let mut last = f64::NEG_INFINITY;
        for &q in &[0.001, 0.2, 0.5, 0.8, 0.999] {
            let (w, lm) = ghk_step(60.0, 84.0, q).unwrap();
            assert!((60.0..=84.0).contains(&w) && w > last);
            assert!((lm - ln_upper_tail(60.0)).abs() < 1e-9);
            let (wm, lmm) = ghk_step(-84.0, -60.0, 1.0 - q).unwrap();
            assert!((wm + w).abs() < 1e-9 && (lmm - lm).abs() < 1e-12);
            last = w;
        }
        // Exponential-tail check: Q(w)/Q(60) = 1 − q ⇒ w ≈ 60 − ln(1 − q)/60.
        let (w, _) = ghk_step(60.0, 84.0, 0.5).unwrap();
        assert!((w - (60.0 + 2f64.ln() / 60.0)).abs() < 1e-4, "{w}");
        assert!(ghk_step(1.0, 1.0, 0.5).is_none());
    }
}
