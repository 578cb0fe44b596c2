//! Seed handling shared by the diagnose test files that run the diagnosis on synthetic trials.
//!
//! `SURAE_DIAG_SEEDS` moves a file's trials to other seeds: `fresh` draws a base seed from the
//! clock, a non-negative integer is the base seed itself. Each file has its own default base,
//! so a plain `cargo test` is reproducible.

use diagnose::{no_observer, run, DiagnoseSettings, Diagnosis};
use experiment::{Trial, Unloaded};

/// The base seed: `default` unless `SURAE_DIAG_SEEDS` is set.
///
/// # Panics
/// When `SURAE_DIAG_SEEDS` is neither `fresh` nor a non-negative integer: a mistyped value
/// must not rerun the default seeds while the caller believes the trials are new.
pub fn base_seed(default: u64) -> u64 {
    match std::env::var("SURAE_DIAG_SEEDS") {
        Ok(s) if s == "fresh" => {
            let t = std::time::SystemTime::now()
                .duration_since(std::time::UNIX_EPOCH)
                .map(|d| d.as_nanos() as u64)
                .unwrap_or(1);
            let base = t % 1_000_000_007;
            eprintln!("SURAE_DIAG_SEEDS=fresh: base seed {base}");
            base
        }
        Ok(s) => s.trim().parse().unwrap_or_else(|_| {
            panic!("SURAE_DIAG_SEEDS={s:?} is neither `fresh` nor a non-negative integer")
        }),
        Err(std::env::VarError::NotPresent) => default,
        Err(std::env::VarError::NotUnicode(s)) => {
            panic!("SURAE_DIAG_SEEDS={s:?} is neither `fresh` nor a non-negative integer")
        }
    }
}

/// The diagnosis with default settings of a synthetic trial and its unloaded run.
///
/// # Panics
/// When the diagnosis fails, naming the seed the trial was made from.
pub fn diagnose_with_defaults(trial: &Trial, unloaded: &Unloaded, seed: u64) -> Diagnosis {
    run(
        trial,
        Some(unloaded),
        &DiagnoseSettings::default(),
        &mut no_observer,
    )
    .unwrap_or_else(|e| panic!("seed {seed}: diagnosis failed: {e}"))
}
