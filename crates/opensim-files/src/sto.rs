//! OpenSim storage files (`.sto`, `.mot`): a header, `endheader`, a line of column labels and
//! rows of numbers.
//!
//! # Format
//!
//! ```text
//! simulate                 ← version 1: the first line is the table's name
//! version=1
//! nRows=3
//! nColumns=3               ← counts the time column
//! inDegrees=yes
//! endheader
//! time→ankle_angle_r→ankle_angle_r_moment    (→: a tab)
//! 0→-20→12.5
//! …
//! ```
//!
//! Version 2 (what OpenSim 4's `TimeSeriesTable` writes) has `key=value` lines only
//! (`version=2`, `OpenSimVersion=…`, `DataType=double`, `inDegrees=…`) and no `nRows` /
//! `nColumns`. The reader accepts both: every header line before `endheader` is either
//! `key=value` or, when it has no `=`, the table's name; `nRows` and `nColumns`, when present,
//! must match the data; `inDegrees` is `yes` or `no` (angles in degrees or radians; the reader
//! reports it and converts nothing). Labels are separated by tabs (by runs of white space when
//! the line has no tab); numbers by any white space. A `time` column is required.
//!
//! The writer writes version 1 with `nRows`, `nColumns` and `inDegrees`, tab-separated, every
//! number in the shortest form that reads back to the same `f64`.

use crate::OpenSimError;

/// A storage table: header facts and its columns by label (`time` among them).
#[derive(Clone, Debug, PartialEq)]
pub struct StoTable {
    /// The table's name (first header line of version 1; empty when the header has none).
    pub name: String,
    /// `version` from the header (1 when absent).
    pub version: u32,
    /// `inDegrees`: `Some(true)` for `yes`, `Some(false)` for `no`, `None` when absent.
    pub in_degrees: Option<bool>,
    /// Column labels in file order.
    pub labels: Vec<String>,
    /// Columns, `columns[j]` under `labels[j]`, one value per row.
    pub columns: Vec<Vec<f64>>,
}

impl StoTable {
    /// The column labelled `label`.
    pub fn column(&self, label: &str) -> Option<&[f64]> {
        self.labels
            .iter()
            .position(|l| l == label)
            .map(|j| self.columns[j].as_slice())
    }

    /// The `time` column (every table read has one).
    pub fn time(&self) -> Option<&[f64]> {
        self.column("time")
    }

    /// Number of rows.
    pub fn rows(&self) -> usize {
        self.columns.first().map_or(0, Vec::len)
    }
}

fn at(file: &str, line: usize, column: usize, message: impl Into<String>) -> OpenSimError {
    OpenSimError::At {
        file: file.to_string(),
        line: u32::try_from(line).unwrap_or(u32::MAX),
        column: u32::try_from(column).unwrap_or(u32::MAX),
        message: message.into(),
    }
}

/// The fields of `line` with their 1-based character columns.
fn fields(line: &str, tabs_only: bool) -> Vec<(usize, &str)> {
    let mut out = Vec::new();
    let mut start: Option<usize> = None;
    let is_sep = |c: char| {
        if tabs_only {
            c == '\t'
        } else {
            c.is_whitespace()
        }
    };
    for (i, c) in line.char_indices() {
        match (is_sep(c), start) {
            (true, Some(s)) => {
                out.push((s, &line[s..i]));
                start = None;
            }
            (false, None) => start = Some(i),
            _ => {}
        }
    }
    if let Some(s) = start {
        out.push((s, &line[s..]));
    }
    out.into_iter()
        .map(|(s, f)| (line[..s].chars().count() + 1, f.trim()))
        .collect()
}

/// Reads a storage file's text; `file` names it in errors.
///
/// # Errors
/// No `endheader`, a malformed `version` / `nRows` / `nColumns` / `inDegrees`, no labels, a
/// duplicate label, no `time` column, a row with the wrong number of values or a value that is
/// not a number (each naming the line and column), or counts that contradict the header.
pub fn read_sto(text: &str, file: &str) -> Result<StoTable, OpenSimError> {
    let mut lines = text.lines().enumerate().map(|(i, l)| (i + 1, l));
    let mut name = String::new();
    let mut version = 1u32;
    let mut in_degrees = None;
    let mut n_rows: Option<(usize, usize)> = None;
    let mut n_columns: Option<(usize, usize)> = None;
    let mut ended = false;
    for (ln, raw) in lines.by_ref() {
        let line = raw.trim();
        if line.eq_ignore_ascii_case("endheader") {
            ended = true;
            break;
        }
        let Some((key, value)) = line.split_once('=') else {
            if name.is_empty() {
                name = line.to_string();
            }
            continue;
        };
        let (key, value) = (key.trim(), value.trim());
        let count = |v: &str| {
            v.parse::<usize>()
                .map_err(|_| at(file, ln, 1, format!("{key}=`{v}` is not a count")))
        };
        match key {
            "version" => {
                version = value
                    .parse()
                    .map_err(|_| at(file, ln, 1, format!("version=`{value}` is not a number")))?
            }
            "nRows" | "datarows" => n_rows = Some((count(value)?, ln)),
            "nColumns" | "datacolumns" => n_columns = Some((count(value)?, ln)),
            "inDegrees" => {
                in_degrees = Some(match value.to_ascii_lowercase().as_str() {
                    "yes" => true,
                    "no" => false,
                    _ => {
                        return Err(at(
                            file,
                            ln,
                            1,
                            format!("inDegrees=`{value}`: expected yes or no"),
                        ))
                    }
                })
            }
            _ => {}
        }
    }
    if !ended {
        return Err(OpenSimError::File {
            file: file.to_string(),
            message: "no `endheader` line: not an OpenSim storage file".into(),
        });
    }
    let (label_ln, label_line) = lines
        .by_ref()
        .find(|(_, l)| !l.trim().is_empty())
        .ok_or_else(|| OpenSimError::File {
            file: file.to_string(),
            message: "no column labels after `endheader`".into(),
        })?;
    let labels: Vec<(usize, String)> = fields(label_line, label_line.contains('\t'))
        .into_iter()
        .map(|(c, f)| (c, f.to_string()))
        .collect();
    for (k, (c, l)) in labels.iter().enumerate() {
        if labels[..k].iter().any(|(_, m)| m == l) {
            return Err(at(
                file,
                label_ln,
                *c,
                format!("column `{l}` appears twice"),
            ));
        }
    }
    if !labels.iter().any(|(_, l)| l == "time") {
        return Err(at(file, label_ln, 1, "no `time` column"));
    }
    if let Some((n, ln)) = n_columns {
        if n != labels.len() {
            return Err(at(
                file,
                ln,
                1,
                format!("nColumns={n} but the file has {} columns", labels.len()),
            ));
        }
    }
    let mut columns = vec![Vec::new(); labels.len()];
    for (ln, line) in lines {
        if line.trim().is_empty() {
            continue;
        }
        let values = fields(line, false);
        if values.len() != labels.len() {
            return Err(at(
                file,
                ln,
                1,
                format!("{} values but {} columns", values.len(), labels.len()),
            ));
        }
        for ((c, v), (col, (_, label))) in values.into_iter().zip(columns.iter_mut().zip(&labels)) {
            let x: f64 = v.parse().map_err(|_| {
                at(
                    file,
                    ln,
                    c,
                    format!("column `{label}`: `{v}` is not a number"),
                )
            })?;
            col.push(x);
        }
    }
    if let Some((n, ln)) = n_rows {
        if n != columns[0].len() {
            return Err(at(
                file,
                ln,
                1,
                format!("nRows={n} but the file has {} rows", columns[0].len()),
            ));
        }
    }
    Ok(StoTable {
        name,
        version,
        in_degrees,
        labels: labels.into_iter().map(|(_, l)| l).collect(),
        columns,
    })
}

/// Writes `table` as a version 1 storage file (module documentation). `table.version` is not
/// used; `inDegrees` is written as `yes` unless `table.in_degrees` is `Some(false)`.
///
/// # Errors
/// Labels and columns of different counts, columns of different lengths, a label with white
/// space, or no `time` column.
pub fn write_sto(table: &StoTable) -> Result<String, OpenSimError> {
    let bad = |message: String| OpenSimError::File {
        file: table.name.clone(),
        message,
    };
    if table.labels.len() != table.columns.len() {
        return Err(bad(format!(
            "{} labels for {} columns",
            table.labels.len(),
            table.columns.len()
        )));
    }
    if let Some(l) = table
        .labels
        .iter()
        .find(|l| l.is_empty() || l.contains(char::is_whitespace))
    {
        return Err(bad(format!(
            "column label `{l}` is empty or has white space"
        )));
    }
    if !table.labels.iter().any(|l| l == "time") {
        return Err(bad("no `time` column".into()));
    }
    let rows = table.rows();
    if let Some((l, c)) = table
        .labels
        .iter()
        .zip(&table.columns)
        .find(|(_, c)| c.len() != rows)
    {
        return Err(bad(format!(
            "column `{l}` has {} values, expected {rows}",
            c.len()
        )));
    }
    let name = if table.name.trim().is_empty() || table.name.contains('=') {
        "surae"
    } else {
        table.name.lines().next().unwrap_or("surae")
    };
    let mut out = String::with_capacity(64 + rows * table.columns.len() * 20);
    out.push_str(name);
    out.push('\n');
    out.push_str("version=1\n");
    out.push_str(&format!("nRows={rows}\n"));
    out.push_str(&format!("nColumns={}\n", table.columns.len()));
    out.push_str(if table.in_degrees == Some(false) {
        "inDegrees=no\n"
    } else {
        "inDegrees=yes\n"
    });
    out.push_str("endheader\n");
    out.push_str(&table.labels.join("\t"));
    out.push('\n');
    for i in 0..rows {
        for (j, c) in table.columns.iter().enumerate() {
            if j > 0 {
                out.push('\t');
            }
            out.push_str(&format!("{}", c[i]));
        }
        out.push('\n');
    }
    Ok(out)
}
