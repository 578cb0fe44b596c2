//! The crate's error type.

use thiserror::Error;

/// Everything that can go wrong in a diagnosis.
#[derive(Debug, Error)]
#[non_exhaustive]
pub enum DiagnoseError {
    /// The trial could not be turned into model inputs.
    #[error("trial: {0}")]
    Input(#[from] experiment::ExperimentError),
    /// The model rejected a parameter set or a simulation failed.
    #[error("model: {0}")]
    Model(#[from] muscle_model::ModelError),
    /// The trial's motion could not be segmented into holds and sweeps.
    #[error("{recording}: cannot segment the motion: {reason}")]
    Segmentation {
        /// `trial` or `unloaded run`.
        recording: &'static str,
        /// What was missing.
        reason: String,
    },
    /// The unloaded run does not fit the trial (sampling rate, length).
    #[error("unloaded run: {reason}")]
    Unloaded {
        /// Why it cannot be used.
        reason: String,
    },
    /// A prepared recording's torque or weights do not fit its inputs.
    #[error("recording: {reason}")]
    Recording {
        /// What does not fit.
        reason: String,
    },
    /// A setting is out of range.
    #[error("setting `{name}`: {reason}")]
    Settings {
        /// Setting name.
        name: &'static str,
        /// Why it is invalid.
        reason: String,
    },
    /// A fit could not start (the model fails at the start point).
    #[error("fit of {model}: {reason}")]
    Fit {
        /// Model being fitted (e.g. `baseline`, `baseline+gravity`).
        model: String,
        /// What failed.
        reason: String,
    },
    /// The observer asked to stop.
    #[error("cancelled by the observer")]
    Cancelled,
}
