//! Readers for CEINMS's file formats, into plain structs (no model types): the data files of
//! a trial folder ([`table`]), the folder itself ([`trial`]) and the subject XML
//! ([`subject`]). Every error is one [`CeinmsError`] naming the file and, where it can, the
//! line and column or the XML element.
//!
//! How CEINMS drives a muscle that has no EMG channel of its own is set in its excitation
//! generator XML, per muscle: `operation="assign"` copies one recorded channel, and other
//! muscles are left without excitation (`operation="nil"`). CEINMS's own test set-up for
//! this subject's 16 channels and 34 muscles (`TestCfg/emgGenerator/emgGenerator-16To34.xml`
//! in github.com/CEINMS/CEINMS) assigns the `perlong_r` channel to `perbrev_r` and
//! `perter_r` as well as to `perlong_r`; [`emg_channel_for`] gives that mapping.
//!
//! ```
//! use ceinms_files::{format_table, parse_table};
//! use std::path::Path;
//! let text = format_table(&["sol_r"], &[0.0, 0.004], &[&[-0.042, -0.043]])?;
//! let t = parse_table(&text, Path::new("R_ankle_feMa.txt"))?;
//! assert_eq!(t.column("sol_r"), Some(&[-0.042, -0.043][..]));
//! # Ok::<(), ceinms_files::CeinmsError>(())
//! ```

mod error;
pub mod subject;
pub mod table;
pub mod trial;

pub use error::CeinmsError;
pub use subject::{parse_subject, read_subject, CeinmsMtu, CeinmsSubject, SubjectFormat};
pub use table::{format_table, parse_table, read_table, CeinmsTable};
pub use trial::{read_trial_folder, trial_file_names, CeinmsTrialFolder, DEFAULT_JOINT};

/// The EMG channel that drives muscle `muscle` when the EMG file has no channel of its own
/// name: the peroneus brevis and tertius take the peroneus longus's (`perlong_r`, likewise
/// for `_l`), as CEINMS's test excitation generator does; every other muscle its own name.
pub fn emg_channel_for(muscle: &str) -> String {
    for side in ["_r", "_l"] {
        if muscle == format!("perbrev{side}") || muscle == format!("perter{side}") {
            return format!("perlong{side}");
        }
    }
    muscle.to_string()
}

#[cfg(test)]
mod tests {
    #[test]
    fn peronei_share_the_longus_channel() {
        assert_eq!(super::emg_channel_for("perbrev_r"), "perlong_r");
        assert_eq!(super::emg_channel_for("perter_l"), "perlong_l");
        assert_eq!(super::emg_channel_for("tibant_r"), "tibant_r");
        assert_eq!(super::emg_channel_for("perlong_r"), "perlong_r");
    }
}
