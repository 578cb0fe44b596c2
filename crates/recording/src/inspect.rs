//! `surae inspect`: what a file holds (format, channels, rate, duration, ranges) and a starter
//! recording map for it, the first thing a user runs on a new file.
//!
//! The starter map assigns a column to a channel of the trial by its label:
//! exact surae names first (`ankle_angle_deg`, `emg_sol`, …), then common export names,
//! case-insensitive: a label with `ankle` and `angle`, or `angle` without `knee`, is the ankle
//! angle (`knee` and `angle`: the knee angle); `torque` or `moment` is the torque (an OpenSim
//! `*_moment` column gets `sign: -1`, OpenSim's moment being positive towards dorsiflexion);
//! `sol` is the soleus, `gastro`/`gas`/`gm`/`gl` with `med`/`lat` the gastrocnemii, `tib`
//! the tibialis anterior. When a label names a side (`LT`/`RT`, `left`/`right`, `_l`/`_r`), the
//! first side found is taken and the others are listed. A channel in volts or millivolts gets
//! scale 1 and a note: its calibration (N·m or degrees per mV) is the lab's to fill in.

use std::collections::BTreeMap;
use std::path::{Component, Path, PathBuf};

use serde::Serialize;

use crate::error::Result;
use crate::map::{ChannelMap, RecordingMap};
use crate::table::{RecordingFormat, RecordingTable};

/// One channel's summary.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct ChannelSummary {
    /// Its label.
    pub label: String,
    /// Its unit, when the file states one.
    pub unit: Option<String>,
    /// Smallest finite value.
    pub min: f64,
    /// Largest finite value.
    pub max: f64,
    /// Missing samples (NaN).
    pub missing: usize,
}

/// One file's summary.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct FileSummary {
    /// The file.
    pub path: String,
    /// How it was read.
    pub format: RecordingFormat,
    /// Rows (samples of the longest channel).
    pub rows: usize,
    /// Sampling rate (Hz) from the time column or the file's stated rate, when known.
    pub rate_hz: Option<f64>,
    /// `t_last − t_first` (s), when the rate is known.
    pub duration_s: Option<f64>,
    /// The time column, when it has one.
    pub time_column: Option<String>,
    /// Its channels in file order.
    pub channels: Vec<ChannelSummary>,
}

impl FileSummary {
    /// Summarises a table.
    #[must_use]
    pub fn of(table: &RecordingTable) -> Self {
        let (rate_hz, duration_s) = match (&table.time_label, table.rate_hz) {
            (Some(l), _) => table.channel(l).map_or((None, None), |c| {
                let t = &c.values;
                if t.len() >= 2 {
                    let d = t[t.len() - 1] - t[0];
                    (Some((t.len() - 1) as f64 / d), Some(d))
                } else {
                    (None, None)
                }
            }),
            (None, Some(r)) => (Some(r), Some(table.rows().saturating_sub(1) as f64 / r)),
            (None, None) => (None, None),
        };
        let channels = table
            .channels
            .iter()
            .map(|c| {
                let finite = c.values.iter().copied().filter(|x| x.is_finite());
                let (min, max) = finite.fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), x| {
                    (a.min(x), b.max(x))
                });
                ChannelSummary {
                    label: c.label.clone(),
                    unit: c.unit.clone(),
                    min,
                    max,
                    missing: c.values.iter().filter(|x| x.is_nan()).count(),
                }
            })
            .collect();
        Self {
            path: table.name(),
            format: table.format.clone(),
            rows: table.rows(),
            rate_hz,
            duration_s,
            time_column: table.time_label.clone(),
            channels,
        }
    }

    /// Lines for a terminal: the file, its format, rate and duration, then a line per channel.
    #[must_use]
    pub fn lines(&self) -> Vec<String> {
        let mut out = vec![format!(
            "{}: {}, {} rows{}{}",
            self.path,
            self.format.describe(),
            self.rows,
            self.rate_hz
                .map(|r| format!(", {r:.3} Hz"))
                .unwrap_or_else(|| ", no clock (give rate_hz in the map)".into()),
            self.duration_s
                .map(|d| format!(", {d:.3} s"))
                .unwrap_or_default()
        )];
        for (j, c) in self.channels.iter().enumerate() {
            let unit = c
                .unit
                .as_deref()
                .map(|u| format!(" [{u}]"))
                .unwrap_or_default();
            let missing = if c.missing > 0 {
                format!(", {} missing", c.missing)
            } else {
                String::new()
            };
            let time = if self.time_column.as_deref() == Some(c.label.as_str()) {
                "  (time)"
            } else {
                ""
            };
            out.push(format!(
                "  {:>3}  {:<28}{unit}  {} … {}{missing}{time}",
                j + 1,
                format!("'{}'", c.label),
                short(c.min),
                short(c.max)
            ));
        }
        out
    }
}

fn short(x: f64) -> String {
    if !x.is_finite() {
        return "—".into();
    }
    let a = x.abs();
    if a != 0.0 && !(1e-3..1e6).contains(&a) {
        format!("{x:.4e}")
    } else {
        format!("{x:.4}")
    }
}

/// What `surae inspect` found: a summary per file and a starter map.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Inspection {
    /// One summary per file.
    pub files: Vec<FileSummary>,
    /// The starter map (`None` for a CEINMS folder, which needs none).
    pub map: Option<RecordingMap>,
    /// Channels of a trial that no column was found for.
    pub unassigned: Vec<String>,
    /// What to check before using the map.
    pub notes: Vec<String>,
}

/// Words of a label, lower case, split at anything that is not a letter or digit.
fn words(label: &str) -> Vec<String> {
    label
        .to_ascii_lowercase()
        .split(|c: char| !c.is_ascii_alphanumeric())
        .filter(|w| !w.is_empty())
        .map(str::to_string)
        .collect()
}

/// The side a label names, if any (`l` or `r`).
fn side_of(label: &str) -> Option<char> {
    let w = words(label);
    let has = |s: &str| w.iter().any(|x| x == s);
    if has("lt") || has("left") || has("l") || label.ends_with("_l") {
        Some('l')
    } else if has("rt") || has("right") || has("r") || label.ends_with("_r") {
        Some('r')
    } else {
        None
    }
}

/// The trial channel a label suggests.
fn guess(label: &str, format: &RecordingFormat) -> Option<(String, f64)> {
    let l = label.trim();
    if crate::map::Target::parse(l).is_ok() {
        return Some((l.to_string(), 1.0));
    }
    let w = words(l);
    let low = l.to_ascii_lowercase();
    let has = |s: &str| w.iter().any(|x| x == s);
    let any = |s: &str| w.iter().any(|x| x.contains(s));
    let storage = matches!(format, RecordingFormat::Storage { .. });
    if any("velocity") || any("direction") || has("vel") || has("dir") {
        return None;
    }
    if has("knee") && (any("angle") || any("flex")) {
        return Some(("knee_angle_deg".into(), 1.0));
    }
    if any("torque") || any("moment") {
        let sign = if storage && low.ends_with("_moment") {
            -1.0
        } else {
            1.0
        };
        return Some(("torque_nm".into(), sign));
    }
    if (has("ankle") && any("angle")) || (any("angle") && !has("knee") && !has("hip")) {
        return Some(("ankle_angle_deg".into(), 1.0));
    }
    if any("sol") {
        return Some(("emg_sol".into(), 1.0));
    }
    let gastro = any("gastro") || any("gas") || has("gm") || has("gl") || has("mg") || has("lg");
    if gastro {
        if any("med") || has("gm") || has("mg") {
            return Some(("emg_gm".into(), 1.0));
        }
        if any("lat") || has("gl") || has("lg") {
            return Some(("emg_gl".into(), 1.0));
        }
    }
    if any("tib") || has("ta") {
        return Some(("emg_ta".into(), 1.0));
    }
    None
}

/// `p` made absolute with its links resolved, also when it does not exist yet (a folder about
/// to be created): its deepest existing ancestor is resolved and the rest appended.
fn absolute(p: &Path) -> PathBuf {
    let p = if p.is_absolute() {
        p.to_path_buf()
    } else {
        std::env::current_dir()
            .map(|d| d.join(p))
            .unwrap_or_else(|_| p.to_path_buf())
    };
    let mut rest = Vec::new();
    let mut cur = p.as_path();
    loop {
        if let Ok(c) = std::fs::canonicalize(cur) {
            let mut out = c;
            for r in rest.iter().rev() {
                out.push(r);
            }
            return out;
        }
        match (cur.parent(), cur.file_name()) {
            (Some(parent), Some(name)) => {
                rest.push(name.to_os_string());
                cur = parent;
            }
            _ => return p.clone(),
        }
    }
}

/// `target` relative to the folder `from` (which need not exist yet); `target` made absolute
/// when no relative path exists.
#[must_use]
pub fn relative_path(target: &Path, from: &Path) -> PathBuf {
    let (t, f) = (absolute(target), absolute(from));
    let tc: Vec<Component> = t.components().collect();
    let fc: Vec<Component> = f.components().collect();
    let common = tc.iter().zip(&fc).take_while(|(a, b)| a == b).count();
    if common == 0 {
        return t;
    }
    let mut out = PathBuf::new();
    for _ in common..fc.len() {
        out.push("..");
    }
    for c in &tc[common..] {
        out.push(c.as_os_str());
    }
    out
}

/// Inspects the data files `paths` (one recording, possibly split over several files) and
/// writes a starter map whose paths are relative to `map_dir`.
///
/// # Errors
/// A file that cannot be read (each reader's own error).
pub fn inspect(paths: &[PathBuf], map_dir: &Path) -> Result<Inspection> {
    let mut files = Vec::new();
    let mut tables = Vec::new();
    for p in paths {
        if p.is_dir() {
            let ts = crate::ceinms::read_ceinms_tables(p, ceinms_files::DEFAULT_JOINT)?;
            for t in &ts {
                files.push(FileSummary::of(t));
            }
            return Ok(Inspection {
                files,
                map: None,
                unassigned: Vec::new(),
                notes: vec![format!(
                    "{} is a CEINMS trial folder: it needs no map; give it as --trial or as a \
                     session trial's \"recording\"",
                    p.display()
                )],
            });
        }
        let t = crate::kind::open_table(p, &crate::delimited::DelimitedOptions::default())?;
        files.push(FileSummary::of(&t));
        tables.push((p.clone(), t));
    }
    let single = tables.len() == 1;
    let Guesses {
        channels,
        mut notes,
        side,
        others,
        need_rate,
    } = guess_channels(&tables, map_dir, single);
    if let Some(s) = side {
        notes.push(format!(
            "the {} leg's channels were taken{}",
            if s == 'l' { "left" } else { "right" },
            if others.is_empty() {
                String::new()
            } else {
                format!("; not mapped: {}", others.join(", "))
            }
        ));
    } else if !others.is_empty() {
        notes.push(format!(
            "also candidates, not mapped: {}",
            others.join(", ")
        ));
    }
    if side == Some('l') {
        notes.push(
            "a left leg: check the torque's sign (plantarflexion must be positive; \"sign\": -1 \
             flips it)"
                .into(),
        );
    }
    let unassigned: Vec<String> = [
        "ankle_angle_deg",
        "torque_nm",
        "emg_sol",
        "emg_gm",
        "emg_gl",
    ]
    .iter()
    .filter(|k| !channels.contains_key(**k))
    .map(|k| (*k).to_string())
    .collect();
    if !unassigned.is_empty() {
        notes.push(format!(
            "no column found for {}: add them to \"channels\" by hand",
            unassigned.join(", ")
        ));
    }
    let rate_hz = need_rate.map(|f| {
        notes.push(format!(
            "{f} has no time column: set rate_hz to its sampling rate (2048 is a placeholder)"
        ));
        2048.0
    });
    let file = single.then(|| relative_path(&tables[0].0, map_dir).display().to_string());
    let map = RecordingMap {
        comment: (!notes.is_empty()).then(|| serde_json::json!(notes)),
        file,
        rate_hz,
        header_line: None,
        decimal_comma: None,
        channels,
        emg_is_envelope: false,
        path: map_dir.join("map.json"),
    };
    Ok(Inspection {
        files,
        map: Some(map),
        unassigned,
        notes,
    })
}

/// What [`guess_channels`] made of the files' columns.
struct Guesses {
    channels: BTreeMap<String, ChannelMap>,
    notes: Vec<String>,
    /// The leg (`'l'` or `'r'`) whose channels were taken, when a label names one.
    side: Option<char>,
    /// Candidate columns left unmapped (the other leg's, or a second candidate for a target).
    others: Vec<String>,
    /// A file without a time column or a rate, relative to the map's folder.
    need_rate: Option<String>,
}

/// A target for every column whose label suggests one (one leg's channels only), with the
/// notes a lab needs to finish the map.
fn guess_channels(tables: &[(PathBuf, RecordingTable)], map_dir: &Path, single: bool) -> Guesses {
    let mut notes = Vec::new();
    let mut channels = BTreeMap::<String, ChannelMap>::new();
    let mut side: Option<char> = None;
    let mut others: Vec<String> = Vec::new();
    let mut need_rate = None;
    for (p, t) in tables {
        let rel = relative_path(p, map_dir).display().to_string();
        if t.time_label.is_none() && t.rate_hz.is_none() {
            need_rate = Some(rel.clone());
        }
        for c in &t.channels {
            if t.time_label.as_deref() == Some(c.label.as_str()) {
                let u = c.unit.as_deref().unwrap_or("").to_ascii_lowercase();
                if u == "ms" {
                    let mut ch = ChannelMap::column(&c.label);
                    ch.scale = 1e-3;
                    ch.file = (!single).then(|| rel.clone());
                    channels.insert("time_s".into(), ch);
                    notes.push(format!("'{}' is in ms: time_s takes scale 0.001", c.label));
                }
                continue;
            }
            let Some((target, sign)) = guess(&c.label, &t.format) else {
                continue;
            };
            if let Some(s) = side_of(&c.label) {
                if target.starts_with("emg_") || target.ends_with("_deg") {
                    match side {
                        None => side = Some(s),
                        Some(x) if x != s => {
                            others.push(c.label.clone());
                            continue;
                        }
                        _ => {}
                    }
                }
            }
            if channels.contains_key(&target) {
                others.push(c.label.clone());
                continue;
            }
            let mut ch = ChannelMap::column(&c.label);
            ch.sign = sign;
            ch.file = (!single).then(|| rel.clone());
            let unit = c.unit.as_deref().unwrap_or("").to_ascii_lowercase();
            if !target.starts_with("emg_") && (unit == "mv" || unit == "v") {
                notes.push(format!(
                    "{target} ← '{}' is in {}: set its scale (and offset) to the lab's \
                     calibration, {} per {}",
                    c.label,
                    c.unit.as_deref().unwrap_or(""),
                    if target == "torque_nm" {
                        "N·m"
                    } else {
                        "degrees"
                    },
                    c.unit.as_deref().unwrap_or("")
                ));
            }
            if sign < 0.0 {
                notes.push(format!(
                    "torque_nm ← '{}' takes sign -1: OpenSim's moment is positive towards \
                     dorsiflexion, surae's torque towards plantarflexion",
                    c.label
                ));
            }
            channels.insert(target, ch);
        }
    }
    Guesses {
        channels,
        notes,
        side,
        others,
        need_rate,
    }
}
