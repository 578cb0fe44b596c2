//! How `surae inspect` places a file's columns: which column is which channel of the trial,
//! with which sign, from which leg, and whether the EMG is raw or an envelope already.
//!
//! Each column's label suggests at most one target ([`target_of`]); the leg is the first side
//! an EMG or angle label names; each target then takes the first column of that leg (or of no
//! leg) that suggests it, except the torque, which takes the moment of the chosen ankle
//! angle's own coordinate. Every other candidate is listed as not mapped.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use crate::error::{RecordingError, Result};
use crate::map::{ChannelMap, Target};
use crate::table::{RecordingChannel, RecordingFormat, RecordingTable};

/// What [`guess_channels`] made of the files' columns.
pub(super) struct Guesses {
    pub channels: BTreeMap<String, ChannelMap>,
    pub notes: Vec<String>,
    /// The leg (`'l'` or `'r'`) whose channels were taken, when a label names one.
    pub side: Option<char>,
    /// Candidate columns left unmapped (the other leg's, or a second candidate for a target).
    pub others: Vec<String>,
    /// A file without a time column or a rate, relative to the map's folder.
    pub need_rate: Option<String>,
    /// Whether the mapped EMG channels look like envelopes already.
    pub emg_is_envelope: bool,
    /// Whether the torque is an OpenSim joint moment (its sign is known, unlike a
    /// dynamometer's).
    pub torque_is_moment: bool,
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

/// Whether a label is a vertical ground reaction force (`ground_force_vy`, `l_ground_force_vy`:
/// OpenSim's external-loads columns, y up).
fn is_vertical_force(label: &str) -> bool {
    label.trim().to_ascii_lowercase().ends_with("force_vy")
}

/// The side of a vertical force column: the side its label names; OpenSim's gait examples
/// (and CEINMS-RT's data) write the right foot's force without a prefix (`ground_force_vy`)
/// and the left's with `l_`, so a force without a side is the right foot's.
fn force_side(label: &str) -> char {
    side_of(label).unwrap_or('r')
}

/// The trial channel a label suggests and its sign. In an OpenSim storage file the labels are
/// a model's coordinate names: only an ankle coordinate's `<coordinate>_moment` is a torque
/// (not `pelvis_tilt_moment`), only `ankle`/`knee` coordinates are angles (not
/// `subtalar_angle_r`), and other forces and torques (`pelvis_tx_force`, `ground_torque_x`)
/// are nothing.
fn target_of(label: &str, format: &RecordingFormat) -> Option<(String, f64)> {
    let l = label.trim();
    if Target::parse(l).is_ok() {
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
    if is_vertical_force(l) {
        return Some(("grf_vertical_n".into(), 1.0));
    }
    if storage {
        if let Some(coordinate) = low.strip_suffix("_moment") {
            // OpenSim's moment is positive towards dorsiflexion, surae's torque towards
            // plantarflexion
            return words(coordinate)
                .iter()
                .any(|x| x == "ankle")
                .then(|| ("torque_nm".into(), -1.0));
        }
        if any("force") || any("torque") {
            return None;
        }
        if has("knee") && (any("angle") || any("flex")) {
            return Some(("knee_angle_deg".into(), 1.0));
        }
        if has("ankle") && (any("angle") || any("flex")) {
            return Some(("ankle_angle_deg".into(), 1.0));
        }
        return emg_target(&w);
    }
    if has("knee") && (any("angle") || any("flex")) {
        return Some(("knee_angle_deg".into(), 1.0));
    }
    if any("torque") || any("moment") {
        return Some(("torque_nm".into(), 1.0));
    }
    if (has("ankle") && any("angle")) || (any("angle") && !has("knee") && !has("hip")) {
        return Some(("ankle_angle_deg".into(), 1.0));
    }
    emg_target(&w)
}

/// The EMG channel a label's words suggest.
fn emg_target(w: &[String]) -> Option<(String, f64)> {
    let has = |s: &str| w.iter().any(|x| x == s);
    let any = |s: &str| w.iter().any(|x| x.contains(s));
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

/// Smallest and largest finite value of a channel (`(∞, −∞)` when it has none).
fn range(c: &RecordingChannel) -> (f64, f64) {
    c.values
        .iter()
        .copied()
        .filter(|x| x.is_finite())
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), x| {
            (a.min(x), b.max(x))
        })
}

/// A column that suggests a target.
struct Candidate<'t> {
    target: String,
    sign: f64,
    /// The leg its label names.
    side: Option<char>,
    table: usize,
    channel: &'t RecordingChannel,
}

/// The first side an EMG or angle candidate names (a dynamometer export names the tested leg
/// there); failing that, a force's or moment's, the right when both legs are there.
fn chosen_side(cands: &[Candidate<'_>]) -> Option<char> {
    let limb = cands
        .iter()
        .find(|c| (c.target.starts_with("emg_") || c.target.ends_with("_deg")) && c.side.is_some());
    if let Some(c) = limb {
        return c.side;
    }
    let sides: Vec<char> = cands.iter().filter_map(|c| c.side).collect();
    if sides.contains(&'r') {
        Some('r')
    } else {
        sides.first().copied()
    }
}

/// A target for every column whose label suggests one (one leg's channels only), with the
/// notes a lab needs to finish the map.
///
/// # Errors
/// A ground reaction force file (columns named `*ground_force*`) without the chosen leg's
/// vertical force, naming the file and the column it lacks.
pub(super) fn guess_channels(
    tables: &[(PathBuf, RecordingTable)],
    map_dir: &Path,
    single: bool,
) -> Result<Guesses> {
    let mut notes = Vec::new();
    let mut channels = BTreeMap::<String, ChannelMap>::new();
    let mut others: Vec<String> = Vec::new();
    let mut need_rate = None;
    let rel: Vec<String> = tables
        .iter()
        .map(|(p, _)| super::relative_path(p, map_dir).display().to_string())
        .collect();
    let mut cands = Vec::new();
    for (i, (_, t)) in tables.iter().enumerate() {
        if t.time_label.is_none() && t.rate_hz.is_none() {
            need_rate = Some(rel[i].clone());
        }
        for c in &t.channels {
            if t.time_label.as_deref() == Some(c.label.as_str()) {
                let u = c.unit.as_deref().unwrap_or("").to_ascii_lowercase();
                if u == "ms" {
                    let mut ch = ChannelMap::column(&c.label);
                    ch.scale = 1e-3;
                    ch.file = (!single).then(|| rel[i].clone());
                    channels.insert("time_s".into(), ch);
                    notes.push(format!("'{}' is in ms: time_s takes scale 0.001", c.label));
                }
                continue;
            }
            let Some((target, sign)) = target_of(&c.label, &t.format) else {
                continue;
            };
            let side = if target == "grf_vertical_n" {
                Some(force_side(&c.label))
            } else {
                side_of(&c.label)
            };
            cands.push(Candidate {
                target,
                sign,
                side,
                table: i,
                channel: c,
            });
        }
    }
    let side = chosen_side(&cands);
    // the other leg's columns are listed, never mapped
    let (mine, theirs): (Vec<_>, Vec<_>) = cands
        .into_iter()
        .partition(|c| side.is_none() || c.side.is_none() || c.side == side);
    others.extend(theirs.iter().map(|c| c.channel.label.clone()));
    // the torque is the moment of the coordinate whose angle was taken (or of the leg's
    // ankle): OpenSim's inverse dynamics writes a moment for every coordinate
    let ankle_label = mine
        .iter()
        .find(|c| c.target == "ankle_angle_deg")
        .map(|c| c.channel.label.clone())
        .unwrap_or_else(|| format!("ankle_angle_{}", side.unwrap_or('r')));
    let own_moment = format!("{ankle_label}_moment");
    let mut order: Vec<&Candidate<'_>> = mine.iter().collect();
    order.sort_by_key(|c| c.target == "torque_nm" && c.channel.label != own_moment);
    let mut torque_is_moment = false;
    for c in order {
        if channels.contains_key(&c.target) {
            others.push(c.channel.label.clone());
            continue;
        }
        let mut ch = ChannelMap::column(&c.channel.label);
        ch.sign = c.sign;
        ch.file = (!single).then(|| rel[c.table].clone());
        let unit = c.channel.unit.as_deref().unwrap_or("").to_ascii_lowercase();
        if !c.target.starts_with("emg_") && (unit == "mv" || unit == "v") {
            notes.push(format!(
                "{} ← '{}' is in {}: set its scale (and offset) to the lab's calibration, {} \
                 per {}",
                c.target,
                c.channel.label,
                c.channel.unit.as_deref().unwrap_or(""),
                match c.target.as_str() {
                    "torque_nm" => "N·m",
                    "grf_vertical_n" => "N",
                    _ => "degrees",
                },
                c.channel.unit.as_deref().unwrap_or("")
            ));
        }
        match c.target.as_str() {
            "torque_nm" if c.sign < 0.0 => {
                torque_is_moment = true;
                notes.push(format!(
                    "torque_nm ← '{}' takes sign -1: OpenSim's moment is positive towards \
                     dorsiflexion, surae's torque towards plantarflexion",
                    c.channel.label
                ));
            }
            "knee_angle_deg"
                if matches!(tables[c.table].1.format, RecordingFormat::Storage { .. }) =>
            {
                let (lo, hi) = range(c.channel);
                // gait2392's knee coordinate is negative in flexion (−120° … 10°); surae's
                // knee angle is 0 extended and positive flexed: a range centred below zero is
                // flexion written negative
                if lo + hi < 0.0 {
                    ch.sign = -1.0;
                    notes.push(format!(
                        "knee_angle_deg ← '{}' takes sign -1: its values ({} … {}°) are \
                         negative in flexion, as in OpenSim's gait2392 model; surae's knee \
                         angle is 0 extended, positive flexed",
                        c.channel.label,
                        super::short(lo),
                        super::short(hi)
                    ));
                }
            }
            "grf_vertical_n" => notes.push(format!(
                "grf_vertical_n ← '{}': the {} foot's vertical ground reaction force (N), \
                 which marks the stances (force above a threshold)",
                c.channel.label,
                leg_name(c.side.unwrap_or('r'))
            )),
            _ => {}
        }
        channels.insert(c.target.clone(), ch);
    }
    check_force_file(tables, &channels, side)?;
    let emg_is_envelope = envelope_guess(tables, &mine, &channels, &mut notes);
    Ok(Guesses {
        channels,
        notes,
        side,
        others,
        need_rate,
        emg_is_envelope,
        torque_is_moment,
    })
}

/// `left` or `right`.
pub(super) fn leg_name(side: char) -> &'static str {
    if side == 'l' {
        "left"
    } else {
        "right"
    }
}

/// A ground reaction force file (a column named `*ground_force*`) must hold the chosen leg's
/// vertical force: without it the file was given for nothing, and stride detection would
/// silently have no stances.
fn check_force_file(
    tables: &[(PathBuf, RecordingTable)],
    channels: &BTreeMap<String, ChannelMap>,
    side: Option<char>,
) -> Result<()> {
    if channels.contains_key("grf_vertical_n") {
        return Ok(());
    }
    let leg = side.unwrap_or('r');
    for (_, t) in tables {
        let forces: Vec<&str> = t
            .channels
            .iter()
            .map(|c| c.label.as_str())
            .filter(|l| l.to_ascii_lowercase().contains("ground_force"))
            .collect();
        if forces.is_empty() {
            continue;
        }
        let expected = if leg == 'l' {
            "l_ground_force_vy"
        } else {
            "ground_force_vy"
        };
        return Err(RecordingError::column(
            t.name(),
            expected,
            format!(
                "no vertical ground reaction force of the {} foot in this ground reaction \
                 force file (its force columns: {}); give the file with that foot's \
                 ground_force_vy or leave it out",
                leg_name(leg),
                forces.join(", ")
            ),
        ));
    }
    Ok(())
}

/// The rate of a table's clock (Hz), when it has one.
fn table_rate(t: &RecordingTable) -> Option<f64> {
    super::clock_of(t).0
}

/// How far below zero an envelope may reach, as a share of its peak, before the channel counts
/// as raw (bipolar) EMG.
const UNDERSHOOT: f64 = 0.1;

/// Whether the mapped EMG channels are envelopes already (`emg_is_envelope`), with a note
/// saying why. Raw EMG swings both ways around zero and needs a rate of twice the top of the
/// EMG band; an envelope is non-negative (up to a filter's small undershoot, [`UNDERSHOOT`]).
/// So EMG that is not bipolar is taken as an envelope when it is sampled below that rate, when
/// no value passes 1 (normalised), or when its file says so (a title or file name with
/// `envelope`, `filt` or `normali`, and not `raw` or `unfilt`).
fn envelope_guess(
    tables: &[(PathBuf, RecordingTable)],
    mine: &[Candidate<'_>],
    channels: &BTreeMap<String, ChannelMap>,
    notes: &mut Vec<String>,
) -> bool {
    let emg: Vec<&Candidate<'_>> = mine
        .iter()
        .filter(|c| {
            c.target.starts_with("emg_")
                && channels
                    .get(&c.target)
                    .is_some_and(|m| m.column == c.channel.label)
        })
        .collect();
    if emg.is_empty() {
        return false;
    }
    let raw_rate_hz = 2.0 * crate::checks::CheckSettings::default().emg_band_hz[1];
    let ranges: Vec<(f64, f64)> = emg.iter().map(|c| range(c.channel)).collect();
    // an envelope low-pass filtered after rectification undershoots zero a little (walk36's
    // tibialis anterior by 1.5 % of its peak); raw EMG reaches about as far below zero as
    // above it
    let bipolar = ranges
        .iter()
        .any(|&(lo, hi)| lo < -UNDERSHOOT * hi.max(0.0));
    let slowest = emg
        .iter()
        .filter_map(|c| table_rate(&tables[c.table].1))
        .fold(f64::INFINITY, f64::min);
    let mut reasons = Vec::new();
    if slowest < raw_rate_hz {
        reasons.push(format!(
            "sampled at {slowest:.1} Hz, below the {raw_rate_hz:.0} Hz raw EMG needs"
        ));
    }
    if ranges.iter().all(|&(_, hi)| hi <= 1.0) {
        reasons.push("every value within [0, 1]".into());
    }
    let says = |text: &str| {
        let t = text.to_ascii_lowercase();
        !t.contains("raw")
            && !t.contains("unfilt")
            && (t.contains("envelope") || t.contains("filt") || t.contains("normali"))
    };
    let mut told: Vec<usize> = emg.iter().map(|c| c.table).collect();
    told.dedup();
    for i in told {
        let (p, t) = &tables[i];
        let title = match &t.format {
            RecordingFormat::Storage { title, .. } => title.clone(),
            _ => None,
        };
        // the file's own name, not its path: the note reads the same wherever the file is
        let file = p
            .file_name()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_default();
        let stem = p
            .file_stem()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_default();
        if let Some(title) = title.filter(|s| says(s)) {
            reasons.push(format!("{file} is titled '{title}'"));
        } else if says(&stem) {
            reasons.push(format!("its file's name ({file}) says so"));
        }
    }
    if bipolar {
        if slowest < raw_rate_hz {
            notes.push(format!(
                "the EMG swings below zero like raw EMG but is sampled at {slowest:.1} Hz, \
                 below the {raw_rate_hz:.0} Hz raw EMG needs: check the file (an envelope \
                 needs \"emg_is_envelope\": true)"
            ));
        }
        return false;
    }
    if reasons.is_empty() {
        return false;
    }
    notes.push(format!(
        "the EMG channels are taken as envelopes already (emg_is_envelope: true): {}; set it \
         to false if they are raw EMG",
        reasons.join("; ")
    ));
    true
}
