//! Reading a session's trial file: a trial CSV or a recording map, with the geometry series a
//! map may carry.

use crate::error::{AppError, AppResult};
use crate::jobs::ModelSettings;
use crate::Reporter;
use std::path::Path;

/// A session's trial file: a trial CSV, or a recording map (with the geometry series it maps).
/// The session normalises every trial's EMG alike: a map whose EMG is envelopes already, in a
/// session whose other trials are raw EMG, needs `--emg-is-envelope` (a session of maps that all
/// say so is read as envelopes without it).
pub fn read_session_trial(
    p: &Path,
    model: &ModelSettings,
    rep: &Reporter,
) -> AppResult<(experiment::Trial, Vec<recording::MappedGeometry>)> {
    let (trial, geometry, envelopes) = read_trial_or_map(p, rep)?;
    if envelopes && !model.emg_is_envelope {
        return Err(AppError::bad(format!(
            "{}: emg_is_envelope: in a session every trial's EMG is read alike: give \
             --emg-is-envelope for the session",
            p.display()
        )));
    }
    Ok((trial, geometry))
}

/// A trial CSV or a recording map read into a trial, with the map's geometry series and
/// whether it says its EMG is envelopes already.
pub(super) fn read_trial_or_map(
    p: &Path,
    rep: &Reporter,
) -> AppResult<(experiment::Trial, Vec<recording::MappedGeometry>, bool)> {
    if recording::file_kind(p) != recording::FileKind::Map {
        return Ok((
            experiment::read_trial(p).map_err(AppError::bad)?,
            Vec::new(),
            false,
        ));
    }
    let map = recording::read_map(p).map_err(AppError::bad)?;
    let rec = recording::read_trial_recording(&map).map_err(AppError::bad)?;
    for n in &rec.notes {
        rep.warn(format!("{}: {n}", p.display()));
    }
    Ok((rec.trial, rec.geometry, rec.emg_is_envelope))
}
