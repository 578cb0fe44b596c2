//! The delimited-text reader under both file kinds: UTF-8 decoding, comments, the header and
//! its known columns, numeric cells, uniform sampling and duration, each failure an error
//! naming the file, line and column.
//!
//! The [`csv`] crate splits the text into records and fields, and un-quotes `"a,b"` fields.
//! The checks stay here, so that each failure keeps its own message and [`ErrorKind`] instead
//! of a generic CSV error: the reader is built `flexible` and without a header row, and this
//! module reports a row with the wrong number of fields, a header separated by `;` or tabs, an
//! empty, repeated or misspelled column name, a cell that is not a number, and the time checks.
//! Only `\n` ends a record (a lone CR is a control character of the line and reported as such;
//! one CR before the `\n` is dropped), and a quoted field may not run over the end of its line.
//! Blank lines and comment lines (`#` after optional blanks) are recognised on the physical
//! line, before any quoting applies to them, and the text of a comment is kept.

use std::borrow::Cow;
use std::io::Cursor;
use std::path::Path;

use super::number::format_f64;
use super::records::ReadOptions;
use crate::error::{ErrorKind, ExperimentError, Result};

/// A parsed file: its known columns, comments and the columns it ignored.
pub(super) struct Table {
    /// Parsed columns, indexed like `known` (required then optional); `None` if absent.
    pub(super) columns: Vec<Option<Vec<f64>>>,
    /// 1-based field index of each known column in the header (0 if absent).
    pub(super) field_of: Vec<usize>,
    /// Columns named `<prefix><name>` (see [`parse_table`]), in header order: the full column
    /// name, its 1-based field index and its values.
    pub(super) extra: Vec<(String, usize, Vec<f64>)>,
    pub(super) comments: Vec<String>,
    pub(super) ignored: Vec<String>,
}

fn normalise_name(s: &str) -> String {
    s.trim()
        .chars()
        .filter(|c| !c.is_whitespace())
        .map(|c| match c {
            '-' | '.' => '_',
            c => c.to_ascii_lowercase(),
        })
        .collect()
}

fn quote(cell: &str) -> String {
    const MAX: usize = 40;
    if cell.chars().count() > MAX {
        let head: String = cell.chars().take(MAX).collect();
        format!("'{head}…'")
    } else {
        format!("'{cell}'")
    }
}

fn describe_control(c: char) -> String {
    format!("U+{:04X}", c as u32)
}

/// Decodes bytes as UTF-8 (an optional BOM is skipped), naming the line of the first bad byte.
pub(super) fn decode<'a>(bytes: &'a [u8], path: &str) -> Result<&'a str> {
    let bytes = bytes.strip_prefix(b"\xEF\xBB\xBF").unwrap_or(bytes);
    match std::str::from_utf8(bytes) {
        Ok(s) => Ok(s),
        Err(e) => {
            let pos = e.valid_up_to();
            let line = 1 + bytes[..pos].iter().filter(|&&b| b == b'\n').count();
            Err(ExperimentError::Line {
                path: path.to_string(),
                line,
                kind: ErrorKind::InvalidUtf8,
                reason: format!("invalid UTF-8 at byte {pos}: not a text file (binary data?)"),
            })
        }
    }
}

/// `true` for a name usable after an extra-column prefix: a lower-case letter, then lower-case
/// letters, digits and `_` (the muscle names of the parameters JSON).
pub(super) fn is_channel_name(s: &str) -> bool {
    let mut chars = s.chars();
    chars.next().is_some_and(|c| c.is_ascii_lowercase())
        && chars.all(|c| c.is_ascii_lowercase() || c.is_ascii_digit() || c == '_')
}

/// Reads a table whose columns are `required`, then `optional`, then, when `extra_prefix` is
/// given, any number of further columns named `<extra_prefix><name>` ([`is_channel_name`]);
/// every other column is ignored.
pub(super) fn parse_table(
    text: &str,
    path: &str,
    required: &[&str],
    optional: &[&str],
    extra_prefix: Option<&str>,
    opts: &ReadOptions,
) -> Result<Table> {
    let text = text.strip_prefix('\u{FEFF}').unwrap_or(text);
    let known: Vec<&str> = required.iter().chain(optional.iter()).copied().collect();
    let spec = Spec {
        path,
        known: &known,
        required,
        extra_prefix,
    };
    let time_idx = known.iter().position(|&k| k == "time_s");
    let p = || path.to_string();

    let mut comments = Vec::new();
    let mut header: Option<(usize, Vec<String>)> = None;
    let mut cols = Columns::of_known(&known);
    let mut row_lines: Vec<usize> = Vec::new();

    let with_newline;
    let text = if text.is_empty() || text.ends_with('\n') {
        text
    } else {
        // a final `\n` makes a quote left open on the last line show like on any other line
        with_newline = format!("{text}\n");
        &with_newline
    };
    let mut lines = Lines::new(text);
    while let Some(Line {
        number: lineno,
        text: line,
        spans_lines,
    }) = lines.next(path)?
    {
        check_no_control(line, lineno, path)?;
        let trimmed = line.trim();
        if trimmed.is_empty() || trimmed.starts_with('#') {
            if let Some(rest) = trimmed.strip_prefix('#') {
                comments.push(rest.to_string());
            }
            if spans_lines {
                // a '"' in the comment opened a quoted field: the comment is this line only
                lines.resume_after_line(path)?;
            }
            continue;
        }
        let record = &lines.record;
        if spans_lines {
            return Err(unbalanced_quote(record, lineno, path));
        }
        match &header {
            None => {
                let names = read_header(&spec, record, line, lineno, &mut cols)?;
                header = Some((lineno, names));
            }
            Some((_, names)) => {
                read_row(path, record, line, lineno, names.len(), &mut cols)?;
                row_lines.push(lineno);
            }
        }
    }

    let Some((header_line, _)) = header else {
        let reason = if comments.is_empty() {
            "empty file: no header and no data"
        } else {
            "empty file: only comment lines, no header and no data"
        };
        return Err(ExperimentError::File {
            path: p(),
            kind: ErrorKind::Empty,
            reason: reason.into(),
        });
    };
    if row_lines.is_empty() {
        return Err(ExperimentError::Line {
            path: p(),
            line: header_line,
            kind: ErrorKind::HeaderOnly,
            reason: "header only: the file has no data rows".into(),
        });
    }
    if let Some(ti) = time_idx {
        check_time(&cols.values[ti], cols.field_of[ti], &row_lines, opts, path)?;
    }
    Ok(cols.into_table(known.len(), comments))
}

/// What [`parse_table`] reads: the file's name and the columns it knows.
struct Spec<'a> {
    path: &'a str,
    /// The required columns, then the optional ones.
    known: &'a [&'a str],
    required: &'a [&'a str],
    extra_prefix: Option<&'a str>,
}

/// The columns read so far: the known ones, then the extra ones in header order.
struct Columns {
    /// Names of every read column.
    all: Vec<String>,
    /// The 1-based header column of each read column; 0 for a known column not in the header.
    field_of: Vec<usize>,
    values: Vec<Vec<f64>>,
    /// For each header field: Some(read column index) or None (ignored).
    field_map: Vec<Option<usize>>,
    ignored: Vec<String>,
}

impl Columns {
    fn of_known(known: &[&str]) -> Self {
        Self {
            all: known.iter().map(|k| (*k).to_string()).collect(),
            field_of: vec![0usize; known.len()],
            values: vec![Vec::new(); known.len()],
            field_map: Vec::new(),
            ignored: Vec::new(),
        }
    }

    /// The table: the first `known` columns by position (`None` where absent), the rest extra.
    fn into_table(self, known: usize, comments: Vec<String>) -> Table {
        let Self {
            mut all,
            mut field_of,
            mut values,
            ignored,
            ..
        } = self;
        let extra_values = values.split_off(known);
        let extra = all
            .split_off(known)
            .into_iter()
            .zip(field_of.split_off(known))
            .zip(extra_values)
            .map(|((name, col), v)| (name, col, v))
            .collect();
        let columns = values
            .into_iter()
            .enumerate()
            .map(|(k, v)| if field_of[k] == 0 { None } else { Some(v) })
            .collect();
        Table {
            columns,
            field_of,
            extra,
            comments,
            ignored,
        }
    }
}

/// A control character (other than a tab) on a line is binary data, not CSV.
fn check_no_control(line: &str, lineno: usize, path: &str) -> Result<()> {
    let p = || path.to_string();
    if let Some(c) = line.chars().find(|&c| c.is_control() && c != '\t') {
        return Err(ExperimentError::Line {
            path: p(),
            line: lineno,
            kind: ErrorKind::Binary,
            reason: format!(
                "control character {} in the text: not a CSV file (binary data?)",
                describe_control(c)
            ),
        });
    }
    Ok(())
}

/// The error for a quoted field that does not end on its line.
fn unbalanced_quote(record: &csv::ByteRecord, lineno: usize, path: &str) -> ExperimentError {
    let p = || path.to_string();
    let col = record
        .iter()
        .position(|f| f.contains(&b'\n'))
        .map_or(record.len(), |j| j + 1);
    ExperimentError::Line {
        path: p(),
        line: lineno,
        kind: ErrorKind::FieldCount,
        reason: format!(
            "unbalanced quote: the quoted field in column {col} does not end on this \
             line (a '\"' without its closing '\"'?)"
        ),
    }
}

/// The header's column names, each classified into `cols`: a known or extra column is read,
/// any other ignored; a header that is empty, repeated, misspelled, separated by another
/// delimiter or lacks a required column is an error.
fn read_header(
    spec: &Spec<'_>,
    record: &csv::ByteRecord,
    line: &str,
    lineno: usize,
    cols: &mut Columns,
) -> Result<Vec<String>> {
    let p = || spec.path.to_string();
    if !line.contains(',') {
        let delim = if line.contains(';') {
            Some("';'")
        } else if line.contains('\t') {
            Some("a tab")
        } else {
            None
        };
        if let Some(d) = delim {
            return Err(ExperimentError::Line {
                path: p(),
                line: lineno,
                kind: ErrorKind::WrongDelimiter,
                reason: format!(
                    "wrong delimiter: the header is separated by {d}; fields must be separated by ','"
                ),
            });
        }
    }
    let names: Vec<String> = record.iter().map(|f| field(f).into_owned()).collect();
    for (j, name) in names.iter().enumerate() {
        let col = j + 1;
        if name.is_empty() {
            return Err(ExperimentError::Cell {
                path: p(),
                line: lineno,
                column: col,
                name: String::new(),
                kind: ErrorKind::EmptyColumnName,
                reason: "empty column name in the header".into(),
            });
        }
        let extra = spec
            .extra_prefix
            .and_then(|pre| name.strip_prefix(pre))
            .is_some_and(is_channel_name);
        if let Some(k) = cols.all.iter().position(|k| k == name) {
            if cols.field_of[k] != 0 {
                return Err(ExperimentError::Cell {
                    path: p(),
                    line: lineno,
                    column: col,
                    name: name.clone(),
                    kind: ErrorKind::DuplicateColumn,
                    reason: format!(
                        "column '{name}' appears twice (also column {})",
                        cols.field_of[k]
                    ),
                });
            }
            cols.field_of[k] = col;
            cols.field_map.push(Some(k));
        } else if let Some(&k) = spec
            .known
            .iter()
            .find(|&&k| normalise_name(name) == normalise_name(k))
        {
            return Err(ExperimentError::Cell {
                path: p(),
                line: lineno,
                column: col,
                name: name.clone(),
                kind: ErrorKind::MisspelledColumn,
                reason: format!(
                    "column {} looks like '{k}'; column names are exact and lower case",
                    quote(name)
                ),
            });
        } else if extra {
            cols.all.push(name.clone());
            cols.field_of.push(col);
            cols.values.push(Vec::new());
            cols.field_map.push(Some(cols.all.len() - 1));
        } else if let Some(prefix) = spec.extra_prefix.filter(|pre| {
            let n = normalise_name(name);
            n.starts_with(pre) && n.len() > pre.len()
        }) {
            // a channel the user meant to supply, misnamed: ignoring it would
            // quietly drop it
            return Err(ExperimentError::Cell {
                path: p(),
                line: lineno,
                column: col,
                name: name.clone(),
                kind: ErrorKind::MisspelledColumn,
                reason: format!(
                    "column {} looks like a channel '{prefix}<name>'; the name after \
                     '{prefix}' is lower case: letters, digits and '_', starting with a letter",
                    quote(name)
                ),
            });
        } else {
            cols.ignored.push(name.clone());
            cols.field_map.push(None);
        }
    }
    let missing: Vec<&str> = spec
        .required
        .iter()
        .enumerate()
        .filter(|(k, _)| cols.field_of[*k] == 0)
        .map(|(_, &n)| n)
        .collect();
    if !missing.is_empty() {
        let list = missing
            .iter()
            .map(|m| format!("'{m}'"))
            .collect::<Vec<_>>()
            .join(", ");
        let plural = if missing.len() > 1 { "s" } else { "" };
        return Err(ExperimentError::Line {
            path: p(),
            line: lineno,
            kind: ErrorKind::MissingColumn,
            reason: format!(
                "missing required column{plural} {list} (the header has: {})",
                names.join(", ")
            ),
        });
    }
    Ok(names)
}

/// One data row's cells into `cols`: the row has the header's `width` fields, and every read
/// cell is a finite number (within the joint's range for an angle).
fn read_row(
    path: &str,
    record: &csv::ByteRecord,
    line: &str,
    lineno: usize,
    width: usize,
    cols: &mut Columns,
) -> Result<()> {
    let p = || path.to_string();
    let nfields = record.len();
    if nfields != width {
        let hint = if line.contains(';') {
            " (the line contains ';': fields must be separated by ',' and decimals written with '.')"
        } else if line.contains('\t') {
            " (the line contains a tab: fields must be separated by ',')"
        } else {
            ""
        };
        let what = if nfields < width {
            "too few"
        } else {
            "too many"
        };
        return Err(ExperimentError::Line {
            path: p(),
            line: lineno,
            kind: ErrorKind::FieldCount,
            reason: format!("{what} fields: expected {width}, found {nfields}{hint}"),
        });
    }
    for (j, cell) in record.iter().enumerate() {
        let Some(k) = cols.field_map[j] else { continue };
        let cell = field(cell);
        let cell = cell.as_ref();
        let cell_err = |kind, reason| ExperimentError::Cell {
            path: p(),
            line: lineno,
            column: j + 1,
            name: cols.all[k].clone(),
            kind,
            reason,
        };
        if cell.is_empty() {
            return Err(cell_err(ErrorKind::EmptyCell, "empty cell".into()));
        }
        let v: f64 = cell.parse().map_err(|_| {
            cell_err(
                ErrorKind::NotANumber,
                format!("{} is not a number", quote(cell)),
            )
        })?;
        if !v.is_finite() {
            return Err(cell_err(
                ErrorKind::NotFinite,
                format!("{} is not a finite number", quote(cell)),
            ));
        }
        if let Some((lo, hi)) = plausible_range(&cols.all[k]) {
            if !(lo..=hi).contains(&v) {
                return Err(cell_err(
                    ErrorKind::OutOfRange,
                    format!(
                        "{} degrees is outside the joint's range [{lo}, {hi}]",
                        quote(cell)
                    ),
                ));
            }
        }
        cols.values[k].push(v);
    }
    Ok(())
}

/// Time: strictly increasing, uniform, long enough; `tcol` is its header column.
fn check_time(
    t: &[f64],
    tcol: usize,
    row_lines: &[usize],
    opts: &ReadOptions,
    path: &str,
) -> Result<()> {
    let p = || path.to_string();
    let terr = |row: usize, kind, reason| ExperimentError::Cell {
        path: p(),
        line: row_lines[row],
        column: tcol,
        name: "time_s".into(),
        kind,
        reason,
    };
    for i in 1..t.len() {
        if t[i] <= t[i - 1] {
            let reason = if t[i] == t[i - 1] {
                format!(
                    "time does not increase: {} repeats the previous sample (line {})",
                    human(t[i]),
                    row_lines[i - 1]
                )
            } else {
                format!(
                    "time goes backwards: {} after {} (line {})",
                    human(t[i]),
                    human(t[i - 1]),
                    row_lines[i - 1]
                )
            };
            return Err(terr(i, ErrorKind::TimeNotIncreasing, reason));
        }
    }
    if t.len() >= 2 {
        let mut d: Vec<f64> = t.windows(2).map(|w| w[1] - w[0]).collect();
        let mid = d.len() / 2;
        let (_, med, _) = d.select_nth_unstable_by(mid, f64::total_cmp);
        let med = *med;
        for i in 1..t.len() {
            let dt = t[i] - t[i - 1];
            let rel = (dt - med).abs() / med;
            if rel > opts.time_tolerance {
                let reason = if dt > 1.5 * med {
                    format!(
                        "gap in time: {} s since the previous sample (line {}), expected {} s ({} missing)",
                        human(dt),
                        row_lines[i - 1],
                        human(med),
                        missing_samples(dt, med)
                    )
                } else {
                    format!(
                        "non-uniform sampling: step {} s differs from the median step {} s by {:.3e} (relative), more than {:e}",
                        human(dt),
                        human(med),
                        rel,
                        opts.time_tolerance
                    )
                };
                let kind = if dt > 1.5 * med {
                    ErrorKind::TimeGap
                } else {
                    ErrorKind::NonUniformTime
                };
                return Err(terr(i, kind, reason));
            }
        }
    }
    let dur = t[t.len() - 1] - t[0];
    if t.len() < 2 || dur < opts.min_duration_s * (1.0 - 1e-9) {
        return Err(ExperimentError::File {
            path: p(),
            kind: ErrorKind::TooShort,
            reason: format!(
                "too short: {} s of data ({} samples); at least {} s is required",
                human(if t.len() < 2 { 0.0 } else { dur }),
                t.len(),
                human(opts.min_duration_s)
            ),
        });
    }
    Ok(())
}

/// A field of a record as text, trimmed like [`str::trim`].
fn field(bytes: &[u8]) -> Cow<'_, str> {
    // the fields are pieces of a `&str` cut at ASCII bytes, so always valid UTF-8 (borrowed)
    match String::from_utf8_lossy(bytes) {
        Cow::Borrowed(s) => Cow::Borrowed(s.trim()),
        Cow::Owned(s) => Cow::Owned(s.trim().to_string()),
    }
}

/// The record that starts on one physical line.
struct Line<'a> {
    /// 1-based number of the line.
    number: usize,
    /// The line, without its `\n` and one `\r` before it.
    text: &'a str,
    /// The record goes on over the next lines (a quoted field holds a `\n`).
    spans_lines: bool,
}

/// The records of a text as the [`csv`] crate splits them, each with the physical line it
/// starts on. The lines are counted here: the position of a csv record lies before the blank
/// lines the csv reader skips ahead of it.
struct Lines<'a> {
    /// The text, ending with `\n` unless empty.
    text: &'a str,
    reader: csv::Reader<Cursor<&'a [u8]>>,
    /// Fields of the record last returned by [`Lines::next`].
    record: csv::ByteRecord,
    /// Byte offset at which the reader goes on, and the line number there.
    at: (usize, usize),
    /// Byte offset and line number after the first line of the last record.
    after_line: (usize, usize),
}

impl<'a> Lines<'a> {
    fn new(text: &'a str) -> Self {
        let reader = csv::ReaderBuilder::new()
            .has_headers(false)
            .flexible(true)
            .terminator(csv::Terminator::Any(b'\n'))
            .from_reader(Cursor::new(text.as_bytes()));
        Self {
            text,
            reader,
            record: csv::ByteRecord::new(),
            at: (0, 1),
            after_line: (0, 1),
        }
    }

    /// The next record (in [`Lines::record`]) and its first line, or `None` at the end.
    fn next(&mut self, path: &str) -> Result<Option<Line<'a>>> {
        let bytes = self.text.as_bytes();
        // the csv reader skips empty lines (only those) before a record
        let skipped = bytes[self.at.0..]
            .iter()
            .take_while(|&&b| b == b'\n')
            .count();
        let start = self.at.0 + skipped;
        let number = self.at.1 + skipped;
        let more = self
            .reader
            .read_byte_record(&mut self.record)
            .map_err(|e| read_error(path, number, &e))?;
        if !more {
            return Ok(None);
        }
        let end = usize::try_from(self.reader.position().byte())
            .map_or(bytes.len(), |e| e.clamp(start, bytes.len()));
        let line_end = bytes[start..]
            .iter()
            .position(|&b| b == b'\n')
            .map_or(bytes.len(), |i| start + i);
        // a quoted field holding a `\n` (also one left open on the last line, which the csv
        // reader closes at the end of the text)
        let spans_lines = self.record.as_slice().contains(&b'\n');
        let newlines = if end > line_end + 1 {
            bytes[start..end].iter().filter(|&&b| b == b'\n').count()
        } else {
            usize::from(end > line_end)
        };
        self.at = (end, number + newlines);
        self.after_line = ((line_end + 1).min(bytes.len()), number + 1);
        let raw = &self.text[start..line_end];
        Ok(Some(Line {
            number,
            text: raw.strip_suffix('\r').unwrap_or(raw),
            spans_lines,
        }))
    }

    /// Goes on after the first line of the last record instead of after the whole record.
    fn resume_after_line(&mut self, path: &str) -> Result<()> {
        let (byte, line) = self.after_line;
        let mut pos = csv::Position::new();
        pos.set_byte(u64::try_from(byte).unwrap_or(u64::MAX))
            .set_line(u64::try_from(line).unwrap_or(u64::MAX));
        self.reader
            .seek(pos)
            .map_err(|e| read_error(path, line, &e))?;
        self.at = self.after_line;
        Ok(())
    }
}

/// A failure of the csv reader itself (reading from memory: not expected).
fn read_error(path: &str, line: usize, e: &csv::Error) -> ExperimentError {
    ExperimentError::Line {
        path: path.to_string(),
        line,
        kind: ErrorKind::Io,
        reason: format!("cannot read: {e}"),
    }
}

/// Physically possible range of an angle column (degrees), if it has one.
fn plausible_range(column: &str) -> Option<(f64, f64)> {
    match column {
        "ankle_angle_deg" => Some((-90.0, 90.0)),
        "knee_angle_deg" => Some((-30.0, 180.0)),
        _ => None,
    }
}

/// A short human-readable number for messages (10 significant digits at most).
fn human(x: f64) -> String {
    let s = format!("{x:.9e}");
    let back: f64 = s.parse().unwrap_or(x);
    format_f64(back)
}

fn missing_samples(dt: f64, med: f64) -> String {
    let k = ((dt / med).round() - 1.0).max(1.0);
    if k == 1.0 {
        "about 1 sample".into()
    } else {
        format!("about {k} samples")
    }
}

/// The bytes of the file at `path` (a missing file, a folder or a read failure is an error).
pub(super) fn read_bytes(path: &Path) -> Result<Vec<u8>> {
    std::fs::read(path).map_err(|e| {
        let (kind, reason) = match e.kind() {
            std::io::ErrorKind::NotFound => (ErrorKind::NotFound, "no such file".to_string()),
            _ if path.is_dir() => (ErrorKind::Io, "is a folder, not a file".to_string()),
            _ => (ErrorKind::Io, format!("cannot read: {e}")),
        };
        ExperimentError::File {
            path: path.display().to_string(),
            kind,
            reason,
        }
    })
}
