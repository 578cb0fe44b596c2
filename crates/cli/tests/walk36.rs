//! The bundled real gait recording (`fixtures/walk36/`, CEINMS-RT's treadmill walking in
//! OpenSim files, with its CEINMS-RT subject XML) end to end through the `surae` binary:
//! `inspect` writes a map that reads it by OpenSim's conventions, `simulate` runs on that map
//! as it is and with the subject XML as parameters, `identify --session` draws the fit as an
//! ensemble over the strides, `diagnose --session` fits a window of strides and judges the trial
//! by the later strides held out, and bad input in the new parts (a ground
//! force file without the leg's vertical force, a subject XML missing a field) is refused with
//! exit 2, one line naming the file and the column, and nothing written.

mod common;

use common::{json, ok, refusal_problems, snapshot, surae};
use std::path::{Path, PathBuf};

fn walk36() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../fixtures/walk36")
}

fn fixture(name: &str) -> String {
    walk36().join(name).display().to_string()
}

/// Data rows of a CSV written by `surae simulate`.
fn rows(path: &Path) -> usize {
    std::fs::read_to_string(path)
        .unwrap()
        .lines()
        .filter(|l| !l.starts_with('#'))
        .count()
        - 1
}

#[test]
fn identify_draws_the_fit_over_the_strides_without_the_flagged_ones() {
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("id");
    let o = surae(
        &[
            "identify",
            "--method",
            "sa",
            "--session",
            &fixture("session.json"),
            "--chains",
            "1",
            "--quiet",
            "--out",
            out.to_str().unwrap(),
        ],
        tmp.path(),
    );
    ok(&o);
    let doc = json(&out.join("identify.json"));
    // eleven parameters (the recording defaults) and one chain, as asked
    assert_eq!(doc["params"].as_object().unwrap().len(), 11);
    assert_eq!(doc["sa"]["chains"], 1);
    assert!(
        doc["trials"][0]["r2"].as_f64().unwrap() > 0.8,
        "{}",
        doc["trials"][0]
    );
    assert!(out.join("strides_walk36.svg").is_file());
    let html = std::fs::read_to_string(out.join("report.html")).unwrap();
    // 49 strides from the ground force; the checks flag 5 (strides 4, 5, 28, 33, 45)
    assert!(
        html.contains(
            "mean ± sd over 44 of its 49 strides (5 flagged by the recording checks left out)"
        ),
        "the ensemble's caption"
    );
}

#[test]
fn inspect_writes_a_map_by_opensim_conventions() {
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("insp");
    let files: Vec<String> = ["emgFilt.sto", "ik.sto", "id.sto", "XLD.mot"]
        .iter()
        .map(|f| fixture(f))
        .collect();
    let mut args = vec!["inspect"];
    args.extend(files.iter().map(String::as_str));
    args.extend(["--out", out.to_str().unwrap()]);
    let o = surae(&args, tmp.path());
    ok(&o);
    let map = json(&out.join("map.json"));
    let ch = &map["channels"];
    assert_eq!(ch["torque_nm"]["column"], "ankle_angle_r_moment");
    assert_eq!(ch["torque_nm"]["sign"].as_f64(), Some(-1.0));
    assert_eq!(ch["knee_angle_deg"]["column"], "knee_angle_r");
    assert_eq!(ch["knee_angle_deg"]["sign"].as_f64(), Some(-1.0));
    assert_eq!(ch["ankle_angle_deg"]["column"], "ankle_angle_r");
    assert_eq!(ch["emg_sol"]["column"], "soleus_r");
    assert_eq!(ch["emg_gm"]["column"], "med_gas_r");
    assert_eq!(ch["emg_gl"]["column"], "lat_gas_r");
    assert_eq!(ch["emg_ta"]["column"], "tib_ant_r");
    assert_eq!(ch["grf_vertical_n"]["column"], "ground_force_vy");
    assert_eq!(map["emg_is_envelope"].as_bool(), Some(true));
    let report = json(&out.join("inspect.json"));
    assert_eq!(report["unassigned"].as_array().map(Vec::len), Some(0));

    // used as it is, from another working folder
    let sim = tmp.path().join("sim.csv");
    let o = surae(
        &[
            "simulate",
            "--trial",
            out.join("map.json").to_str().unwrap(),
            "--out",
            sim.to_str().unwrap(),
        ],
        Path::new("/"),
    );
    ok(&o);
    assert_eq!(rows(&sim), 6097);
}

#[test]
fn simulate_runs_on_the_committed_map() {
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("sim");
    let o = surae(
        &[
            "simulate",
            "--trial",
            &fixture("map.json"),
            "--out",
            out.to_str().unwrap(),
        ],
        tmp.path(),
    );
    ok(&o);
    assert_eq!(rows(&out.join("simulate.csv")), 6097);
    // and with CEINMS-RT's calibrated subject as the parameters
    let out = tmp.path().join("sim_xml");
    let o = surae(
        &[
            "simulate",
            "--trial",
            &fixture("map.json"),
            "--params",
            &fixture("subjectCalibrated.xml"),
            "--out",
            out.to_str().unwrap(),
        ],
        tmp.path(),
    );
    ok(&o);
    assert_eq!(rows(&out.join("simulate.csv")), 6097);
}

/// A session of the walk36 trial with `params`; its `simulate.json`.
fn session_simulate(dir: &Path, name: &str, params: serde_json::Value) -> serde_json::Value {
    let manifest = serde_json::json!({
        "params": params,
        "trials": [{"name": "walk", "recording": fixture("map.json")}],
    });
    let path = dir.join(format!("{name}.json"));
    std::fs::write(&path, manifest.to_string()).unwrap();
    let out = dir.join(name);
    let o = surae(
        &[
            "simulate",
            "--session",
            path.to_str().unwrap(),
            "--emg-is-envelope",
            "--out",
            out.to_str().unwrap(),
        ],
        dir,
    );
    ok(&o);
    json(&out.join("simulate.json"))
}

#[test]
fn a_session_takes_the_ceinms_rt_subject_as_its_parameters() {
    let tmp = tempfile::tempdir().unwrap();
    let xml = session_simulate(tmp.path(), "xml", fixture("subjectCalibrated.xml").into());
    // the same values written as a parameters JSON: F0 = maxIsometricForce ×
    // strengthCoefficient, LOM, LST, α0 of soleus_r, med_gas_r, lat_gas_r as the file writes them
    let s = 0.50000658823958;
    let params = serde_json::json!({"muscles": {
        "sol": {"fom_n": 3549.0 * s, "lom_m": 0.0511703542155837,
                "lst_m": 0.246520266638787, "alpha_deg": 24.9999998282},
        "gm": {"fom_n": 1558.0 * s, "lom_m": 0.0588682449818936,
               "lst_m": 0.371472993009162, "alpha_deg": 16.9999998373},
        "gl": {"fom_n": 683.0 * s, "lom_m": 0.0625302649952696,
               "lst_m": 0.361023072500765, "alpha_deg": 7.99999999086}}});
    let p = tmp.path().join("params.json");
    std::fs::write(&p, params.to_string()).unwrap();
    let by_hand = session_simulate(tmp.path(), "json", p.display().to_string().into());
    let rms = |v: &serde_json::Value| v["mean_rms_nm"].as_f64().unwrap();
    assert_eq!(rms(&xml), rms(&by_hand));
    // and they are not the nominal parameters' result
    let nominal = session_simulate(tmp.path(), "nominal", serde_json::Value::Null);
    assert_ne!(rms(&xml), rms(&nominal));
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
    assert!(problems.is_empty(), "{args:?}: {problems:?}");
    assert_eq!(snapshot(dir.path()), before, "{args:?}: files were written");
}

fn read(name: &str) -> String {
    std::fs::read_to_string(walk36().join(name)).unwrap()
}

#[test]
fn a_ground_force_file_without_the_vertical_force_is_refused() {
    // the right foot's vertical force renamed to its fore-aft one
    let mot = read("XLD.mot").replace("time\tground_force_vy", "time\tground_force_vx");
    let files = [
        ("emgFilt.sto", read("emgFilt.sto")),
        ("ik.sto", read("ik.sto")),
        ("id.sto", read("id.sto")),
        ("XLD.mot", mot),
    ];
    refused(
        &files,
        &["inspect", "emgFilt.sto", "ik.sto", "id.sto", "XLD.mot"],
        &["XLD.mot", "column 'ground_force_vy'", "right foot"],
    );
}

#[test]
fn a_ceinms_rt_subject_missing_a_field_is_refused() {
    let text = read("subjectCalibrated.xml");
    let field = "<tendonSlackLength>0.246520266638787</tendonSlackLength>";
    assert_eq!(text.matches(field).count(), 1);
    let files = [
        ("subject.xml", text.replace(field, "")),
        ("map.json", read("map.json")),
        ("emgFilt.sto", read("emgFilt.sto")),
        ("ik.sto", read("ik.sto")),
        ("id.sto", read("id.sto")),
        ("XLD.mot", read("XLD.mot")),
    ];
    refused(
        &files,
        &["simulate", "--trial", "map.json", "--params", "subject.xml"],
        &[
            "subject.xml:398:5",
            "(muscle soleus_r)",
            "missing `tendonSlackLength`",
        ],
    );
}

#[test]
fn diagnose_fits_a_window_of_strides_and_judges_the_trial_by_its_held_out_strides() {
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("diag");
    let o = surae(
        &[
            "diagnose",
            "--session",
            &fixture("session.json"),
            "--out",
            out.to_str().unwrap(),
        ],
        tmp.path(),
    );
    ok(&o);
    let said = format!(
        "{}{}",
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr)
    );
    // 61 s of walking: 5 of the 49 strides at the middle are fitted
    assert!(
        said.contains("diagnosed on 5 of its 49 strides (25.8–31.5 s"),
        "{said}"
    );
    let all = json(&out.join("diagnosis_session.json"));
    let h = &all["held_out_shape"];
    let trial = &h["per_trial"][0];
    assert_eq!(trial["name"], "walk36");
    let part = &trial["parts"][0];
    // the later strides predicted by the first half's calibration, without the 3 flagged ones
    assert_eq!(part["fold"], "later_strides", "{trial}");
    assert_eq!(part["segments"], 20, "{trial}");
    assert!(part["r2"].as_f64().unwrap() > 0.8, "{trial}");
    // the residual the model leaves there has the first half's shape in every stride
    assert_eq!(trial["reproducible"], true, "{trial}");
    assert!(trial["p_value"].as_f64().unwrap() < 1e-3, "{trial}");
    assert_eq!(all["verdict"], "deficient");
    let one = json(&out.join("walk36/diagnosis.json"));
    assert_eq!(one["verdict"], "deficient");
    assert_eq!(one["held_out_shape"]["reproducible"], true);
}
