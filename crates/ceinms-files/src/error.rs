//! The crate's error type: every variant names the file, and where it can the line and the
//! column (1-based), so that a message points at the place to fix.

use std::path::{Path, PathBuf};

/// Everything that can go wrong reading CEINMS files.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum CeinmsError {
    /// A file could not be read (missing, unreadable, not UTF-8).
    #[error("{}: {reason}", path.display())]
    File {
        /// The file.
        path: PathBuf,
        /// What went wrong.
        reason: String,
    },
    /// A line as a whole is wrong (a missing or malformed `datacolumns` / `datarows` line, a
    /// header without `time`, a row count that disagrees with `datarows`).
    #[error("{}:{line}: {reason}", path.display())]
    Line {
        /// The file.
        path: PathBuf,
        /// 1-based line number.
        line: usize,
        /// What went wrong.
        reason: String,
    },
    /// One cell of a data table is wrong.
    #[error("{}:{line}:{column} ({name}): {reason}", path.display())]
    Cell {
        /// The file.
        path: PathBuf,
        /// 1-based line number.
        line: usize,
        /// 1-based column number.
        column: usize,
        /// The column's header name.
        name: String,
        /// What went wrong.
        reason: String,
    },
    /// A table lacks a column that is needed.
    #[error("{}: no column `{name}`", path.display())]
    MissingColumn {
        /// The file.
        path: PathBuf,
        /// The column looked for.
        name: String,
    },
    /// A subject XML is malformed or lacks an element; line and column of the element (or of
    /// the XML syntax error).
    #[error("{}:{line}:{column} ({key}): {reason}", path.display())]
    Xml {
        /// The file.
        path: PathBuf,
        /// 1-based line number.
        line: u32,
        /// 1-based column number.
        column: u32,
        /// The element (e.g. `mtu sol_r/tendonSlackLength`).
        key: String,
        /// What went wrong.
        reason: String,
    },
}

impl CeinmsError {
    /// The file the error is about.
    pub fn path(&self) -> &Path {
        match self {
            Self::File { path, .. }
            | Self::Line { path, .. }
            | Self::Cell { path, .. }
            | Self::MissingColumn { path, .. }
            | Self::Xml { path, .. } => path,
        }
    }

    /// The 1-based line, when the error has one.
    pub fn line(&self) -> Option<usize> {
        match self {
            Self::Line { line, .. } | Self::Cell { line, .. } => Some(*line),
            Self::Xml { line, .. } => Some(*line as usize),
            Self::File { .. } | Self::MissingColumn { .. } => None,
        }
    }

    /// The 1-based column, when the error has one.
    pub fn column(&self) -> Option<usize> {
        match self {
            Self::Cell { column, .. } => Some(*column),
            Self::Xml { column, .. } => Some(*column as usize),
            _ => None,
        }
    }
}

/// Reads `path` as UTF-8 text, the error naming the file.
pub(crate) fn read_text(path: &Path) -> Result<String, CeinmsError> {
    let bytes = std::fs::read(path).map_err(|e| CeinmsError::File {
        path: path.to_path_buf(),
        reason: if e.kind() == std::io::ErrorKind::NotFound {
            "no such file".to_string()
        } else {
            e.to_string()
        },
    })?;
    String::from_utf8(bytes).map_err(|e| CeinmsError::File {
        path: path.to_path_buf(),
        reason: format!("not UTF-8 text (byte {})", e.utf8_error().valid_up_to()),
    })
}
