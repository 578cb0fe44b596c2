//! Bounded Levenberg–Marquardt for nonlinear least squares, with the residuals' exact Jacobian
//! when they have one and a finite-difference Jacobian otherwise.
//!
//! Minimises `C(x) = ‖r(x)‖² = Σᵢ rᵢ(x)²` over the box `l ≤ x ≤ h`. Steps are taken in
//! unit-box coordinates `u = (x − l)/(h − l)`, so that one damping and one difference step
//! serve parameters of any scale. Each iteration
//!
//! 1. forms the Jacobian `J = ∂r/∂u`: the residuals' own ([`Residuals::jacobian`]) times each
//!    range, or by finite differences of step `s` (a share of each range):
//!    forward, `(r(u + s·eⱼ) − r(u))/s` (backward at the upper bound), or central,
//!    `(r(u⁺) − r(u⁻))/(u⁺ⱼ − u⁻ⱼ)` with `u±ⱼ = uⱼ ± s` clipped to `[0, 1]`; the columns are
//!    evaluated in parallel and the result does not depend on the number of threads;
//! 2. forms `g = Jᵀr` (half the gradient of `C`) and holds every coordinate at a bound whose
//!    descent direction `−gⱼ` points out of the box;
//! 3. solves `(JᵀJ + λ·diag(JᵀJ)) δ = −g` on the other coordinates (Cholesky; the diagonal
//!    floored at 10⁻¹² so that a parameter without influence still gets a defined step),
//!    clips `u + δ` to `[0, 1]` and accepts it when the cost decreases:
//!    `λ ← max(λ/3, λ_min)`; otherwise (or when the system is not positive definite)
//!    `λ ← 4λ` and the step is solved again.
//!
//! It stops after `max_iterations` Jacobians; when an accepted step lowers the cost by less
//! than `ftol_rel` of it; when `max_rejections` steps in a row were rejected or `λ` exceeds
//! `λ_max`; when every coordinate is held; or when the Jacobian cannot be evaluated.
//!
//! ```
//! use numerics::lm::{levenberg_marquardt, FiniteDifferences, LevenbergMarquardtSettings};
//! // y = a·exp(−b t) through three points of a = 2, b = 3
//! let t = [0.0, 0.2, 0.5];
//! let r = |x: &[f64], _: &mut (), out: &mut Vec<f64>| {
//!     out.clear();
//!     out.extend(t.iter().map(|t| x[0] * (-x[1] * t).exp() - 2.0 * (-3.0 * t).exp()));
//!     true
//! };
//! let settings = LevenbergMarquardtSettings {
//!     differences: FiniteDifferences::Central,
//!     ..LevenbergMarquardtSettings::default()
//! };
//! let fit = levenberg_marquardt(&r, &[1.0, 1.0], &[(0.0, 5.0), (0.0, 5.0)], &settings, |_| {})
//!     .unwrap();
//! assert!((fit.x[0] - 2.0).abs() < 1e-5 && (fit.x[1] - 3.0).abs() < 1e-5);
//! ```

use rayon::prelude::*;

use crate::cholesky::cholesky_solve_in_place;
use crate::objective::UnitBox;
use crate::NumericsError;

/// Smallest diagonal entry of `JᵀJ` used to scale the damping.
const DIAGONAL_FLOOR: f64 = 1e-12;

/// How the Jacobian's columns are differenced.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[cfg_attr(feature = "serde", serde(rename_all = "snake_case"))]
pub enum FiniteDifferences {
    /// One evaluation per column, `(r(u + s) − r(u))/s` (backward at the upper bound).
    #[default]
    Forward,
    /// Two evaluations per column, `(r(u + s) − r(u − s))/2s` (one-sided at a bound): half
    /// the truncation error's order, for residuals with integrator noise.
    Central,
}

/// Settings of [`levenberg_marquardt`]. Plain data; check with
/// [`LevenbergMarquardtSettings::validate`] ([`levenberg_marquardt`] checks again).
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[cfg_attr(feature = "serde", serde(default))]
pub struct LevenbergMarquardtSettings {
    /// Maximum iterations (Jacobians). Default 30; 0 evaluates the start point only.
    pub max_iterations: usize,
    /// Difference scheme of the Jacobian. Default [`FiniteDifferences::Forward`].
    pub differences: FiniteDifferences,
    /// Difference step in unit-box coordinates (share of each range), in `(0, 0.5)`.
    /// Default 1e-3.
    pub fd_step: f64,
    /// Initial damping `λ` (relative to the diagonal of `JᵀJ`). Default 1e-3.
    pub lambda0: f64,
    /// Floor of `λ` after an accepted step. Default 1e-9.
    pub lambda_min: f64,
    /// The search stops when a rejection raises `λ` above this (may be `+∞`). Default 1e10.
    pub lambda_max: f64,
    /// The search stops after this many rejected steps in a row on one Jacobian (a system
    /// that is not positive definite counts as one). Default `usize::MAX` (no limit).
    pub max_rejections: usize,
    /// Stop when an accepted step lowers the cost by less than this fraction. Default 1e-7.
    pub ftol_rel: f64,
}

impl Default for LevenbergMarquardtSettings {
    fn default() -> Self {
        Self {
            max_iterations: 30,
            differences: FiniteDifferences::Forward,
            fd_step: 1e-3,
            lambda0: 1e-3,
            lambda_min: 1e-9,
            lambda_max: 1e10,
            max_rejections: usize::MAX,
            ftol_rel: 1e-7,
        }
    }
}

impl LevenbergMarquardtSettings {
    /// Check every field; returns the settings unchanged when valid.
    ///
    /// # Errors
    /// [`NumericsError::InvalidSetting`] naming the first invalid field.
    pub fn validate(self) -> Result<Self, NumericsError> {
        let bad = NumericsError::setting;
        if !(self.fd_step > 0.0 && self.fd_step < 0.5) {
            return bad("fd_step", self.fd_step, "must be in (0, 0.5)");
        }
        if !(self.lambda0 > 0.0 && self.lambda0.is_finite()) {
            return bad("lambda0", self.lambda0, "must be positive and finite");
        }
        if !(self.lambda_min > 0.0 && self.lambda_min.is_finite()) {
            return bad("lambda_min", self.lambda_min, "must be positive and finite");
        }
        if self.lambda_max.is_nan() || self.lambda_max < self.lambda0 {
            return bad("lambda_max", self.lambda_max, "must be at least lambda0");
        }
        if self.max_rejections == 0 {
            return bad("max_rejections", 0.0, "must be at least 1");
        }
        if !(self.ftol_rel >= 0.0 && self.ftol_rel.is_finite()) {
            return bad("ftol_rel", self.ftol_rel, "must be finite and non-negative");
        }
        Ok(self)
    }
}

/// A residual vector `r(x)` evaluated into a caller-owned buffer.
///
/// Evaluations run in parallel (one per Jacobian column), each with its own
/// [`Residuals::Workspace`]. Implemented for every
/// `Fn(&[f64], &mut (), &mut Vec<f64>) -> bool + Sync`.
pub trait Residuals: Sync {
    /// Scratch state of one evaluation (e.g. a simulation workspace).
    type Workspace: Send;
    /// A fresh workspace.
    fn workspace(&self) -> Self::Workspace;
    /// Write `r(x)` into `out` (resizing it; the length must not change between calls);
    /// `false` when it cannot be evaluated. Non-finite entries count as a failure.
    fn residuals(&self, x: &[f64], workspace: &mut Self::Workspace, out: &mut Vec<f64>) -> bool;
    /// The exact Jacobian `∂r/∂x` at `x` (x units, column-major: column `j` is
    /// `jac[j·m..(j + 1)·m]` for `m` residuals), when the residuals have one: `Some(true)` when
    /// written; `Some(false)` when it cannot be evaluated at `x` and `None` (the default) both
    /// make the search difference the residuals instead (a failure counts as one failed
    /// evaluation).
    fn jacobian(
        &self,
        x: &[f64],
        workspace: &mut Self::Workspace,
        jac: &mut [f64],
    ) -> Option<bool> {
        let _ = (x, workspace, jac);
        None
    }
}

impl<F: Fn(&[f64], &mut (), &mut Vec<f64>) -> bool + Sync> Residuals for F {
    type Workspace = ();
    fn workspace(&self) {}
    fn residuals(&self, x: &[f64], workspace: &mut (), out: &mut Vec<f64>) -> bool {
        self(x, workspace, out)
    }
}

/// Why [`levenberg_marquardt`] stopped.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[cfg_attr(feature = "serde", serde(rename_all = "snake_case"))]
pub enum LevenbergMarquardtStop {
    /// `max_iterations` Jacobians were used.
    MaxIterations,
    /// An accepted step lowered the cost by less than `ftol_rel`.
    SmallDecrease,
    /// No step was accepted within `max_rejections` tries or below `lambda_max`.
    NoDecrease,
    /// Every coordinate sits at a bound with its descent direction pointing outwards.
    AtBounds,
    /// A Jacobian column could not be evaluated.
    JacobianFailed,
}

/// One iteration's report to the observer of [`levenberg_marquardt`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LevenbergMarquardtProgress {
    /// Iteration (from 1).
    pub iteration: usize,
    /// Best cost so far.
    pub cost: f64,
    /// Residual evaluations so far.
    pub evaluations: usize,
}

/// What [`levenberg_marquardt`] found.
#[derive(Debug, Clone, PartialEq)]
pub struct LevenbergMarquardtOutcome {
    /// Best point (the start point clamped into the box when no step was accepted).
    pub x: Vec<f64>,
    /// `‖r(x)‖²`.
    pub cost: f64,
    /// `r(x)`.
    pub residuals: Vec<f64>,
    /// The last Jacobian `∂r/∂x` (x units, column-major: column `j` is
    /// `jacobian[j·m..(j + 1)·m]` for `m` residuals); `None` when none could be evaluated.
    pub jacobian: Option<Vec<f64>>,
    /// Whether `jacobian` was taken at `x` (false when the last accepted step came after it).
    pub jacobian_at_x: bool,
    /// Iterations (Jacobians attempted).
    pub iterations: usize,
    /// Accepted steps.
    pub accepted: usize,
    /// Residual evaluations, the start point's included.
    pub evaluations: usize,
    /// Evaluations that failed.
    pub failed_evaluations: usize,
    /// Why the search stopped.
    pub stop: LevenbergMarquardtStop,
}

/// Evaluate `r(x)` into `out`; false on failure, a length other than `m` or a non-finite entry.
fn evaluate<R: Residuals + ?Sized>(
    residuals: &R,
    x: &[f64],
    ws: &mut R::Workspace,
    out: &mut Vec<f64>,
    m: Option<usize>,
) -> bool {
    residuals.residuals(x, ws, out)
        && m.is_none_or(|m| out.len() == m)
        && out.iter().all(|v| v.is_finite())
}

/// Finite-difference Jacobian `∂r/∂u` at the unit point `u` with residual `r0`, column-major
/// into `jac` (`n·m`); returns (success, evaluations, failed evaluations).
fn jacobian_unit<R: Residuals + ?Sized>(
    residuals: &R,
    ubox: &UnitBox,
    u: &[f64],
    r0: &[f64],
    settings: &LevenbergMarquardtSettings,
    jac: &mut [f64],
) -> (bool, usize, usize) {
    let m = r0.len();
    let x = ubox.to_box(u);
    let mut exact_failed = 0;
    if let Some(ok) = residuals.jacobian(&x, &mut residuals.workspace(), jac) {
        if ok && jac.iter().all(|v| v.is_finite()) {
            // ∂r/∂u = ∂r/∂x·(hi − lo), column by column
            for (j, col) in jac.chunks_mut(m).enumerate() {
                let w = ubox.width()[j];
                col.iter_mut().for_each(|v| *v *= w);
            }
            return (true, 1, 0);
        }
        // an exact Jacobian that cannot be evaluated here: difference the residuals instead
        exact_failed = 1;
    }
    let h = settings.fd_step;
    let central = settings.differences == FiniteDifferences::Central;
    let columns: Vec<(bool, usize)> = jac
        .par_chunks_mut(m)
        .enumerate()
        .map_init(
            || (residuals.workspace(), Vec::new(), Vec::new(), u.to_vec()),
            |(ws, rp, rm, uu), (j, col)| {
                uu.copy_from_slice(u);
                let (up, um) = if central {
                    ((u[j] + h).min(1.0), (u[j] - h).max(0.0))
                } else if u[j] + h > 1.0 {
                    (u[j] - h, u[j])
                } else {
                    (u[j] + h, u[j])
                };
                uu[j] = up;
                let ok_p = evaluate(residuals, &ubox.to_box(uu), ws, rp, Some(m));
                let ok_m = if central {
                    uu[j] = um;
                    evaluate(residuals, &ubox.to_box(uu), ws, rm, Some(m))
                } else {
                    true
                };
                let failed = usize::from(!ok_p) + usize::from(!ok_m);
                let base: &[f64] = if central { rm } else { r0 };
                let d = up - um;
                if failed > 0 || d == 0.0 {
                    return (false, failed);
                }
                for ((c, p), q) in col.iter_mut().zip(rp.iter()).zip(base) {
                    *c = (p - q) / d;
                }
                (true, failed)
            },
        )
        .collect();
    let per_column = if central { 2 } else { 1 };
    let failed = columns.iter().map(|c| c.1).sum::<usize>() + exact_failed;
    (
        columns.iter().all(|c| c.0),
        per_column * columns.len() + exact_failed,
        failed,
    )
}

/// The Jacobian `∂r/∂x` (x units, column-major) of `residuals` at `x` (residual `r`) inside
/// `bounds`: their exact one ([`Residuals::jacobian`]) when they offer it, otherwise by
/// differences with the scheme and step of `settings`; and the evaluations used (an exact
/// Jacobian counts as one). `None` for the Jacobian when it cannot be evaluated.
///
/// # Errors
/// Invalid settings or bounds, or `x` of the wrong length.
pub fn residual_jacobian<R: Residuals + ?Sized>(
    residuals: &R,
    x: &[f64],
    r: &[f64],
    bounds: &[(f64, f64)],
    settings: &LevenbergMarquardtSettings,
) -> Result<(Option<Vec<f64>>, usize), NumericsError> {
    let settings = settings.validate()?;
    let ubox = UnitBox::from_bounds(bounds)?;
    let u = unit_point(&ubox, x)?.1;
    let mut jac = vec![0.0; x.len() * r.len()];
    if r.is_empty() {
        return Ok((Some(jac), 0));
    }
    let (ok, evaluations, _) = jacobian_unit(residuals, &ubox, &u, r, &settings, &mut jac);
    Ok((
        ok.then(|| to_x_units(jac, ubox.width(), r.len())),
        evaluations,
    ))
}

/// `x` clamped into the box, and its unit coordinates.
fn unit_point(ubox: &UnitBox, x0: &[f64]) -> Result<(Vec<f64>, Vec<f64>), NumericsError> {
    let n = ubox.dim();
    if x0.len() != n {
        return Err(NumericsError::DimensionMismatch {
            expected: n,
            found: x0.len(),
        });
    }
    let mut x = Vec::with_capacity(n);
    let mut u = Vec::with_capacity(n);
    for (i, ((&v, &lo), &w)) in x0.iter().zip(ubox.lower()).zip(ubox.width()).enumerate() {
        if !v.is_finite() {
            return Err(NumericsError::StartOutOfBounds {
                index: i,
                value: v,
                lower: lo,
                upper: lo + w,
            });
        }
        let xi = v.clamp(lo, lo + w);
        x.push(xi);
        u.push(((xi - lo) / w).clamp(0.0, 1.0));
    }
    Ok((x, u))
}

/// Column `j` of a unit-box Jacobian divided by the width of coordinate `j`.
fn to_x_units(mut jac: Vec<f64>, width: &[f64], m: usize) -> Vec<f64> {
    for (col, w) in jac.chunks_mut(m).zip(width) {
        col.iter_mut().for_each(|v| *v /= w);
    }
    jac
}

/// Minimise `‖r(x)‖²` from `x0` (clamped into `bounds`) by the bounded Levenberg–Marquardt of
/// the module documentation; `progress` is called after every iteration that tried a step.
///
/// # Errors
/// Invalid settings or bounds, `x0` of the wrong length or not finite, no residuals, or
/// residuals that cannot be evaluated at the start point
/// ([`NumericsError::StartEvaluationFailed`]).
pub fn levenberg_marquardt<R: Residuals + ?Sized>(
    residuals: &R,
    x0: &[f64],
    bounds: &[(f64, f64)],
    settings: &LevenbergMarquardtSettings,
    mut progress: impl FnMut(&LevenbergMarquardtProgress),
) -> Result<LevenbergMarquardtOutcome, NumericsError> {
    let s = settings.validate()?;
    let ubox = UnitBox::from_bounds(bounds)?;
    let n = ubox.dim();
    let (mut x, mut u) = unit_point(&ubox, x0)?;
    let mut ws = residuals.workspace();
    let mut r = Vec::new();
    if !evaluate(residuals, &x, &mut ws, &mut r, None) {
        return Err(NumericsError::StartEvaluationFailed);
    }
    let m = r.len();
    if m == 0 {
        return Err(NumericsError::EmptyProblem);
    }
    let mut out = LevenbergMarquardtOutcome {
        x: Vec::new(),
        cost: r.iter().map(|v| v * v).sum(),
        residuals: Vec::new(),
        jacobian: None,
        jacobian_at_x: false,
        iterations: 0,
        accepted: 0,
        evaluations: 1,
        failed_evaluations: 0,
        stop: LevenbergMarquardtStop::MaxIterations,
    };
    let mut lambda = s.lambda0;
    let mut jac = vec![0.0; n * m];
    let mut trial_jac = vec![0.0; n * m];
    let mut have_jac = false;
    let mut trial_r = Vec::with_capacity(m);
    let mut jtj = vec![0.0; n * n];
    let mut g = vec![0.0; n];
    for it in 1..=s.max_iterations {
        out.iterations = it;
        let (ok, evaluations, failed) = jacobian_unit(residuals, &ubox, &u, &r, &s, &mut trial_jac);
        out.evaluations += evaluations;
        out.failed_evaluations += failed;
        if !ok {
            out.stop = LevenbergMarquardtStop::JacobianFailed;
            break;
        }
        std::mem::swap(&mut jac, &mut trial_jac);
        have_jac = true;
        out.jacobian_at_x = true;
        // Normal equations g = Jᵀr, JᵀJ.
        for a in 0..n {
            let ca = &jac[a * m..(a + 1) * m];
            g[a] = ca.iter().zip(&r).map(|(p, q)| p * q).sum();
            for b in 0..=a {
                let cb = &jac[b * m..(b + 1) * m];
                let v: f64 = ca.iter().zip(cb).map(|(p, q)| p * q).sum();
                jtj[a * n + b] = v;
                jtj[b * n + a] = v;
            }
        }
        let free: Vec<usize> = (0..n)
            .filter(|&j| !((u[j] <= 0.0 && g[j] > 0.0) || (u[j] >= 1.0 && g[j] < 0.0)))
            .collect();
        if free.is_empty() {
            out.stop = LevenbergMarquardtStop::AtBounds;
            break;
        }
        let k = free.len();
        let mut a = vec![0.0; k * k];
        let mut delta = vec![0.0; k];
        let mut tries = 0;
        let mut improved = false;
        let mut converged = false;
        while tries < s.max_rejections {
            tries += 1;
            for (p, &i) in free.iter().enumerate() {
                delta[p] = -g[i];
                for (q, &j) in free.iter().enumerate() {
                    a[p * k + q] = jtj[i * n + j];
                }
                a[p * k + p] += lambda * jtj[i * n + i].max(DIAGONAL_FLOOR);
            }
            if cholesky_solve_in_place(&mut a, &mut delta).is_ok() {
                let mut un = u.clone();
                for (p, &i) in free.iter().enumerate() {
                    un[i] = (u[i] + delta[p]).clamp(0.0, 1.0);
                }
                let xn = ubox.to_box(&un);
                out.evaluations += 1;
                if evaluate(residuals, &xn, &mut ws, &mut trial_r, Some(m)) {
                    let c: f64 = trial_r.iter().map(|v| v * v).sum();
                    if c < out.cost {
                        let gain = (out.cost - c) / out.cost.max(1e-300);
                        u = un;
                        x = xn;
                        out.cost = c;
                        std::mem::swap(&mut r, &mut trial_r);
                        out.accepted += 1;
                        out.jacobian_at_x = false;
                        lambda = (lambda / 3.0).max(s.lambda_min);
                        improved = true;
                        converged = gain < s.ftol_rel;
                        break;
                    }
                } else {
                    out.failed_evaluations += 1;
                }
            }
            lambda *= 4.0;
            if !(lambda <= s.lambda_max && lambda.is_finite()) {
                break;
            }
        }
        progress(&LevenbergMarquardtProgress {
            iteration: it,
            cost: out.cost,
            evaluations: out.evaluations,
        });
        if !improved {
            out.stop = LevenbergMarquardtStop::NoDecrease;
            break;
        }
        if converged {
            out.stop = LevenbergMarquardtStop::SmallDecrease;
            break;
        }
    }
    out.x = x;
    out.residuals = r;
    out.jacobian = have_jac.then(|| to_x_units(jac, ubox.width(), m));
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `y = a·exp(−b t)` with `(a, b) = (2, 3)` on 50 points.
    fn curve(x: &[f64], out: &mut Vec<f64>) {
        out.clear();
        out.extend((0..50).map(|i| {
            let t = i as f64 * 0.02;
            x[0] * (-x[1] * t).exp() - 2.0 * (-3.0 * t).exp()
        }));
    }

    fn fit(bounds: &[(f64, f64)], differences: FiniteDifferences) -> LevenbergMarquardtOutcome {
        let r = |x: &[f64], _: &mut (), out: &mut Vec<f64>| {
            curve(x, out);
            true
        };
        let s = LevenbergMarquardtSettings {
            differences,
            ..Default::default()
        };
        levenberg_marquardt(&r, &[1.0, 1.0], bounds, &s, |_| {}).unwrap()
    }

    #[test]
    fn both_schemes_solve_a_curve_fit() {
        for d in [FiniteDifferences::Forward, FiniteDifferences::Central] {
            let o = fit(&[(0.0, 5.0), (0.0, 5.0)], d);
            assert!(
                (o.x[0] - 2.0).abs() < 1e-5 && (o.x[1] - 3.0).abs() < 1e-5,
                "{d:?}: {o:?}"
            );
            assert!(o.cost < 1e-10);
            // the start, two columns per Jacobian, at least one trial per accepted step
            let per_column = if d == FiniteDifferences::Central {
                2
            } else {
                1
            };
            let trials = o.evaluations - 1 - o.iterations * 2 * per_column;
            assert!(o.accepted >= 1 && trials >= o.accepted, "{o:?}");
            assert_eq!(o.failed_evaluations, 0);
        }
    }

    /// `y = a·exp(−b t)` with its exact Jacobian, counting the Jacobians taken.
    struct Decay {
        calls: std::sync::atomic::AtomicUsize,
        fail: bool,
    }

    impl Residuals for Decay {
        type Workspace = ();
        fn workspace(&self) {}
        fn residuals(&self, x: &[f64], _: &mut (), out: &mut Vec<f64>) -> bool {
            out.clear();
            out.extend(
                T.iter()
                    .map(|t| x[0] * (-x[1] * t).exp() - 2.0 * (-3.0 * t).exp()),
            );
            true
        }
        fn jacobian(&self, x: &[f64], _: &mut (), jac: &mut [f64]) -> Option<bool> {
            self.calls
                .fetch_add(1, std::sync::atomic::Ordering::Relaxed);
            if self.fail {
                return Some(false);
            }
            let m = T.len();
            for (i, t) in T.iter().enumerate() {
                jac[i] = (-x[1] * t).exp();
                jac[m + i] = -x[0] * t * (-x[1] * t).exp();
            }
            Some(true)
        }
    }

    const T: [f64; 3] = [0.0, 0.2, 0.5];

    #[test]
    fn an_exact_jacobian_replaces_the_differences() {
        let r = Decay {
            calls: Default::default(),
            fail: false,
        };
        let bounds = [(0.0, 5.0), (0.0, 5.0)];
        let o = levenberg_marquardt(
            &r,
            &[1.0, 1.0],
            &bounds,
            &LevenbergMarquardtSettings::default(),
            |_| {},
        )
        .unwrap();
        assert!(
            (o.x[0] - 2.0).abs() < 1e-6 && (o.x[1] - 3.0).abs() < 1e-6,
            "{o:?}"
        );
        let calls = r.calls.load(std::sync::atomic::Ordering::Relaxed);
        assert_eq!(calls, o.iterations);
        // one evaluation per Jacobian instead of one per column
        let trials = o.evaluations - 1 - o.iterations;
        assert!(o.accepted >= 1 && trials >= o.accepted, "{o:?}");
        // the exact Jacobian comes back in x units
        let (jac, evaluations) = residual_jacobian(
            &r,
            &[2.0, 3.0],
            &[0.0; 3],
            &bounds,
            &LevenbergMarquardtSettings::default(),
        )
        .unwrap();
        let jac = jac.unwrap();
        assert_eq!(evaluations, 1);
        assert!(
            (jac[0] - 1.0).abs() < 1e-15 && (jac[4] + 2.0 * 0.2 * (-0.6f64).exp()).abs() < 1e-14
        );
        // a Jacobian that cannot be evaluated falls back to differences, and the fit still
        // converges
        let failing = Decay {
            calls: Default::default(),
            fail: true,
        };
        let o = levenberg_marquardt(
            &failing,
            &[1.0, 1.0],
            &bounds,
            &LevenbergMarquardtSettings::default(),
            |_| {},
        )
        .unwrap();
        assert!(
            (o.x[0] - 2.0).abs() < 1e-5 && (o.x[1] - 3.0).abs() < 1e-5,
            "{o:?}"
        );
        assert_eq!(o.failed_evaluations, o.iterations);
    }

    #[test]
    fn a_bound_holds_the_fit() {
        let o = fit(&[(0.0, 5.0), (0.0, 2.5)], FiniteDifferences::Forward);
        assert_eq!(o.x[1], 2.5);
        let free = fit(&[(0.0, 5.0), (0.0, 5.0)], FiniteDifferences::Forward);
        assert!(o.cost > free.cost);
    }

    #[test]
    fn the_jacobian_is_in_x_units() {
        // r = (3x₀ − 1, x₀x₁): ∂r/∂x at (1, 2) is [[3, 0], [2, 1]]
        let r = |x: &[f64], _: &mut (), out: &mut Vec<f64>| {
            out.clear();
            out.extend([3.0 * x[0] - 1.0, x[0] * x[1]]);
            true
        };
        let s = LevenbergMarquardtSettings {
            differences: FiniteDifferences::Central,
            ..Default::default()
        };
        let bounds = [(-10.0, 10.0), (0.0, 100.0)];
        let (j, ev) = residual_jacobian(&r, &[1.0, 2.0], &[2.0, 2.0], &bounds, &s).unwrap();
        let j = j.unwrap();
        assert_eq!(ev, 4);
        for (got, want) in j.iter().zip([3.0, 2.0, 0.0, 1.0]) {
            assert!((got - want).abs() < 1e-9, "{j:?}");
        }
    }

    #[test]
    fn failures_are_reported_not_panicked() {
        let bounds = [(0.0, 1.0)];
        let s = LevenbergMarquardtSettings::default();
        let never = |_: &[f64], _: &mut (), _: &mut Vec<f64>| false;
        assert_eq!(
            levenberg_marquardt(&never, &[0.5], &bounds, &s, |_| {}),
            Err(NumericsError::StartEvaluationFailed)
        );
        // fails everywhere but at the start point: the first Jacobian fails
        let only_start = |x: &[f64], _: &mut (), out: &mut Vec<f64>| {
            out.clear();
            out.push(x[0]);
            x[0] == 0.5
        };
        let o = levenberg_marquardt(&only_start, &[0.5], &bounds, &s, |_| {}).unwrap();
        assert_eq!(o.stop, LevenbergMarquardtStop::JacobianFailed);
        assert_eq!((o.jacobian, o.accepted, o.failed_evaluations), (None, 0, 1));
        let nan = |_: &[f64], _: &mut (), out: &mut Vec<f64>| {
            out.clear();
            out.push(f64::NAN);
            true
        };
        assert!(levenberg_marquardt(&nan, &[0.5], &bounds, &s, |_| {}).is_err());
        assert!(levenberg_marquardt(&only_start, &[0.5, 0.5], &bounds, &s, |_| {}).is_err());
        assert!(levenberg_marquardt(&only_start, &[f64::NAN], &bounds, &s, |_| {}).is_err());
        assert!(levenberg_marquardt(&only_start, &[0.5], &[(1.0, 0.0)], &s, |_| {}).is_err());
    }

    #[test]
    fn settings_are_checked() {
        let s = LevenbergMarquardtSettings::default();
        assert!(s.validate().is_ok());
        let name = |s: LevenbergMarquardtSettings| match s.validate() {
            Err(NumericsError::InvalidSetting { name, .. }) => name,
            other => panic!("{other:?}"),
        };
        assert_eq!(
            name(LevenbergMarquardtSettings { fd_step: 0.5, ..s }),
            "fd_step"
        );
        assert_eq!(
            name(LevenbergMarquardtSettings { lambda0: 0.0, ..s }),
            "lambda0"
        );
        assert_eq!(
            name(LevenbergMarquardtSettings {
                lambda_min: f64::NAN,
                ..s
            }),
            "lambda_min"
        );
        assert_eq!(
            name(LevenbergMarquardtSettings {
                lambda_max: 1e-6,
                ..s
            }),
            "lambda_max"
        );
        assert_eq!(
            name(LevenbergMarquardtSettings {
                max_rejections: 0,
                ..s
            }),
            "max_rejections"
        );
        assert_eq!(
            name(LevenbergMarquardtSettings {
                ftol_rel: -1.0,
                ..s
            }),
            "ftol_rel"
        );
    }

    #[test]
    fn rejections_and_damping_end_a_hopeless_search() {
        // a kink at the start point that no damped step can get past: the cost is |x − 0.3|
        // made flat on the far side, so every step along −g increases it
        let r = |x: &[f64], _: &mut (), out: &mut Vec<f64>| {
            out.clear();
            out.push(if x[0] >= 0.3 {
                1.0 + (x[0] - 0.3)
            } else {
                1.0 + 10.0 * (0.3 - x[0])
            });
            true
        };
        let bounds = [(0.0, 1.0)];
        let by_count = LevenbergMarquardtSettings {
            max_rejections: 10,
            lambda_max: f64::INFINITY,
            ..Default::default()
        };
        let o = levenberg_marquardt(&r, &[0.3], &bounds, &by_count, |_| {}).unwrap();
        assert_eq!(o.stop, LevenbergMarquardtStop::NoDecrease);
        assert_eq!(o.evaluations, 1 + 1 + 10);
        let by_damping = LevenbergMarquardtSettings::default();
        let o = levenberg_marquardt(&r, &[0.3], &bounds, &by_damping, |_| {}).unwrap();
        assert_eq!(o.stop, LevenbergMarquardtStop::NoDecrease);
        // λ from 10⁻³ past 10¹⁰ takes 22 rejections
        assert_eq!(o.evaluations, 1 + 1 + 22);
    }
}
