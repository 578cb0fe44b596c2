//! The crate's error type.

/// Everything that can go wrong when setting up or running an optimisation.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum Error {
    /// No random start point could be evaluated.
    #[error("the objective failed at {attempts} random start points")]
    NoFeasibleStart {
        /// How many random points were tried.
        attempts: u32,
    },
    /// The muscle model rejected the problem or its inputs (identification only).
    #[error("model: {0}")]
    Model(#[from] muscle_model::ModelError),
    /// A trial or unloaded run could not be turned into a problem (identification only).
    #[error("{0}")]
    Experiment(#[from] experiment::ExperimentError),
    /// A problem or setting the shared optimisers reject, or any other failure of a `numerics`
    /// routine: no parameters, a dimension mismatch, invalid bounds, an invalid setting (a field
    /// of [`crate::AnnealSettings`] or [`crate::NelderMeadSettings`], integers converted to
    /// `f64`), a start point outside the bounds, or an objective failing at the start point.
    #[error(transparent)]
    Numerics(#[from] numerics::NumericsError),
    /// The search set of [`crate::identify_set_with_search`] does not fit the whole set: other
    /// free parameters or bounds, or no chain's point can be simulated on the whole set.
    #[error("search set: {0}")]
    Search(&'static str),
    /// The evaluation budget is too small to evaluate even the start point.
    #[error("evaluation budget {budget} is too small (need at least {needed})")]
    BudgetTooSmall {
        /// Budget supplied.
        budget: u64,
        /// Minimum needed.
        needed: u64,
    },
}
