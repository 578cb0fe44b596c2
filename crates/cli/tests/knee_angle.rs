//! `--knee-angle-deg` on `simulate`, `identify` and `diagnose`: a constant knee angle for a
//! trial file without a `knee_angle_deg` column, refused (exit code 2, one line naming the
//! file and the column, nothing written) when the file's column holds other values.

use experiment::{synthesize, write_trial, Protocol, SynthConfig, Trial};
use std::path::{Path, PathBuf};
mod common;
use common::{stderr_of, surae};

/// A synthetic seed trial (seed 31), with the given knee column, written into `dir`.
fn trial_file(dir: &Path, name: &str, knee: Option<f64>) -> PathBuf {
    let mut trial: Trial = synthesize(&SynthConfig::new(Protocol::Seed, 31))
        .unwrap()
        .trial;
    trial.knee_angle_deg = knee.map(|k| vec![k; trial.len()]);
    let path = dir.join(name);
    write_trial(&path, &trial).unwrap();
    path
}

/// The `torque_nm` column of a `simulate` output.
fn simulated_torque(path: &Path) -> Vec<f64> {
    let text = std::fs::read_to_string(path).unwrap();
    let mut lines = text.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    let col = header.iter().position(|&h| h == "torque_nm").unwrap();
    lines
        .map(|l| l.split(',').nth(col).unwrap().parse().unwrap())
        .collect()
}

/// Files under `dir`, for "nothing written" checks.
fn listing(dir: &Path) -> Vec<PathBuf> {
    let mut v: Vec<PathBuf> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .collect();
    v.sort();
    v
}

/// The constant flag and a column holding the same constant give the same torque: the flag
/// is the column's shorthand.
#[test]
fn the_flag_and_an_equal_column_simulate_the_same_torque() {
    let dir = tempfile::tempdir().unwrap();
    let bare = trial_file(dir.path(), "bare.csv", None);
    let with_column = trial_file(dir.path(), "knee90.csv", Some(90.0));
    let p = |p: &Path| p.to_str().unwrap().to_string();
    let o = surae(
        &[
            "simulate",
            "--trial",
            &p(&bare),
            "--knee-angle-deg",
            "90",
            "--out",
            "flag.csv",
        ],
        dir.path(),
    );
    assert!(o.status.success(), "{}", stderr_of(&o));
    // the column alone, and the column with an agreeing flag
    for (out, extra) in [
        ("column.csv", &[][..]),
        ("both.csv", &["--knee-angle-deg", "90.0"][..]),
    ] {
        let mut args = vec!["simulate", "--trial"];
        let t = p(&with_column);
        args.push(&t);
        args.extend_from_slice(extra);
        args.extend_from_slice(&["--out", out]);
        let o = surae(&args, dir.path());
        assert!(o.status.success(), "{out}: {}", stderr_of(&o));
    }
    let flag = simulated_torque(&dir.path().join("flag.csv"));
    assert_eq!(flag, simulated_torque(&dir.path().join("column.csv")));
    assert_eq!(flag, simulated_torque(&dir.path().join("both.csv")));
}

/// At 90° of knee flexion the gastrocnemii are 0.020 m × π/2 = 31 mm shorter: their slack
/// tendons carry far less force, so the torque falls by well over 1 N·m RMS. Needs the
/// simulation to use the knee angle.
#[test]
fn simulate_at_90_degrees_of_knee_flexion_changes_the_torque() {
    let dir = tempfile::tempdir().unwrap();
    let bare = trial_file(dir.path(), "bare.csv", None);
    let t = bare.to_str().unwrap();
    let o = surae(
        &["simulate", "--trial", t, "--out", "extended.csv"],
        dir.path(),
    );
    assert!(o.status.success(), "{}", stderr_of(&o));
    let o = surae(
        &[
            "simulate",
            "--trial",
            t,
            "--knee-angle-deg",
            "90",
            "--out",
            "flexed.csv",
        ],
        dir.path(),
    );
    assert!(o.status.success(), "{}", stderr_of(&o));
    let extended = simulated_torque(&dir.path().join("extended.csv"));
    let flexed = simulated_torque(&dir.path().join("flexed.csv"));
    let d = numerics::rms_diff(&extended, &flexed);
    assert!(d > 1.0, "RMS torque change at 90° knee flexion {d} N·m");
    let peak = |v: &[f64]| v.iter().copied().fold(f64::MIN, f64::max);
    assert!(
        peak(&flexed) < peak(&extended),
        "peak torque {} (flexed) vs {} (extended)",
        peak(&flexed),
        peak(&extended)
    );
}

/// A flag that disagrees with the file's column is refused by every command that takes it,
/// before anything is written.
#[test]
fn a_flag_that_disagrees_with_the_column_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let trial = trial_file(dir.path(), "knee30.csv", Some(30.0));
    let t = trial.to_str().unwrap();
    let before = listing(dir.path());
    for cmd in [
        &["simulate"][..],
        &["identify", "--method", "sa", "--quiet"][..],
        &["diagnose", "--quiet"][..],
    ] {
        let mut args = cmd.to_vec();
        args.extend_from_slice(&["--trial", t, "--knee-angle-deg", "90", "--out", "fresh"]);
        let o = surae(&args, dir.path());
        let err = stderr_of(&o);
        assert_eq!(o.status.code(), Some(2), "{cmd:?}: {err}");
        assert_eq!(err.trim_end().lines().count(), 1, "{cmd:?}: {err}");
        assert!(err.contains("knee30.csv"), "{cmd:?}: {err}");
        assert!(err.contains("column 7 (knee_angle_deg)"), "{cmd:?}: {err}");
        assert!(err.contains("30") && err.contains("90"), "{cmd:?}: {err}");
        assert!(!err.contains("panicked"), "{cmd:?}: {err}");
        assert_eq!(listing(dir.path()), before, "{cmd:?} wrote something");
    }
}

/// A knee angle outside the knee's range, or not a number, is a one-line error naming the flag.
#[test]
fn an_impossible_knee_angle_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let trial = trial_file(dir.path(), "bare.csv", None);
    let t = trial.to_str().unwrap();
    let before = listing(dir.path());
    for value in ["200", "-45", "nan", "inf"] {
        for cmd in [
            &["simulate"][..],
            &["identify", "--method", "sa", "--quiet"][..],
            &["diagnose", "--quiet"][..],
        ] {
            let mut args = cmd.to_vec();
            args.extend_from_slice(&["--trial", t, "--knee-angle-deg", value, "--out", "fresh"]);
            let o = surae(&args, dir.path());
            let err = stderr_of(&o);
            assert_eq!(o.status.code(), Some(2), "{cmd:?} {value}: {err}");
            assert_eq!(err.trim_end().lines().count(), 1, "{cmd:?} {value}: {err}");
            assert!(err.contains("--knee-angle-deg"), "{cmd:?} {value}: {err}");
            assert_eq!(
                listing(dir.path()),
                before,
                "{cmd:?} {value} wrote something"
            );
        }
    }
}
