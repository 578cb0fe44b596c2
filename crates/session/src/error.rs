//! The one error type of the crate.

/// Why a session could not be read.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum SessionError {
    /// The manifest could not be read from disk.
    #[error("{path}: {reason}")]
    Io {
        /// The file.
        path: String,
        /// The operating system's reason.
        reason: String,
    },
    /// The manifest is not valid JSON or does not have the manifest's shape.
    #[error("{path}:{line}:{column}: {reason}")]
    Syntax {
        /// The file.
        path: String,
        /// 1-based line.
        line: usize,
        /// 1-based column.
        column: usize,
        /// What is wrong.
        reason: String,
    },
    /// A value that is well-formed but not acceptable, named by its key.
    #[error("{path}: {key}: {reason}")]
    Invalid {
        /// The file.
        path: String,
        /// Where in the manifest (e.g. `trials[2].knee_angle_deg`).
        key: String,
        /// What is wrong.
        reason: String,
    },
}
