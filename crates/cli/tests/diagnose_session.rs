//! `surae diagnose --session`: a CEINMS trial folder (written here from a synthetic trial,
//! never from real recordings) with a hidden electromechanical delay is diagnosed with the
//! delay named; the same folder without the delay is adequate, with the effects that need a
//! joint angle reported as not testable; a session of trial CSVs gives what `--trial` and
//! `--unloaded` give.

use ceinms_files::format_table;
use experiment::{random_error, synthesize, DynamometerSettings, Recording, SynthConfig};
use muscle_model::{simulate, Effects, GeometrySeries, ModelParams, Muscle, SimSettings};
use serde_json::Value;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn surae(args: &[&str], cwd: &Path) -> Output {
    Command::new(env!("CARGO_BIN_EXE_surae"))
        .args(args)
        .current_dir(cwd)
        .output()
        .expect("the surae binary runs")
}

fn ok(o: &Output) {
    assert!(
        o.status.success(),
        "exit {:?}\nstdout: {}\nstderr: {}",
        o.status.code(),
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr)
    );
}

fn json(path: &Path) -> Value {
    serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap()
}

/// CEINMS names of the muscles written, surae's name of each.
const MUSCLES: [(&str, &str); 4] = [
    ("sol_r", "sol"),
    ("gasmed_r", "gm"),
    ("gaslat_r", "gl"),
    ("tibant_r", "tibant_r"),
];

/// Lead-in of the EMG before the moment file's first sample (s), as in CEINMS's trials.
const LEAD_IN_S: f64 = 0.13;

/// The first `seconds` of a synthetic trial written as a CEINMS folder: envelopes at the
/// trial's rate, lengths and moment arms at 250 Hz (CEINMS's sign, plantarflexion negative),
/// and the moment of `truth` with `effects` plus the dynamometer's seeded random error, from
/// [`LEAD_IN_S`] on, at 250 Hz.
fn ceinms_folder(dir: &Path, seed: u64, seconds: f64, truth: &ModelParams, effects: &Effects) {
    std::fs::create_dir_all(dir).unwrap();
    let syn = synthesize(&SynthConfig::new("seed".parse().unwrap(), seed)).unwrap();
    let fs = syn.inputs.fs();
    let n = ((seconds * fs) as usize).min(syn.inputs.len());
    let t: Vec<f64> = syn.inputs.times()[..n].to_vec();
    let write = |file: &str, names: &[&str], time: &[f64], cols: &[Vec<f64>]| {
        let cols: Vec<&[f64]> = cols.iter().map(Vec::as_slice).collect();
        std::fs::write(dir.join(file), format_table(names, time, &cols).unwrap()).unwrap();
    };
    let ta_env: Vec<f64> = t.iter().map(|t| 0.1 + 0.05 * (3.0 * t).sin()).collect();
    let env = |m: Muscle| syn.inputs.envelope(m)[..n].to_vec();
    let names: Vec<&str> = MUSCLES.iter().map(|m| m.0).collect();
    write(
        "emg.txt",
        &names,
        &t,
        &[
            env(Muscle::Sol),
            env(Muscle::Gm),
            env(Muscle::Gl),
            ta_env.clone(),
        ],
    );
    let grid: Vec<f64> = (0..)
        .map(|k| t[0] + k as f64 / 250.0)
        .take_while(|&s| s <= t[n - 1])
        .collect();
    let q: Vec<f64> = grid.iter().map(|&s| syn.inputs.angle_value_at(s)).collect();
    let mut lmt = Vec::new();
    let mut ma = Vec::new();
    for m in Muscle::ALL {
        let p = truth.muscle(m);
        lmt.push(q.iter().map(|&q| p.lmt(q)).collect::<Vec<_>>());
        ma.push(q.iter().map(|&q| -p.moment_arm(q)).collect::<Vec<_>>());
    }
    lmt.push(q.iter().map(|&q| 0.32 - 0.035 * q).collect());
    ma.push(vec![0.035; grid.len()]);
    write("lmt.txt", &names, &grid, &lmt);
    write("R_ankle_feMa.txt", &names, &grid, &ma);

    // the model's moment on the series the reader builds (no ankle angle: the lengths and
    // moment arms carry the motion)
    let resample = |v: &[f64]| numerics::interpolate::resample_linear(&grid, v, &t).unwrap();
    let mut inputs = muscle_model::TrialInputs::new(
        fs,
        t[0],
        vec![0.0; n],
        [env(Muscle::Sol), env(Muscle::Gm), env(Muscle::Gl)],
        None,
    )
    .unwrap()
    .with_envelope("tibant_r", ta_env)
    .unwrap();
    for (k, (_, name)) in MUSCLES.iter().enumerate() {
        inputs = inputs
            .with_geometry(
                name,
                GeometrySeries {
                    lmt_m: resample(&lmt[k]),
                    moment_arm_m: resample(&ma[k]).iter().map(|r| -r).collect(),
                },
            )
            .unwrap();
    }
    let sim = simulate(&inputs, truth, effects, &SimSettings::default()).unwrap();
    let noise = random_error(
        n,
        1.0 / fs,
        &DynamometerSettings::default(),
        seed,
        Recording::Trial,
    )
    .unwrap();
    let measured: Vec<f64> = sim.torque.iter().zip(&noise).map(|(a, b)| a + b).collect();
    let moment_t: Vec<f64> = grid
        .iter()
        .copied()
        .filter(|&s| s >= t[0] + LEAD_IN_S)
        .collect();
    let moment: Vec<f64> = numerics::interpolate::resample_linear(&t, &measured, &moment_t)
        .unwrap()
        .iter()
        .map(|x| -x)
        .collect();
    write(
        "R_ankle_feTorque.txt",
        &["R_ankle_fe"],
        &moment_t,
        &[moment],
    );
}

/// A CEINMS subject XML holding `p`'s sol, gm, gl (strength coefficient 1) and tibialis.
fn subject_xml(p: &ModelParams) -> String {
    let mut s = String::from(
        "<?xml version=\"1.0\"?>\n<subject>\n<mtuDefault><emDelay>0</emDelay></mtuDefault>\n<mtuSet>\n",
    );
    let mut mtu = |name: &str, m: &muscle_model::MuscleParams| {
        s += &format!(
            "<mtu><name>{name}</name><c1>-0.5</c1><c2>-0.5</c2><shapeFactor>-1</shapeFactor>\
             <optimalFibreLength>{}</optimalFibreLength><pennationAngle>{}</pennationAngle>\
             <tendonSlackLength>{}</tendonSlackLength><maxIsometricForce>{}</maxIsometricForce>\
             <strengthCoefficient>1</strengthCoefficient></mtu>\n",
            m.lom_m, m.alpha_deg, m.lst_m, m.fom_n
        );
    };
    mtu("sol_r", p.muscle(Muscle::Sol));
    mtu("gasmed_r", p.muscle(Muscle::Gm));
    mtu("gaslat_r", p.muscle(Muscle::Gl));
    mtu("tibant_r", &p.fixed.get("tibant_r").unwrap().params);
    s + "</mtuSet>\n</subject>\n"
}

/// Nominal sol, gm, gl and a tibialis anterior with fixed parameters.
fn truth() -> ModelParams {
    let mut p = ModelParams::nominal();
    let ta = muscle_model::MuscleParams {
        fom_n: 905.0,
        lom_m: 0.098,
        lst_m: 0.223,
        alpha_deg: 5.0,
        vmax_lom_per_s: 10.0,
        lmt_poly_m: [f64::NAN; 4],
        knee_moment_arm_m: 0.0,
    };
    p.fixed.insert("tibant_r", ta).unwrap();
    p
}

/// Writes a one-trial session of `folder` with the subject XML, runs `diagnose --session` on
/// it into `out`, and returns that trial's `diagnosis.json` and its line of
/// `diagnosis_session.json`.
fn diagnose_folder(d: &Path, folder: &str, out: &str) -> (Value, Value) {
    let manifest = format!(
        r#"{{"params": "subject.xml", "trials": [{{"name": "walk", "recording": "{folder}"}}]}}"#
    );
    let session = format!("{folder}.json");
    std::fs::write(d.join(&session), manifest).unwrap();
    ok(&surae(
        &["diagnose", "--session", &session, "--out", out, "--quiet"],
        d,
    ));
    let one = json(&d.join(out).join("walk/diagnosis.json"));
    let all = json(&d.join(out).join("diagnosis_session.json"));
    assert_eq!(all["trials"].as_array().unwrap().len(), 1);
    assert!(d.join(out).join("walk/report.html").exists());
    assert!(d.join(out).join("walk/torque_fit.svg").exists());
    (one, all["trials"][0].clone())
}

fn angle_effects_not_testable(one: &Value, row: &Value) {
    let names: Vec<&str> = one["not_testable"]
        .as_array()
        .unwrap()
        .iter()
        .map(|t| t["effect"].as_str().unwrap())
        .collect();
    assert_eq!(
        names,
        [
            "passive_joint_torque",
            "gravity",
            "viscous_damping",
            "inertia"
        ]
    );
    assert_eq!(
        one["not_testable"][0]["reason"],
        "not testable on this trial: no joint angle"
    );
    assert_eq!(row["not_testable"].as_array().unwrap().len(), 4);
    // never fitted nor scored
    for c in one["candidates"].as_array().unwrap() {
        assert!(!names.contains(&c["effect"].as_str().unwrap()), "{c}");
    }
}

#[test]
fn a_ceinms_folder_with_a_hidden_delay_names_it_and_one_without_is_adequate() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let truth = truth();
    std::fs::write(d.join("subject.xml"), subject_xml(&truth)).unwrap();
    let delay = Effects::from_json_str(r#"{"electromechanical_delay": {"delay_ms": 40}}"#).unwrap();
    ceinms_folder(&d.join("walk_delay"), 31, 8.0, &truth, &delay);
    ceinms_folder(&d.join("walk_clean"), 31, 8.0, &truth, &Effects::none());

    let (one, row) = diagnose_folder(d, "walk_delay", "out_delay");
    assert_eq!(one["verdict"], "deficient", "{}", one["causes"]);
    assert_eq!(row["causes"][0], "electromechanical_delay", "{row}");
    assert_eq!(row["verdict"], "deficient");
    let ms = one["extended"]["effects"]["electromechanical_delay"]["delay_ms"]
        .as_f64()
        .unwrap();
    assert!((ms - 40.0).abs() < 5.0, "delay {ms} ms");
    assert!(
        row["heldout_rms_reduction_pct"].as_f64().unwrap() > 0.0,
        "{row}"
    );
    assert!(
        row["moment_fit"]["extended"]["r2"].as_f64().unwrap() > 0.9,
        "{row}"
    );
    assert_eq!(one["noise"]["source"], "trial_residual");
    assert!(one["unloaded"].is_null());
    angle_effects_not_testable(&one, &row);

    let (one, row) = diagnose_folder(d, "walk_clean", "out_clean");
    assert_eq!(one["verdict"], "adequate", "{row}");
    assert_eq!(row["causes"].as_array().unwrap().len(), 0, "{row}");
    angle_effects_not_testable(&one, &row);
}

/// The repository's seed fixture (trial and unloaded run).
fn fixture(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../fixtures/seed")
        .join(name)
}

#[test]
fn a_session_of_trial_csvs_diagnoses_what_trial_and_unloaded_do() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let (trial, unloaded) = (fixture("trial.csv"), fixture("unloaded.csv"));
    std::fs::write(
        d.join("s.json"),
        format!(
            r#"{{"trials": [{{"name": "seed", "trial": "{}", "unloaded": "{}"}}]}}"#,
            trial.display(),
            unloaded.display()
        ),
    )
    .unwrap();
    ok(&surae(
        &[
            "diagnose",
            "--session",
            "s.json",
            "--out",
            "by_session",
            "--quiet",
        ],
        d,
    ));
    let (t, u) = (trial.to_str().unwrap(), unloaded.to_str().unwrap());
    ok(&surae(
        &[
            "diagnose",
            "--trial",
            t,
            "--unloaded",
            u,
            "--out",
            "by_trial",
            "--quiet",
        ],
        d,
    ));
    let mut s = json(&d.join("by_session/seed/diagnosis.json"));
    let mut b = json(&d.join("by_trial/diagnosis.json"));
    for v in [&mut s, &mut b] {
        let o = v.as_object_mut().unwrap();
        o.remove("wall_s");
        o.remove("trial");
        o.remove("source");
        o.remove("unloaded");
    }
    assert_eq!(s, b);
    let row = &json(&d.join("by_session/diagnosis_session.json"))["trials"][0];
    assert_eq!(row["verdict"], b["verdict"]);
    assert_eq!(row["causes"], b["causes"]);
    assert!(row["not_testable"].as_array().unwrap().is_empty());
    assert!(row["moment_fit"].is_null());
}

#[test]
fn a_bad_session_is_a_one_line_error_and_writes_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::write(
        d.join("s.json"),
        r#"{"trials": [{"name": "a", "trial": "missing.csv"}]}"#,
    )
    .unwrap();
    let o = surae(&["diagnose", "--session", "s.json", "--out", "o"], d);
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(err.contains("missing.csv"), "{err}");
    assert_eq!(err.trim_end().lines().count(), 1, "{err}");
    assert!(!d.join("o").exists());
    // --params belongs to --session
    let o = surae(&["diagnose", "--params", "p.json"], d);
    assert_eq!(o.status.code(), Some(2));
}
