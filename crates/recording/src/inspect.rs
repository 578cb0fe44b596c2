//! `surae inspect`: what a file holds (format, channels, rate, duration, ranges) and a starter
//! recording map for it, the first thing a user runs on a new file.
//!
//! The starter map assigns a column to a channel of the trial by its label:
//! exact surae names first (`ankle_angle_deg`, `emg_sol`, …), then common export names,
//! case-insensitive: a label with `ankle` and `angle`, or `angle` without `knee`, is the ankle
//! angle (`knee` and `angle`: the knee angle); `torque` or `moment` is the torque; `sol` is the
//! soleus, `gastro`/`gas`/`gm`/`gl` with `med`/`lat` the gastrocnemii, `tib` the tibialis
//! anterior; a label ending in `force_vy` is the vertical ground reaction force
//! (`grf_vertical_n`). When a label names a side (`LT`/`RT`, `left`/`right`, `_l`/`_r`), the
//! first side an EMG or angle label names is taken and the other leg's columns are listed. A
//! channel in volts or millivolts gets scale 1 and a note: its calibration (N·m or degrees per
//! mV) is the lab's to fill in.
//!
//! OpenSim storage files follow OpenSim's conventions: the torque is the chosen ankle
//! coordinate's own `<coordinate>_moment` (`ankle_angle_r_moment`, not the first `_moment`
//! column), with `sign: -1` (OpenSim's moment is positive towards dorsiflexion); a knee angle
//! whose values are centred below zero (gait2392's knee is negative in flexion) gets
//! `sign: -1`; of the ground reaction forces, the leg's `ground_force_vy` (the right foot's
//! has no prefix, the left's `l_`) is the vertical force, and a force file without it is an
//! error. EMG that does not swing below zero is taken as an envelope already
//! (`emg_is_envelope: true`) when it is sampled below the rate raw EMG needs, lies within
//! [0, 1], or its file's title or name says so (`Normalized EMG Linear Envelopes`,
//! `emgFilt.sto`).

use std::path::{Component, Path, PathBuf};

use serde::Serialize;

use crate::error::Result;
use crate::map::RecordingMap;
use crate::table::{RecordingFormat, RecordingTable};

mod guess;

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

/// A table's rate (Hz) and duration (s): from its time column, else from the rate it states.
fn clock_of(table: &RecordingTable) -> (Option<f64>, Option<f64>) {
    match (&table.time_label, table.rate_hz) {
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
    }
}

impl FileSummary {
    /// Summarises a table.
    #[must_use]
    pub fn of(table: &RecordingTable) -> Self {
        let (rate_hz, duration_s) = clock_of(table);
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
    let guess::Guesses {
        channels,
        mut notes,
        side,
        others,
        need_rate,
        emg_is_envelope,
        torque_is_moment,
    } = guess::guess_channels(&tables, map_dir, single)?;
    if let Some(s) = side {
        notes.push(format!(
            "the {} leg's channels were taken{}",
            guess::leg_name(s),
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
    // an OpenSim moment's sign is the same for both legs; a dynamometer's depends on the leg
    if side == Some('l') && !torque_is_moment {
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
        emg_is_envelope,
        path: map_dir.join("map.json"),
    };
    Ok(Inspection {
        files,
        map: Some(map),
        unassigned,
        notes,
    })
}
