//! A lab's recordings in: the files an EMG system, a dynamometer or OpenSim writes, read
//! through a recording map into the [`experiment::Trial`] every surae command takes, and the
//! checks a lab needs before trusting a file.
//!
//! * [`parse_delimited`] / [`read_delimited`]: comma / semicolon / tab separated text with
//!   quoted headers, units in the header and decimal commas (the `csv` crate splits the fields);
//! * [`parse_storage`] / [`read_storage`]: OpenSim `.sto` / `.mot` (header versions 1 and 2,
//!   `inDegrees`);
//! * [`c3d`]: a C3D file's analog channels by label (the `c3dio` crate);
//! * [`ceinms`]: a CEINMS trial folder's files, for `surae inspect`;
//! * [`file_kind`] / [`open_table`]: which of these readers a file needs;
//! * [`RecordingMap`]: the recording map, `channel = sign·(scale·raw + offset)`;
//! * [`read_trial_recording`] / [`read_unloaded_recording`]: the mapped channels on one clock
//!   (the EMG's), files joined on time;
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

mod assemble;
pub mod c3d;
pub mod ceinms;
pub mod checks;
mod delimited;
mod error;
pub mod inspect;
mod kind;
mod map;
mod read;
mod storage;
mod table;

pub use assemble::{
    read_trial_recording, read_unloaded_recording, ChannelSource, MappedGeometry, MappedRecording,
};
pub use delimited::{parse_delimited, read_delimited, unit_of_label, DelimitedOptions};
pub use error::{RecordingError, Result};
pub use kind::{file_kind, open_table, FileKind};
pub use map::{parse_map, read_map, ChannelMap, RecordingMap, Target};
pub use storage::{parse_storage, read_storage};
pub use table::{RecordingChannel, RecordingFormat, RecordingTable};
