//! Failures of a command and their exit codes (2: bad input, 1: anything else).

use std::fmt;

/// Why a command failed.
#[derive(Debug)]
pub enum Failure {
    /// The user's input is unusable (exit code 2). One line, naming the file
    /// (and line and column where that applies).
    BadInput(String),
    /// Something went wrong that is not the input's fault (exit code 1).
    Internal(String),
    /// A front end's [`crate::progress::ProgressObserver`] stopped the run (exit code 130, the
    /// shell's code for an interrupt); nothing was written.
    Interrupted,
}

impl Failure {
    /// Exit code of the process for this failure.
    pub fn exit_code(&self) -> i32 {
        match self {
            Failure::BadInput(_) => 2,
            Failure::Internal(_) => 1,
            Failure::Interrupted => 130,
        }
    }

    /// A bad-input failure from anything printable.
    pub fn bad(msg: impl fmt::Display) -> Self {
        Failure::BadInput(one_line(&msg.to_string()))
    }

    /// An internal failure from anything printable.
    pub fn internal(msg: impl fmt::Display) -> Self {
        Failure::Internal(one_line(&msg.to_string()))
    }
}

impl fmt::Display for Failure {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Failure::BadInput(m) => write!(f, "error: {m}"),
            Failure::Internal(m) => write!(f, "internal error: {m}"),
            Failure::Interrupted => write!(f, "interrupted"),
        }
    }
}

/// Folds a message onto one line.
fn one_line(s: &str) -> String {
    s.split_whitespace().collect::<Vec<_>>().join(" ")
}

/// Result of a command.
pub type CmdResult<T = ()> = Result<T, Failure>;
