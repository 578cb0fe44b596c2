//! `identify --method mcmc --session`: a session of one trial writes the `identify.json` of
//! `--trial` (same seed); a session of two trials (knee extended and flexed) reports each
//! trial's fit, the posterior correlation matrix and the chains.

use experiment::{synthesize, write_trial, write_unloaded, SynthConfig};
use serde_json::Value;
use std::path::Path;
mod common;
use common::{json, ok, surae};

/// Writes `<name>.csv` and `<name>_unloaded.csv` of synthetic trial `protocol` (seed `seed`).
fn write_synthetic(d: &Path, name: &str, protocol: &str, seed: u64) {
    let syn = synthesize(&SynthConfig::for_protocol(protocol.parse().unwrap(), seed)).unwrap();
    write_trial(d.join(format!("{name}.csv")), &syn.trial).unwrap();
    write_unloaded(d.join(format!("{name}_unloaded.csv")), &syn.unloaded).unwrap();
}

/// Short chains: the two runs are compared, not judged (1 000 warm-up + 500 iterations).
const SHORT: [&str; 4] = ["--max-iterations", "1500", "--seed", "9"];

#[test]
fn a_session_of_one_trial_writes_the_identify_json_of_the_trial() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    write_synthetic(d, "seed5", "knee0@30", 5);
    std::fs::write(
        d.join("session.json"),
        r#"{"trials": [{"name": "seed5", "trial": "seed5.csv", "unloaded": "seed5_unloaded.csv"}]}"#,
    )
    .unwrap();
    let mut a = vec!["identify", "--method", "mcmc", "--session", "session.json"];
    a.extend(["--out", "by_session", "--quiet"]);
    a.extend(SHORT);
    ok(&surae(&a, d));
    let mut b = vec!["identify", "--method", "mcmc", "--trial", "seed5.csv"];
    b.extend([
        "--unloaded",
        "seed5_unloaded.csv",
        "--out",
        "by_trial",
        "--quiet",
    ]);
    b.extend(SHORT);
    ok(&surae(&b, d));
    let s = json(&d.join("by_session/identify.json"));
    let t = json(&d.join("by_trial/identify.json"));
    // Where the data came from is said differently (a manifest against a file and its unloaded
    // run; a session's adequacy names its trial); wall time differs; everything else is the
    // same.
    let differ = [
        "wall_s",
        "trial",
        "noise",
        "dynamometer",
        "trials",
        "checks",
        "adequacy",
    ];
    for (key, value) in t.as_object().unwrap() {
        if !differ.contains(&key.as_str()) {
            assert_eq!(&s[key], value, "{key}");
        }
    }
    assert_eq!(s["dynamometer"][0], t["dynamometer"]);
    assert_eq!(s["trials"][0]["dynamometer"], t["dynamometer"]);
    // a session's recording checks are per trial
    assert!(s.get("checks").is_none());
    assert_eq!(s["trials"][0]["checks"], t["checks"]);
    // the trial's structure test is the one `--trial` runs
    assert_eq!(s["trials"][0]["adequacy"], t["adequacy"]);
    assert_eq!(s["adequacy"]["structure_p"], t["adequacy"]["structure_p"]);
    assert_eq!(s["adequacy"]["trial"], "seed5");
    for key in ["rms_nm", "r2", "rms_raw_nm", "noise_model"] {
        assert_eq!(s["trials"][0][key], t["trials"][0][key], "trials[0].{key}");
    }
    assert_eq!(s["trials"][0]["name"], "seed5");
    assert_eq!(
        t["posterior_correlation"]["matrix"]
            .as_array()
            .unwrap()
            .len(),
        9
    );
    assert!(d.join("by_session/chains/chain_4.csv").exists());
    assert!(d.join("by_session/torque_fit_seed5.svg").exists());
}

#[test]
fn a_two_trial_session_reports_each_trial_and_the_correlation_matrix() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    write_synthetic(d, "knee0", "knee0@30", 21);
    write_synthetic(d, "knee90", "knee90@30", 22);
    std::fs::write(
        d.join("session.json"),
        r#"{"subject": "S01", "trials": [
            {"name": "knee0_30", "trial": "knee0.csv", "unloaded": "knee0_unloaded.csv"},
            {"name": "knee90_30", "trial": "knee90.csv", "unloaded": "knee90_unloaded.csv"}]}"#,
    )
    .unwrap();
    let mut a = vec!["identify", "--method", "mcmc", "--session", "session.json"];
    a.extend(["--out", "out"]);
    a.extend(SHORT);
    let o = surae(&a, d);
    ok(&o);
    let stdout = String::from_utf8_lossy(&o.stdout);
    for needle in ["knee0_30 ", "knee90_30 ", "identifiable: ", "2 trials"] {
        assert!(stdout.contains(needle), "no {needle:?} in\n{stdout}");
    }
    let doc = json(&d.join("out/identify.json"));
    assert_eq!(doc["method"], "mcmc");
    assert_eq!(doc["subject"], "S01");
    let trials = doc["trials"].as_array().unwrap();
    assert_eq!(trials.len(), 2);
    for (t, name) in trials.iter().zip(["knee0_30", "knee90_30"]) {
        assert_eq!(t["name"], name);
        let rms = t["rms_nm"].as_f64().unwrap();
        let r2 = t["r2"].as_f64().unwrap();
        // corrected by its own unloaded run: the residual is the dynamometer's random error
        assert!(rms > 0.5 && rms < 3.0, "{name}: RMS {rms}");
        assert!(r2 > 0.95 && r2 <= 1.0, "{name}: R² {r2}");
        assert!(t["rms_raw_nm"].as_f64().unwrap() > rms);
        assert!(t["dynamometer"].is_object());
    }
    let corr = &doc["posterior_correlation"];
    let names: Vec<&str> = corr["names"]
        .as_array()
        .unwrap()
        .iter()
        .map(|v| v.as_str().unwrap())
        .collect();
    assert_eq!(names.len(), 9);
    assert_eq!(names[0], "sol.lst_m");
    let matrix = corr["matrix"].as_array().unwrap();
    for (i, row) in matrix.iter().enumerate() {
        let row: Vec<f64> = row
            .as_array()
            .unwrap()
            .iter()
            .map(|v| v.as_f64().unwrap())
            .collect();
        assert_eq!(row.len(), 9);
        assert!((row[i] - 1.0).abs() < 1e-9);
        assert!(row.iter().all(|r| r.abs() <= 1.0 + 1e-9));
    }
    let posterior = doc["posterior"].as_object().unwrap();
    assert!(posterior.values().all(|p| p["identifiable"].is_boolean()));
    for f in [
        "chains.csv",
        "chains/chain_1.csv",
        "report.html",
        "torque_fit_knee0_30.svg",
        "torque_fit_knee90_30.svg",
        "corner.svg",
    ] {
        assert!(d.join("out").join(f).exists(), "{f}");
    }
    // the whole model at the posterior mean
    let model: &Value = &doc["model"]["muscles"];
    for (m, f) in [("sol", "lst_m"), ("gm", "fom_n"), ("gl", "alpha_deg")] {
        assert_eq!(model[m][f], doc["params"][format!("{m}.{f}")], "{m}.{f}");
    }
}
