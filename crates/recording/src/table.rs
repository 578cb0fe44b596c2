//! What every reader returns: a [`RecordingTable`], the labelled channels of one file on one
//! clock, before any map is applied.

use std::path::PathBuf;

use serde::Serialize;

/// Which reader a file went through, and what it said about the file.
#[derive(Clone, Debug, PartialEq, Serialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum RecordingFormat {
    /// Delimited text: comma, semicolon or tab separated.
    Delimited {
        /// The field delimiter (`,`, `;` or a tab).
        delimiter: char,
        /// Whether numbers are written with a decimal comma (`0,5`).
        decimal_comma: bool,
    },
    /// An OpenSim storage file (`.sto`, `.mot`).
    Storage {
        /// Header version (1 or 2).
        version: u32,
        /// `inDegrees` of the header, when it has one.
        in_degrees: Option<bool>,
        /// The table's name, the header's first line without `=` (`Normalized EMG Linear
        /// Envelopes`), when it has one: `surae inspect` reads what the file says it holds.
        #[serde(skip_serializing_if = "Option::is_none")]
        title: Option<String>,
    },
    /// A C3D file's analog channels.
    C3d,
    /// A CEINMS trial folder.
    CeinmsFolder,
}

impl RecordingFormat {
    /// A short name for summaries (`delimited text (tab)`, `OpenSim storage v2`, `C3D`, …).
    #[must_use]
    pub fn describe(&self) -> String {
        match self {
            Self::Delimited {
                delimiter,
                decimal_comma,
            } => {
                let d = match delimiter {
                    '\t' => "tab".to_string(),
                    c => format!("'{c}'"),
                };
                if *decimal_comma {
                    format!("delimited text ({d}, decimal comma)")
                } else {
                    format!("delimited text ({d})")
                }
            }
            Self::Storage {
                version,
                in_degrees,
                ..
            } => match in_degrees {
                Some(true) => format!("OpenSim storage v{version}, inDegrees=yes"),
                Some(false) => format!("OpenSim storage v{version}, inDegrees=no"),
                None => format!("OpenSim storage v{version}"),
            },
            Self::C3d => "C3D analog channels".into(),
            Self::CeinmsFolder => "CEINMS trial folder".into(),
        }
    }
}

/// One labelled channel of a file.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct RecordingChannel {
    /// The label as the file writes it (a delimited header's cell without its quotes, an
    /// OpenSim column label, a C3D analog label with trailing blanks removed).
    pub label: String,
    /// Its unit when the file states one (a C3D `ANALOG:UNITS` entry, a header's `,mV`,
    /// `[Nm]` or `(deg)` suffix), else `None`.
    pub unit: Option<String>,
    /// Its samples, in the file's unit after the file's own scaling (a C3D's scale and offset).
    pub values: Vec<f64>,
    /// Where its samples are on the file's clock: `None` for every channel of a text or
    /// storage file (one row a sample); for a C3D, its own rate when it is not the file's.
    pub rate_hz: Option<f64>,
}

/// The channels of one file and its clock.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct RecordingTable {
    /// The file (a folder for CEINMS).
    pub path: PathBuf,
    /// The reader and what it found.
    pub format: RecordingFormat,
    /// The label of the time column, when the file has one (`time` in OpenSim files, a
    /// `time`/`Time,s`/`time_s` column of a text export); it is among `channels`.
    pub time_label: Option<String>,
    /// The sampling rate the file states (a C3D's analog rate), when it states one.
    pub rate_hz: Option<f64>,
    /// Time of the first sample when the file states it without a time column (a C3D's first
    /// frame), in seconds.
    pub start_s: f64,
    /// The channels in file order.
    pub channels: Vec<RecordingChannel>,
    /// For a text file, the 1-based line of each row (messages name the line of a bad
    /// sample); empty for a binary file.
    #[serde(skip)]
    pub row_lines: Vec<usize>,
}

impl RecordingTable {
    /// The channel labelled `label` (exact match).
    #[must_use]
    pub fn channel(&self, label: &str) -> Option<&RecordingChannel> {
        self.channels.iter().find(|c| c.label == label)
    }

    /// Number of rows (the longest channel's length).
    #[must_use]
    pub fn rows(&self) -> usize {
        self.channels
            .iter()
            .map(|c| c.values.len())
            .max()
            .unwrap_or(0)
    }

    /// Where sample `i` is, for messages: `line L` in a text file, `sample i` elsewhere.
    #[must_use]
    pub fn locate(&self, i: usize) -> String {
        match self.row_lines.get(i) {
            Some(l) => format!("line {l}"),
            None => format!("sample {}", i + 1),
        }
    }

    /// The file's name for messages.
    #[must_use]
    pub fn name(&self) -> String {
        self.path.display().to_string()
    }
}

/// Paths a reader names in its messages.
pub(crate) fn display(path: &std::path::Path) -> String {
    PathBuf::from(path).display().to_string()
}
