//! A CEINMS trial folder: `emg.txt` (normalised EMG envelopes, one column per EMG channel),
//! `lmt.txt` (musculotendon lengths, m), `<joint>Ma.txt` (moment arms about the joint, m, one
//! column per muscle crossing it) and `<joint>Torque.txt` (the joint moment from inverse
//! dynamics, N·m, in a column named after the joint). The joint is `R_ankle_fe` unless said
//! otherwise. The files may be at different rates and start at different times; bringing
//! them to one grid is the caller's choice.

use crate::error::CeinmsError;
use crate::table::{read_table, CeinmsTable};
use std::path::{Path, PathBuf};

/// The joint whose files a trial folder is read for when none is named.
pub const DEFAULT_JOINT: &str = "R_ankle_fe";

/// The four tables of one CEINMS trial folder.
#[derive(Clone, Debug, PartialEq)]
pub struct CeinmsTrialFolder {
    /// The folder.
    pub dir: PathBuf,
    /// The joint (file-name prefix of the moment-arm and torque files).
    pub joint: String,
    /// `emg.txt`.
    pub emg: CeinmsTable,
    /// `lmt.txt`.
    pub lmt: CeinmsTable,
    /// `<joint>Ma.txt`.
    pub moment_arm: CeinmsTable,
    /// `<joint>Torque.txt`.
    pub torque: CeinmsTable,
}

impl CeinmsTrialFolder {
    /// The measured joint moment (the torque file's column named after the joint).
    pub fn joint_moment(&self) -> &[f64] {
        // checked when the folder was read
        self.torque.column(&self.joint).unwrap_or(&[])
    }
}

/// The names of the four files of a trial folder for `joint`, in the order `emg`, `lmt`,
/// moment arm, torque.
pub fn trial_file_names(joint: &str) -> [String; 4] {
    [
        "emg.txt".to_string(),
        "lmt.txt".to_string(),
        format!("{joint}Ma.txt"),
        format!("{joint}Torque.txt"),
    ]
}

/// Reads the trial folder `dir` for `joint` ([`DEFAULT_JOINT`] for the ankle).
///
/// # Errors
/// [`CeinmsError::File`] naming the first of the four files that is missing (the message
/// lists the files a folder needs); any error of [`read_table`]; [`CeinmsError::MissingColumn`]
/// when the torque file has no column named after the joint, or when a muscle of the
/// moment-arm file has no column in `lmt.txt`.
pub fn read_trial_folder(dir: &Path, joint: &str) -> Result<CeinmsTrialFolder, CeinmsError> {
    let names = trial_file_names(joint);
    if !dir.is_dir() {
        return Err(CeinmsError::File {
            path: dir.to_path_buf(),
            reason: "not a folder (a CEINMS trial folder holds emg.txt, lmt.txt, \
                     <joint>Ma.txt and <joint>Torque.txt)"
                .to_string(),
        });
    }
    for n in &names {
        let p = dir.join(n);
        if !p.is_file() {
            return Err(CeinmsError::File {
                path: p,
                reason: format!(
                    "missing: a CEINMS trial folder for joint {joint} needs {}",
                    names.join(", ")
                ),
            });
        }
    }
    let [emg, lmt, ma, torque] = names.map(|n| dir.join(n));
    let folder = CeinmsTrialFolder {
        dir: dir.to_path_buf(),
        joint: joint.to_string(),
        emg: read_table(&emg)?,
        lmt: read_table(&lmt)?,
        moment_arm: read_table(&ma)?,
        torque: read_table(&torque)?,
    };
    folder.torque.require(joint)?;
    for m in &folder.moment_arm.names {
        folder.lmt.require(m)?;
    }
    Ok(folder)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::table::format_table;

    fn write(dir: &Path, name: &str, names: &[&str], time: &[f64], cols: &[&[f64]]) {
        std::fs::write(dir.join(name), format_table(names, time, cols).unwrap()).unwrap();
    }

    fn folder(dir: &Path) {
        let t250 = [0.0, 0.004, 0.008];
        let t2000: Vec<f64> = (0..20).map(|i| -0.002 + i as f64 / 2000.0).collect();
        let e = vec![0.1; 20];
        write(dir, "emg.txt", &["sol_r", "tibant_r"], &t2000, &[&e, &e]);
        let l = [0.3, 0.31, 0.32];
        write(
            dir,
            "lmt.txt",
            &["sol_r", "tibant_r", "vaslat_r"],
            &t250,
            &[&l, &l, &l],
        );
        let r = [-0.04, -0.041, -0.042];
        write(
            dir,
            "R_ankle_feMa.txt",
            &["sol_r", "tibant_r"],
            &t250,
            &[&r, &r],
        );
        write(
            dir,
            "R_ankle_feTorque.txt",
            &["R_ankle_fe"],
            &t250,
            &[&[-10.0, -20.0, -30.0]],
        );
    }

    #[test]
    fn reads_a_folder() {
        let d = tempfile::tempdir().unwrap();
        folder(d.path());
        let f = read_trial_folder(d.path(), DEFAULT_JOINT).unwrap();
        assert_eq!(f.emg.len(), 20);
        assert_eq!(f.moment_arm.names, vec!["sol_r", "tibant_r"]);
        assert_eq!(f.joint_moment(), &[-10.0, -20.0, -30.0]);
    }

    #[test]
    fn a_missing_file_is_named() {
        let d = tempfile::tempdir().unwrap();
        folder(d.path());
        std::fs::remove_file(d.path().join("R_ankle_feMa.txt")).unwrap();
        let e = read_trial_folder(d.path(), DEFAULT_JOINT).unwrap_err();
        assert_eq!(e.path(), d.path().join("R_ankle_feMa.txt"));
        assert!(
            e.to_string().contains("missing: a CEINMS trial folder"),
            "{e}"
        );
        // another joint's files are not there at all
        let e = read_trial_folder(d.path(), "L_knee").unwrap_err();
        assert_eq!(e.path(), d.path().join("L_kneeMa.txt"));
        let e = read_trial_folder(&d.path().join("nope"), DEFAULT_JOINT).unwrap_err();
        assert!(e.to_string().contains("not a folder"), "{e}");
    }

    #[test]
    fn inconsistent_files_are_errors() {
        let d = tempfile::tempdir().unwrap();
        folder(d.path());
        let t = [0.0, 0.004, 0.008];
        write(
            d.path(),
            "R_ankle_feTorque.txt",
            &["L_ankle"],
            &t,
            &[&[1.0, 2.0, 3.0]],
        );
        let e = read_trial_folder(d.path(), DEFAULT_JOINT).unwrap_err();
        assert!(
            e.to_string()
                .ends_with("R_ankle_feTorque.txt: no column `R_ankle_fe`"),
            "{e}"
        );
        folder(d.path());
        let l = [0.3, 0.31, 0.32];
        write(d.path(), "lmt.txt", &["sol_r"], &t, &[&l]);
        let e = read_trial_folder(d.path(), DEFAULT_JOINT).unwrap_err();
        assert!(
            e.to_string().ends_with("lmt.txt: no column `tibant_r`"),
            "{e}"
        );
    }
}
