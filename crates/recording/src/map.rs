//! The recording map: which column of which file is which channel of a trial, and how to
//! turn its numbers into surae's units.
//!
//! ```json
//! {"file": "S01_iso30.tsv",
//!  "rate_hz": 1500,
//!  "channels": {
//!    "ankle_angle_deg": {"column": "CN ANGLE,mV", "scale": 0.1024, "offset": -35.2},
//!    "torque_nm": {"column": "CN TORQUE,mV", "scale": 0.0749, "offset": 0.69, "sign": -1},
//!    "emg_sol": {"column": "LT SOLEUS,uV"},
//!    "emg_gm": {"column": "LT MED. GASTRO,uV"},
//!    "emg_gl": {"column": "LT LAT. GASTRO,uV"}},
//!  "emg_is_envelope": false}
//! ```
//!
//! Each channel is `sign·(scale·raw + offset)` (defaults 1, 0, 1), computed in that order so
//! that the defaults carry a number bit for bit. Targets are `time_s`, `ankle_angle_deg`,
//! `torque_nm`, `knee_angle_deg`, `emg_<muscle>` (sol, gm, gl required; ta and any further
//! muscle optional), `grf_vertical_n` (the tested foot's vertical ground reaction force, for
//! gait trials) and the geometry series `lmt_<muscle>_m` / `ma_<muscle>_m` (a pair per
//! muscle). A channel may name its own `file`; `rate_hz` (the map's or a channel's) gives the
//! clock of a file without a time column. Paths are relative to the map's folder.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use crate::error::{RecordingError, Result};

/// One channel of a map: where its numbers are and how to convert them.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ChannelMap {
    /// The file it is read from, relative to the map (the map's `file` when absent).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub file: Option<String>,
    /// The column's label in that file, exactly as the file writes it (without quotes).
    pub column: String,
    /// Multiplies the raw number (default 1).
    #[serde(default = "one", skip_serializing_if = "is_one")]
    pub scale: f64,
    /// Added after scaling (default 0), in the channel's unit.
    #[serde(default, skip_serializing_if = "is_zero")]
    pub offset: f64,
    /// `1` or `-1` (default 1): flips the channel after scale and offset (a left leg, OpenSim's
    /// moment sign).
    #[serde(default = "one", skip_serializing_if = "is_one")]
    pub sign: f64,
    /// This channel's own sampling rate when its file has no time column and it is not at the
    /// map's `rate_hz`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub rate_hz: Option<f64>,
}

fn one() -> f64 {
    1.0
}
#[allow(clippy::trivially_copy_pass_by_ref, clippy::float_cmp)]
fn is_one(x: &f64) -> bool {
    *x == 1.0
}
#[allow(clippy::trivially_copy_pass_by_ref)]
fn is_zero(x: &f64) -> bool {
    *x == 0.0
}

impl ChannelMap {
    /// A channel read as it is from `column`.
    #[must_use]
    pub fn column(column: &str) -> Self {
        Self {
            file: None,
            column: column.to_string(),
            scale: 1.0,
            offset: 0.0,
            sign: 1.0,
            rate_hz: None,
        }
    }

    /// `sign·(scale·raw + offset)`.
    #[must_use]
    pub fn apply(&self, raw: f64) -> f64 {
        self.sign * (self.scale * raw + self.offset)
    }
}

/// A recording map (module documentation).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RecordingMap {
    /// Free text for the reader of the map (ignored): a string or a list of strings.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub comment: Option<serde_json::Value>,
    /// The file the channels are read from unless they name their own.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub file: Option<String>,
    /// Sampling rate of files without a time column (Hz).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub rate_hz: Option<f64>,
    /// The 1-based line of a delimited file's header, when the export writes a preamble.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub header_line: Option<usize>,
    /// Whether a delimited file writes numbers with a decimal comma (found by itself when
    /// absent).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub decimal_comma: Option<bool>,
    /// Target channel → where it is.
    pub channels: BTreeMap<String, ChannelMap>,
    /// The EMG channels are normalised envelopes already (skip the EMG filtering).
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub emg_is_envelope: bool,
    /// The map's own file (set by [`read_map`]; paths are relative to its folder).
    #[serde(skip)]
    pub path: PathBuf,
}

/// What a target channel is.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Target {
    /// `time_s`.
    Time,
    /// `ankle_angle_deg`.
    Angle,
    /// `torque_nm`.
    Torque,
    /// `knee_angle_deg`.
    Knee,
    /// `grf_vertical_n`: the tested foot's vertical ground reaction force (N).
    VerticalForce,
    /// `emg_<muscle>`.
    Emg(String),
    /// `lmt_<muscle>_m`.
    Length(String),
    /// `ma_<muscle>_m`.
    MomentArm(String),
}

/// A muscle name in a target: a lower-case letter, then lower-case letters, digits and `_`.
fn is_muscle_name(s: &str) -> bool {
    let mut chars = s.chars();
    chars.next().is_some_and(|c| c.is_ascii_lowercase())
        && chars.all(|c| c.is_ascii_lowercase() || c.is_ascii_digit() || c == '_')
}

impl Target {
    /// Parses a target name.
    ///
    /// # Errors
    /// A name that is not one of the targets (the message lists them).
    pub fn parse(name: &str) -> std::result::Result<Self, String> {
        let muscle = |m: &str| is_muscle_name(m).then(|| m.to_string());
        let t = match name {
            "time_s" => Some(Self::Time),
            "ankle_angle_deg" => Some(Self::Angle),
            "torque_nm" => Some(Self::Torque),
            "knee_angle_deg" => Some(Self::Knee),
            "grf_vertical_n" => Some(Self::VerticalForce),
            _ => name
                .strip_prefix("emg_")
                .and_then(muscle)
                .map(Self::Emg)
                .or_else(|| {
                    name.strip_prefix("lmt_")
                        .and_then(|s| s.strip_suffix("_m"))
                        .and_then(muscle)
                        .map(Self::Length)
                })
                .or_else(|| {
                    name.strip_prefix("ma_")
                        .and_then(|s| s.strip_suffix("_m"))
                        .and_then(muscle)
                        .map(Self::MomentArm)
                }),
        };
        t.ok_or_else(|| {
            "not a channel of a trial: expected time_s, ankle_angle_deg, torque_nm, \
             knee_angle_deg, grf_vertical_n, emg_<muscle>, lmt_<muscle>_m or ma_<muscle>_m"
                .to_string()
        })
    }

    /// Whether the target is an angle in degrees (converted from radians when it is read from
    /// an OpenSim file with `inDegrees=no`).
    #[must_use]
    pub fn is_degrees(&self) -> bool {
        matches!(self, Self::Angle | Self::Knee)
    }
}

impl RecordingMap {
    /// The folder paths are relative to.
    #[must_use]
    pub fn base_dir(&self) -> PathBuf {
        self.path
            .parent()
            .map_or_else(|| PathBuf::from("."), Path::to_path_buf)
    }

    /// The file a channel is read from, resolved against the map's folder.
    ///
    /// # Errors
    /// A channel with no `file` in a map with none.
    pub fn file_of(&self, target: &str, ch: &ChannelMap) -> Result<PathBuf> {
        let rel = ch.file.as_ref().or(self.file.as_ref()).ok_or_else(|| {
            self.key_error(
                &format!("channels.{target}"),
                "no file: give the map a \"file\" or the channel its own",
            )
        })?;
        Ok(self.base_dir().join(rel))
    }

    /// The map's name for messages.
    #[must_use]
    pub fn name(&self) -> String {
        self.path.display().to_string()
    }

    /// An error about `key`; control characters in the key and the reason (a key, a column
    /// label with a line break) are escaped so that the message stays on one line.
    pub(crate) fn key_error(&self, key: &str, reason: impl Into<String>) -> RecordingError {
        RecordingError::Map {
            path: self.name(),
            key: crate::read::printable(key),
            reason: crate::read::printable(&reason.into()),
        }
    }

    /// Checks the map's values: known targets, finite scales and offsets, signs of ±1,
    /// positive rates.
    ///
    /// # Errors
    /// The first bad key, named as a JSON path (`channels.torque_nm.sign`).
    pub fn validate(&self) -> Result<()> {
        if self.channels.is_empty() {
            return Err(self.key_error("channels", "empty: map at least the trial's channels"));
        }
        let rate_ok = |r: Option<f64>| r.is_none_or(|r| r.is_finite() && r > 0.0);
        if !rate_ok(self.rate_hz) {
            return Err(self.key_error("rate_hz", "must be a positive number of Hz"));
        }
        if self.header_line == Some(0) {
            return Err(self.key_error("header_line", "lines count from 1"));
        }
        for (target, ch) in &self.channels {
            let key = |k: &str| format!("channels.{target}.{k}");
            Target::parse(target).map_err(|r| self.key_error(&format!("channels.{target}"), r))?;
            if ch.column.trim().is_empty() {
                return Err(self.key_error(&key("column"), "empty column label"));
            }
            if !ch.scale.is_finite() || ch.scale == 0.0 {
                return Err(self.key_error(&key("scale"), "must be a finite non-zero number"));
            }
            if !ch.offset.is_finite() {
                return Err(self.key_error(&key("offset"), "must be a finite number"));
            }
            #[allow(clippy::float_cmp)]
            if ch.sign != 1.0 && ch.sign != -1.0 {
                return Err(self.key_error(&key("sign"), "must be 1 or -1"));
            }
            if !rate_ok(ch.rate_hz) {
                return Err(self.key_error(&key("rate_hz"), "must be a positive number of Hz"));
            }
        }
        Ok(())
    }

    /// The map as pretty JSON text (what `surae inspect` writes).
    #[must_use]
    pub fn to_json_text(&self) -> String {
        let mut s = serde_json::to_string_pretty(self).unwrap_or_default();
        s.push('\n');
        s
    }
}

/// Parses a map's JSON text; `path` is where it lives (paths in it are relative to its
/// folder).
///
/// # Errors
/// Invalid JSON or an unknown key (with line and column), or a bad value
/// ([`RecordingMap::validate`]).
pub fn parse_map(text: &str, path: &Path) -> Result<RecordingMap> {
    let name = path.display().to_string();
    let mut map: RecordingMap = serde_json::from_str(text).map_err(|e| RecordingError::Line {
        path: name.clone(),
        line: e.line(),
        reason: crate::read::printable(&format!("column {}: not a recording map: {e}", e.column())),
    })?;
    map.path = path.to_path_buf();
    map.validate()?;
    Ok(map)
}

/// Reads a recording map.
///
/// # Errors
/// An unreadable file and every error of [`parse_map`].
pub fn read_map(path: &Path) -> Result<RecordingMap> {
    let bytes = crate::read::read_bytes(path)?;
    let text = std::str::from_utf8(&bytes)
        .map_err(|_| RecordingError::file(path.display().to_string(), "not UTF-8 text"))?;
    parse_map(text, path)
}
