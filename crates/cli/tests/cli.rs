//! End-to-end tests of the `surae` binary: outputs, agreement with scipy, and
//! bad input (exit code 2, one line naming the file, nothing written).

use std::path::{Path, PathBuf};
mod common;
use common::{stderr_of, surae};

fn data(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/data")
        .join(name)
}

fn read_table(path: &Path) -> (Vec<String>, Vec<Vec<f64>>) {
    let text = std::fs::read_to_string(path).unwrap();
    let mut lines = text.lines().filter(|l| !l.starts_with('#'));
    let header: Vec<String> = lines
        .next()
        .unwrap()
        .split(',')
        .map(|s| s.to_string())
        .collect();
    let rows = lines
        .map(|l| l.split(',').map(|v| v.parse::<f64>().unwrap()).collect())
        .collect();
    (header, rows)
}

#[test]
fn envelope_on_the_bundled_trial_writes_every_sample() {
    let dir = tempfile::tempdir().unwrap();
    let o = surae(&["envelope"], dir.path());
    assert!(o.status.success(), "{}", stderr_of(&o));
    let (header, rows) = read_table(&dir.path().join("out/envelope/envelope.csv"));
    assert_eq!(header, ["time_s", "emg_sol", "emg_gm", "emg_gl"]);
    assert_eq!(rows.len(), 6827);
    for r in &rows {
        for v in &r[1..] {
            assert!((0.0..=1.0).contains(v));
        }
    }
    // normalised by the trial maximum: every channel reaches 1
    for c in 1..4 {
        let max = rows.iter().map(|r| r[c]).fold(0.0, f64::max);
        assert_eq!(max, 1.0);
    }
}

#[test]
fn envelope_of_an_external_recording_matches_scipy() {
    // tests/data/external_trial.csv is not a fixture: 1000 Hz, four channels;
    // the expected envelopes come from scipy (tests/data/make_scipy_envelope.py).
    let dir = tempfile::tempdir().unwrap();
    let trial = data("external_trial.csv");
    let out = dir.path().join("env.csv");
    let o = surae(
        &[
            "envelope",
            "--trial",
            trial.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
        ],
        dir.path(),
    );
    assert!(o.status.success(), "{}", stderr_of(&o));
    let (h_got, got) = read_table(&out);
    let (h_ref, reference) = read_table(&data("external_envelope_scipy.csv"));
    assert_eq!(h_got, h_ref);
    assert_eq!(got.len(), reference.len());
    for c in 1..h_ref.len() {
        let max_ref = reference.iter().map(|r| r[c].abs()).fold(0.0, f64::max);
        let err = got
            .iter()
            .zip(&reference)
            .map(|(a, b)| (a[c] - b[c]).abs())
            .fold(0.0, f64::max);
        assert!(
            err <= 1e-8 * max_ref,
            "{}: max error {err:e} vs max {max_ref}",
            h_ref[c]
        );
    }
}

#[test]
fn simulate_writes_the_spec_columns() {
    let dir = tempfile::tempdir().unwrap();
    let o = surae(&["simulate", "--out", "sim"], dir.path());
    assert!(o.status.success(), "{}", stderr_of(&o));
    let (header, rows) = read_table(&dir.path().join("sim/simulate.csv"));
    assert_eq!(
        header,
        [
            "time_s",
            "ankle_angle_deg",
            "torque_nm",
            "torque_sol_nm",
            "torque_gm_nm",
            "torque_gl_nm"
        ]
    );
    assert_eq!(rows.len(), 6827);
    for r in &rows {
        // no effect: the total is the sum of the muscles
        assert!((r[2] - (r[3] + r[4] + r[5])).abs() < 1e-9 * r[2].abs().max(1.0));
    }
    let peak = rows.iter().map(|r| r[2]).fold(f64::MIN, f64::max);
    assert!(peak > 100.0 && peak < 400.0, "peak {peak}");
}

#[test]
fn simulate_with_a_delay_effect_changes_the_torque() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(
        dir.path().join("e.json"),
        r#"{"electromechanical_delay": {"delay_ms": 60}}"#,
    )
    .unwrap();
    let base = surae(&["simulate", "--out", "a.csv"], dir.path());
    assert!(base.status.success());
    let o = surae(
        &["simulate", "--effects", "e.json", "--out", "b.csv"],
        dir.path(),
    );
    assert!(o.status.success(), "{}", stderr_of(&o));
    let (_, a) = read_table(&dir.path().join("a.csv"));
    let (_, b) = read_table(&dir.path().join("b.csv"));
    let rms = (a
        .iter()
        .zip(&b)
        .map(|(x, y)| (x[2] - y[2]).powi(2))
        .sum::<f64>()
        / a.len() as f64)
        .sqrt();
    assert!(rms > 1.0, "a 60 ms delay must change the torque, rms {rms}");
}

#[test]
fn sensitivity_ranks_soleus_slack_length_first() {
    let dir = tempfile::tempdir().unwrap();
    let o = surae(&["sensitivity", "--step", "10"], dir.path());
    assert!(o.status.success(), "{}", stderr_of(&o));
    let json: serde_json::Value = serde_json::from_str(
        &std::fs::read_to_string(dir.path().join("out/sensitivity/sensitivity.json")).unwrap(),
    )
    .unwrap();
    let ranking = json["ranking"].as_array().unwrap();
    assert_eq!(ranking.len(), 9);
    assert_eq!(ranking[0]["param"], "sol.lst_m");
    assert!(dir.path().join("out/sensitivity/sensitivity.csv").exists());
}

/// Runs a command that must fail on bad input: exit code 2, one line on
/// stderr containing every `needle`, no panic, and nothing written.
fn assert_bad_input(args: &[&str], files: &[(&str, &[u8])], needles: &[&str]) {
    let dir = tempfile::tempdir().unwrap();
    for (name, content) in files {
        std::fs::write(dir.path().join(name), content).unwrap();
    }
    let o = surae(args, dir.path());
    let err = stderr_of(&o);
    assert_eq!(o.status.code(), Some(2), "{args:?}: {err}");
    assert!(!err.contains("panicked"), "{err}");
    assert_eq!(err.trim_end().lines().count(), 1, "one line: {err}");
    for n in needles {
        assert!(err.contains(n), "{args:?}: '{err}' lacks '{n}'");
    }
    assert!(!dir.path().join("out").exists(), "nothing is written");
}

const GOOD_HEADER: &str = "time_s,ankle_angle_deg,torque_nm,emg_sol,emg_gm,emg_gl\n";

fn good_rows(n: usize) -> String {
    let mut s = String::new();
    for i in 0..n {
        let t = i as f64 / 1000.0;
        let x = ((i * 7919) % 1000) as f64 / 1000.0 - 0.5;
        s.push_str(&format!(
            "{t},{},{},{x},{},{}\n",
            10.0 - t,
            5.0 * t,
            -x,
            x * 0.5
        ));
    }
    s
}

#[test]
fn bad_inputs_exit_2_with_one_line_naming_the_file() {
    let mut bad_cell = String::from(GOOD_HEADER);
    bad_cell.push_str(&good_rows(1500));
    bad_cell = bad_cell.replacen("\n0.002,", "\n0.002,abc", 1);
    let mut short = String::from(GOOD_HEADER);
    short.push_str(&good_rows(200));
    let mut missing = String::from("time_s,ankle_angle_deg,torque_nm,emg_sol,emg_gm\n");
    missing.push_str("0,1,2,3,4\n");
    let mut zero = String::from(GOOD_HEADER);
    for i in 0..1500 {
        zero.push_str(&format!("{},0,0,0.1,0.2,0\n", i as f64 / 1000.0));
    }

    assert_bad_input(&["envelope", "--trial", "nope.csv"], &[], &["nope.csv"]);
    assert_bad_input(
        &["envelope", "--trial", "e.csv"],
        &[("e.csv", b"")],
        &["e.csv"],
    );
    assert_bad_input(
        &["envelope", "--trial", "t.csv"],
        &[("t.csv", bad_cell.as_bytes())],
        &["t.csv:4:2", "ankle_angle_deg"],
    );
    assert_bad_input(
        &["simulate", "--trial", "t.csv"],
        &[("t.csv", short.as_bytes())],
        &["t.csv"],
    );
    assert_bad_input(
        &["simulate", "--trial", "t.csv"],
        &[("t.csv", missing.as_bytes())],
        &["t.csv", "emg_gl"],
    );
    assert_bad_input(
        &["envelope", "--trial", "t.csv"],
        &[("t.csv", zero.as_bytes())],
        &["t.csv", "emg_gl"],
    );
    assert_bad_input(
        &["simulate", "--params", "p.json"],
        &[("p.json", br#"{"muscles": {"sol": {"lst_mm": 0.25}}}"#)],
        &["p.json", "lst_mm"],
    );
    assert_bad_input(
        &["simulate", "--params", "p.json"],
        &[("p.json", br#"{"muscles": {"soleus": {}}}"#)],
        &["p.json", "soleus"],
    );
    assert_bad_input(
        &["simulate", "--params", "p.json"],
        &[("p.json", br#"{"muscles": {"sol": {"fom_n": -5}}}"#)],
        &["p.json", "fom_n"],
    );
    assert_bad_input(
        &["simulate", "--params", "p.json"],
        &[("p.json", b"{\"muscles\": ")],
        &["p.json"],
    );
    assert_bad_input(
        &["simulate", "--effects", "e.json"],
        &[("e.json", br#"{"telepathy": {"gain": 1}}"#)],
        &["e.json", "telepathy"],
    );
    assert_bad_input(
        &["simulate", "--effects", "e.json"],
        &[(
            "e.json",
            br#"{"electromechanical_delay": {"delay_ms": 900}}"#,
        )],
        &["e.json", "delay_ms"],
    );
    assert_bad_input(
        &["envelope", "--trial", "b.csv"],
        &[("b.csv", &[0u8, 159, 146, 150, 255, 0, 1, 2])],
        &["b.csv"],
    );
    assert_bad_input(&["frobnicate"], &[], &["frobnicate"]);
}

#[test]
fn out_never_overwrites_an_input_or_a_file_given_as_folder() {
    let dir = tempfile::tempdir().unwrap();
    let trial = dir.path().join("t.csv");
    std::fs::copy(data("external_trial.csv"), &trial).unwrap();
    let before = std::fs::read(&trial).unwrap();
    let o = surae(
        &["envelope", "--trial", "t.csv", "--out", "t.csv"],
        dir.path(),
    );
    assert_eq!(o.status.code(), Some(2), "{}", stderr_of(&o));
    assert!(stderr_of(&o).contains("t.csv"));
    assert_eq!(std::fs::read(&trial).unwrap(), before, "input untouched");

    std::fs::write(dir.path().join("afile"), b"x").unwrap();
    let o = surae(&["sensitivity", "--out", "afile"], dir.path());
    assert_eq!(o.status.code(), Some(2), "{}", stderr_of(&o));
    assert!(stderr_of(&o).contains("afile"));
}

#[test]
fn crlf_trials_are_read() {
    let dir = tempfile::tempdir().unwrap();
    let text = std::fs::read_to_string(data("external_trial.csv")).unwrap();
    std::fs::write(dir.path().join("crlf.csv"), text.replace('\n', "\r\n")).unwrap();
    let o = surae(
        &["envelope", "--trial", "crlf.csv", "--out", "a.csv"],
        dir.path(),
    );
    assert!(o.status.success(), "{}", stderr_of(&o));
    let o2 = surae(
        &[
            "envelope",
            "--trial",
            data("external_trial.csv").to_str().unwrap(),
            "--out",
            "b.csv",
        ],
        dir.path(),
    );
    assert!(o2.status.success());
    assert_eq!(
        std::fs::read(dir.path().join("a.csv")).unwrap(),
        std::fs::read(dir.path().join("b.csv")).unwrap()
    );
}

#[test]
fn help_opens_with_what_the_program_does() {
    let o = surae(&["--help"], Path::new(env!("CARGO_MANIFEST_DIR")));
    assert!(o.status.success());
    let text = String::from_utf8_lossy(&o.stdout);
    let first = text.lines().next().unwrap_or("");
    assert!(
        first.starts_with("Identify the calf's muscle parameters"),
        "surae --help opens with: {first}"
    );
}
