//! A lab's recordings in: the files an EMG system, a dynamometer or OpenSim writes, read
//! through a recording map into the [`experiment::Trial`] every surae command takes, and the
//! checks a lab needs before trusting a file.
//!
//! * [`delimited`]: comma / semicolon / tab separated text with quoted headers, units in the
//!   header and decimal commas (the `csv` crate splits the fields);
//! * [`storage`]: OpenSim `.sto` / `.mot` (header versions 1 and 2, `inDegrees`);
//! * [`c3d`]: a C3D file's analog channels by label (the `c3dio` crate);
//! * [`ceinms`]: a CEINMS trial folder's files, for `surae inspect`;
//! * [`map`]: the recording map, `channel = sign·(scale·raw + offset)`;
//! * [`assemble`]: the mapped channels on one clock (the EMG's), files joined on time;
//! * [`inspect`]: what a file holds and a starter map for it;
//! * [`checks`]: angle range and velocity plateaus, saturation, flat or power-line EMG, a
//!   flipped torque.
//!
//! ```
//! use recording::{parse_map, read_trial_recording};
//! # let dir = tempfile::tempdir()?;
//! let rows: String = (0..2048)
//!     .map(|i| {
//!         let t = i as f64 / 1024.0;
//!         format!("{t};{};{};{};{};{}\n", 15.0 - t, 2.0 * t, 0.01 + t, 0.02, -0.01)
//!             .replace('.', ",")
//!     })
//!     .collect();
//! std::fs::write(
//!     dir.path().join("export.csv"),
//!     format!("\"Time,s\";\"ANGLE,deg\";\"TORQUE,mV\";SOL;MG;LG\n{rows}"),
//! )?;
//! let map_path = dir.path().join("map.json");
//! let map = parse_map(
//!     r#"{"file": "export.csv", "channels": {
//!         "ankle_angle_deg": {"column": "ANGLE,deg"},
//!         "torque_nm": {"column": "TORQUE,mV", "scale": 0.0749, "sign": -1},
//!         "emg_sol": {"column": "SOL"}, "emg_gm": {"column": "MG"}, "emg_gl": {"column": "LG"}}}"#,
//!     &map_path,
//! )?;
//! let rec = read_trial_recording(&map)?;
//! assert_eq!(rec.trial.len(), 2048);
//! assert_eq!(rec.trial.time_s[1], 1.0 / 1024.0);
//! assert_eq!(rec.trial.torque_nm[1024], -(0.0749 * 2.0));
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

pub mod assemble;
pub mod c3d;
pub mod ceinms;
pub mod checks;
pub mod delimited;
pub mod error;
pub mod inspect;
pub mod map;
pub mod storage;
pub mod table;

use std::path::Path;

pub use assemble::{
    read_trial_recording, read_unloaded_recording, ChannelSource, MappedGeometry, MappedRecording,
};
pub use delimited::{parse_delimited, read_delimited, DelimitedOptions};
pub use error::{RecordingError, Result};
pub use map::{parse_map, read_map, ChannelMap, RecordingMap, Target};
pub use storage::{parse_storage, read_storage};
pub use table::{RecordingChannel, RecordingFormat, RecordingTable};

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

/// `text` with every control character written as its escape (`\n`, `\r`, `\u{0}`), so that
/// a label, a key or a cell quoted in a message keeps the message on one line.
pub(crate) fn printable(text: &str) -> String {
    if !text.chars().any(char::is_control) {
        return text.to_string();
    }
    text.chars()
        .map(|c| {
            if c.is_control() {
                c.escape_default().to_string()
            } else {
                c.to_string()
            }
        })
        .collect()
}

/// The bytes of a file; a missing file, a folder or a read failure is an error naming it.
pub(crate) fn read_bytes(path: &Path) -> Result<Vec<u8>> {
    std::fs::read(path).map_err(|e| {
        let reason = match e.kind() {
            std::io::ErrorKind::NotFound => "no such file".to_string(),
            _ if path.is_dir() => "is a folder, not a file".to_string(),
            _ => format!("cannot read: {e}"),
        };
        RecordingError::file(path.display().to_string(), reason)
    })
}
