//! Reading trial files.

use std::path::Path;

use super::records::{ReadOptions, Trial, EMG_PREFIX, TRIAL_OPTIONAL, TRIAL_REQUIRED};
use super::table::{decode, parse_table, read_bytes, Table};
use crate::error::{ErrorKind, ExperimentError, Result};

/// An EMG column of only zeros is an error (a disconnected electrode).
fn check_not_all_zero(table: &Table, known: &[&str], path: &str) -> Result<()> {
    for (k, name) in known.iter().enumerate() {
        if !name.starts_with("emg_") {
            continue;
        }
        if let Some(col) = &table.columns[k] {
            if col.iter().all(|&x| x == 0.0) {
                return Err(ExperimentError::Column {
                    path: path.to_string(),
                    column: table.field_of[k],
                    name: (*name).to_string(),
                    kind: ErrorKind::ZeroChannel,
                    reason: "EMG channel is all zeros (disconnected electrode?)".into(),
                });
            }
        }
    }
    for (name, column, col) in &table.extra {
        if col.iter().all(|&x| x == 0.0) {
            return Err(ExperimentError::Column {
                path: path.to_string(),
                column: *column,
                name: name.clone(),
                kind: ErrorKind::ZeroChannel,
                reason: "EMG channel is all zeros (disconnected electrode?)".into(),
            });
        }
    }
    Ok(())
}

/// Parses trial CSV text; `name` is the file name used in error messages.
///
/// # Errors
/// Any validation failure, as a one-line [`ExperimentError`] naming `name`, line and column.
pub fn parse_trial(text: &str, name: &str) -> Result<Trial> {
    parse_trial_with(text, name, &ReadOptions::default())
}

/// [`parse_trial`] with explicit [`ReadOptions`].
///
/// # Errors
/// As [`parse_trial`].
pub fn parse_trial_with(text: &str, name: &str, opts: &ReadOptions) -> Result<Trial> {
    let mut t = parse_table(
        text,
        name,
        &TRIAL_REQUIRED,
        &TRIAL_OPTIONAL,
        Some(EMG_PREFIX),
        opts,
    )?;
    let known: Vec<&str> = TRIAL_REQUIRED
        .iter()
        .chain(TRIAL_OPTIONAL.iter())
        .copied()
        .collect();
    check_not_all_zero(&t, &known, name)?;
    let emg_other = std::mem::take(&mut t.extra)
        .into_iter()
        .map(|(column, _, v)| {
            let name = column
                .strip_prefix(EMG_PREFIX)
                .unwrap_or(&column)
                .to_string();
            (name, v)
        })
        .collect();
    let mut take = |k: usize| t.columns[k].take();
    let req = |c: Option<Vec<f64>>| c.unwrap_or_default();
    Ok(Trial {
        time_s: req(take(0)),
        ankle_angle_deg: req(take(1)),
        torque_nm: req(take(2)),
        emg_sol: req(take(3)),
        emg_gm: req(take(4)),
        emg_gl: req(take(5)),
        emg_ta: take(6),
        emg_other,
        knee_angle_deg: take(7),
        grf_vertical_n: None,
        comments: t.comments,
        ignored_columns: t.ignored,
    })
}

/// Parses trial CSV bytes (UTF-8, optional BOM); rejects binary data.
///
/// # Errors
/// As [`parse_trial`], plus invalid UTF-8.
pub fn parse_trial_bytes(bytes: &[u8], name: &str) -> Result<Trial> {
    parse_trial(decode(bytes, name)?, name)
}

/// Reads and validates a trial CSV file.
///
/// # Errors
/// A missing or unreadable file, or any error of [`parse_trial_bytes`].
pub fn read_trial(path: impl AsRef<Path>) -> Result<Trial> {
    let path = path.as_ref();
    let bytes = read_bytes(path)?;
    parse_trial_bytes(&bytes, &path.display().to_string())
}
