//! Reading unloaded-run files.

use std::path::Path;

use super::records::{ReadOptions, Unloaded, UNLOADED_REQUIRED};
use super::table::{decode, parse_table, read_bytes};
use crate::error::Result;

/// Parses unloaded-run CSV text; `name` is the file name used in error messages.
///
/// # Errors
/// As [`super::parse_trial`].
pub fn parse_unloaded(text: &str, name: &str) -> Result<Unloaded> {
    parse_unloaded_with(text, name, &ReadOptions::default())
}

/// [`parse_unloaded`] with explicit [`ReadOptions`].
///
/// # Errors
/// As [`super::parse_trial`].
pub fn parse_unloaded_with(text: &str, name: &str, opts: &ReadOptions) -> Result<Unloaded> {
    let mut t = parse_table(text, name, &UNLOADED_REQUIRED, &[], None, opts)?;
    let mut take = |k: usize| t.columns[k].take().unwrap_or_default();
    Ok(Unloaded {
        time_s: take(0),
        ankle_angle_deg: take(1),
        torque_nm: take(2),
        comments: t.comments,
        ignored_columns: t.ignored,
    })
}

/// Parses unloaded-run CSV bytes (UTF-8, optional BOM).
///
/// # Errors
/// As [`super::parse_trial_bytes`].
pub fn parse_unloaded_bytes(bytes: &[u8], name: &str) -> Result<Unloaded> {
    parse_unloaded(decode(bytes, name)?, name)
}

/// Reads and validates an unloaded-run CSV file.
///
/// # Errors
/// As [`super::read_trial`].
pub fn read_unloaded(path: impl AsRef<Path>) -> Result<Unloaded> {
    let path = path.as_ref();
    let bytes = read_bytes(path)?;
    parse_unloaded_bytes(&bytes, &path.display().to_string())
}
