//! The trials of one subject that share one set of muscle parameters: the session manifest
//! (`docs/formats.md`, "Session manifest") and its reading.
//!
//! ```
//! use session::{parse_session_manifest, TrialSource};
//! use std::path::Path;
//!
//! let m = parse_session_manifest(
//!     r#"{"params": "model.json",
//!         "trials": [{"name": "a", "trial": "a.csv", "knee_angle_deg": 90},
//!                    {"name": "walk", "recording": "walk"}]}"#,
//!     Path::new("lab/S01/session.json"),
//! )?;
//! assert_eq!(m.params.as_deref(), Some(Path::new("lab/S01/model.json")));
//! assert_eq!(m.trials[0].knee_angle_deg, Some(90.0));
//! assert_eq!(m.trials[1].source, TrialSource::Recording("lab/S01/walk".into()));
//! # Ok::<(), session::SessionError>(())
//! ```

mod error;
pub mod manifest;

pub use error::SessionError;
pub use manifest::{
    parse_session_manifest, read_session_manifest, EmgNormalisationScope, GeometryFiles,
    SessionManifest, SessionTrialEntry, TrialSource, MAX_KNEE_ANGLE_DEG,
};
