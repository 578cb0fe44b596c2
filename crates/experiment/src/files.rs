//! Trial and unloaded-run CSV files (SPEC §5): validating reader, round-trip-exact atomic writer.

use std::fmt::Write as _;
use std::path::Path;

use serde::{Deserialize, Serialize};

use crate::error::{ErrorKind, ExperimentError, Result};

/// Required columns of a trial file, in the order they are written.
pub const TRIAL_REQUIRED: [&str; 6] = [
    "time_s",
    "ankle_angle_deg",
    "torque_nm",
    "emg_sol",
    "emg_gm",
    "emg_gl",
];
/// Optional columns of a trial file, in the order they are written (after the required ones).
pub const TRIAL_OPTIONAL: [&str; 2] = ["emg_ta", "knee_angle_deg"];
/// Required columns of an unloaded-run file (it has no optional ones).
pub const UNLOADED_REQUIRED: [&str; 3] = ["time_s", "ankle_angle_deg", "torque_nm"];

/// Default tolerance on sampling uniformity: every time step must lie within this
/// relative distance of the median step.
pub const DEFAULT_TIME_TOLERANCE: f64 = 1e-6;
/// Default minimum duration `t_last − t_first` in seconds.
pub const DEFAULT_MIN_DURATION_S: f64 = 1.0;

/// Options of the reader. `Default` is what [`parse_trial`] and [`read_trial`] use.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct ReadOptions {
    /// Relative tolerance of every time step against the median step (default 1e-6).
    pub time_tolerance: f64,
    /// Minimum `t_last − t_first` in seconds (default 1 s).
    pub min_duration_s: f64,
}

impl Default for ReadOptions {
    fn default() -> Self {
        Self {
            time_tolerance: DEFAULT_TIME_TOLERANCE,
            min_duration_s: DEFAULT_MIN_DURATION_S,
        }
    }
}

/// One isokinetic trial: uniformly sampled columns of equal length (SI-ish file units:
/// seconds, degrees with dorsiflexion > 0, N·m with plantarflexion > 0, raw EMG in any unit).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Trial {
    /// Time in seconds, strictly increasing and uniform.
    pub time_s: Vec<f64>,
    /// Ankle angle in degrees, dorsiflexion positive.
    pub ankle_angle_deg: Vec<f64>,
    /// Measured joint torque in N·m, plantarflexion positive.
    pub torque_nm: Vec<f64>,
    /// Raw EMG of soleus.
    pub emg_sol: Vec<f64>,
    /// Raw EMG of gastrocnemius medialis.
    pub emg_gm: Vec<f64>,
    /// Raw EMG of gastrocnemius lateralis.
    pub emg_gl: Vec<f64>,
    /// Raw EMG of tibialis anterior, if recorded.
    pub emg_ta: Option<Vec<f64>>,
    /// Knee angle in degrees (0 = extended), if recorded.
    pub knee_angle_deg: Option<Vec<f64>>,
    /// Text of the `#` comment lines (after the `#`), in file order; written at the top.
    pub comments: Vec<String>,
    /// Names of unknown columns that the reader ignored (a warning list; never written).
    pub ignored_columns: Vec<String>,
}

/// An unloaded run: the dynamometer moving with nothing attached (SPEC §1, §4).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Unloaded {
    /// Time in seconds, strictly increasing and uniform.
    pub time_s: Vec<f64>,
    /// Ankle (dynamometer arm) angle in degrees, dorsiflexion positive.
    pub ankle_angle_deg: Vec<f64>,
    /// Recorded torque in N·m (the dynamometer's own error).
    pub torque_nm: Vec<f64>,
    /// Text of the `#` comment lines (after the `#`), in file order; written at the top.
    pub comments: Vec<String>,
    /// Names of unknown columns that the reader ignored (never written).
    pub ignored_columns: Vec<String>,
}

fn sample_interval(t: &[f64]) -> f64 {
    if t.len() < 2 {
        return f64::NAN;
    }
    (t[t.len() - 1] - t[0]) / (t.len() - 1) as f64
}

impl Trial {
    /// Number of samples.
    #[must_use]
    pub fn len(&self) -> usize {
        self.time_s.len()
    }
    /// True when there are no samples.
    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.time_s.is_empty()
    }
    /// Sampling interval `(t_last − t_first)/(n − 1)` in seconds (NaN with < 2 samples).
    #[must_use]
    pub fn dt(&self) -> f64 {
        sample_interval(&self.time_s)
    }
    /// Sampling rate `1/dt` in Hz.
    #[must_use]
    pub fn sample_rate_hz(&self) -> f64 {
        1.0 / self.dt()
    }
    /// The EMG columns present, as `(column name, samples)`: sol, gm, gl, then ta if present.
    #[must_use]
    pub fn emg_channels(&self) -> Vec<(&'static str, &[f64])> {
        let mut v: Vec<(&'static str, &[f64])> = vec![
            ("emg_sol", &self.emg_sol),
            ("emg_gm", &self.emg_gm),
            ("emg_gl", &self.emg_gl),
        ];
        if let Some(ta) = &self.emg_ta {
            v.push(("emg_ta", ta));
        }
        v
    }
    /// Checks everything the reader checks (as if the trial were written to `name`).
    ///
    /// # Errors
    /// The same errors the reader would report for the written file.
    pub fn validate(&self, name: &str) -> Result<()> {
        format_trial_named(self, name).map(|_| ())
    }
}

impl Unloaded {
    /// Number of samples.
    #[must_use]
    pub fn len(&self) -> usize {
        self.time_s.len()
    }
    /// True when there are no samples.
    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.time_s.is_empty()
    }
    /// Sampling interval `(t_last − t_first)/(n − 1)` in seconds (NaN with < 2 samples).
    #[must_use]
    pub fn dt(&self) -> f64 {
        sample_interval(&self.time_s)
    }
    /// Sampling rate `1/dt` in Hz.
    #[must_use]
    pub fn sample_rate_hz(&self) -> f64 {
        1.0 / self.dt()
    }
    /// Checks everything the reader checks (as if the run were written to `name`).
    ///
    /// # Errors
    /// The same errors the reader would report for the written file.
    pub fn validate(&self, name: &str) -> Result<()> {
        format_unloaded_named(self, name).map(|_| ())
    }
}

// ---------------------------------------------------------------------------------------------
// Number format
// ---------------------------------------------------------------------------------------------

/// Appends `x` in the crate's file format: the shortest decimal string that parses back to
/// exactly `x` (Rust's round-trip `Display`/`LowerExp` digits). Plain notation for
/// `1e-5 ≤ |x| < 1e15` and for zero, scientific (`4.2e-7`) otherwise. `-0.0` is written `-0`.
pub fn write_f64(out: &mut String, x: f64) {
    let a = x.abs();
    // Writing into a String cannot fail.
    if a == 0.0 || ((1e-5..1e15).contains(&a)) || !x.is_finite() {
        let _ = write!(out, "{x}");
    } else {
        let _ = write!(out, "{x:e}");
    }
}

/// [`write_f64`] into a new string.
#[must_use]
pub fn format_f64(x: f64) -> String {
    let mut s = String::new();
    write_f64(&mut s, x);
    s
}

// ---------------------------------------------------------------------------------------------
// Generic table reader
// ---------------------------------------------------------------------------------------------

struct Table {
    /// Parsed columns, indexed like `known` (required then optional); `None` if absent.
    columns: Vec<Option<Vec<f64>>>,
    /// 1-based field index of each known column in the header (0 if absent).
    field_of: Vec<usize>,
    comments: Vec<String>,
    ignored: Vec<String>,
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
fn decode<'a>(bytes: &'a [u8], path: &str) -> Result<&'a str> {
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

#[allow(clippy::too_many_lines)]
fn parse_table(
    text: &str,
    path: &str,
    required: &[&str],
    optional: &[&str],
    opts: &ReadOptions,
) -> Result<Table> {
    let text = text.strip_prefix('\u{FEFF}').unwrap_or(text);
    let known: Vec<&str> = required.iter().chain(optional.iter()).copied().collect();
    let time_idx = known.iter().position(|&k| k == "time_s");
    let p = || path.to_string();

    let mut comments = Vec::new();
    let mut header: Option<(usize, Vec<String>)> = None;
    // For each header field: Some(known index) or None (ignored).
    let mut field_map: Vec<Option<usize>> = Vec::new();
    let mut field_of = vec![0usize; known.len()];
    let mut values: Vec<Vec<f64>> = vec![Vec::new(); known.len()];
    let mut row_lines: Vec<usize> = Vec::new();
    let mut ignored = Vec::new();

    let mut pieces = text.split('\n').peekable();
    let mut lineno = 0usize;
    while let Some(raw) = pieces.next() {
        lineno += 1;
        if raw.is_empty() && pieces.peek().is_none() {
            break; // the empty piece after a final newline
        }
        let line = raw.strip_suffix('\r').unwrap_or(raw);
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
        let trimmed = line.trim();
        if trimmed.is_empty() {
            continue;
        }
        if let Some(rest) = trimmed.strip_prefix('#') {
            comments.push(rest.to_string());
            continue;
        }
        match &header {
            None => {
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
                let names: Vec<String> = line.split(',').map(|s| s.trim().to_string()).collect();
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
                    if let Some(k) = known.iter().position(|&k| k == name) {
                        if field_of[k] != 0 {
                            return Err(ExperimentError::Cell {
                                path: p(),
                                line: lineno,
                                column: col,
                                name: name.clone(),
                                kind: ErrorKind::DuplicateColumn,
                                reason: format!(
                                    "column '{name}' appears twice (also column {})",
                                    field_of[k]
                                ),
                            });
                        }
                        field_of[k] = col;
                        field_map.push(Some(k));
                    } else if let Some(&k) = known
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
                    } else {
                        ignored.push(name.clone());
                        field_map.push(None);
                    }
                }
                let missing: Vec<&str> = required
                    .iter()
                    .enumerate()
                    .filter(|(k, _)| field_of[*k] == 0)
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
                header = Some((lineno, names));
            }
            Some((_, names)) => {
                let nfields = line.split(',').count();
                if nfields != names.len() {
                    let hint = if line.contains(';') {
                        " (the line contains ';': fields must be separated by ',' and decimals written with '.')"
                    } else if line.contains('\t') {
                        " (the line contains a tab: fields must be separated by ',')"
                    } else {
                        ""
                    };
                    let what = if nfields < names.len() {
                        "too few"
                    } else {
                        "too many"
                    };
                    return Err(ExperimentError::Line {
                        path: p(),
                        line: lineno,
                        kind: ErrorKind::FieldCount,
                        reason: format!(
                            "{what} fields: expected {}, found {nfields}{hint}",
                            names.len()
                        ),
                    });
                }
                for (j, cell) in line.split(',').enumerate() {
                    let Some(k) = field_map[j] else { continue };
                    let cell = cell.trim();
                    let cell_err = |kind, reason| ExperimentError::Cell {
                        path: p(),
                        line: lineno,
                        column: j + 1,
                        name: known[k].to_string(),
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
                    if let Some((lo, hi)) = plausible_range(known[k]) {
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
                    values[k].push(v);
                }
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

    // Time: strictly increasing, uniform, long enough.
    if let Some(ti) = time_idx {
        let t = &values[ti];
        let tcol = field_of[ti];
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
    }

    let columns = values
        .into_iter()
        .enumerate()
        .map(|(k, v)| if field_of[k] == 0 { None } else { Some(v) })
        .collect();
    Ok(Table {
        columns,
        field_of,
        comments,
        ignored,
    })
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
    Ok(())
}

// ---------------------------------------------------------------------------------------------
// Trial
// ---------------------------------------------------------------------------------------------

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
    let mut t = parse_table(text, name, &TRIAL_REQUIRED, &TRIAL_OPTIONAL, opts)?;
    let known: Vec<&str> = TRIAL_REQUIRED
        .iter()
        .chain(TRIAL_OPTIONAL.iter())
        .copied()
        .collect();
    check_not_all_zero(&t, &known, name)?;
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
        knee_angle_deg: take(7),
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

fn read_bytes(path: &Path) -> Result<Vec<u8>> {
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

/// Reads and validates a trial CSV file.
///
/// # Errors
/// A missing or unreadable file, or any error of [`parse_trial_bytes`].
pub fn read_trial(path: impl AsRef<Path>) -> Result<Trial> {
    let path = path.as_ref();
    let bytes = read_bytes(path)?;
    parse_trial_bytes(&bytes, &path.display().to_string())
}

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
/// (required, then `emg_ta`, `knee_angle_deg` if present), `\n` line ends, [`write_f64`] numbers.
///
/// # Errors
/// Columns of different lengths, or anything the reader would reject.
pub fn format_trial(trial: &Trial) -> Result<String> {
    format_trial_named(trial, "<trial>")
}

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

// ---------------------------------------------------------------------------------------------
// Unloaded
// ---------------------------------------------------------------------------------------------

/// Parses unloaded-run CSV text; `name` is the file name used in error messages.
///
/// # Errors
/// As [`parse_trial`].
pub fn parse_unloaded(text: &str, name: &str) -> Result<Unloaded> {
    parse_unloaded_with(text, name, &ReadOptions::default())
}

/// [`parse_unloaded`] with explicit [`ReadOptions`].
///
/// # Errors
/// As [`parse_trial`].
pub fn parse_unloaded_with(text: &str, name: &str, opts: &ReadOptions) -> Result<Unloaded> {
    let mut t = parse_table(text, name, &UNLOADED_REQUIRED, &[], opts)?;
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
/// As [`parse_trial_bytes`].
pub fn parse_unloaded_bytes(bytes: &[u8], name: &str) -> Result<Unloaded> {
    parse_unloaded(decode(bytes, name)?, name)
}

/// Reads and validates an unloaded-run CSV file.
///
/// # Errors
/// As [`read_trial`].
pub fn read_unloaded(path: impl AsRef<Path>) -> Result<Unloaded> {
    let path = path.as_ref();
    let bytes = read_bytes(path)?;
    parse_unloaded_bytes(&bytes, &path.display().to_string())
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
