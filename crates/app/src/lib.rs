//! The library a program embeds to do surae's jobs: the command line (`surae`), the Python
//! module and `cargo xtask` all run these and only these.
//!
//! A job is a function of typed settings and a [`Reporter`] (the front end's
//! [`JobObserver`]: progress, warnings, summary lines, and a way to stop the job), returning
//! `Ok` once everything it writes is written, or an [`AppError`] that says whose fault the
//! failure is. Loading (a trial CSV, a recording map, a CEINMS trial folder, a session
//! manifest) is shared by every job, so a user's file reads the same whichever command reads
//! it. A program may give a trial, an unloaded run or a parameters object in memory
//! ([`InMemory`]) in place of its file, and ask for no files at all (`discard_files`): the job's
//! JSON result then reaches it through [`JobObserver::result_json`] alone.
//!
//! | job | settings | writes |
//! |---|---|---|
//! | [`envelope`] | [`EnvelopeJob`] | `envelopes.csv` |
//! | [`simulate`] | [`SimulateJob`] | `simulation.csv` |
//! | [`sensitivity`] | [`SensitivityJob`] | `sensitivity.json`, figure |
//! | [`identify`] | [`IdentifyJob`] | `identify.json`, figures, report |
//! | [`diagnose()`] | [`DiagnoseJob`] | `diagnosis.json`, figures, report |
//! | [`design()`] | [`DesignJob`] | `design.json`, figure |
//! | [`inspect`] | [`InspectJob`] | a starter recording map |
//! | [`validate()`] | [`ValidateJob`] | `validate.json`, figures, report |

pub mod bundled;
mod error;
mod figures;
mod jobs;
mod memory;
mod output;
mod progress;

use std::path::PathBuf;

/// The design defaults the front ends show in their help.
pub use design::{DEFAULT_EMG_DRAWS, DEFAULT_EMG_SEED, OFFSET_PRIOR_SD_NM};
pub use error::{AppError, AppResult};
pub use jobs::design::{
    run as design, DesignJob, DesignNoiseReport, DesignReport, EmgDrawsReport, JacobianStepReport,
    ProtocolReport,
};
pub use jobs::diagnose::{
    run as diagnose, DiagnoseJob, FitFigures, MomentFitReport, SessionDiagnosisReport,
    SessionTrialDiagnosisRow, TrialDiagnosisReport,
};
pub use jobs::envelope::{run as envelope, EnvelopeJob};
pub use jobs::identify::{
    run as identify, AdequacyReport, CorrelationMatrixReport, CorrelationReport, IdentifyJob,
    IdentifyReport, McmcReport, McmcTrialReport, Method, NoiseCorrectionReport, NoiseUseReport,
    NutsReport, PosteriorReport, SaChainsReport,
};
pub use jobs::inspect::{run as inspect, InspectJob, MapInspectionReport, TrialSpanReport};
pub use jobs::sensitivity::{run as sensitivity, SensitivityJob};
pub use jobs::session::{load_session, EmgNormalisationReport, LoadedSession};
pub use jobs::simulate::{
    run as simulate, SessionSimulationReport, SimulateJob, SimulatedTrialReport,
};
pub use jobs::validate::{
    run as validate, ExtensionHeldOut, ExtensionResult, ExtensionScheme, ExtensionStudy,
    ValidateJob, ValidatedTrialReport, ValidationReport,
};
pub use jobs::{read_json, KneeSettings, ModelSettings};
pub use memory::InMemory;
pub use output::write_file_checked;
pub use progress::{JobObserver, ProgressDisplay, Reporter, SilentObserver};
pub use session::EmgNormalisationScope;

/// Default output folder of a command.
pub(crate) fn default_out(command: &str) -> PathBuf {
    PathBuf::from("out").join(command)
}
