//! What the command-line tests share: running the `surae` binary and reading its output.
// each test file uses its own subset
#![allow(dead_code)]

use std::path::Path;
use std::process::{Command, Output};

/// Runs `surae` with `args` in `cwd`.
pub fn surae(args: &[&str], cwd: &Path) -> Output {
    Command::new(env!("CARGO_BIN_EXE_surae"))
        .args(args)
        .current_dir(cwd)
        .output()
        .expect("the surae binary runs")
}

/// Standard error as text.
pub fn stderr_of(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}
