//! The crate's error type.

/// Everything that can go wrong in this crate's routines.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum NumericsError {
    /// The problem has no parameters (or no residuals).
    #[error("the objective has no parameters (dimension 0)")]
    EmptyProblem,
    /// A vector or matrix has the wrong length.
    #[error("dimension mismatch: expected {expected} values, found {found}")]
    DimensionMismatch {
        /// The length required.
        expected: usize,
        /// The length supplied.
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
        /// Field name.
        name: &'static str,
        /// The value supplied (integers converted to `f64`).
        value: f64,
        /// What the valid range is.
        reason: &'static str,
    },
    /// A start point lies outside the bounds (or is not finite).
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
    /// The function failed (or gave a non-finite value) at the start point.
    #[error("the objective failed at the supplied start point")]
    StartEvaluationFailed,
    /// A Cholesky factorisation met a pivot that is not positive and finite.
    #[error("the matrix is not positive definite (pivot {pivot})")]
    NotPositiveDefinite {
        /// Index of the first failing pivot.
        pivot: usize,
    },
    /// Sample times that are empty, not finite or not strictly increasing, or a requested
    /// time that is not finite ([`crate::interpolate`]).
    #[error("{which}[{index}]: {reason}")]
    BadTimes {
        /// Which times (`sample times` or `requested times`).
        which: &'static str,
        /// Index of the first offending time.
        index: usize,
        /// What is wrong with it.
        reason: &'static str,
    },
}

impl NumericsError {
    /// The `Err` of a failed settings check.
    pub(crate) fn setting<T>(
        name: &'static str,
        value: f64,
        reason: &'static str,
    ) -> Result<T, Self> {
        Err(Self::InvalidSetting {
            name,
            value,
            reason,
        })
    }
}
