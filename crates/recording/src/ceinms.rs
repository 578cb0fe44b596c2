//! A CEINMS trial folder (`emg.txt`, `lmt.txt`, `<joint>Ma.txt`, `<joint>Torque.txt`) as
//! recording tables, one per file, for `surae inspect`. Its channels are named by muscle and
//! joint, so it needs no map: `simulate`, `identify` and `diagnose` read it as a session of one
//! (`--trial FOLDER`) or as a session trial's `recording` (`experiment::read_ceinms_trial`).

use std::path::Path;

use crate::error::{RecordingError, Result};
use crate::table::{RecordingChannel, RecordingFormat, RecordingTable};

/// The four files of the folder `dir` for `joint` (`R_ankle_fe` for the right ankle).
///
/// # Errors
/// A missing file or any error of the CEINMS reader, naming the file, line and column.
pub fn read_ceinms_tables(dir: &Path, joint: &str) -> Result<Vec<RecordingTable>> {
    let folder =
        ceinms_files::read_trial_folder(dir, joint).map_err(|e| RecordingError::Reader {
            path: e.path().display().to_string(),
            message: e.to_string(),
        })?;
    Ok([folder.emg, folder.lmt, folder.moment_arm, folder.torque]
        .into_iter()
        .map(|t| {
            let mut channels = vec![RecordingChannel {
                label: "time".into(),
                unit: Some("s".into()),
                values: t.time.clone(),
                rate_hz: None,
            }];
            channels.extend(
                t.names
                    .iter()
                    .zip(&t.columns)
                    .map(|(n, v)| RecordingChannel {
                        label: n.clone(),
                        unit: None,
                        values: v.clone(),
                        rate_hz: None,
                    }),
            );
            RecordingTable {
                path: t.path.clone(),
                format: RecordingFormat::CeinmsFolder,
                time_label: Some("time".into()),
                rate_hz: None,
                start_s: 0.0,
                channels,
                row_lines: Vec::new(),
            }
        })
        .collect())
}
