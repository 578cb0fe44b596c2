//! The crate's single error type, [`RecordingError`]: every message is one line that names the
//! file and, where it applies, the line, the column (by number and by name) or the map's key.

/// What can go wrong reading a recording or its map.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum RecordingError {
    /// The whole file (missing, unreadable, not the format it claims, too short).
    #[error("{path}: {reason}")]
    File {
        /// The file, as given.
        path: String,
        /// Why.
        reason: String,
    },
    /// A line of a text file.
    #[error("{path}:{line}: {reason}")]
    Line {
        /// The file.
        path: String,
        /// 1-based line.
        line: usize,
        /// Why.
        reason: String,
    },
    /// One cell of a text file.
    #[error("{path}:{line}:{column} ({name}): {reason}")]
    Cell {
        /// The file.
        path: String,
        /// 1-based line.
        line: usize,
        /// 1-based field.
        column: usize,
        /// The column's label.
        name: String,
        /// Why.
        reason: String,
    },
    /// A whole column or channel (missing, all NaN, flat, wrong length).
    #[error("{path}: column '{name}': {reason}")]
    Column {
        /// The file.
        path: String,
        /// The column's label as the file or the map names it.
        name: String,
        /// Why.
        reason: String,
    },
    /// An error of a reader underneath (OpenSim's, CEINMS's), whose message already names the
    /// file, line and column.
    #[error("{message}")]
    Reader {
        /// The file.
        path: String,
        /// The reader's one-line message.
        message: String,
    },
    /// A key of a recording map.
    #[error("{path}: {key}: {reason}")]
    Map {
        /// The map file.
        path: String,
        /// The key, as a path into the JSON (`channels.torque_nm.scale`).
        key: String,
        /// Why.
        reason: String,
    },
}

impl RecordingError {
    /// The file the error is about.
    #[must_use]
    pub fn path(&self) -> &str {
        match self {
            Self::File { path, .. }
            | Self::Line { path, .. }
            | Self::Cell { path, .. }
            | Self::Column { path, .. }
            | Self::Reader { path, .. }
            | Self::Map { path, .. } => path,
        }
    }

    pub(crate) fn file(path: impl Into<String>, reason: impl Into<String>) -> Self {
        Self::File {
            path: path.into(),
            reason: reason.into(),
        }
    }

    pub(crate) fn column(
        path: impl Into<String>,
        name: impl Into<String>,
        reason: impl Into<String>,
    ) -> Self {
        Self::Column {
            path: path.into(),
            name: name.into(),
            reason: reason.into(),
        }
    }
}

/// The crate's result type.
pub type Result<T, E = RecordingError> = std::result::Result<T, E>;
