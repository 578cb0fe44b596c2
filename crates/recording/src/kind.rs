//! Which reader a file needs: a folder, the extension or the first bytes decide.

use std::path::Path;

use crate::c3d;
use crate::delimited::{read_delimited, DelimitedOptions};
use crate::error::{RecordingError, Result};
use crate::storage::read_storage;
use crate::table::RecordingTable;

/// The kinds of file a recording may be.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FileKind {
    /// surae's own trial CSV or any delimited text.
    Delimited,
    /// OpenSim `.sto` / `.mot`.
    Storage,
    /// C3D.
    C3d,
    /// A recording map (`.json`).
    Map,
    /// A CEINMS trial folder.
    CeinmsFolder,
}

/// What kind of file `path` is: a folder is a CEINMS trial folder; otherwise the extension
/// decides (`.c3d`, `.sto`/`.mot`, `.json`), and any other file is sniffed: a C3D's second
/// byte is 0x50, a storage file has an `endheader` line; the rest is delimited text.
#[must_use]
pub fn file_kind(path: &Path) -> FileKind {
    if path.is_dir() {
        return FileKind::CeinmsFolder;
    }
    let ext = path
        .extension()
        .map(|e| e.to_string_lossy().to_ascii_lowercase())
        .unwrap_or_default();
    match ext.as_str() {
        "c3d" => FileKind::C3d,
        "sto" | "mot" => FileKind::Storage,
        "json" => FileKind::Map,
        _ => {
            let Ok(bytes) = std::fs::read(path) else {
                return FileKind::Delimited;
            };
            if bytes.len() >= 512 && bytes[1] == 0x50 {
                FileKind::C3d
            } else if bytes
                .split(|&b| b == b'\n')
                .take(200)
                .any(|l| l.trim_ascii().eq_ignore_ascii_case(b"endheader"))
            {
                FileKind::Storage
            } else {
                FileKind::Delimited
            }
        }
    }
}

/// Reads one data file (not a map, not a folder) with the reader its kind needs.
///
/// # Errors
/// The reader's; a map or a folder given where a data file is expected.
pub fn open_table(path: &Path, opts: &DelimitedOptions) -> Result<RecordingTable> {
    match file_kind(path) {
        FileKind::C3d => c3d::read_c3d(path),
        FileKind::Storage => read_storage(path),
        FileKind::Delimited => read_delimited(path, opts),
        FileKind::Map => Err(RecordingError::file(
            path.display().to_string(),
            "a recording map cannot name another map as its data file",
        )),
        FileKind::CeinmsFolder => Err(RecordingError::file(
            path.display().to_string(),
            "a folder: a CEINMS trial folder is read as a recording itself, without a map",
        )),
    }
}
