//! The crate's single error type.

/// Every error of held-out validation. `Display` is one line.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum ValidateError {
    /// A trial's model cannot be built or simulated.
    #[error("{trial}: {source}")]
    Model {
        /// The trial.
        trial: String,
        /// What the model said.
        source: muscle_model::ModelError,
    },
    /// A calibration failed.
    #[error("calibration of fold {fold}: {source}")]
    Calibration {
        /// The fold.
        fold: String,
        /// What the annealer said.
        source: identify_sa::Error,
    },
    /// A fold cannot be formed or a setting is out of range.
    #[error("{what}: {reason}")]
    Invalid {
        /// The setting or input at fault.
        what: String,
        /// Why.
        reason: String,
    },
}

impl ValidateError {
    pub(crate) fn invalid(what: impl Into<String>, reason: impl Into<String>) -> Self {
        Self::Invalid {
            what: what.into(),
            reason: reason.into(),
        }
    }
}
