//! `identify` and `diagnose` subtract one dynamometer correction: for the same trial and
//! unloaded run, the `"dynamometer"` objects of `identify.json` and `diagnosis.json` are
//! identical (docs/dynamometer.md).

use std::path::{Path, PathBuf};
use std::process::Command;

use serde_json::Value;

fn fixture(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../fixtures")
        .join(name)
}

/// Runs `surae ARGS --quiet --out DIR` in `cwd` and returns the `"dynamometer"` object of
/// `DIR/FILE`.
fn dynamometer_of(args: &[&str], cwd: &Path, dir: &str, file: &str) -> Value {
    let o = Command::new(env!("CARGO_BIN_EXE_surae"))
        .args(args)
        .args(["--quiet", "--out", dir])
        .current_dir(cwd)
        .output()
        .expect("the surae binary runs");
    assert!(
        o.status.success(),
        "{args:?}: {}",
        String::from_utf8_lossy(&o.stderr)
    );
    let text = std::fs::read_to_string(cwd.join(dir).join(file)).unwrap();
    let doc: Value = serde_json::from_str(&text).unwrap();
    doc.get("dynamometer")
        .cloned()
        .unwrap_or_else(|| panic!("{args:?}: no \"dynamometer\" in {file}"))
}

fn assert_reported(d: &Value, what: &str) {
    for key in ["offset_nm", "ar1_sd_nm", "ar1_corr_time_s", "white_sd_nm"] {
        assert!(
            d[key].as_f64().is_some_and(f64::is_finite),
            "{what}: {key} in {d}"
        );
    }
}

#[test]
fn identify_and_diagnose_report_the_same_correction() {
    let dir = tempfile::tempdir().unwrap();
    let cwd = dir.path();
    // the bundled trial and its unloaded run
    let sa = dynamometer_of(&["identify", "--method", "sa"], cwd, "sa", "identify.json");
    let diag = dynamometer_of(&["diagnose"], cwd, "diag", "diagnosis.json");
    assert_reported(&sa, "bundled");
    assert!(sa["transient"]["freq_hz"].as_f64().is_some(), "{sa}");
    assert_eq!(sa, diag, "bundled trial");

    // a fixture given as files
    let f = fixture("torque_offset");
    let (trial, unloaded) = (f.join("trial.csv"), f.join("unloaded.csv"));
    let (trial, unloaded) = (trial.to_str().unwrap(), unloaded.to_str().unwrap());
    let files = ["--trial", trial, "--unloaded", unloaded];
    let sa = dynamometer_of(
        &[&["identify", "--method", "sa"][..], &files].concat(),
        cwd,
        "sa2",
        "identify.json",
    );
    let diag = dynamometer_of(
        &[&["diagnose"][..], &files].concat(),
        cwd,
        "diag2",
        "diagnosis.json",
    );
    assert_reported(&sa, "torque_offset");
    assert_eq!(sa, diag, "fixtures/torque_offset");

    // without an unloaded run identify subtracts nothing; diagnose fits the transient and
    // the random part to the trial's residual, without an offset
    let sa = dynamometer_of(
        &["identify", "--method", "sa", "--trial", trial],
        cwd,
        "sa3",
        "identify.json",
    );
    assert_eq!(sa, Value::Null);
    let diag = dynamometer_of(
        &["diagnose", "--trial", trial],
        cwd,
        "diag3",
        "diagnosis.json",
    );
    assert_reported(&diag, "torque_offset without unloaded run");
    assert_eq!(diag["offset_nm"].as_f64(), Some(0.0), "{diag}");
}
