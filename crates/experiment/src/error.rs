//! The crate's single error type, [`ExperimentError`], and its machine-readable [`ErrorKind`].

use serde::{Deserialize, Serialize};

/// What went wrong, independent of where (for programs and tests that branch on it).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum ErrorKind {
    /// The path does not exist.
    NotFound,
    /// Any other operating-system error while reading or writing.
    Io,
    /// The bytes are not valid UTF-8.
    InvalidUtf8,
    /// Control characters (binary data) in the text.
    Binary,
    /// No header: the file is empty or holds only comments and blank lines.
    Empty,
    /// A header but no data rows.
    HeaderOnly,
    /// A required column is absent.
    MissingColumn,
    /// A column name appears twice.
    DuplicateColumn,
    /// A column name that looks like a known one but is spelled differently (case, dashes, spaces).
    MisspelledColumn,
    /// An empty column name in the header.
    EmptyColumnName,
    /// The header is separated by `;` or tabs instead of commas.
    WrongDelimiter,
    /// A row with too few or too many fields.
    FieldCount,
    /// A cell that is empty.
    EmptyCell,
    /// A cell that is not a number.
    NotANumber,
    /// A cell that parses to NaN or ±infinity.
    NotFinite,
    /// A value outside the physically possible range (an angle beyond the joint's range).
    OutOfRange,
    /// Time equal to or smaller than the previous sample's.
    TimeNotIncreasing,
    /// A step in time much larger than the sampling interval (missing samples).
    TimeGap,
    /// A step in time that differs from the sampling interval by more than the tolerance.
    NonUniformTime,
    /// Less than the minimum duration of data.
    TooShort,
    /// An EMG channel whose samples are all zero.
    ZeroChannel,
    /// Columns of different lengths (in-memory data only).
    LengthMismatch,
    /// A protocol string that cannot be parsed.
    InvalidProtocol,
    /// Settings out of their valid range.
    InvalidSettings,
    /// Two sources of one quantity disagree (a trial's knee-angle column and a constant knee
    /// angle given with it).
    Conflict,
}

/// Every error of this crate. `Display` is always one line:
/// `file`, `file:line`, or `file:line:column (name)`, then the reason.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum ExperimentError {
    /// A problem with the file as a whole (missing, unreadable, empty, too short).
    #[error("{path}: {reason}")]
    File {
        /// The file (as given by the caller).
        path: String,
        /// What went wrong.
        kind: ErrorKind,
        /// Human-readable reason.
        reason: String,
    },
    /// A problem with one physical line (1-based, comment lines counted).
    #[error("{path}:{line}: {reason}")]
    Line {
        /// The file.
        path: String,
        /// 1-based physical line.
        line: usize,
        /// What went wrong.
        kind: ErrorKind,
        /// Human-readable reason.
        reason: String,
    },
    /// A problem with one cell: 1-based line, 1-based field index and the column's name.
    #[error("{path}:{line}:{column} ({name}): {reason}")]
    Cell {
        /// The file.
        path: String,
        /// 1-based physical line.
        line: usize,
        /// 1-based field index.
        column: usize,
        /// Column name from the header.
        name: String,
        /// What went wrong.
        kind: ErrorKind,
        /// Human-readable reason.
        reason: String,
    },
    /// A problem with a whole column (e.g. an EMG channel that is all zeros).
    #[error("{path}: column {column} ({name}): {reason}")]
    Column {
        /// The file.
        path: String,
        /// 1-based field index.
        column: usize,
        /// Column name.
        name: String,
        /// What went wrong.
        kind: ErrorKind,
        /// Human-readable reason.
        reason: String,
    },
    /// An invalid argument that is not a file (protocol string, settings).
    #[error("invalid {what}: {reason}")]
    Invalid {
        /// What was invalid (e.g. `protocol`, `dynamometer settings`).
        what: String,
        /// What went wrong.
        kind: ErrorKind,
        /// Human-readable reason.
        reason: String,
    },
}

impl ExperimentError {
    /// The machine-readable kind.
    #[must_use]
    pub fn kind(&self) -> ErrorKind {
        match self {
            Self::File { kind, .. }
            | Self::Line { kind, .. }
            | Self::Cell { kind, .. }
            | Self::Column { kind, .. }
            | Self::Invalid { kind, .. } => *kind,
        }
    }

    /// The 1-based physical line, when the error has one.
    #[must_use]
    pub fn line(&self) -> Option<usize> {
        match self {
            Self::Line { line, .. } | Self::Cell { line, .. } => Some(*line),
            _ => None,
        }
    }

    /// The 1-based column index, when the error has one.
    #[must_use]
    pub fn column(&self) -> Option<usize> {
        match self {
            Self::Cell { column, .. } | Self::Column { column, .. } => Some(*column),
            _ => None,
        }
    }

    /// The file the error is about, when there is one.
    #[must_use]
    pub fn path(&self) -> Option<&str> {
        match self {
            Self::File { path, .. }
            | Self::Line { path, .. }
            | Self::Cell { path, .. }
            | Self::Column { path, .. } => Some(path),
            Self::Invalid { .. } => None,
        }
    }

    pub(crate) fn invalid(what: &str, kind: ErrorKind, reason: impl Into<String>) -> Self {
        Self::Invalid {
            what: what.to_string(),
            kind,
            reason: reason.into(),
        }
    }
}

/// Shorthand for this crate's results.
pub type Result<T> = std::result::Result<T, ExperimentError>;
