//! Failures of the integrators ([`OdeError`]): they are values, never panics.

/// Errors of the integrators.
#[derive(thiserror::Error, Debug, Clone, PartialEq)]
#[non_exhaustive]
pub enum OdeError {
    /// The controller asked for a step smaller than the minimum.
    #[error("step size underflow at t = {t}: h = {h:e} is below the minimum")]
    StepSizeUnderflow {
        /// Time at which the step was attempted.
        t: f64,
        /// The step size that was too small.
        h: f64,
    },
    /// The state or its derivative became NaN or infinite.
    #[error("non-finite state or derivative at t = {t}")]
    NonFinite {
        /// Time at which it happened.
        t: f64,
    },
    /// The step budget ran out before the end time.
    #[error("maximum number of steps ({steps}) reached at t = {t}")]
    MaxSteps {
        /// Time reached.
        t: f64,
        /// The budget.
        steps: usize,
    },
    /// Settings or arguments that make no sense.
    #[error("invalid input: {what}")]
    InvalidInput {
        /// What is wrong.
        what: &'static str,
    },
}
