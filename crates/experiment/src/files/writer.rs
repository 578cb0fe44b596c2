//! Writing trial and unloaded-run files: canonical column order, round-trip-exact numbers,
//! checked by reading back, and written atomically.

use std::path::Path;

use super::number::write_f64;
use super::records::{Trial, Unloaded, EMG_PREFIX, TRIAL_REQUIRED, UNLOADED_REQUIRED};
use super::trial::parse_trial;
use super::unloaded::parse_unloaded;
use crate::error::{ErrorKind, ExperimentError, Result};

/// A comment with a line break or control character cannot be written.
fn check_comments(comments: &[String], path: &str) -> Result<()> {
    for c in comments {
        if c.chars().any(char::is_control) {
            return Err(ExperimentError::File {
                path: path.to_string(),
                kind: ErrorKind::Binary,
                reason: "a comment contains a line break or control character".into(),
            });
        }
    }
    Ok(())
}

/// Every column as long as the first (`time_s`).
fn check_lengths(cols: &[(&str, usize)], path: &str) -> Result<()> {
    let n = cols[0].1;
    for (i, &(name, len)) in cols.iter().enumerate() {
        if len != n {
            return Err(ExperimentError::Column {
                path: path.to_string(),
                column: i + 1,
                name: name.to_string(),
                kind: ErrorKind::LengthMismatch,
                reason: format!("{len} samples, but time_s has {n}"),
            });
        }
    }
    Ok(())
}

/// Comments, header and rows.
fn format_rows(out: &mut String, comments: &[String], names: &[&str], cols: &[&[f64]]) {
    for c in comments {
        out.push('#');
        out.push_str(c);
        out.push('\n');
    }
    out.push_str(&names.join(","));
    out.push('\n');
    let n = cols.first().map_or(0, |c| c.len());
    for i in 0..n {
        for (j, c) in cols.iter().enumerate() {
            if j > 0 {
                out.push(',');
            }
            write_f64(out, c[i]);
        }
        out.push('\n');
    }
}

fn format_trial_named(trial: &Trial, path: &str) -> Result<String> {
    check_comments(&trial.comments, path)?;
    let other: Vec<String> = trial
        .emg_other
        .iter()
        .map(|(n, _)| format!("{EMG_PREFIX}{n}"))
        .collect();
    let mut names: Vec<&str> = TRIAL_REQUIRED.to_vec();
    let mut cols: Vec<&[f64]> = vec![
        &trial.time_s,
        &trial.ankle_angle_deg,
        &trial.torque_nm,
        &trial.emg_sol,
        &trial.emg_gm,
        &trial.emg_gl,
    ];
    if let Some(ta) = &trial.emg_ta {
        names.push("emg_ta");
        cols.push(ta);
    }
    for (name, (_, raw)) in other.iter().zip(&trial.emg_other) {
        names.push(name);
        cols.push(raw);
    }
    if let Some(k) = &trial.knee_angle_deg {
        names.push("knee_angle_deg");
        cols.push(k);
    }
    let lens: Vec<(&str, usize)> = names
        .iter()
        .copied()
        .zip(cols.iter().map(|c| c.len()))
        .collect();
    check_lengths(&lens, path)?;
    let mut out = String::with_capacity(trial.len() * 16 * cols.len() + 256);
    format_rows(&mut out, &trial.comments, &names, &cols);
    parse_trial(&out, path)?; // what we write must read back
    Ok(out)
}

/// The CSV text [`write_trial`] writes: comments as `#text`, canonical column order
/// (required, then `emg_ta`, the further `emg_<name>` columns in their order and
/// `knee_angle_deg`, each if present), `\n` line ends, [`write_f64`] numbers.
///
/// # Errors
/// Columns of different lengths, or anything the reader would reject.
pub fn format_trial(trial: &Trial) -> Result<String> {
    format_trial_named(trial, "<trial>")
}

/// Writes `text` to a temporary file in `path`'s folder, then renames it to `path`.
fn write_atomic(path: &Path, text: &str) -> Result<()> {
    use std::io::Write;
    let err = |e: std::io::Error| ExperimentError::File {
        path: path.display().to_string(),
        kind: ErrorKind::Io,
        reason: format!("cannot write: {e}"),
    };
    let dir = match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d,
        _ => Path::new("."),
    };
    let mut tmp = tempfile::Builder::new()
        .prefix(".surae-tmp-")
        .tempfile_in(dir)
        .map_err(err)?;
    tmp.write_all(text.as_bytes()).map_err(err)?;
    tmp.as_file().sync_all().map_err(err)?;
    tmp.persist(path).map_err(|e| err(e.error))?;
    Ok(())
}

/// Writes a trial atomically: a temporary file in the same folder, then a rename, so `path`
/// is never left half-written. Reading the file back gives `trial` exactly (minus
/// `ignored_columns`), and writing that again gives the same bytes.
///
/// # Errors
/// Invalid data (see [`format_trial`]) or an I/O failure.
pub fn write_trial(path: impl AsRef<Path>, trial: &Trial) -> Result<()> {
    let path = path.as_ref();
    let text = format_trial_named(trial, &path.display().to_string())?;
    write_atomic(path, &text)
}

fn format_unloaded_named(run: &Unloaded, path: &str) -> Result<String> {
    check_comments(&run.comments, path)?;
    let cols: [&[f64]; 3] = [&run.time_s, &run.ankle_angle_deg, &run.torque_nm];
    let lens: Vec<(&str, usize)> = UNLOADED_REQUIRED
        .iter()
        .copied()
        .zip(cols.iter().map(|c| c.len()))
        .collect();
    check_lengths(&lens, path)?;
    let mut out = String::with_capacity(run.len() * 48 + 256);
    format_rows(&mut out, &run.comments, &UNLOADED_REQUIRED, &cols);
    parse_unloaded(&out, path)?;
    Ok(out)
}

/// The CSV text [`write_unloaded`] writes (same rules as [`format_trial`]).
///
/// # Errors
/// Columns of different lengths, or anything the reader would reject.
pub fn format_unloaded(run: &Unloaded) -> Result<String> {
    format_unloaded_named(run, "<unloaded>")
}

/// Writes an unloaded run atomically (temporary file, then rename).
///
/// # Errors
/// Invalid data or an I/O failure.
pub fn write_unloaded(path: impl AsRef<Path>, run: &Unloaded) -> Result<()> {
    let path = path.as_ref();
    let text = format_unloaded_named(run, &path.display().to_string())?;
    write_atomic(path, &text)
}

impl Trial {
    /// Checks everything the reader checks (as if the trial were written to `name`).
    ///
    /// # Errors
    /// The same errors the reader would report for the written file.
    pub fn validate(&self, name: &str) -> Result<()> {
        format_trial_named(self, name).map(|_| ())
    }
}

impl Unloaded {
    /// Checks everything the reader checks (as if the run were written to `name`).
    ///
    /// # Errors
    /// The same errors the reader would report for the written file.
    pub fn validate(&self, name: &str) -> Result<()> {
        format_unloaded_named(self, name).map(|_| ())
    }
}
