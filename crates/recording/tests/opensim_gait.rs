//! A gait lab's OpenSim files read as OpenSim writes them: `inspect` on the bundled walk36
//! recording (CEINMS-RT's treadmill walking, `fixtures/walk36/`) and on small copies of its
//! headers with a few hundred rows, edited to test one convention at a time: the chosen ankle's
//! own moment (not the first `_moment` column) with OpenSim's sign flipped, gait2392's knee
//! sign, EMG envelopes recognised, the leg's vertical ground force as `grf_vertical_n`.

use recording::inspect::inspect;
use recording::{parse_map, read_trial_recording, read_unloaded_recording, RecordingError};
use std::path::{Path, PathBuf};

fn walk36() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../fixtures/walk36")
}

const FILES: [&str; 4] = ["emgFilt.sto", "ik.sto", "id.sto", "XLD.mot"];

fn fixture_files() -> Vec<PathBuf> {
    FILES.iter().map(|f| walk36().join(f)).collect()
}

/// A column of an OpenSim storage file by label.
fn sto_column(path: &Path, label: &str) -> Vec<f64> {
    let text = std::fs::read_to_string(path).unwrap();
    let t = opensim_files::read_sto(&text, &path.display().to_string()).unwrap();
    t.column(label).unwrap().to_vec()
}

#[test]
fn inspect_maps_walk36_by_opensim_conventions() {
    let found = inspect(&fixture_files(), &walk36()).unwrap();
    let map = found.map.expect("a starter map");
    let ch = |t: &str| {
        map.channels
            .get(t)
            .unwrap_or_else(|| panic!("no {t}: {map:?}"))
    };
    assert_eq!(ch("torque_nm").column, "ankle_angle_r_moment");
    assert_eq!(ch("torque_nm").sign, -1.0);
    assert_eq!(ch("torque_nm").file.as_deref(), Some("id.sto"));
    assert_eq!(ch("knee_angle_deg").column, "knee_angle_r");
    assert_eq!(ch("knee_angle_deg").sign, -1.0);
    assert_eq!(ch("ankle_angle_deg").column, "ankle_angle_r");
    assert_eq!(ch("ankle_angle_deg").sign, 1.0);
    assert_eq!(ch("emg_sol").column, "soleus_r");
    assert_eq!(ch("emg_gm").column, "med_gas_r");
    assert_eq!(ch("emg_gl").column, "lat_gas_r");
    assert_eq!(ch("emg_ta").column, "tib_ant_r");
    assert_eq!(ch("grf_vertical_n").column, "ground_force_vy");
    assert_eq!(ch("grf_vertical_n").file.as_deref(), Some("XLD.mot"));
    assert!(map.emg_is_envelope);
    assert!(found.unassigned.is_empty(), "{:?}", found.unassigned);
    let notes = found.notes.join("\n");
    assert!(notes.contains("Normalized EMG Linear Envelopes"), "{notes}");
    assert!(notes.contains("gait2392"), "{notes}");

    // the map, as written, reads the trial in surae's conventions
    let map = parse_map(&map.to_json_text(), &walk36().join("map.json")).unwrap();
    let rec = read_trial_recording(&map).unwrap();
    let t = &rec.trial;
    assert_eq!(t.len(), 6097);
    assert!(rec.emg_is_envelope);
    let moment = sto_column(&walk36().join("id.sto"), "ankle_angle_r_moment");
    assert_eq!(t.torque_nm, moment.iter().map(|m| -m).collect::<Vec<_>>());
    let knee = t.knee_angle_deg.as_ref().unwrap();
    assert!(
        knee.iter().all(|&k| (0.0..=71.0).contains(&k)),
        "flexion positive"
    );
    let force = sto_column(&walk36().join("XLD.mot"), "ground_force_vy");
    assert_eq!(t.grf_vertical_n.as_deref(), Some(force.as_slice()));
    // plantarflexion is positive: the push-off peak of the ankle moment
    let peak = t.torque_nm.iter().copied().fold(f64::MIN, f64::max);
    assert!((81.0..82.0).contains(&peak), "{peak}");
}

#[test]
fn the_committed_walk36_map_is_what_inspect_writes() {
    let found = inspect(&fixture_files(), &walk36()).unwrap();
    let committed = std::fs::read_to_string(walk36().join("map.json")).unwrap();
    assert_eq!(found.map.unwrap().to_json_text(), committed);
}

/// The header of `name` in walk36 and its first `rows` rows (`nRows` set to match).
fn excerpt(name: &str, rows: usize) -> String {
    let text = std::fs::read_to_string(walk36().join(name)).unwrap();
    let mut out = String::new();
    let mut data = None;
    for line in text.lines() {
        let keep = match data {
            None => {
                if line.trim() == "endheader" {
                    data = Some(0usize);
                }
                true
            }
            Some(n) => {
                data = Some(n + 1);
                n <= rows
            }
        };
        if keep {
            let line = if line.starts_with("nRows=") {
                format!("nRows={rows}")
            } else {
                line.to_string()
            };
            out.push_str(&line);
            out.push('\n');
        }
    }
    out
}

/// A storage text with its column label `from` renamed `to`.
fn relabel(text: &str, from: &str, to: &str) -> String {
    let mut lines: Vec<String> = text.lines().map(str::to_string).collect();
    let at = lines.iter().position(|l| l.starts_with("time\t")).unwrap();
    lines[at] = lines[at]
        .split('\t')
        .map(|l| if l == from { to } else { l })
        .collect::<Vec<_>>()
        .join("\t");
    lines.join("\n") + "\n"
}

/// `text` with its labels line replaced by `labels`, `nColumns` set to their count and the
/// fields of each data row mapped by `row`.
fn rewrite(text: &str, labels: &[&str], row: impl Fn(&[&str]) -> Vec<String>) -> String {
    let mut out = Vec::new();
    let mut data = false;
    for l in text.lines() {
        if l.starts_with("nColumns=") {
            out.push(format!("nColumns={}", labels.len()));
        } else if l.starts_with("time\t") {
            out.push(labels.join("\t"));
            data = true;
        } else if data {
            let f: Vec<&str> = l.split('\t').collect();
            out.push(row(&f).join("\t"));
        } else {
            out.push(l.to_string());
        }
    }
    out.join("\n") + "\n"
}

/// Writes the four files (300 rows each, with `edits` per file) into a temporary folder.
fn copies(edits: &[(&str, &dyn Fn(String) -> String)]) -> (tempfile::TempDir, Vec<PathBuf>) {
    let dir = tempfile::tempdir().unwrap();
    let mut paths = Vec::new();
    for f in FILES {
        let mut text = excerpt(f, 300);
        for (name, edit) in edits {
            if *name == f {
                text = edit(text);
            }
        }
        let p = dir.path().join(f);
        std::fs::write(&p, text).unwrap();
        paths.push(p);
    }
    (dir, paths)
}

#[test]
fn a_few_hundred_rows_map_the_same_and_read() {
    let (dir, paths) = copies(&[]);
    let map = inspect(&paths, dir.path()).unwrap().map.unwrap();
    let committed = recording::read_map(&walk36().join("map.json")).unwrap();
    assert_eq!(map.channels, committed.channels);
    assert!(map.emg_is_envelope);
    let map = parse_map(&map.to_json_text(), &dir.path().join("map.json")).unwrap();
    let t = read_trial_recording(&map).unwrap().trial;
    assert_eq!(t.len(), 300);
    assert_eq!(t.grf_vertical_n.as_ref().map(Vec::len), Some(300));
    // an unloaded run has no ground force
    let u = read_unloaded_recording(&map).unwrap();
    assert_eq!(u.len(), 300);
}

#[test]
fn the_torque_is_the_chosen_ankles_own_moment() {
    // a moment of another coordinate comes first in id.sto; the left ankle's moment too
    let id = |t: String| {
        // another coordinate's moment first, the other leg's ankle, a second ankle coordinate
        // of the same leg (a model with an ankle inversion), then the chosen ankle's
        let labels = [
            "time",
            "pelvis_tilt_moment",
            "ankle_angle_l_moment",
            "ankle_inversion_r_moment",
            "ankle_angle_r_moment",
        ];
        rewrite(&t, &labels, |f| {
            let m: f64 = f[1].parse().unwrap();
            vec![
                f[0].into(),
                "1.5".into(),
                (-m).to_string(),
                "0.5".into(),
                f[1].into(),
            ]
        })
    };
    let (dir, paths) = copies(&[("id.sto", &id)]);
    let found = inspect(&paths, dir.path()).unwrap();
    let map = found.map.unwrap();
    assert_eq!(map.channels["torque_nm"].column, "ankle_angle_r_moment");
    assert_eq!(map.channels["torque_nm"].sign, -1.0);
    assert!(
        found
            .notes
            .iter()
            .any(|n| n.contains("not mapped: ankle_angle_l_moment, ankle_inversion_r_moment")),
        "{:?}",
        found.notes
    );
    assert!(!found.notes.join(" ").contains("pelvis_tilt_moment"));

    // the left leg's EMG and angles: the left ankle's moment and the left foot's force
    let emg = |t: String| {
        ["soleus", "med_gas", "lat_gas", "tib_ant"]
            .iter()
            .fold(t, |t, m| relabel(&t, &format!("{m}_r"), &format!("{m}_l")))
    };
    let ik = |t: String| {
        let t = relabel(&t, "knee_angle_r", "knee_angle_l");
        relabel(&t, "ankle_angle_r", "ankle_angle_l")
    };
    let grf = |t: String| relabel(&t, "ground_force_vy", "l_ground_force_vy");
    let (dir, paths) = copies(&[
        ("emgFilt.sto", &emg),
        ("ik.sto", &ik),
        ("id.sto", &id),
        ("XLD.mot", &grf),
    ]);
    let found = inspect(&paths, dir.path()).unwrap();
    let map = found.map.unwrap();
    assert_eq!(map.channels["torque_nm"].column, "ankle_angle_l_moment");
    assert_eq!(map.channels["torque_nm"].sign, -1.0);
    assert_eq!(map.channels["grf_vertical_n"].column, "l_ground_force_vy");
    assert_eq!(map.channels["knee_angle_deg"].column, "knee_angle_l");
    // OpenSim's left-leg moment has the right leg's sign: no note asking to check it
    assert!(
        !found
            .notes
            .iter()
            .any(|n| n.contains("check the torque's sign")),
        "{:?}",
        found.notes
    );
}

#[test]
fn a_knee_positive_in_flexion_keeps_its_sign() {
    // a model whose knee coordinate is positive in flexion (Rajagopal's, 0 … 120°)
    let ik = |t: String| {
        rewrite(&t, &["time", "knee_angle_r", "ankle_angle_r"], |f| {
            let knee: f64 = f[1].parse().unwrap();
            vec![f[0].into(), (-knee).to_string(), f[2].into()]
        })
    };
    let (dir, paths) = copies(&[("ik.sto", &ik)]);
    let map = inspect(&paths, dir.path()).unwrap().map.unwrap();
    assert_eq!(map.channels["knee_angle_deg"].sign, 1.0);
}

#[test]
fn raw_emg_is_not_taken_for_an_envelope() {
    // the formats fixture's EMG is raw (µV, 2048 Hz, both signs)
    let d = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../fixtures/formats/opensim");
    let files: Vec<PathBuf> = ["emg.sto", "ik.mot", "id.sto"]
        .iter()
        .map(|f| d.join(f))
        .collect();
    let map = inspect(&files, &d).unwrap().map.unwrap();
    assert!(!map.emg_is_envelope);
    // walk36's envelopes with raw EMG's swings below zero, at 100 Hz: not an envelope either,
    // and a note says the file needs a look
    let emg = |t: String| {
        let labels = ["time", "soleus_r", "med_gas_r", "lat_gas_r", "tib_ant_r"];
        let odd = std::cell::Cell::new(false);
        rewrite(&t, &labels, |f| {
            odd.set(!odd.get());
            f.iter()
                .enumerate()
                .map(|(j, x)| {
                    if j > 0 && odd.get() {
                        (-x.parse::<f64>().unwrap()).to_string()
                    } else {
                        (*x).to_string()
                    }
                })
                .collect()
        })
    };
    let (dir, paths) = copies(&[("emgFilt.sto", &emg)]);
    let found = inspect(&paths, dir.path()).unwrap();
    assert!(!found.map.unwrap().emg_is_envelope);
    assert!(
        found
            .notes
            .iter()
            .any(|n| n.contains("below zero like raw EMG")),
        "{:?}",
        found.notes
    );
}

#[test]
fn a_ground_force_file_without_the_legs_vertical_force_is_an_error() {
    // only the left foot's vertical force, for a right leg
    let grf = |t: String| relabel(&t, "ground_force_vy", "l_ground_force_vy");
    let (dir, paths) = copies(&[("XLD.mot", &grf)]);
    let e = inspect(&paths, dir.path()).unwrap_err();
    let text = e.to_string();
    assert!(
        matches!(&e, RecordingError::Column { name, .. } if name == "ground_force_vy"),
        "{e:?}"
    );
    assert_eq!(e.path(), paths[3].display().to_string());
    assert!(text.contains("XLD.mot: column 'ground_force_vy'"), "{text}");
    assert!(text.contains("right foot"), "{text}");
    assert!(!text.contains('\n'), "{text}");
    // a force file with the horizontal forces only
    let grf = |t: String| relabel(&t, "ground_force_vy", "ground_force_vx");
    let (dir, paths) = copies(&[("XLD.mot", &grf)]);
    let e = inspect(&paths, dir.path()).unwrap_err().to_string();
    assert!(e.contains("column 'ground_force_vy'"), "{e}");
    assert!(e.contains("ground_force_vx"), "{e}");
}

#[test]
fn a_map_reads_the_vertical_force_and_names_a_missing_column() {
    let (dir, _) = copies(&[]);
    let map_text = std::fs::read_to_string(walk36().join("map.json")).unwrap();
    let bad = map_text.replace("\"ground_force_vy\"", "\"ground_force_vz\"");
    let map = parse_map(&bad, &dir.path().join("map.json")).unwrap();
    let e = read_trial_recording(&map).unwrap_err().to_string();
    assert!(
        e.contains("channels.grf_vertical_n.column") && e.contains("no column 'ground_force_vz'"),
        "{e}"
    );
    // the target's name is checked like every other
    let bad = map_text.replace("\"grf_vertical_n\"", "\"grf_vertical\"");
    let e = parse_map(&bad, &dir.path().join("map.json"))
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("channels.grf_vertical: not a channel of a trial"),
        "{e}"
    );
    assert!(e.contains("grf_vertical_n"), "{e}");
}
