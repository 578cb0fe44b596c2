//! The crate's error type.

/// Everything that can go wrong when setting up or running an optimisation.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum Error {
    /// The objective has no parameters.
    #[error("the objective has no parameters (dimension 0)")]
    EmptyProblem,
    /// `bounds().len()` differs from `dim()`, or a start point has the wrong length.
    #[error("dimension mismatch: expected {expected} values, found {found}")]
    DimensionMismatch {
        /// The objective's dimension.
        expected: usize,
        /// The length that was supplied.
        found: usize,
    },
    /// A bound pair is not finite or not strictly increasing.
    #[error("invalid bounds for parameter {index}: lower {lower}, upper {upper} (need finite lower < upper)")]
    InvalidBounds {
        /// Parameter index.
        index: usize,
        /// Lower bound supplied.
        lower: f64,
        /// Upper bound supplied.
        upper: f64,
    },
    /// A setting is outside its valid range.
    #[error("invalid setting `{name}` = {value}: {reason}")]
    InvalidSetting {
        /// Field name in [`crate::AnnealSettings`] or [`crate::NelderMeadSettings`].
        name: &'static str,
        /// The value supplied (integers converted to `f64`).
        value: f64,
        /// What the valid range is.
        reason: &'static str,
    },
    /// A supplied start point lies outside the bounds (or is not finite).
    #[error("start point coordinate {index} = {value} is outside [{lower}, {upper}]")]
    StartOutOfBounds {
        /// Parameter index.
        index: usize,
        /// Value supplied.
        value: f64,
        /// Lower bound.
        lower: f64,
        /// Upper bound.
        upper: f64,
    },
    /// The objective failed (returned `None` or a non-finite value) at the supplied start point.
    #[error("the objective failed at the supplied start point")]
    StartEvaluationFailed,
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
    /// Any other failure of a `numerics` routine.
    #[error("{0}")]
    Numerics(numerics::NumericsError),
    /// The evaluation budget is too small to evaluate even the start point.
    #[error("evaluation budget {budget} is too small (need at least {needed})")]
    BudgetTooSmall {
        /// Budget supplied.
        budget: u64,
        /// Minimum needed.
        needed: u64,
    },
}

/// The shared optimisers report their errors as [`numerics::NumericsError`]; here each keeps
/// the variant this crate has always used for it, so callers matching on them see no change.
impl From<numerics::NumericsError> for Error {
    fn from(e: numerics::NumericsError) -> Self {
        use numerics::NumericsError as N;
        match e {
            N::EmptyProblem => Error::EmptyProblem,
            N::DimensionMismatch { expected, found } => {
                Error::DimensionMismatch { expected, found }
            }
            N::InvalidBounds {
                index,
                lower,
                upper,
            } => Error::InvalidBounds {
                index,
                lower,
                upper,
            },
            N::InvalidSetting {
                name,
                value,
                reason,
            } => Error::InvalidSetting {
                name,
                value,
                reason,
            },
            N::StartOutOfBounds {
                index,
                value,
                lower,
                upper,
            } => Error::StartOutOfBounds {
                index,
                value,
                lower,
                upper,
            },
            N::StartEvaluationFailed => Error::StartEvaluationFailed,
            other => Error::Numerics(other),
        }
    }
}
