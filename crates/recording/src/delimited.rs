//! Delimited text exports of an EMG system or a dynamometer (Noraxon, Delsys, Biodex, a
//! spreadsheet): comma, semicolon or tab separated, with quoted headers, units in the header
//! and a decimal comma where the delimiter is not a comma.
//!
//! The `csv` crate splits the fields (quotes, doubled quotes, CRLF); this module finds the
//! header, the delimiter and the decimal mark, and turns cells into numbers:
//!
//! * lines before the header that start with `#` are comments; blank lines are skipped; the
//!   header is the first other line, or the line the map names (`header_line`) when an export
//!   writes a preamble of its own;
//! * the delimiter is a tab when the header line has one outside quotes, else `;` when it has
//!   one, else `,`: labels hold commas (`Time,s`, unquoted in some exports) and semicolons far
//!   more often than tabs, so the most frequent character would take a tab-separated header
//!   of `Name,unit` labels for a comma-separated one;
//! * the decimal mark is a comma when the delimiter is not a comma and a cell of the data
//!   rows reads as `digits,digits`; the map may say so instead (`decimal_comma`);
//! * a unit is taken from a label's tail, `Name,unit` (Noraxon), `Name [unit]` or
//!   `Name (unit)`, for `surae inspect` to show; the label stays the whole header cell;
//! * the time column is the first whose label, lower-cased, starts with `time`;
//! * an empty cell or `NaN` is a missing sample (NaN); any other cell that is not a number is
//!   an error naming the line, the column number and its label; a row with more fields than
//!   the header is an error, one with fewer is an error too (a truncated export);
//! * a row's line is counted in the file (comments, blank lines and CRLF endings included; a
//!   lone CR after the header ends a line, as it ends a record), not taken from the `csv`
//!   crate, whose record positions lag behind blank lines and CR;
//! * a label with a control character in it (a line break inside quotes) is an error, and a
//!   cell quoted in a message has its control characters escaped: every message is one line.
//!
//! Bytes that are not UTF-8 are read as Latin-1 (Windows exports write `µV` as byte 0xB5).

use std::path::Path;

use crate::error::{RecordingError, Result};
use crate::table::{RecordingChannel, RecordingFormat, RecordingTable};

/// How to read a delimited file; `Default` finds everything itself.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct DelimitedOptions {
    /// The 1-based line of the header, when the export writes a preamble before it.
    pub header_line: Option<usize>,
    /// Force (`Some(true)`) or forbid (`Some(false)`) the decimal comma.
    pub decimal_comma: Option<bool>,
}

/// Decodes a text file's bytes: UTF-8 (with or without a BOM), else Latin-1.
pub(crate) fn decode_text(bytes: &[u8]) -> String {
    let bytes = bytes.strip_prefix(b"\xEF\xBB\xBF").unwrap_or(bytes);
    match std::str::from_utf8(bytes) {
        Ok(s) => s.to_string(),
        Err(_) => bytes.iter().map(|&b| char::from(b)).collect(),
    }
}

/// Reads a delimited file.
///
/// # Errors
/// As [`parse_delimited`], and a file that cannot be read.
pub fn read_delimited(path: &Path, opts: &DelimitedOptions) -> Result<RecordingTable> {
    let bytes = crate::read::read_bytes(path)?;
    parse_delimited(&bytes, path, opts)
}

/// Counts of each candidate delimiter outside double quotes.
fn delimiter_counts(line: &str) -> [(char, usize); 3] {
    let mut counts = [('\t', 0usize), (';', 0), (',', 0)];
    let mut quoted = false;
    for c in line.chars() {
        if c == '"' {
            quoted = !quoted;
        } else if !quoted {
            for (d, n) in &mut counts {
                if c == *d {
                    *n += 1;
                }
            }
        }
    }
    counts
}

/// `digits,digits` (with an optional sign): a number written with a decimal comma.
fn looks_decimal_comma(cell: &str) -> bool {
    let s = cell.trim();
    let s = s.strip_prefix(['-', '+']).unwrap_or(s);
    let Some((a, b)) = s.split_once(',') else {
        return false;
    };
    let b = b.split(['e', 'E']).next().unwrap_or("");
    !a.is_empty()
        && !b.is_empty()
        && a.chars().all(|c| c.is_ascii_digit())
        && b.chars().all(|c| c.is_ascii_digit())
}

/// The unit in a label's tail: `Name,unit`, `Name [unit]` or `Name (unit)`.
#[must_use]
pub fn unit_of_label(label: &str) -> Option<String> {
    let l = label.trim();
    let bracketed = |open: char, close: char| {
        l.strip_suffix(close)
            .and_then(|s| s.rsplit_once(open))
            .map(|(_, u)| u.trim().to_string())
    };
    let unit = bracketed('[', ']')
        .or_else(|| bracketed('(', ')'))
        .or_else(|| l.rsplit_once(',').map(|(_, u)| u.trim().to_string()))?;
    (!unit.is_empty() && unit.len() <= 12 && !unit.contains(' ')).then_some(unit)
}

/// Whether a label names a time column.
#[must_use]
pub fn is_time_label(label: &str) -> bool {
    label.trim().to_ascii_lowercase().starts_with("time")
}

fn cell_number(cell: &str, decimal_comma: bool) -> Option<f64> {
    let s = cell.trim();
    if s.is_empty() || s.eq_ignore_ascii_case("nan") {
        return Some(f64::NAN);
    }
    if decimal_comma {
        if s.contains('.') {
            return None;
        }
        s.replace(',', ".").parse().ok()
    } else {
        s.parse().ok()
    }
}

fn quote(cell: &str) -> String {
    const MAX: usize = 40;
    if cell.chars().count() > MAX {
        let head: String = cell.chars().take(MAX).collect();
        format!("'{}…'", crate::read::printable(&head))
    } else {
        format!("'{}'", crate::read::printable(cell))
    }
}

/// Parses a delimited file's bytes; `path` names it in messages.
///
/// # Errors
/// An empty file, a header with an empty or repeated label, a row with a different number of
/// fields than the header, a cell that is not a number, and a control character (binary data),
/// each naming the line (and column).
pub fn parse_delimited(
    bytes: &[u8],
    path: &Path,
    opts: &DelimitedOptions,
) -> Result<RecordingTable> {
    let name = crate::table::display(path);
    let text = decode_text(bytes);
    let (header_line, start) = find_header(&text, opts, &name)?;
    let rest = &text[start..];
    let header_text = rest.lines().next().unwrap_or("");
    // tab before ';' before ',' (module docs)
    let delimiter = delimiter_counts(header_text)
        .iter()
        .find(|(_, n)| *n > 0)
        .map_or(',', |(d, _)| *d);

    let mut reader = csv::ReaderBuilder::new()
        .delimiter(u8::try_from(delimiter).unwrap_or(b','))
        .has_headers(false)
        .flexible(true)
        .from_reader(rest.as_bytes());
    let mut records = reader.records();
    // the line a record starts on: the csv crate's position is where the previous record
    // ended, before the line ends and blank lines it skips; a line ends, as for the csv
    // crate, at LF, CRLF or a lone CR
    let bytes = rest.as_bytes();
    let line_breaks: Vec<usize> = (0..bytes.len())
        .filter(|&i| bytes[i] == b'\n' || (bytes[i] == b'\r' && bytes.get(i + 1) != Some(&b'\n')))
        .collect();
    let line_at = |p: Option<&csv::Position>| {
        p.map_or(header_line, |p| {
            let mut at = usize::try_from(p.byte())
                .unwrap_or(usize::MAX)
                .min(bytes.len());
            while at < bytes.len() && matches!(bytes[at], b'\r' | b'\n') {
                at += 1;
            }
            header_line + line_breaks.partition_point(|&i| i < at)
        })
    };
    let csv_err = |e: &csv::Error| {
        let line = line_at(e.position());
        RecordingError::Line {
            path: name.clone(),
            line,
            reason: format!("unreadable line: {e}"),
        }
    };
    let header = match records.next() {
        Some(Ok(r)) => r,
        Some(Err(e)) => return Err(csv_err(&e)),
        None => return Err(RecordingError::file(name, "empty file: no header")),
    };
    let labels: Vec<String> = header.iter().map(|s| s.trim().to_string()).collect();
    check_labels(&labels, &name, header_line)?;
    let width = if labels.last().is_some_and(String::is_empty) {
        labels.len() - 1
    } else {
        labels.len()
    };

    let mut rows: Vec<(usize, csv::StringRecord)> = Vec::new();
    for r in records {
        let r = r.map_err(|e| csv_err(&e))?;
        let line = line_at(r.position());
        if r.iter().all(|f| f.trim().is_empty()) {
            continue;
        }
        rows.push((line, r));
    }
    if rows.is_empty() {
        return Err(RecordingError::Line {
            path: name,
            line: header_line,
            reason: "header only: the file has no data rows".into(),
        });
    }
    let decimal_comma = opts.decimal_comma.unwrap_or_else(|| {
        delimiter != ',' && rows.iter().any(|(_, r)| r.iter().any(looks_decimal_comma))
    });

    let columns = fill_columns(
        &rows,
        &labels,
        width,
        (delimiter, decimal_comma),
        &name,
        header_line,
    )?;
    let channels: Vec<RecordingChannel> = labels
        .iter()
        .take(width)
        .zip(columns)
        .map(|(label, values)| RecordingChannel {
            label: label.clone(),
            unit: unit_of_label(label),
            values,
            rate_hz: None,
        })
        .collect();
    let time_label = channels
        .iter()
        .find(|c| is_time_label(&c.label))
        .map(|c| c.label.clone());
    Ok(RecordingTable {
        path: path.to_path_buf(),
        format: RecordingFormat::Delimited {
            delimiter,
            decimal_comma,
        },
        time_label,
        rate_hz: None,
        start_s: 0.0,
        channels,
        row_lines: rows.iter().map(|(l, _)| *l).collect(),
    })
}

/// The header: the line `opts.header_line` names, or the first line that is neither blank nor
/// a comment, as (1-based line, byte offset); a control character before it is an error.
fn find_header(text: &str, opts: &DelimitedOptions, name: &str) -> Result<(usize, usize)> {
    let mut header_at: Option<(usize, usize)> = None; // (1-based line, byte offset)
    let mut offset = 0usize;
    for (i, line) in text.split_inclusive('\n').enumerate() {
        let lineno = i + 1;
        let body = line.trim_end_matches(['\n', '\r']);
        if let Some(c) = body.chars().find(|&c| c.is_control() && c != '\t') {
            return Err(RecordingError::Line {
                path: name.to_string(),
                line: lineno,
                reason: format!(
                    "control character U+{:04X} in the text: not a delimited text file (binary data?)",
                    c as u32
                ),
            });
        }
        let is_header = match opts.header_line {
            Some(h) => lineno == h,
            None => !body.trim().is_empty() && !body.trim_start().starts_with('#'),
        };
        if is_header {
            header_at = Some((lineno, offset));
            break;
        }
        offset += line.len();
    }
    header_at.ok_or_else(|| match opts.header_line {
        Some(h) => RecordingError::file(name, format!("header_line {h}: the file has fewer lines")),
        None => RecordingError::file(name, "empty file: no header and no data"),
    })
}

/// That every label is printable, not empty (but for a trailing one) and not repeated.
fn check_labels(labels: &[String], name: &str, header_line: usize) -> Result<()> {
    for (j, l) in labels.iter().enumerate() {
        if l.chars().any(|c| c.is_control() && c != '\t') {
            return Err(RecordingError::Cell {
                path: name.to_string(),
                line: header_line,
                column: j + 1,
                name: crate::read::printable(l),
                reason: "a control character (a line break inside quotes?) in the label".into(),
            });
        }
        if l.is_empty() {
            // a trailing delimiter after the last label is common in exports
            if j + 1 == labels.len() && j > 0 {
                continue;
            }
            return Err(RecordingError::Cell {
                path: name.to_string(),
                line: header_line,
                column: j + 1,
                name: String::new(),
                reason: "empty column label in the header".into(),
            });
        }
        if let Some(k) = labels[..j].iter().position(|m| m == l) {
            return Err(RecordingError::Cell {
                path: name.to_string(),
                line: header_line,
                column: j + 1,
                name: l.clone(),
                reason: format!("label '{l}' appears twice (also column {})", k + 1),
            });
        }
    }
    Ok(())
}

/// The rows' numbers, column by column; a row of another width than the header, or a cell that
/// is not a number, is an error naming its line (and column).
fn fill_columns(
    rows: &[(usize, csv::StringRecord)],
    labels: &[String],
    width: usize,
    format: (char, bool),
    name: &str,
    header_line: usize,
) -> Result<Vec<Vec<f64>>> {
    let (delimiter, decimal_comma) = format;
    let mut columns: Vec<Vec<f64>> = vec![Vec::with_capacity(rows.len()); width];
    for (line, r) in rows {
        // a trailing empty field (a delimiter at the end of the line) is not a value
        let mut n = r.len();
        while n > width && r.get(n - 1).is_some_and(|f| f.trim().is_empty()) {
            n -= 1;
        }
        if n != width {
            let what = if n < width { "too few" } else { "too many" };
            return Err(RecordingError::Line {
                path: name.to_string(),
                line: *line,
                reason: format!(
                    "{what} fields: expected {width} as in the header (line {header_line}), found {n}"
                ),
            });
        }
        for (j, col) in columns.iter_mut().enumerate() {
            let cell = r.get(j).unwrap_or("");
            let v = cell_number(cell, decimal_comma).ok_or_else(|| {
                let hint = match (decimal_comma, delimiter) {
                    (false, ',') if looks_decimal_comma(cell) => {
                        " (a decimal comma in a comma-separated file: use ';' or tabs between \
                         fields)"
                    }
                    (false, _) if looks_decimal_comma(cell) => {
                        " (a decimal comma, but the map says \"decimal_comma\": false)"
                    }
                    _ => "",
                };
                RecordingError::Cell {
                    path: name.to_string(),
                    line: *line,
                    column: j + 1,
                    name: labels[j].clone(),
                    reason: format!("{} is not a number{hint}", quote(cell.trim())),
                }
            })?;
            col.push(v);
        }
    }
    Ok(columns)
}
