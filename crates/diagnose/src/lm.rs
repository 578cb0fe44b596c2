//! The diagnosis's use of the bounded Levenberg–Marquardt of `numerics::lm`: residual functions
//! that return a new vector, and fits that carry their Jacobian as a matrix.
//!
//! Minimises `‖r(x)‖²` over a box with the residuals' exact Jacobian when they carry one (a
//! model's residual, `crate::fit::ModelResiduals`) and forward-difference Jacobians (`h = 10⁻³`
//! of each range, backwards at the upper bound) otherwise; the algorithm and its stopping rules are those of
//! `numerics::lm`. The inference that follows a fit (score tests, Laplace errors, the structure
//! tests) uses the Jacobian at the fitted point, so when the iteration budget ends right after
//! an accepted step the Jacobian is evaluated once more there.
//!
//! The settings are `numerics::LevenbergMarquardtSettings`, the one Levenberg–Marquardt
//! settings type of the workspace; its `Default` are the diagnosis's values: 30 iterations,
//! forward differences of 10⁻³, `λ₀ = 10⁻³` kept in `[10⁻⁹, 10¹⁰]`, a stop below a relative
//! decrease of 10⁻⁷.

use nalgebra::DMatrix;
use numerics::lm::residual_jacobian;
use numerics::{
    levenberg_marquardt, LevenbergMarquardtSettings, LevenbergMarquardtStop, Residuals,
};

/// Result of [`minimise`].
#[derive(Clone, Debug)]
#[non_exhaustive]
pub struct LmOutcome {
    /// Best point.
    pub x: Vec<f64>,
    /// `‖r(x)‖²`.
    pub cost: f64,
    /// Residual at `x`.
    pub residual: Vec<f64>,
    /// Jacobian `∂r/∂x` (x units) at the last linearisation point (`x` unless the last step
    /// was accepted with a relative decrease below `ftol_rel`).
    pub jacobian: DMatrix<f64>,
    /// Residual evaluations used.
    pub evaluations: usize,
    /// Iterations (Jacobians).
    pub iterations: usize,
}

/// A residual function returning a new vector, `None` on failure.
pub(crate) struct VecResiduals<'a, F>(pub &'a F);

impl<F> Residuals for VecResiduals<'_, F>
where
    F: Fn(&[f64]) -> Option<Vec<f64>> + Sync,
{
    type Workspace = ();
    fn workspace(&self) {}
    fn residuals(&self, x: &[f64], _: &mut (), out: &mut Vec<f64>) -> bool {
        match (self.0)(x) {
            Some(v) => {
                *out = v;
                true
            }
            None => false,
        }
    }
}

/// Minimises `‖f(x)‖²` from `x0` inside `bounds`; `None` if `f` fails at `x0`, the first
/// Jacobian cannot be evaluated, or the settings or bounds are invalid.
pub fn minimise<F>(
    f: &F,
    x0: &[f64],
    bounds: &[(f64, f64)],
    s: &LevenbergMarquardtSettings,
) -> Option<LmOutcome>
where
    F: Fn(&[f64]) -> Option<Vec<f64>> + Sync,
{
    minimise_residuals(&VecResiduals(f), x0, bounds, s)
}

/// [`minimise`] of residuals that may carry their exact Jacobian ([`Residuals::jacobian`]),
/// which then replaces the differences at every iteration.
pub(crate) fn minimise_residuals<R: Residuals + ?Sized>(
    residuals: &R,
    x0: &[f64],
    bounds: &[(f64, f64)],
    s: &LevenbergMarquardtSettings,
) -> Option<LmOutcome> {
    let o = levenberg_marquardt(residuals, x0, bounds, s, |_| {}).ok()?;
    let mut evaluations = o.evaluations;
    let mut jacobian = o.jacobian;
    if o.stop == LevenbergMarquardtStop::MaxIterations && !o.jacobian_at_x {
        let (fresh, used) = residual_jacobian(residuals, &o.x, &o.residuals, bounds, s).ok()?;
        evaluations += used;
        jacobian = fresh.or(jacobian);
    }
    let jacobian = DMatrix::from_vec(o.residuals.len(), o.x.len(), jacobian?);
    Some(LmOutcome {
        x: o.x,
        cost: o.cost,
        residual: o.residuals,
        jacobian,
        evaluations,
        iterations: o.iterations,
    })
}
