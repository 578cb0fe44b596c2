//! The log-density trait the sampler runs on, and a closure adapter.

/// An unnormalised log posterior density on a box.
///
/// The prior is uniform on [`bounds`](LogDensity::bounds); the sampler rejects
/// every proposal outside the box without calling
/// [`log_density`](LogDensity::log_density), so the method only has to return
/// the log-likelihood (plus any non-uniform prior term) inside it.
///
/// `log_density` returns `None` when the evaluation fails (e.g. a simulation
/// that did not integrate): the proposal is rejected and counted in
/// [`RunResult::failed_evaluations`](crate::RunResult::failed_evaluations),
/// never a crash. `Some(v)` with `v` NaN or `+∞` is treated as a failure too;
/// `Some(−∞)` is a zero density (rejected, not a failure).
///
/// The trait is `Sync` because the chains evaluate it from several threads at
/// once; a model that needs scratch space keeps it per call or per thread.
pub trait LogDensity: Sync {
    /// Number of parameters.
    fn dim(&self) -> usize;
    /// `(lower, upper)` for every parameter; `lower < upper`, both finite.
    fn bounds(&self) -> &[(f64, f64)];
    /// `log π(x)` up to a constant, for `x` inside the bounds; `None` on failure.
    fn log_density(&self, x: &[f64]) -> Option<f64>;
    /// Bounds of the reported coordinates (see [`LogDensity::evaluate`]); used for the
    /// identifiability summary. Default: [`LogDensity::bounds`].
    fn report_bounds(&self) -> &[(f64, f64)] {
        self.bounds()
    }
    /// `log π(x)` together with what a kept draw records: the reported coordinates, written
    /// into `report` (`dim()` long), and the value stored as the draw's log density. The draws,
    /// the R̂/ESS monitoring and the summaries all use the reported coordinates, so a target
    /// sampled in transformed coordinates is monitored in the quantities it reports. Default:
    /// `report = x` and the stored value `log π(x)`.
    fn evaluate(&self, x: &[f64], report: &mut [f64]) -> Option<(f64, f64)> {
        report.copy_from_slice(x);
        self.log_density(x).map(|v| (v, v))
    }
}

impl<T: LogDensity + ?Sized> LogDensity for &T {
    fn dim(&self) -> usize {
        (**self).dim()
    }
    fn bounds(&self) -> &[(f64, f64)] {
        (**self).bounds()
    }
    fn log_density(&self, x: &[f64]) -> Option<f64> {
        (**self).log_density(x)
    }
    fn report_bounds(&self) -> &[(f64, f64)] {
        (**self).report_bounds()
    }
    fn evaluate(&self, x: &[f64], report: &mut [f64]) -> Option<(f64, f64)> {
        (**self).evaluate(x, report)
    }
}

/// A [`LogDensity`] made of bounds and a closure `Fn(&[f64]) -> Option<f64>`.
///
/// ```
/// use identify_mcmc::{FnLogDensity, LogDensity};
/// let normal = FnLogDensity::new(vec![(-10.0, 10.0)], |x: &[f64]| Some(-0.5 * x[0] * x[0]));
/// assert_eq!(normal.dim(), 1);
/// assert_eq!(normal.log_density(&[2.0]), Some(-2.0));
/// ```
#[derive(Debug, Clone)]
pub struct FnLogDensity<F> {
    bounds: Vec<(f64, f64)>,
    f: F,
}

impl<F: Fn(&[f64]) -> Option<f64> + Sync> FnLogDensity<F> {
    /// Wrap `f` with the box `bounds` (validated when the sampler starts).
    pub fn new(bounds: Vec<(f64, f64)>, f: F) -> Self {
        Self { bounds, f }
    }
}

impl<F: Fn(&[f64]) -> Option<f64> + Sync> LogDensity for FnLogDensity<F> {
    fn dim(&self) -> usize {
        self.bounds.len()
    }
    fn bounds(&self) -> &[(f64, f64)] {
        &self.bounds
    }
    fn log_density(&self, x: &[f64]) -> Option<f64> {
        (self.f)(x)
    }
}

/// A [`LogDensity`] that also gives its gradient, for the gradient-based sampler
/// ([`run_nuts`](crate::run_nuts)).
///
/// [`log_density_grad`](GradLogDensity::log_density_grad) takes `x` inside the box (the
/// target's own coordinates), writes `∂ log π/∂x` into `grad` (`dim()` long) and returns
/// `log π(x)`, the same value as [`LogDensity::log_density`]. `None`, a non-finite value or a
/// non-finite gradient component is a failed evaluation: the sampler treats it as a divergence
/// of the trajectory that reached `x`, never a crash. The sampler maps the box onto `ℝᵈ` itself
/// ([`LogisticBox`](crate::LogisticBox)); the target never sees the transform.
pub trait GradLogDensity: LogDensity {
    /// `log π(x)` and its gradient in `grad`; `None` on failure.
    fn log_density_grad(&self, x: &[f64], grad: &mut [f64]) -> Option<f64>;
}

impl<T: GradLogDensity + ?Sized> GradLogDensity for &T {
    fn log_density_grad(&self, x: &[f64], grad: &mut [f64]) -> Option<f64> {
        (**self).log_density_grad(x, grad)
    }
}

/// A [`GradLogDensity`] made of bounds and a closure
/// `Fn(&[f64], &mut [f64]) -> Option<f64>` giving `log π(x)` and writing its gradient.
///
/// ```
/// use identify_mcmc::{FnGradLogDensity, GradLogDensity, LogDensity};
/// let normal = FnGradLogDensity::new(vec![(-10.0, 10.0)], |x: &[f64], g: &mut [f64]| {
///     g[0] = -x[0];
///     Some(-0.5 * x[0] * x[0])
/// });
/// let mut g = [0.0];
/// assert_eq!(normal.log_density_grad(&[2.0], &mut g), Some(-2.0));
/// assert_eq!(g, [-2.0]);
/// assert_eq!(normal.log_density(&[2.0]), Some(-2.0));
/// ```
#[derive(Debug, Clone)]
pub struct FnGradLogDensity<F> {
    bounds: Vec<(f64, f64)>,
    f: F,
}

impl<F: Fn(&[f64], &mut [f64]) -> Option<f64> + Sync> FnGradLogDensity<F> {
    /// Wrap `f` with the box `bounds` (validated when the sampler starts).
    pub fn new(bounds: Vec<(f64, f64)>, f: F) -> Self {
        Self { bounds, f }
    }
}

impl<F: Fn(&[f64], &mut [f64]) -> Option<f64> + Sync> LogDensity for FnGradLogDensity<F> {
    fn dim(&self) -> usize {
        self.bounds.len()
    }
    fn bounds(&self) -> &[(f64, f64)] {
        &self.bounds
    }
    fn log_density(&self, x: &[f64]) -> Option<f64> {
        let mut g = vec![0.0; x.len()];
        (self.f)(x, &mut g)
    }
}

impl<F: Fn(&[f64], &mut [f64]) -> Option<f64> + Sync> GradLogDensity for FnGradLogDensity<F> {
    fn log_density_grad(&self, x: &[f64], grad: &mut [f64]) -> Option<f64> {
        (self.f)(x, grad)
    }
}
