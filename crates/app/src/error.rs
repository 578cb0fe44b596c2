//! Why a job failed, and the exit code a command line gives it (2: bad input, 1: anything
//! else, 130: interrupted).

/// Why a job failed.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum AppError {
    /// The user's input is unusable (exit code 2). One line, naming the file (and line and
    /// column where that applies).
    #[error("error: {0}")]
    BadInput(String),
    /// Something went wrong that is not the input's fault (exit code 1).
    #[error("internal error: {0}")]
    Internal(String),
    /// The front end's [`crate::JobObserver`] stopped the run (exit code 130, the shell's code
    /// for an interrupt); nothing was written.
    #[error("interrupted")]
    Interrupted,
}

impl AppError {
    /// Exit code of the process for this failure.
    pub fn exit_code(&self) -> i32 {
        match self {
            AppError::BadInput(_) => 2,
            AppError::Internal(_) => 1,
            AppError::Interrupted => 130,
        }
    }

    /// A bad-input failure from anything printable.
    pub fn bad(msg: impl std::fmt::Display) -> Self {
        AppError::BadInput(one_line(&msg.to_string()))
    }

    /// An internal failure from anything printable.
    pub fn internal(msg: impl std::fmt::Display) -> Self {
        AppError::Internal(one_line(&msg.to_string()))
    }
}

/// Folds a message onto one line.
fn one_line(s: &str) -> String {
    s.split_whitespace().collect::<Vec<_>>().join(" ")
}

/// Result of a job.
pub type AppResult<T = ()> = Result<T, AppError>;
