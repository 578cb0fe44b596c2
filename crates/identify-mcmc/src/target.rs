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
