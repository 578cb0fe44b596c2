//! `surae validate` on the bundled gait trial (`fixtures/walk36/`): with the recording defaults
//! the later strides are predicted better than by the linear baseline and CEINMS-RT's own
//! calibration; each held-out part is also
//! scored stride by stride, with the strides the recording checks flag marked, and drawn as
//! ensembles over the strides without the flagged ones; bad input in those parts (a ground
//! force file without the map's vertical force column, a stride shorter than 0.2 s, condition
//! labels that cannot make the leave-one-condition-out folds) is refused with exit 2, one line
//! naming the file and the column or key, and nothing written.

mod common;

use common::{json, ok, refusal_problems, snapshot, surae};
use std::path::{Path, PathBuf};

fn walk36() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../fixtures/walk36")
}

fn read(name: &str) -> String {
    std::fs::read_to_string(walk36().join(name)).unwrap()
}

/// The fixture's files, `edit` applied to them by name.
fn walk36_files(edit: impl Fn(&str, String) -> String) -> Vec<(&'static str, String)> {
    [
        "session.json",
        "map.json",
        "uncalibratedSubject.xml",
        "emgFilt.sto",
        "ik.sto",
        "id.sto",
        "XLD.mot",
    ]
    .into_iter()
    .map(|n| (n, edit(n, read(n))))
    .collect()
}

/// Runs `args` (with `--out fresh`) in a folder holding `files` and checks the refusal: exit 2,
/// one line naming every needle, nothing created or changed.
fn refused(files: &[(&str, String)], args: &[&str], needles: &[&str]) {
    let dir = tempfile::tempdir().unwrap();
    for (name, text) in files {
        std::fs::write(dir.path().join(name), text).unwrap();
    }
    let before = snapshot(dir.path());
    let mut all: Vec<&str> = args.to_vec();
    all.extend(["--out", "fresh"]);
    let o = surae(&all, dir.path());
    let needles: Vec<String> = needles.iter().map(|s| (*s).to_string()).collect();
    let problems = refusal_problems(&o, &needles);
    assert!(
        problems.is_empty(),
        "{args:?}: {problems:?}\nstderr: {}",
        String::from_utf8_lossy(&o.stderr)
    );
    assert!(
        !dir.path().join("fresh").exists(),
        "{args:?}: out folder made"
    );
    assert_eq!(snapshot(dir.path()), before, "{args:?}: files were written");
}

const VALIDATE: [&str; 3] = ["validate", "--session", "session.json"];

#[test]
fn held_out_strides_are_scored_and_drawn_without_the_flagged_ones() {
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("val");
    let session = walk36().join("session.json");
    let peer = walk36().join("subjectCalibrated.xml");
    let o = surae(
        &[
            "validate",
            "--session",
            session.to_str().unwrap(),
            "--peer",
            peer.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
        ],
        tmp.path(),
    );
    ok(&o);
    let v = json(&out.join("validate.json"));
    // the recording defaults calibrated on the first half predict the later strides better
    // than the linear EMG baseline fitted on the same half and than CEINMS-RT's calibration
    let scheme = &v["schemes"][0];
    let rms = |who: &serde_json::Value| who["rms_nm"].as_f64().unwrap();
    let (model, linear) = (rms(&scheme["model"]), rms(&scheme["linear"]));
    let peer_rms = rms(&scheme["peers"]["subjectCalibrated"]);
    assert!(
        model < linear && model < peer_rms,
        "model {model} linear {linear} peer {peer_rms}"
    );
    let folds = v["folds"].as_array().unwrap();
    assert_eq!(folds.len(), 1, "one trial: the later strides only");
    let h = &folds[0]["held_out"][0];
    let (a, b) = (
        h["span_s"][0].as_f64().unwrap(),
        h["span_s"][1].as_f64().unwrap(),
    );
    let strides = h["strides"].as_array().unwrap();
    assert!(strides.len() >= 20, "{}", strides.len());
    let mut samples = 0;
    let mut last_end = a;
    for s in strides {
        let (s0, s1) = (s["start_s"].as_f64().unwrap(), s["end_s"].as_f64().unwrap());
        // inside the held-out span, in order, not overlapping
        assert!(s0 >= last_end - 1e-9 && s1 > s0 && s1 <= b + 0.011, "{s}");
        last_end = s1;
        for who in ["model", "linear"] {
            assert!(s[who]["rms_nm"].as_f64().unwrap() > 0.0, "{s}");
            assert!(s[who]["r2"].as_f64().unwrap() <= 1.0, "{s}");
        }
        assert!(s["peers"]["subjectCalibrated"]["rms_nm"].as_f64().unwrap() > 0.0);
        samples += s["samples"].as_u64().unwrap();
    }
    assert!(samples <= h["samples"].as_u64().unwrap());
    // the recording checks of the trial (`surae inspect map.json`: checks.strides.flagged)
    // flag strides 4, 5, 28, 33 and 45; the held-out half holds the last three
    let flagged: Vec<u64> = strides
        .iter()
        .filter(|s| s["flagged"].as_bool().unwrap())
        .map(|s| s["stride"].as_u64().unwrap())
        .collect();
    assert_eq!(flagged, vec![28, 33, 45]);
    let kept = strides.len() - 3;
    let stem = "later_strides_later_strides_walk36";
    for f in ["", "_strides", "_residual"] {
        let p = out.join(format!("{stem}{f}.svg"));
        assert!(p.is_file(), "{} missing", p.display());
    }
    let svg = std::fs::read_to_string(out.join(format!("{stem}_strides.svg"))).unwrap();
    assert!(
        svg.contains(&format!("measured ({kept} strides)")),
        "kept strides"
    );
    let html = std::fs::read_to_string(out.join("report.html")).unwrap();
    let caption = format!(
        "over {kept} of its {} held-out strides; 3 strides flagged by the recording checks left out",
        strides.len()
    );
    assert_eq!(html.matches(&caption).count(), 2, "{caption}");
}

#[test]
fn a_ground_force_file_without_the_maps_vertical_force_column_is_refused() {
    let files = walk36_files(|name, text| {
        if name == "XLD.mot" {
            text.replace("time\tground_force_vy", "time\tground_force_vx")
        } else {
            text
        }
    });
    refused(
        &files,
        &VALIDATE,
        &[
            "XLD.mot",
            "channels.grf_vertical_n",
            "no column 'ground_force_vy'",
        ],
    );
}

/// The force of `XLD.mot` with a dip below the stance threshold 0.1 s after the first foot
/// strike: that stance lasts 0.1 s and its stride 0.12 s.
fn with_a_short_stride(mot: &str) -> String {
    let mut lines: Vec<String> = mot.lines().map(str::to_string).collect();
    let h = lines
        .iter()
        .position(|l| l == "time\tground_force_vy")
        .unwrap();
    let force = |l: &str| -> f64 { l.split('\t').nth(1).unwrap().parse().unwrap() };
    let strike = (h + 2..lines.len())
        .find(|&i| force(&lines[i]) > 20.0 && force(&lines[i - 1]) <= 20.0)
        .unwrap();
    for i in [strike + 10, strike + 11] {
        assert!(force(&lines[i]) > 20.0, "the dip falls in stance");
        let t = lines[i].split('\t').next().unwrap().to_string();
        lines[i] = format!("{t}\t0");
    }
    lines.join("\n") + "\n"
}

#[test]
fn a_stride_shorter_than_0_2_s_is_refused_naming_the_force_file_and_column() {
    let files = walk36_files(|name, text| {
        if name == "XLD.mot" {
            with_a_short_stride(&text)
        } else {
            text
        }
    });
    refused(
        &files,
        &VALIDATE,
        &[
            "XLD.mot: column ground_force_vy",
            "stride 0 from 0.61 s to 0.73 s",
            "shorter than the 0.2 s",
        ],
    );
}

#[test]
fn condition_labels_that_cannot_make_the_folds_are_refused_naming_the_manifest_key() {
    let session = |trials: &str| -> Vec<(&'static str, String)> {
        walk36_files(|name, text| {
            if name == "session.json" {
                format!(r#"{{"params": "uncalibratedSubject.xml", "trials": [{trials}]}}"#)
            } else {
                text
            }
        })
    };
    let fold = [
        "validate",
        "--session",
        "session.json",
        "--folds",
        "condition",
    ];
    // no label
    refused(
        &session(r#"{"name": "walk36", "recording": "map.json"}"#),
        &fold,
        &["session.json: trials[0].condition: missing (trial walk36)"],
    );
    // a second trial without one
    refused(
        &session(
            r#"{"name": "a", "recording": "map.json", "condition": "slow"},
               {"name": "b", "recording": "map.json"}"#,
        ),
        &fold,
        &["session.json: trials[1].condition: missing (trial b)"],
    );
    // one label only
    refused(
        &session(
            r#"{"name": "a", "recording": "map.json", "condition": "walk"},
               {"name": "b", "recording": "map.json", "condition": "walk"}"#,
        ),
        &fold,
        &[
            "session.json: trials[0].condition, trials[1].condition",
            "every trial is labelled \"walk\"",
            "at least two conditions",
        ],
    );
    // a label that is not a string, or empty, is refused whatever the folds
    refused(
        &session(r#"{"name": "walk36", "recording": "map.json", "condition": 3.6}"#),
        &VALIDATE,
        &["session.json: trials[0].condition: 3.6 is not a text label (trial walk36)"],
    );
    refused(
        &session(r#"{"name": "walk36", "recording": "map.json", "condition": ""}"#),
        &VALIDATE,
        &["session.json: trials[0].condition: is empty (trial walk36)"],
    );
}

#[test]
fn extensions_are_judged_against_the_plain_calibration_on_the_same_folds() {
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("ext");
    let session = walk36().join("session.json");
    ok(&surae(
        &[
            "validate",
            "--session",
            session.to_str().unwrap(),
            "--extensions",
            "--chains",
            "1",
            "--quiet",
            "--out",
            out.to_str().unwrap(),
        ],
        tmp.path(),
    ));
    let doc = json(&out.join("validate.json"));
    let plain = &doc["schemes"][0]["model"];
    let study = &doc["extensions"];
    let names: Vec<&str> = study["candidates"]
        .as_array()
        .unwrap()
        .iter()
        .map(|c| c["name"].as_str().unwrap())
        .collect();
    assert_eq!(
        names,
        [
            "tendon_compliance",
            "eccentric_plateau",
            "activation_dynamics",
            "antagonist",
            "emg_normalisation"
        ]
    );
    let mut runs: Vec<&serde_json::Value> =
        study["candidates"].as_array().unwrap().iter().collect();
    if !study["combined"].is_null() {
        runs.push(&study["combined"]);
    }
    let mut best: Option<(f64, &str)> = None;
    for r in &runs {
        assert!(r["skipped"].is_null(), "{r}");
        let s = &r["schemes"][0];
        assert_eq!(s["scheme"], "later_strides");
        assert_eq!(
            &s["plain"], plain,
            "{}: the same plain calibration",
            r["name"]
        );
        let (p, m) = (
            s["plain"]["rms_nm"].as_f64().unwrap(),
            s["model"]["rms_nm"].as_f64().unwrap(),
        );
        let gain = s["gain_pct"].as_f64().unwrap();
        assert!((gain - 100.0 * (p - m) / p).abs() < 1e-9, "{r}");
        assert_eq!(r["helps"].as_bool().unwrap(), gain > 0.0, "{r}");
        if gain > 0.0 && best.is_none_or(|(b, _)| m < b) {
            best = Some((m, r["name"].as_str().unwrap()));
        }
    }
    assert_eq!(study["best"].as_str(), best.map(|b| b.1));
    let emg = &study["candidates"][4];
    assert_eq!(emg["emg_normalisation"], "trial");
    // the compliant tendon is calibrated within its recording range, 0.5–3 times the subject's
    // 0.04 strain at F0
    let e0t = study["candidates"][0]["fold_values"][0]["curves.e0t"]
        .as_f64()
        .unwrap();
    assert!((0.02..=0.12).contains(&e0t), "{e0t}");
    // the antagonist's gain, from the TA envelope of the recording, within its range
    let gain = study["candidates"][3]["fold_values"][0]["antagonist_coactivation.gain_nm"]
        .as_f64()
        .unwrap();
    assert!((0.0..=100.0).contains(&gain), "{gain}");
}

#[test]
fn free_names_mixing_added_and_plain_ones_are_refused() {
    let files = walk36_files(|_, t| t);
    let mut args = VALIDATE.to_vec();
    args.extend(["--free", "+curves.e0t,sol.lst_m"]);
    refused(&files, &args, &["--free", "leading +"]);
}
