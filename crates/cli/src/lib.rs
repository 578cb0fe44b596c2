//! The `surae` commands as a library: each subcommand's arguments and its `run`, the bundled
//! trial, and the output helpers, so that other front ends (the Python module) run exactly what
//! the command line runs.

pub mod bundled;
pub mod commands;
pub mod error;
mod figures;
pub mod output;
pub mod progress;

use std::path::PathBuf;

/// Warnings collected during a command, printed after it succeeds.
static WARNINGS: std::sync::Mutex<Vec<String>> = std::sync::Mutex::new(Vec::new());

/// Records a warning for the end of a successful run.
pub fn warn(msg: String) {
    if let Ok(mut w) = WARNINGS.lock() {
        w.push(msg);
    }
}

/// Default output folder of a command.
pub(crate) fn default_out(command: &str) -> PathBuf {
    PathBuf::from("out").join(command)
}

/// The warnings recorded so far, emptied (the command line prints them after a success).
pub fn take_warnings() -> Vec<String> {
    WARNINGS
        .lock()
        .map(|mut w| std::mem::take(&mut *w))
        .unwrap_or_default()
}
