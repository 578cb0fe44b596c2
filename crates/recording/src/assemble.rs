//! A map's channels brought onto one clock: the trial (or unloaded run) the rest of surae reads.
//!
//! Each file's clock is, in this order: its mapped `time_s` channel (`scale` turns
//! milliseconds into seconds), its own time column, the rate its format states (a C3D's analog
//! rate), a channel's `rate_hz`, the map's `rate_hz`; a file with none of them is an error. A
//! clock must increase strictly and be uniform within [`UNIFORM_TOLERANCE`] of its mean step;
//! a clock uniform only to the rounding of its text (OpenSim writes 6–8 decimals) is replaced by
//! the exact grid `t₀ + i·Δ`, which moves no sample by more than that rounding.
//!
//! The trial's grid is the clock of `emg_sol` (the EMG rate; the unloaded run's is its torque's).
//! A channel on the same clock (same file, or a bit-identical time column) is copied as it is;
//! one on another clock is interpolated linearly onto the grid ([`numerics::interpolate`]).
//! For a signal of bandwidth well below both rates linear interpolation errs by at most
//! `h²·max|x''|/8` (`h` the slower channel's step): for the ankle angle of a 30 °/s isokinetic
//! sweep with 50 ms ramps (|q''| ≤ 600 °/s²) sampled at 100 Hz, 0.0075°. Raw EMG should not be
//! interpolated (it has power up to 450 Hz): keep the EMG channels of a trial on one clock.
//! The grid is cut to the time every channel covers.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use experiment::{Trial, Unloaded};
use serde::Serialize;

use crate::error::{RecordingError, Result};
use crate::map::{ChannelMap, RecordingMap, Target};
use crate::table::{RecordingFormat, RecordingTable};

/// Largest relative deviation of a clock's steps from its mean step for it to count as
/// uniform (text rounding of the time column); past it the clock is an error.
pub const UNIFORM_TOLERANCE: f64 = 1e-3;
/// Below this relative deviation the time column is kept as it is (exactly uniform up to
/// floating-point rounding); between it and [`UNIFORM_TOLERANCE`] it is regularised.
pub const EXACT_TOLERANCE: f64 = 1e-6;

/// The geometry series of one muscle read from a map (`lmt_<m>_m`, `ma_<m>_m`).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct MappedGeometry {
    /// The muscle's name (`sol`, `gm`, `gl` or a fixed muscle's).
    pub muscle: String,
    /// Musculotendon length (m) on the trial's samples.
    pub lmt_m: Vec<f64>,
    /// Ankle moment arm (m, plantarflexion positive) on the trial's samples.
    pub moment_arm_m: Vec<f64>,
}

/// How one channel was read (for summaries and `inspect`).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct ChannelSource {
    /// The target (`torque_nm`).
    pub target: String,
    /// The file.
    pub file: String,
    /// The column.
    pub column: String,
    /// The file's rate (Hz).
    pub rate_hz: f64,
    /// Whether it was interpolated onto the grid.
    pub resampled: bool,
}

/// A recording read through its map.
#[derive(Clone, Debug, PartialEq)]
pub struct MappedRecording {
    /// The trial (raw EMG unless `emg_is_envelope`).
    pub trial: Trial,
    /// Geometry series from the map, one per muscle that has them.
    pub geometry: Vec<MappedGeometry>,
    /// The map says the EMG channels are envelopes already.
    pub emg_is_envelope: bool,
    /// Where each channel came from.
    pub sources: Vec<ChannelSource>,
    /// Things the reader did that a user should know (a regularised clock, a resampled
    /// channel, radians converted).
    pub notes: Vec<String>,
}

/// A clock: the times of a file's (or channel's) samples.
#[derive(Clone, Debug)]
struct Clock {
    times: Vec<f64>,
    /// Where the clock came from, for messages.
    what: String,
}

fn rate_of(t: &[f64]) -> f64 {
    if t.len() < 2 {
        return f64::NAN;
    }
    (t.len() - 1) as f64 / (t[t.len() - 1] - t[0])
}

/// Opens each distinct file once.
struct Files<'m> {
    map: &'m RecordingMap,
    tables: BTreeMap<PathBuf, RecordingTable>,
}

impl<'m> Files<'m> {
    fn get(&mut self, path: &Path) -> Result<&RecordingTable> {
        if !self.tables.contains_key(path) {
            let opts = crate::delimited::DelimitedOptions {
                header_line: self.map.header_line,
                decimal_comma: self.map.decimal_comma,
            };
            let t = crate::kind::open_table(path, &opts)?;
            self.tables.insert(path.to_path_buf(), t);
        }
        Ok(&self.tables[path])
    }
}

/// An error about a whole column; control characters in its label are escaped (one line).
fn column_error(path: String, column: &str, reason: impl Into<String>) -> RecordingError {
    RecordingError::Column {
        path,
        name: crate::read::printable(column),
        reason: reason.into(),
    }
}

/// Checks a clock: strictly increasing and uniform; returns it, regularised when it is
/// uniform only to its text's rounding.
fn checked_clock(table: &RecordingTable, label: &str, t: Vec<f64>) -> Result<(Vec<f64>, bool)> {
    let name = table.name();
    let err = |i: usize, reason: String| RecordingError::Column {
        path: name.clone(),
        name: crate::read::printable(label),
        reason: format!("{}: {reason}", table.locate(i)),
    };
    if t.len() < 2 {
        return Err(column_error(name, label, "fewer than 2 samples: no clock"));
    }
    for (i, w) in t.windows(2).enumerate() {
        if !(w[0].is_finite() && w[1].is_finite()) {
            return Err(err(i + 1, "time is missing (NaN)".into()));
        }
        if w[1] <= w[0] {
            return Err(err(
                i + 1,
                format!("time does not increase ({} after {})", w[1], w[0]),
            ));
        }
    }
    let n = t.len();
    let step = (t[n - 1] - t[0]) / (n - 1) as f64;
    let mut worst = (0.0f64, 0usize);
    for (i, w) in t.windows(2).enumerate() {
        let rel = ((w[1] - w[0]) - step).abs() / step;
        if rel > worst.0 {
            worst = (rel, i + 1);
        }
    }
    if worst.0 > UNIFORM_TOLERANCE {
        return Err(err(
            worst.1,
            format!(
                "non-uniform clock: a step of {:.6} s against a mean step of {step:.6} s (a gap or \
                 a second clock in the file?)",
                t[worst.1] - t[worst.1 - 1]
            ),
        ));
    }
    if worst.0 > EXACT_TOLERANCE {
        let t0 = t[0];
        return Ok(((0..n).map(|i| t0 + i as f64 * step).collect(), true));
    }
    Ok((t, false))
}

/// Reads a recording through its map into a trial.
///
/// # Errors
/// A file that cannot be read, a column the map names that the file lacks, a channel all NaN
/// or with a NaN where it is used, an EMG channel all zeros, a clock that is missing,
/// non-uniform or decreasing, files that share less than one second, required channels the
/// map lacks (`ankle_angle_deg`, `torque_nm`, `emg_sol`, `emg_gm`, `emg_gl`), a geometry
/// series without its pair.
pub fn read_trial_recording(map: &RecordingMap) -> Result<MappedRecording> {
    let assembled = assemble(
        map,
        &[
            "ankle_angle_deg",
            "torque_nm",
            "emg_sol",
            "emg_gm",
            "emg_gl",
        ],
        "emg_sol",
    )?;
    let Assembled {
        time,
        mut channels,
        sources,
        notes,
    } = assembled;
    let mut take = |k: &str| channels.remove(k);
    let req = |c: Option<Vec<f64>>| c.unwrap_or_default();
    let ankle = req(take("ankle_angle_deg"));
    let torque = req(take("torque_nm"));
    let sol = req(take("emg_sol"));
    let gm = req(take("emg_gm"));
    let gl = req(take("emg_gl"));
    let ta = take("emg_ta");
    let knee = take("knee_angle_deg");
    let grf_vertical = take("grf_vertical_n");
    let mut emg_other = Vec::new();
    let mut lengths = BTreeMap::new();
    let mut arms = BTreeMap::new();
    for (k, v) in channels {
        match Target::parse(&k) {
            Ok(Target::Emg(m)) => emg_other.push((m, v)),
            Ok(Target::Length(m)) => {
                lengths.insert(m, v);
            }
            Ok(Target::MomentArm(m)) => {
                arms.insert(m, v);
            }
            _ => {}
        }
    }
    let mut geometry = Vec::new();
    for (m, lmt_m) in lengths {
        let moment_arm_m = arms.remove(&m).ok_or_else(|| {
            map.key_error(
                &format!("channels.lmt_{m}_m"),
                format!("a length series needs its moment arm: map ma_{m}_m too"),
            )
        })?;
        geometry.push(MappedGeometry {
            muscle: m,
            lmt_m,
            moment_arm_m,
        });
    }
    if let Some(m) = arms.keys().next() {
        return Err(map.key_error(
            &format!("channels.ma_{m}_m"),
            format!("a moment-arm series needs its length: map lmt_{m}_m too"),
        ));
    }
    let trial = Trial {
        time_s: time,
        ankle_angle_deg: ankle,
        torque_nm: torque,
        emg_sol: sol,
        emg_gm: gm,
        emg_gl: gl,
        emg_ta: ta,
        emg_other,
        knee_angle_deg: knee,
        grf_vertical_n: grf_vertical,
        comments: vec![format!(" read through the recording map {}", map.name())],
        ignored_columns: Vec::new(),
    };
    Ok(MappedRecording {
        trial,
        geometry,
        emg_is_envelope: map.emg_is_envelope,
        sources,
        notes,
    })
}

/// Reads an unloaded run (angle and torque, on the torque's clock) through its map; EMG
/// channels in the map are ignored.
///
/// # Errors
/// As [`read_trial_recording`], with `ankle_angle_deg` and `torque_nm` required.
pub fn read_unloaded_recording(map: &RecordingMap) -> Result<Unloaded> {
    let mut only = map.clone();
    only.channels.retain(|k, _| {
        matches!(
            Target::parse(k),
            Ok(Target::Time | Target::Angle | Target::Torque)
        )
    });
    let mut a = assemble(&only, &["ankle_angle_deg", "torque_nm"], "torque_nm")?;
    Ok(Unloaded {
        time_s: a.time,
        ankle_angle_deg: a.channels.remove("ankle_angle_deg").unwrap_or_default(),
        torque_nm: a.channels.remove("torque_nm").unwrap_or_default(),
        comments: vec![format!(" read through the recording map {}", map.name())],
        ignored_columns: Vec::new(),
    })
}

struct Assembled {
    time: Vec<f64>,
    channels: BTreeMap<String, Vec<f64>>,
    sources: Vec<ChannelSource>,
    notes: Vec<String>,
}

/// One channel read from its file, on its own clock.
struct Read {
    clock: Clock,
    values: Vec<f64>,
    file: PathBuf,
    column: String,
}

/// The mapped channels of `map` on one grid: the clock of `grid_of`, cut to the time every
/// channel covers, every other channel interpolated onto it.
fn assemble(map: &RecordingMap, required: &[&str], grid_of: &str) -> Result<Assembled> {
    check_required(map, required, grid_of)?;
    let mut files = Files {
        map,
        tables: BTreeMap::new(),
    };
    let mut notes = Vec::new();
    let reads = read_channels(map, &mut files, &mut notes)?;
    let grid = common_grid(map, &reads, grid_of, &mut notes)?;
    let (channels, sources) = onto_grid(&files, reads, &grid, &mut notes)?;
    Ok(Assembled {
        time: grid.times,
        channels,
        sources,
        notes,
    })
}

/// That the map names every channel the kind of recording needs.
fn check_required(map: &RecordingMap, required: &[&str], grid_of: &str) -> Result<()> {
    for r in required {
        if !map.channels.contains_key(*r) {
            return Err(map.key_error(
                "channels",
                format!(
                    "no {r}: a {} needs {}",
                    if grid_of == "emg_sol" {
                        "trial"
                    } else {
                        "unloaded run"
                    },
                    required.join(", ")
                ),
            ));
        }
    }
    Ok(())
}

/// Every mapped channel but `time_s`, read from its file on its own clock (each file's clock
/// worked out once).
fn read_channels(
    map: &RecordingMap,
    files: &mut Files<'_>,
    notes: &mut Vec<String>,
) -> Result<Vec<(String, Read)>> {
    // each file's clock: its mapped time_s channel, its time column, its stated rate
    let time_map = map.channels.get("time_s");
    let time_file = match time_map {
        Some(ch) => Some(map.file_of("time_s", ch)?),
        None => None,
    };
    let mut clocks: BTreeMap<PathBuf, Clock> = BTreeMap::new();
    let mut reads: Vec<(String, Read)> = Vec::new();
    for (target, ch) in &map.channels {
        if target == "time_s" {
            continue;
        }
        let file = map.file_of(target, ch)?;
        let tparsed = Target::parse(target).map_err(|r| map.key_error(target, r))?;
        if !files.tables.contains_key(&file)
            && matches!(std::fs::metadata(&file), Err(e) if e.kind() == std::io::ErrorKind::NotFound)
        {
            let key = if ch.file.is_some() {
                format!("channels.{target}.file")
            } else {
                "file".to_string()
            };
            return Err(map.key_error(
                &key,
                format!(
                    "no such file {} (paths are relative to the map's folder)",
                    file.display()
                ),
            ));
        }
        let table = files.get(&file)?;
        let column = table.channel(&ch.column).ok_or_else(|| {
            let labels: Vec<&str> = table.channels.iter().map(|c| c.label.as_str()).collect();
            map.key_error(
                &format!("channels.{target}.column"),
                format!(
                    "no column '{}' in {} (its columns: {})",
                    ch.column,
                    table.name(),
                    labels.join(", ")
                ),
            )
        })?;
        let to_degrees = tparsed.is_degrees()
            && matches!(
                table.format,
                RecordingFormat::Storage {
                    in_degrees: Some(false),
                    ..
                }
            );
        if to_degrees {
            notes.push(format!(
                "{}: {}: inDegrees=no, converted from radians to degrees",
                table.name(),
                ch.column
            ));
        }
        let values: Vec<f64> = column
            .values
            .iter()
            .map(|&raw| {
                let raw = if to_degrees { raw.to_degrees() } else { raw };
                ch.apply(raw)
            })
            .collect();
        let clock = channel_clock(map, target, ch, table)?;
        let mut values = values;
        if let Some(c) = &clock {
            // its samples end where its own clock ends (the empty cells after them dropped)
            values.truncate(c.times.len());
        }
        let clock = match clock {
            Some(c) => c,
            None => {
                if !clocks.contains_key(&file) {
                    let c = file_clock(map, table, &file, &time_file, time_map, notes)?;
                    clocks.insert(file.clone(), c);
                }
                clocks[&file].clone()
            }
        };
        if clock.times.len() != values.len() {
            return Err(column_error(
                table.name(),
                &ch.column,
                format!(
                    "{} samples but its clock ({}) has {}",
                    values.len(),
                    clock.what,
                    clock.times.len()
                ),
            ));
        }
        reads.push((
            target.clone(),
            Read {
                clock,
                values,
                file,
                column: ch.column.clone(),
            },
        ));
    }
    Ok(reads)
}

/// The grid the channels are put on, and where it lies on the clock it was cut from.
struct Grid {
    /// The clock of the channel that sets the grid, whole.
    clock: Vec<f64>,
    /// The grid is `clock[first..last]`.
    first: usize,
    last: usize,
    times: Vec<f64>,
}

/// The grid: the clock of `grid_of`, cut to what every channel covers (at least 1 s).
fn common_grid(
    map: &RecordingMap,
    reads: &[(String, Read)],
    grid_of: &str,
    notes: &mut Vec<String>,
) -> Result<Grid> {
    let grid_clock = reads
        .iter()
        .find(|(t, _)| t == grid_of)
        .map(|(_, r)| r.clock.times.clone())
        .unwrap_or_default();
    let (mut lo, mut hi) = (grid_clock[0], grid_clock[grid_clock.len() - 1]);
    // the channels that start last and end first, for the message
    let (mut lo_by, mut hi_by) = (grid_of, grid_of);
    for (t, r) in reads {
        let (a, b) = (r.clock.times[0], r.clock.times[r.clock.times.len() - 1]);
        if a > lo {
            (lo, lo_by) = (a, t.as_str());
        }
        if b < hi {
            (hi, hi_by) = (b, t.as_str());
        }
    }
    let who = |target: &str| {
        reads.iter().find(|(t, _)| t == target).map_or_else(
            || target.to_string(),
            |(_, r)| {
                format!(
                    "{target} ('{}' in {})",
                    crate::read::printable(&r.column),
                    r.file.display()
                )
            },
        )
    };
    let tol = 1e-9 * (1.0 + hi.abs());
    let first = grid_clock.partition_point(|&t| t < lo - tol);
    let last = grid_clock.partition_point(|&t| t <= hi + tol);
    if last <= first + 1 || grid_clock[last - 1] - grid_clock[first] < 1.0 - 1e-9 {
        return Err(RecordingError::file(
            map.name(),
            format!(
                "the channels share only {:.3} s of time: {} starts at {lo:.3} s, {} ends at \
                 {hi:.3} s; at least 1 s is needed",
                (hi - lo).max(0.0),
                who(lo_by),
                who(hi_by)
            ),
        ));
    }
    if first > 0 || last < grid_clock.len() {
        notes.push(format!(
            "the grid is cut to {:.4}–{:.4} s, the time every channel covers",
            grid_clock[first],
            grid_clock[last - 1]
        ));
    }
    let grid = grid_clock[first..last].to_vec();
    Ok(Grid {
        clock: grid_clock,
        first,
        last,
        times: grid,
    })
}

/// The channels on the grid by target, and where each came from.
type OnGrid = (BTreeMap<String, Vec<f64>>, Vec<ChannelSource>);

/// Every channel on the grid: one on the grid's own clock is cut to it, any other is
/// interpolated linearly onto it; an all-zero EMG channel is an error.
fn onto_grid(
    files: &Files<'_>,
    reads: Vec<(String, Read)>,
    grid: &Grid,
    notes: &mut Vec<String>,
) -> Result<OnGrid> {
    let (grid_clock, first, last) = (&grid.clock, grid.first, grid.last);
    let grid = &grid.times;
    let grid_rate = rate_of(grid);

    let mut channels = BTreeMap::new();
    let mut sources = Vec::new();
    for (target, r) in reads {
        let table = &files.tables[&r.file];
        let same_clock = r.clock.times.len() >= last
            && r.clock.times[first..last]
                .iter()
                .zip(grid)
                .all(|(a, b)| a.to_bits() == b.to_bits())
            && r.clock.times.len() == grid_clock.len();
        let (values, resampled) = if same_clock {
            check_finite(table, &r, &target, first, last)?;
            (r.values[first..last].to_vec(), false)
        } else {
            // the source samples that the grid's span reaches
            let a = r
                .clock
                .times
                .partition_point(|&t| t < grid[0])
                .saturating_sub(1);
            let b = (r
                .clock
                .times
                .partition_point(|&t| t <= grid[grid.len() - 1])
                + 1)
            .min(r.values.len());
            check_finite(table, &r, &target, a, b)?;
            let v =
                numerics::interpolate::resample_linear(&r.clock.times[a..b], &r.values[a..b], grid)
                    .map_err(|e| column_error(table.name(), &r.column, e.to_string()))?;
            notes.push(format!(
                "{target}: {} ({}, {:.1} Hz) interpolated linearly onto the {:.1} Hz grid",
                r.column,
                table.name(),
                rate_of(&r.clock.times),
                grid_rate
            ));
            (v, true)
        };
        if target.starts_with("emg_") && values.iter().all(|&x| x == 0.0) {
            return Err(column_error(
                table.name(),
                &r.column,
                format!("{target} is all zeros (disconnected electrode?)"),
            ));
        }
        sources.push(ChannelSource {
            target: target.clone(),
            file: table.name(),
            column: r.column.clone(),
            rate_hz: rate_of(&r.clock.times),
            resampled,
        });
        channels.insert(target, values);
    }
    Ok((channels, sources))
}

/// A missing sample (NaN) where a channel is used is an error naming where it is.
fn check_finite(table: &RecordingTable, r: &Read, target: &str, a: usize, b: usize) -> Result<()> {
    let used = &r.values[a..b];
    if used.iter().all(|x| x.is_nan()) {
        return Err(column_error(
            table.name(),
            &r.column,
            format!("{target}: the channel is all NaN (no samples)"),
        ));
    }
    if let Some(i) = used.iter().position(|x| !x.is_finite()) {
        return Err(column_error(
            table.name(),
            &r.column,
            format!(
                "{target}: {}: missing sample (NaN or infinite)",
                table.locate(a + i)
            ),
        ));
    }
    Ok(())
}

/// A channel's own clock when it has its own `rate_hz`.
fn channel_clock(
    map: &RecordingMap,
    target: &str,
    ch: &ChannelMap,
    table: &RecordingTable,
) -> Result<Option<Clock>> {
    let Some(rate) = ch.rate_hz else {
        return Ok(None);
    };
    if table.time_label.is_some() {
        return Err(map.key_error(
            &format!("channels.{target}.rate_hz"),
            format!(
                "{} has a time column ('{}'); a channel's rate_hz is for files without one",
                table.name(),
                table.time_label.as_deref().unwrap_or("")
            ),
        ));
    }
    // a channel at a lower rate in a shared table ends in missing cells: its own length
    let col = table.channel(&ch.column).map_or(0, |c| {
        c.values.len() - c.values.iter().rev().take_while(|x| x.is_nan()).count()
    });
    if col < 2 {
        return Err(column_error(
            table.name(),
            &ch.column,
            format!(
                "{target}: {col} sample(s) before its trailing missing cells: no clock at its \
                 rate_hz {rate}"
            ),
        ));
    }
    Ok(Some(Clock {
        times: (0..col).map(|i| table.start_s + i as f64 / rate).collect(),
        what: format!("{} rows at the channel's rate_hz {rate}", col),
    }))
}

/// A file's clock.
fn file_clock(
    map: &RecordingMap,
    table: &RecordingTable,
    file: &Path,
    time_file: &Option<PathBuf>,
    time_map: Option<&ChannelMap>,
    notes: &mut Vec<String>,
) -> Result<Clock> {
    let n = table.rows();
    let (times, label, what) = if let (Some(tf), Some(tm)) = (time_file, time_map) {
        if tf.as_path() == file {
            let c = table.channel(&tm.column).ok_or_else(|| {
                map.key_error(
                    "channels.time_s.column",
                    format!("no column '{}' in {}", tm.column, table.name()),
                )
            })?;
            let t: Vec<f64> = c.values.iter().map(|&x| tm.apply(x)).collect();
            (
                Some(t),
                tm.column.clone(),
                format!("time_s = {}", tm.column),
            )
        } else {
            (None, String::new(), String::new())
        }
    } else {
        (None, String::new(), String::new())
    };
    let from_time_column = times.is_none() && table.time_label.is_some();
    let (times, label, what) = match times {
        Some(t) => (t, label, what),
        None => match (&table.time_label, table.rate_hz, map.rate_hz) {
            (Some(l), _, _) => {
                let t = table
                    .channel(l)
                    .map(|c| c.values.clone())
                    .unwrap_or_default();
                (t, l.clone(), format!("time column {l}"))
            }
            (None, Some(r), _) => (
                (0..n).map(|i| table.start_s + i as f64 / r).collect(),
                "(file rate)".to_string(),
                format!("the file's rate {r} Hz"),
            ),
            (None, None, Some(r)) => (
                (0..n).map(|i| i as f64 / r).collect(),
                "(rate_hz)".to_string(),
                format!("the map's rate_hz {r}"),
            ),
            (None, None, None) => {
                return Err(RecordingError::file(
                    table.name(),
                    "no clock: the file has no time column, and neither the map nor its \
                     channels give rate_hz",
                ))
            }
        },
    };
    let (times, regular) = checked_clock(table, &label, times)?;
    // the map's rate against the file's own time column, once that is known to be a clock (a
    // gap is reported as a gap, not as a rate)
    if let (true, Some(r)) = (from_time_column, map.rate_hz) {
        let found = rate_of(&times);
        if (found - r).abs() > 1e-3 * r {
            return Err(map.key_error(
                "rate_hz",
                format!(
                    "{r} Hz, but the time column '{label}' of {} steps at {found:.3} Hz",
                    table.name()
                ),
            ));
        }
    }
    if regular {
        notes.push(format!(
            "{}: {label}: uniform only to its text's rounding; the exact grid t0 + i·dt is used",
            table.name()
        ));
    }
    Ok(Clock { times, what })
}
