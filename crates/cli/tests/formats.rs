//! One synthetic trial in every format a lab's recording may come in (`fixtures/formats/`:
//! the trial CSV, OpenSim `.sto` EMG + `.mot` angle + `.sto` moment, a C3D, a Noraxon-style
//! tab-separated export in mV and µV with a sign flip and offsets, a semicolon / decimal-comma
//! export), each read through its recording map: every command sees the same trial.

mod common;

use common::{json, ok, surae};
use std::path::{Path, PathBuf};

fn formats_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../fixtures/formats")
}

/// What `--trial` is given for each format.
fn trials() -> Vec<(&'static str, PathBuf)> {
    let d = formats_dir();
    vec![
        ("csv", d.join("trial.csv")),
        ("opensim", d.join("opensim/map.json")),
        ("c3d", d.join("c3d/map.json")),
        ("noraxon", d.join("noraxon/map.json")),
        ("semicolon", d.join("semicolon/map.json")),
    ]
}

/// A numeric column of a CSV written by `surae simulate`.
fn column(path: &Path, name: &str) -> Vec<f64> {
    let text = std::fs::read_to_string(path).unwrap();
    let mut lines = text.lines().filter(|l| !l.starts_with('#'));
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    let j = header.iter().position(|h| *h == name).unwrap();
    lines
        .map(|l| l.split(',').nth(j).unwrap().parse().unwrap())
        .collect()
}

#[test]
fn every_format_gives_the_same_simulated_torque() {
    let dir = tempfile::tempdir().unwrap();
    let mut torques = Vec::new();
    for (name, trial) in trials() {
        let out = dir.path().join(format!("{name}.csv"));
        let o = surae(
            &[
                "simulate",
                "--trial",
                trial.to_str().unwrap(),
                "--out",
                out.to_str().unwrap(),
            ],
            dir.path(),
        );
        ok(&o);
        torques.push((name, column(&out, "torque_nm"), column(&out, "time_s")));
    }
    let (_, reference, ref_time) = &torques[0];
    assert!(reference.len() > 6000);
    for (name, torque, time) in &torques[1..] {
        assert_eq!(time, ref_time, "{name}: time");
        let worst = torque
            .iter()
            .zip(reference)
            .map(|(a, b)| (a - b).abs())
            .fold(0.0, f64::max);
        assert!(worst <= 0.01, "{name}: torque differs by {worst} N·m");
        // every format carries the fixture's numbers exactly, so the torque is bitwise the same
        assert_eq!(torque, reference, "{name}: torque not bitwise equal");
    }
}

#[test]
fn every_format_gives_the_same_sa_identification() {
    let dir = tempfile::tempdir().unwrap();
    let unloaded = formats_dir().join("unloaded.csv");
    let mut results = Vec::new();
    for (name, trial) in trials() {
        let out = dir.path().join(name);
        let o = surae(
            &[
                "identify",
                "--method",
                "sa",
                "--seed",
                "5",
                "--quiet",
                "--trial",
                trial.to_str().unwrap(),
                "--unloaded",
                unloaded.to_str().unwrap(),
                "--out",
                out.to_str().unwrap(),
            ],
            dir.path(),
        );
        ok(&o);
        results.push((name, json(&out.join("identify.json"))));
    }
    let reference = results[0].1["params"].as_object().unwrap().clone();
    assert_eq!(reference.len(), 9);
    for (name, r) in &results[1..] {
        for (k, v) in &reference {
            let a = v.as_f64().unwrap();
            let b = r["params"][k].as_f64().unwrap();
            let rel = (a - b).abs() / a.abs();
            assert!(rel <= 1e-3, "{name}: {k} = {b}, csv gives {a} ({rel:e})");
        }
        assert_eq!(
            r["rms_nm"].as_f64(),
            results[0].1["rms_nm"].as_f64(),
            "{name}: rms"
        );
    }
}

/// `surae inspect` on each example file writes a starter map that, used as it is, reads the
/// file: every channel the trial needs is found, and the mapped trial has the file's length.
#[test]
fn inspect_prints_a_map_that_reads_each_example_file() {
    let d = formats_dir();
    let cases: Vec<(&str, Vec<PathBuf>)> = vec![
        ("csv", vec![d.join("trial.csv")]),
        (
            "opensim",
            vec![
                d.join("opensim/emg.sto"),
                d.join("opensim/ik.mot"),
                d.join("opensim/id.sto"),
            ],
        ),
        ("c3d", vec![d.join("c3d/trial.c3d")]),
        ("noraxon", vec![d.join("noraxon/export.tsv")]),
        ("semicolon", vec![d.join("semicolon/export.csv")]),
    ];
    let tmp = tempfile::tempdir().unwrap();
    for (name, files) in cases {
        let out = tmp.path().join(name);
        let mut args: Vec<String> = vec!["inspect".into()];
        args.extend(files.iter().map(|f| f.display().to_string()));
        args.push("--out".into());
        args.push(out.display().to_string());
        let args: Vec<&str> = args.iter().map(String::as_str).collect();
        let o = surae(&args, tmp.path());
        ok(&o);
        let stdout = String::from_utf8_lossy(&o.stdout);
        assert!(stdout.contains("starter recording map"), "{name}: {stdout}");
        let report = json(&out.join("inspect.json"));
        assert_eq!(
            report["unassigned"].as_array().map(Vec::len),
            Some(0),
            "{name}: {report}"
        );
        let map_path = out.join("map.json");
        // the map as written reads the file, from another working directory
        let sim = tmp.path().join(format!("{name}_sim.csv"));
        let o = surae(
            &[
                "simulate",
                "--trial",
                map_path.to_str().unwrap(),
                "--out",
                sim.to_str().unwrap(),
            ],
            Path::new("/"),
        );
        ok(&o);
        assert!(column(&sim, "time_s").len() > 6000, "{name}");
    }
    // the Noraxon export's left leg was chosen, the right soleus left out, and its mV
    // channels flagged for calibration
    let notes = json(&tmp.path().join("noraxon/inspect.json"))["notes"].to_string();
    assert!(notes.contains("left"), "{notes}");
    assert!(notes.contains("RT SOLEUS"), "{notes}");
    assert!(notes.contains("calibration"), "{notes}");
    // OpenSim's moment gets its sign flipped
    let map = json(&tmp.path().join("opensim/map.json"));
    assert_eq!(map["channels"]["torque_nm"]["sign"].as_f64(), Some(-1.0));
    assert_eq!(
        map["channels"]["torque_nm"]["column"].as_str(),
        Some("ankle_angle_r_moment")
    );
}

/// A map read by `inspect` reports the trial and the recording checks.
#[test]
fn inspect_of_a_map_reports_the_checks() {
    let tmp = tempfile::tempdir().unwrap();
    let map = formats_dir().join("noraxon/map.json");
    let o = surae(
        &[
            "inspect",
            map.to_str().unwrap(),
            "--out",
            tmp.path().join("o").to_str().unwrap(),
        ],
        tmp.path(),
    );
    ok(&o);
    let stdout = String::from_utf8_lossy(&o.stdout);
    assert!(stdout.contains("isokinetic"), "{stdout}");
    let r = json(&tmp.path().join("o/inspect.json"));
    assert_eq!(r["checks"]["motion"]["isokinetic"], true, "{r}");
    assert!(r["checks"]["sign"]["correlation"].as_f64().unwrap() > 0.5);
    assert_eq!(r["checks"]["warnings"].as_array().map(Vec::len), Some(0));
}

/// With a decimal calibration (0.0749 N·m/mV, 0.1024 °/mV), mapped numbers can differ from the
/// originals in their last bit; the simulated torque stays within 0.01 N·m.
#[test]
fn a_decimal_calibration_stays_within_a_hundredth_of_a_newton_metre() {
    let d = formats_dir();
    let trial = experiment::read_trial(d.join("trial.csv")).unwrap();
    let tmp = tempfile::tempdir().unwrap();
    let (sa, oa, st, ot) = (0.1024, -35.2, 0.0749, 0.69);
    let mut text = String::from(
        "\"Time,s\"\t\"CN ANGLE,mV\"\t\"CN TORQUE,mV\"\t\"SOL,uV\"\t\"MG,uV\"\t\"LG,uV\"\n",
    );
    for i in 0..trial.len() {
        text.push_str(&format!(
            "{}\t{}\t{}\t{}\t{}\t{}\n",
            trial.time_s[i],
            (trial.ankle_angle_deg[i] - oa) / sa,
            (-trial.torque_nm[i] - ot) / st,
            trial.emg_sol[i] * 1000.0,
            trial.emg_gm[i] * 1000.0,
            trial.emg_gl[i] * 1000.0
        ));
    }
    std::fs::write(tmp.path().join("export.tsv"), text).unwrap();
    let map = serde_json::json!({"file": "export.tsv", "channels": {
        "ankle_angle_deg": {"column": "CN ANGLE,mV", "scale": sa, "offset": oa},
        "torque_nm": {"column": "CN TORQUE,mV", "scale": st, "offset": ot, "sign": -1},
        "emg_sol": {"column": "SOL,uV", "scale": 0.001},
        "emg_gm": {"column": "MG,uV", "scale": 0.001},
        "emg_gl": {"column": "LG,uV", "scale": 0.001}}});
    std::fs::write(tmp.path().join("map.json"), map.to_string()).unwrap();
    let mapped = tmp.path().join("map.json");
    let mut cols = Vec::new();
    for t in [d.join("trial.csv"), mapped] {
        let out = tmp.path().join("sim.csv");
        ok(&surae(
            &[
                "simulate",
                "--trial",
                t.to_str().unwrap(),
                "--out",
                out.to_str().unwrap(),
            ],
            tmp.path(),
        ));
        cols.push(column(&out, "torque_nm"));
    }
    let worst = cols[0]
        .iter()
        .zip(&cols[1])
        .map(|(a, b)| (a - b).abs())
        .fold(0.0, f64::max);
    assert!(worst <= 0.01, "torque differs by {worst} N·m");
}

/// A session trial and its unloaded run may be recording maps too.
#[test]
fn a_session_takes_recording_maps() {
    let d = formats_dir();
    let tmp = tempfile::tempdir().unwrap();
    // the unloaded run through a map as well (its CSV read as delimited text)
    let unloaded_map = tmp.path().join("unloaded_map.json");
    std::fs::write(
        &unloaded_map,
        serde_json::json!({"file": d.join("unloaded.csv"), "channels": {
            "ankle_angle_deg": {"column": "ankle_angle_deg"},
            "torque_nm": {"column": "torque_nm"}}})
        .to_string(),
    )
    .unwrap();
    let manifest = serde_json::json!({
        "mvc": [d.join("noraxon/map.json")],
        "trials": [
        {"name": "c3d", "recording": d.join("c3d/map.json"), "unloaded": d.join("unloaded.csv")},
        {"name": "csv", "trial": d.join("trial.csv"), "unloaded": unloaded_map}]});
    let s = tmp.path().join("session.json");
    std::fs::write(&s, manifest.to_string()).unwrap();
    let out = tmp.path().join("o");
    let o = surae(
        &[
            "simulate",
            "--session",
            s.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
        ],
        tmp.path(),
    );
    ok(&o);
    let r = json(&out.join("simulate.json"));
    let t = r["trials"].as_array().unwrap();
    assert_eq!(t.len(), 2);
    assert_eq!(t[0]["rms_nm"], t[1]["rms_nm"], "{r}");
    // the MVC trial (a map too) sets one reference per channel, printed one line each
    assert_eq!(r["emg_normalisation"]["source"], "mvc", "{r}");
    let stdout = String::from_utf8_lossy(&o.stdout);
    for ch in ["emg_sol", "emg_gm", "emg_gl"] {
        assert!(
            stdout.lines().any(|l| l.contains(ch)
                && l.contains("reference")
                && l.contains("largest envelope over the MVC trials")),
            "{stdout}"
        );
    }
}

/// A CEINMS trial folder given as `--trial` is a session of one: `simulate` gives what a
/// manifest naming it as a `recording` gives, `inspect` lists its files, and options that do
/// not apply to it are refused.
#[test]
fn a_ceinms_folder_is_a_trial_of_its_own() {
    use common::{ceinms_folder, CeinmsFolder};
    let tmp = tempfile::tempdir().unwrap();
    let d = tmp.path();
    let (truth, none) = (
        muscle_model::ModelParams::nominal(),
        muscle_model::Effects::none(),
    );
    ceinms_folder(
        &d.join("walk"),
        &CeinmsFolder {
            seed: 21,
            seconds: 2.0,
            truth: &truth,
            effects: &none,
            noise: false,
            lead_in_s: 0.1,
        },
    );
    std::fs::write(
        d.join("s.json"),
        r#"{"trials": [{"name": "walk", "recording": "walk"}]}"#,
    )
    .unwrap();
    ok(&surae(
        &["simulate", "--trial", "walk", "--out", "by_trial"],
        d,
    ));
    ok(&surae(
        &["simulate", "--session", "s.json", "--out", "by_session"],
        d,
    ));
    let (a, b) = (
        json(&d.join("by_trial/simulate.json")),
        json(&d.join("by_session/simulate.json")),
    );
    assert_eq!(a["trials"], b["trials"]);
    assert!(a["trials"][0]["r2"].as_f64().unwrap() > 0.99, "{a}");
    let o = surae(&["inspect", "walk", "--out", "insp"], d);
    ok(&o);
    let r = json(&d.join("insp/inspect.json"));
    assert_eq!(r["files"].as_array().map(Vec::len), Some(4), "{r}");
    assert!(r["map"].is_null());
    let o = surae(
        &[
            "identify",
            "--method",
            "sa",
            "--trial",
            "walk",
            "--unloaded",
            "walk/emg.txt",
        ],
        d,
    );
    assert_eq!(o.status.code(), Some(2));
    assert!(common::stderr_of(&o).contains("no unloaded run"));
}
