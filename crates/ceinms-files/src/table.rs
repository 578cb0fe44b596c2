//! CEINMS data files (`emg.txt`, `lmt.txt`, `<joint>Ma.txt`, `<joint>Torque.txt`).
//!
//! ```text
//! datacolumns N
//! datarows M
//! time<TAB>name_1<TAB>…<TAB>name_{N−1}
//! t_1<TAB>v_11<TAB>…                      (M rows of N numbers)
//! ```
//!
//! `N` counts the `time` column. Fields may be separated by tabs or spaces (CEINMS reads them
//! as whitespace-separated). Blank lines after the last row are ignored. Times (s) must
//! increase strictly; every value must be a finite number. A file whose table disagrees with
//! its `datacolumns` or `datarows` line is rejected rather than read in part, since such a
//! file has usually been cut or edited by hand.

use crate::error::{read_text, CeinmsError};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// One CEINMS data file: a time column and named value columns.
#[derive(Clone, Debug, PartialEq)]
pub struct CeinmsTable {
    /// The file it was read from (used in error messages).
    pub path: PathBuf,
    /// Column names after `time`, in file order.
    pub names: Vec<String>,
    /// Sample times (s), strictly increasing.
    pub time: Vec<f64>,
    /// One vector per name, each as long as `time`.
    pub columns: Vec<Vec<f64>>,
}

impl CeinmsTable {
    /// The column called `name`, if the file has it.
    pub fn column(&self, name: &str) -> Option<&[f64]> {
        self.names
            .iter()
            .position(|n| n == name)
            .map(|i| self.columns[i].as_slice())
    }

    /// The column called `name`, or an error naming the file and the column.
    pub fn require(&self, name: &str) -> Result<&[f64], CeinmsError> {
        self.column(name).ok_or_else(|| CeinmsError::MissingColumn {
            path: self.path.clone(),
            name: name.to_string(),
        })
    }

    /// Number of rows.
    pub fn len(&self) -> usize {
        self.time.len()
    }

    /// `true` when the table has no rows.
    pub fn is_empty(&self) -> bool {
        self.time.is_empty()
    }

    /// Mean sampling rate (Hz): `(rows − 1) / (last time − first time)`; 0 with fewer than 2
    /// rows.
    pub fn mean_rate_hz(&self) -> f64 {
        match (self.time.first(), self.time.last()) {
            (Some(a), Some(b)) if self.time.len() > 1 => (self.time.len() - 1) as f64 / (b - a),
            _ => 0.0,
        }
    }
}

/// Parses the text of a CEINMS data file; `path` names it in errors.
///
/// # Errors
/// [`CeinmsError::Line`] for a missing or malformed `datacolumns` / `datarows` line, a
/// header that does not start with `time` or has a duplicate or missing name, a row with the
/// wrong number of fields, or a row count different from `datarows`; [`CeinmsError::Cell`]
/// for a value that is not a finite number or a time that does not increase.
pub fn parse_table(text: &str, path: &Path) -> Result<CeinmsTable, CeinmsError> {
    let line_err = |line: usize, reason: String| CeinmsError::Line {
        path: path.to_path_buf(),
        line,
        reason,
    };
    let mut lines = text.lines().enumerate().map(|(i, l)| (i + 1, l));
    let mut count = |key: &str| -> Result<usize, CeinmsError> {
        let (no, line) = lines
            .next()
            .ok_or_else(|| line_err(1, format!("missing `{key} N` line")))?;
        let mut f = line.split_whitespace();
        match (f.next(), f.next(), f.next()) {
            (Some(k), Some(v), None) if k == key => v.parse::<usize>().map_err(|_| {
                line_err(
                    no,
                    format!("`{key}` must be followed by a whole number, found `{v}`"),
                )
            }),
            _ => Err(line_err(
                no,
                format!("expected `{key} N`, found `{}`", line.trim()),
            )),
        }
    };
    let n_cols = count("datacolumns")?;
    let n_rows = count("datarows")?;
    let (header_no, header) = lines
        .next()
        .ok_or_else(|| line_err(3, "missing header line".to_string()))?;
    let fields: Vec<&str> = header.split_whitespace().collect();
    if fields.first() != Some(&"time") {
        return Err(line_err(
            header_no,
            "the header's first column must be `time`".to_string(),
        ));
    }
    if fields.len() != n_cols {
        return Err(line_err(
            header_no,
            format!(
                "the header has {} columns but `datacolumns` says {n_cols}",
                fields.len()
            ),
        ));
    }
    for (i, f) in fields.iter().enumerate() {
        if fields[..i].contains(f) {
            return Err(line_err(
                header_no,
                format!("column {} `{f}` appears twice", i + 1),
            ));
        }
    }
    let names: Vec<String> = fields[1..].iter().map(|s| s.to_string()).collect();
    let mut time = Vec::with_capacity(n_rows);
    let mut columns = vec![Vec::with_capacity(n_rows); names.len()];
    let mut last_no = header_no;
    for (no, line) in lines {
        if line.trim().is_empty() {
            continue;
        }
        last_no = no;
        if time.len() == n_rows {
            return Err(line_err(
                no,
                format!("more rows than the {n_rows} that `datarows` says"),
            ));
        }
        let cells: Vec<&str> = line.split_whitespace().collect();
        if cells.len() != n_cols {
            return Err(line_err(
                no,
                format!("{} fields, the header has {n_cols}", cells.len()),
            ));
        }
        for (c, cell) in cells.iter().enumerate() {
            let cell_err = |reason: String| CeinmsError::Cell {
                path: path.to_path_buf(),
                line: no,
                column: c + 1,
                name: fields[c].to_string(),
                reason,
            };
            let v: f64 = cell
                .parse()
                .map_err(|_| cell_err(format!("`{cell}` is not a number")))?;
            if !v.is_finite() {
                return Err(cell_err(format!("`{cell}` is not finite")));
            }
            if c == 0 {
                if let Some(&prev) = time.last() {
                    if v <= prev {
                        return Err(cell_err(format!(
                            "time {v} s does not increase (previous row {prev} s)"
                        )));
                    }
                }
                time.push(v);
            } else {
                columns[c - 1].push(v);
            }
        }
    }
    if time.len() != n_rows {
        return Err(line_err(
            last_no,
            format!(
                "{} rows, but `datarows` says {n_rows} (file cut short?)",
                time.len()
            ),
        ));
    }
    Ok(CeinmsTable {
        path: path.to_path_buf(),
        names,
        time,
        columns,
    })
}

/// Reads a CEINMS data file.
///
/// # Errors
/// [`CeinmsError::File`] when the file cannot be read; otherwise as [`parse_table`].
pub fn read_table(path: &Path) -> Result<CeinmsTable, CeinmsError> {
    parse_table(&read_text(path)?, path)
}

/// The text of a CEINMS data file for `names` (after `time`) and their columns; values are
/// written with Rust's shortest round-trip formatting, so reading the text back gives the same
/// numbers.
///
/// # Errors
/// [`CeinmsError::File`] when `names` and `columns` differ in number or a column is not as
/// long as `time`.
pub fn format_table(
    names: &[&str],
    time: &[f64],
    columns: &[&[f64]],
) -> Result<String, CeinmsError> {
    if names.len() != columns.len() || columns.iter().any(|c| c.len() != time.len()) {
        return Err(CeinmsError::File {
            path: PathBuf::from("<table being written>"),
            reason: format!(
                "{} names and {} columns for {} times: every column needs one value per time",
                names.len(),
                columns.len(),
                time.len()
            ),
        });
    }
    let mut s = String::with_capacity(16 * time.len() * (names.len() + 1));
    let _ = writeln!(s, "datacolumns {}", names.len() + 1);
    let _ = writeln!(s, "datarows {}", time.len());
    s.push_str("time");
    for n in names {
        s.push('\t');
        s.push_str(n);
    }
    s.push('\n');
    for (i, t) in time.iter().enumerate() {
        let _ = write!(s, "{t}");
        for c in columns {
            let _ = write!(s, "\t{}", c[i]);
        }
        s.push('\n');
    }
    Ok(s)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse(text: &str) -> Result<CeinmsTable, CeinmsError> {
        parse_table(text, Path::new("x.txt"))
    }

    #[test]
    fn reads_a_well_formed_table() {
        let t =
            parse("datacolumns 3\ndatarows 2\ntime\ta_r\tb_r\n0.5\t1\t-2\n0.504\t1.5\t-2.5\n\n")
                .unwrap();
        assert_eq!(t.names, vec!["a_r", "b_r"]);
        assert_eq!(t.time, vec![0.5, 0.504]);
        assert_eq!(t.column("b_r").unwrap(), &[-2.0, -2.5]);
        assert!((t.mean_rate_hz() - 250.0).abs() < 1e-9);
        assert!(t.column("c_r").is_none());
        let e = t.require("c_r").unwrap_err();
        assert_eq!(e.to_string(), "x.txt: no column `c_r`");
    }

    #[test]
    fn round_trips_through_format_table() {
        let time = [0.1, 0.2, 0.30000000000000004];
        let a = [1.0 / 3.0, -0.0427, 1e-17];
        let text = format_table(&["a_r"], &time, &[&a]).unwrap();
        let t = parse(&text).unwrap();
        assert_eq!(t.time, time);
        assert_eq!(t.columns[0], a);
        assert!(format_table(&["a_r"], &time, &[&a[..2]]).is_err());
    }

    #[test]
    fn bad_input_names_line_and_column() {
        let cases: &[(&str, &str)] = &[
            ("", "x.txt:1: missing `datacolumns N` line"),
            (
                "datacols 3\n",
                "x.txt:1: expected `datacolumns N`, found `datacols 3`",
            ),
            (
                "datacolumns x\n",
                "x.txt:1: `datacolumns` must be followed by a whole number, found `x`",
            ),
            (
                "datacolumns 2\ndatarows 1\nt\ta\n0\t1\n",
                "x.txt:3: the header's first column must be `time`",
            ),
            (
                "datacolumns 3\ndatarows 1\ntime\ta\n0\t1\n",
                "x.txt:3: the header has 2 columns but `datacolumns` says 3",
            ),
            (
                "datacolumns 3\ndatarows 1\ntime\ta\ta\n0\t1\t2\n",
                "x.txt:3: column 3 `a` appears twice",
            ),
            (
                "datacolumns 2\ndatarows 1\ntime\ta\n0\t1\t2\n",
                "x.txt:4: 3 fields, the header has 2",
            ),
            (
                "datacolumns 2\ndatarows 2\ntime\ta\n0\t1\n0.1\tx\n",
                "x.txt:5:2 (a): `x` is not a number",
            ),
            (
                "datacolumns 2\ndatarows 2\ntime\ta\n0\t1\n0.1\tNaN\n",
                "x.txt:5:2 (a): `NaN` is not finite",
            ),
            (
                "datacolumns 2\ndatarows 2\ntime\ta\n0\t1\n0\t1\n",
                "x.txt:5:1 (time): time 0 s does not increase (previous row 0 s)",
            ),
            (
                "datacolumns 2\ndatarows 3\ntime\ta\n0\t1\n0.1\t1\n",
                "x.txt:5: 2 rows, but `datarows` says 3 (file cut short?)",
            ),
            (
                "datacolumns 2\ndatarows 1\ntime\ta\n0\t1\n0.1\t1\n",
                "x.txt:5: more rows than the 1 that `datarows` says",
            ),
        ];
        for (text, msg) in cases {
            let e = parse(text).unwrap_err();
            assert_eq!(&e.to_string(), msg, "input {text:?}");
        }
        let e = parse("datacolumns 2\ndatarows 2\ntime\ta\n0\t1\n0.1\tx\n").unwrap_err();
        assert_eq!((e.line(), e.column()), (Some(5), Some(2)));
    }

    #[test]
    fn a_missing_file_is_named() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("emg.txt");
        let e = read_table(&p).unwrap_err();
        assert_eq!(e.path(), p.as_path());
        assert!(e.to_string().ends_with("emg.txt: no such file"), "{e}");
    }
}
