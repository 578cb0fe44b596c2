//! The crate's error type.

use std::path::PathBuf;

/// Everything that can go wrong while drawing a figure or writing a report.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum ReportError {
    /// A series that must hold data is empty.
    #[error("{figure}: `{series}` is empty")]
    Empty {
        /// The figure being drawn.
        figure: &'static str,
        /// Which input.
        series: String,
    },
    /// Two series that must be parallel have different lengths.
    #[error("{figure}: `{series}` has {got} values, expected {expected}")]
    LengthMismatch {
        /// The figure being drawn.
        figure: &'static str,
        /// Which input.
        series: String,
        /// The length it must have.
        expected: usize,
        /// The length it has.
        got: usize,
    },
    /// A value is NaN or infinite.
    #[error("{figure}: `{series}` has a non-finite value ({value}) at index {index}")]
    NonFinite {
        /// The figure being drawn.
        figure: &'static str,
        /// Which input.
        series: String,
        /// Index of the first bad value.
        index: usize,
        /// The value.
        value: f64,
    },
    /// Any other invalid input (out-of-range index, bad option, malformed SVG …).
    #[error("{figure}: {reason}")]
    Invalid {
        /// The figure (or builder) concerned.
        figure: &'static str,
        /// What is wrong.
        reason: String,
    },
    /// The drawing backend failed (should not happen with valid input).
    #[error("{figure}: drawing failed: {message}")]
    Draw {
        /// The figure being drawn.
        figure: &'static str,
        /// The backend's message.
        message: String,
    },
    /// Writing a file failed.
    #[error("writing {path}: {source}")]
    Io {
        /// The file.
        path: PathBuf,
        /// The cause.
        source: std::io::Error,
    },
}

/// Shorthand result type.
pub type Result<T> = std::result::Result<T, ReportError>;
