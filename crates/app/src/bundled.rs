//! The bundled default trial: `fixtures/seed/` compiled into the binary, so
//! every command works from any folder without `--trial`.

use experiment::{parse_trial, parse_unloaded, ExperimentError, Trial, Unloaded};

/// Name of the bundled trial in messages.
pub const SEED_TRIAL_NAME: &str = "bundled:fixtures/seed/trial.csv";
/// Name of the bundled unloaded run in messages.
pub const SEED_UNLOADED_NAME: &str = "bundled:fixtures/seed/unloaded.csv";

const SEED_TRIAL: &str = include_str!("../../../fixtures/seed/trial.csv");
const SEED_UNLOADED: &str = include_str!("../../../fixtures/seed/unloaded.csv");
/// Name of the bundled truth in messages.
pub const SEED_TRUTH_NAME: &str = "bundled:fixtures/seed/truth.json";
/// Parameters and effects the bundled trial was generated with.
pub const SEED_TRUTH: &str = include_str!("../../../fixtures/seed/truth.json");

/// The bundled seed trial.
pub fn seed_trial() -> Result<Trial, ExperimentError> {
    parse_trial(SEED_TRIAL, SEED_TRIAL_NAME)
}

/// The bundled seed trial's unloaded run.
pub fn seed_unloaded() -> Result<Unloaded, ExperimentError> {
    parse_unloaded(SEED_UNLOADED, SEED_UNLOADED_NAME)
}
