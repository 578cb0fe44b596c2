//! OpenSim storage files (`.sto`, `.mot`) as recordings: every column by its label, `time`
//! as the clock. The header's version (1 or 2), `nRows`/`nColumns` (checked against the data
//! when present) and `inDegrees` are read by `opensim_files::read_sto`; `inDegrees=no` is
//! reported in [`RecordingFormat::Storage`] so that the map converts the angle channels it
//! reads from the file (`*_deg` targets) from radians to degrees.

use std::path::Path;

use crate::error::{RecordingError, Result};
use crate::table::{RecordingChannel, RecordingFormat, RecordingTable};

/// Reads a storage file.
///
/// # Errors
/// An unreadable file, and every error of [`parse_storage`].
pub fn read_storage(path: &Path) -> Result<RecordingTable> {
    let bytes = crate::read::read_bytes(path)?;
    parse_storage(&bytes, path)
}

/// Parses a storage file's bytes; `path` names it in messages.
///
/// # Errors
/// What `opensim_files::read_sto` rejects (no `endheader`, a malformed header value, a
/// duplicate label, no `time` column, a row of the wrong width, a cell that is not a number,
/// `nRows`/`nColumns` that contradict the data), each naming the line and column, and an
/// ASCII control character other than a tab within a line (binary data, a lone carriage
/// return), naming the line.
pub fn parse_storage(bytes: &[u8], path: &Path) -> Result<RecordingTable> {
    let name = crate::table::display(path);
    let text = crate::delimited::decode_text(bytes);
    // no ASCII control character within a line: binary data, and labels and cells quoted in
    // the messages below stay on one line (a Latin-1 file's bytes 0x80–0x9F are let through)
    for (i, line) in text.lines().enumerate() {
        let body = line.strip_suffix('\r').unwrap_or(line);
        if let Some(c) = body.chars().find(|&c| c.is_ascii_control() && c != '\t') {
            return Err(RecordingError::Line {
                path: name,
                line: i + 1,
                reason: format!(
                    "control character U+{:04X} in the text: not an OpenSim storage file \
                     (binary data?)",
                    c as u32
                ),
            });
        }
    }
    let table = opensim_files::read_sto(&text, &name).map_err(|e| RecordingError::Reader {
        path: name.clone(),
        message: e.to_string(),
    })?;
    // line of each row: the data start after the labels line that follows `endheader`
    let mut row_lines = Vec::with_capacity(table.rows());
    let mut after_header = false;
    let mut seen_labels = false;
    for (i, line) in text.lines().enumerate() {
        if !after_header {
            after_header = line.trim().eq_ignore_ascii_case("endheader");
            continue;
        }
        if line.trim().is_empty() {
            continue;
        }
        if !seen_labels {
            seen_labels = true;
            continue;
        }
        row_lines.push(i + 1);
    }
    if table.rows() == 0 {
        return Err(RecordingError::file(name, "no data rows after the labels"));
    }
    let channels = table
        .labels
        .iter()
        .zip(table.columns)
        .map(|(label, values)| RecordingChannel {
            label: label.clone(),
            unit: None,
            values,
            rate_hz: None,
        })
        .collect();
    Ok(RecordingTable {
        path: path.to_path_buf(),
        format: RecordingFormat::Storage {
            version: table.version,
            in_degrees: table.in_degrees,
            title: (!table.name.is_empty()).then(|| table.name.clone()),
        },
        time_label: Some("time".into()),
        rate_hz: None,
        start_s: 0.0,
        channels,
        row_lines,
    })
}
