//! `surae diagnose --session`: a CEINMS trial folder (written here from a synthetic trial,
//! never from real recordings) with a hidden electromechanical delay is diagnosed with the
//! delay named; the same folder without the delay is adequate, with the effects that need a
//! joint angle reported as not testable; a session of one trial CSV gives what `--trial` and
//! `--unloaded` give; a synthetic 3-trial session (knee0@30, knee90@30, knee0@60 with their
//! unloaded runs) with a delay hidden in every trial names it once, for the subject; a session
//! of two CEINMS folders is judged by the residual each trial's held-out prediction leaves.

use muscle_model::Effects;
use serde_json::Value;
use std::path::{Path, PathBuf};
mod common;
use common::{ceinms_folder, json, ok, subject_xml, surae, truth_with_tibialis, CeinmsFolder};

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
    let truth = truth_with_tibialis();
    std::fs::write(d.join("subject.xml"), subject_xml(&truth)).unwrap();
    let delay = Effects::from_json_str(r#"{"electromechanical_delay": {"delay_ms": 40}}"#).unwrap();
    let folder = |effects| CeinmsFolder {
        seed: 31,
        seconds: 8.0,
        truth: &truth,
        effects,
        noise: true,
        lead_in_s: 0.13,
    };
    ceinms_folder(&d.join("walk_delay"), &folder(&delay));
    ceinms_folder(&d.join("walk_clean"), &folder(&Effects::none()));

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

#[test]
fn a_calibration_whose_gain_does_not_carry_to_the_trial_is_told() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let truth = truth_with_tibialis();
    std::fs::write(d.join("subject.xml"), subject_xml(&truth)).unwrap();
    // the same subject, its triceps reaching the moment with 0.7 times the gain
    let mut weak = truth;
    for m in muscle_model::Muscle::ALL {
        weak.muscle_mut(m).fom_n *= 0.7;
    }
    let none = Effects::none();
    let folder = |truth| CeinmsFolder {
        seed: 33,
        seconds: 8.0,
        truth,
        effects: &none,
        noise: true,
        lead_in_s: 0.13,
    };
    ceinms_folder(&d.join("walk_same"), &folder(&truth));
    ceinms_folder(&d.join("walk_weak"), &folder(&weak));
    // `subject.xml` is the calibration carried to each folder
    let run = |name: &str| {
        let manifest = format!(r#"{{"trials": [{{"name": "walk", "recording": "{name}"}}]}}"#);
        std::fs::write(d.join(format!("{name}.json")), manifest).unwrap();
        let out = format!("out_{name}");
        let o = surae(
            &[
                "diagnose",
                "--session",
                &format!("{name}.json"),
                "--params",
                "subject.xml",
                "--out",
                &out,
            ],
            d,
        );
        ok(&o);
        (
            String::from_utf8_lossy(&o.stdout).into_owned(),
            json(&d.join(&out).join("walk/diagnosis.json")),
            json(&d.join(&out).join("diagnosis_session.json")),
        )
    };
    let (_, one, all) = run("walk_same");
    let k = &one["given_params"]["scale"];
    assert!((k["factor"].as_f64().unwrap() - 1.0).abs() < 0.02, "{k}");
    assert_eq!(k["differs"], false, "{k}");
    assert_eq!(all["given_params"][0]["name"], "walk");
    let (text, one, all) = run("walk_weak");
    let k = &one["given_params"]["scale"];
    let f = k["factor"].as_f64().unwrap();
    assert!((0.6..0.8).contains(&f), "{k}");
    assert_eq!(k["differs"], true, "{k}");
    assert_eq!(one["verdict"], "deficient");
    assert_eq!(all["verdict"], "deficient");
    assert!(text.contains("EMG-to-moment gain does not carry"), "{text}");
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
    // the session's own verdict and causes are the trial's
    let all = json(&d.join("by_session/diagnosis_session.json"));
    assert_eq!(all["verdict"], b["verdict"]);
    let causes: Vec<&Value> = all["causes"]
        .as_array()
        .unwrap()
        .iter()
        .map(|c| &c["effect"])
        .collect();
    let named: Vec<&Value> = b["causes"].as_array().unwrap().iter().collect();
    assert_eq!(causes, named);
    assert_eq!(all["heldout"]["scheme"], "within_trial");
    assert_eq!(
        all["heldout"]["extended_rms_nm"],
        b["extended"]["heldout_rms_nm"]
    );
}

#[test]
fn a_three_trial_session_names_a_shared_delay_once() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let delay = Effects::from_json_str(r#"{"electromechanical_delay": {"delay_ms": 40}}"#).unwrap();
    let protocols: Vec<experiment::SynthProtocol> = ["knee0@30", "knee90@30", "knee0@60"]
        .iter()
        .map(|p| p.parse().unwrap())
        .collect();
    let session = experiment::synth_session::synthesize_session(
        &protocols,
        7,
        &muscle_model::ModelParams::nominal(),
        &delay,
    )
    .unwrap();
    let manifest = experiment::synth_session::write_session(d, "S", &protocols, &session).unwrap();
    std::fs::rename(manifest, d.join("s.json")).unwrap();
    ok(&surae(
        &["diagnose", "--session", "s.json", "--out", "o", "--quiet"],
        d,
    ));
    let all = json(&d.join("o/diagnosis_session.json"));
    assert_eq!(all["verdict"], "deficient", "{}", all["causes"]);
    let causes = all["causes"].as_array().unwrap();
    assert_eq!(causes.len(), 1, "{}", all["causes"]);
    assert_eq!(causes[0]["effect"], "electromechanical_delay");
    assert_eq!(causes[0]["scope"], "subject");
    let ms = causes[0]["values"]["delay_ms"].as_f64().unwrap();
    assert!((ms - 40.0).abs() < 5.0, "delay {ms} ms");
    assert_eq!(all["heldout"]["scheme"], "leave_one_trial_out");
    assert!(all["heldout"]["rms_reduction_pct"].as_f64().unwrap() > 0.0);
    assert_eq!(all["heldout"]["per_trial"].as_array().unwrap().len(), 3);
    assert_eq!(all["trial_fits"].as_array().unwrap().len(), 3);
    // each trial diagnosed on its own too, into its folder
    let rows = all["trials"].as_array().unwrap();
    assert_eq!(rows.len(), 3);
    for row in rows {
        assert_eq!(row["causes"][0], "electromechanical_delay", "{row}");
        let folder = row["folder"].as_str().unwrap();
        assert!(d.join("o").join(folder).join("diagnosis.json").exists());
    }
}

/// Writes a session of two CEINMS folders (seeds 31 and 32) with `effects` hidden in both,
/// diagnoses it into `out` and returns `diagnosis_session.json`.
fn diagnose_two_folders(d: &Path, tag: &str, effects: &Effects) -> (Value, String) {
    let truth = truth_with_tibialis();
    std::fs::write(d.join("subject.xml"), subject_xml(&truth)).unwrap();
    for seed in [31, 32] {
        let spec = CeinmsFolder {
            seed,
            seconds: 6.0,
            truth: &truth,
            effects,
            noise: true,
            lead_in_s: 0.13,
        };
        ceinms_folder(&d.join(format!("{tag}_{seed}")), &spec);
    }
    let manifest = format!(
        r#"{{"params": "subject.xml", "trials": [{{"name": "a", "recording": "{tag}_31"}},
            {{"name": "b", "recording": "{tag}_32"}}]}}"#
    );
    std::fs::write(d.join(format!("{tag}.json")), manifest).unwrap();
    let out = format!("out_{tag}");
    let run = surae(
        &[
            "diagnose",
            "--session",
            &format!("{tag}.json"),
            "--out",
            &out,
        ],
        d,
    );
    ok(&run);
    (
        json(&d.join(&out).join("diagnosis_session.json")),
        String::from_utf8_lossy(&run.stdout).into_owned(),
    )
}

#[test]
fn a_session_without_unloaded_runs_is_judged_by_its_held_out_residual() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    // the model's own moment: each trial predicted by the calibration on the other leaves
    // noise, with no shape that comes back
    let (clean, said) = diagnose_two_folders(d, "clean", &Effects::none());
    assert!(!said.contains("--extensions"), "{said}");
    let h = &clean["held_out_shape"];
    let per_trial = h["per_trial"].as_array().unwrap();
    assert_eq!(per_trial.len(), 2, "{h}");
    for (t, name) in per_trial.iter().zip(["a", "b"]) {
        assert_eq!(t["name"], name);
        let parts = t["parts"].as_array().unwrap();
        assert_eq!(parts.len(), 1, "{t}");
        assert!(parts[0]["fold"]
            .as_str()
            .unwrap()
            .starts_with("leave_one_trial_out"));
        assert_eq!(t["reproducible"], false, "{t}");
    }
    assert_eq!(h["reproducible"], false, "{h}");
    assert_eq!(clean["verdict"], "adequate", "{h}");
    let one = json(&d.join("out_clean/a/diagnosis.json"));
    assert_eq!(one["held_out_shape"]["parts"].as_array().unwrap().len(), 1);

    // fatigue, which no parameter of the calibration can take up (a force that falls with the
    // activation integrated since the start), comes back in the trial left out
    let fatigue = Effects::from_json_str(r#"{"fatigue": {"rate_per_s": 0.5}}"#).unwrap();
    let (shifted, said) = diagnose_two_folders(d, "fatigue", &fatigue);
    // the user is sent to the measurement of what would lower the held-out error
    assert!(
        said.contains("surae validate --session fatigue.json --extensions"),
        "{said}"
    );
    let h = &shifted["held_out_shape"];
    assert_eq!(h["reproducible"], true, "{h}");
    assert!(h["p_value"].as_f64().unwrap() < 1e-3, "{h}");
    assert_eq!(shifted["verdict"], "deficient", "{h}");
    for row in shifted["trials"].as_array().unwrap() {
        assert_eq!(row["verdict"], "deficient", "{row}");
    }
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
