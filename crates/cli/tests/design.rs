//! `surae design`: one and three trials, the noise of an unloaded run, and bad input.

mod common;

use common::{json, ok, stderr_of, surae};
use serde_json::Value;
use std::path::{Path, PathBuf};

const PARAMS: [&str; 9] = [
    "sol.lst_m",
    "sol.fom_n",
    "sol.alpha_deg",
    "gm.lst_m",
    "gm.fom_n",
    "gm.alpha_deg",
    "gl.lst_m",
    "gl.fom_n",
    "gl.alpha_deg",
];

/// Reference linearised sds (% of nominal), from a separate hand analysis, for knee0@30 and knee0@30+knee90@30+knee0@60.
const TABLE_ONE: [f64; 9] = [0.62, 7.2, 6.5, 2.6, 16.0, 13.0, 4.5, 22.0, 14.0];
const TABLE_THREE: [f64; 9] = [0.09, 0.66, 3.1, 0.85, 4.6, 5.6, 2.0, 9.8, 6.8];

fn fixture(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../fixtures/seed")
        .join(name)
}

fn sd(row: &Value, key: &str, p: &str) -> f64 {
    row[key][p].as_f64().unwrap()
}

/// The one- and three-trial protocols: what the command writes, what three trials add, and
/// which parameters they identify. The sds are printed against the reference table
/// (`--nocapture`), which they do not reproduce where the torque barely depends on a
/// parameter: a ±20 % change of α0 moves the torque by 2.1 (sol), 0.55 (gm) and 0.06 N·m RMS
/// (gl) (`surae sensitivity`), too little against 1.26 N·m of correlated noise for the
/// table's 13–14 % (docs/design.md). The numbers themselves are checked against repeated fits
/// (`crates/design/tests/fisher_checks.rs`) and against MCMC posteriors on synthetic sessions
/// (`crates/identify-mcmc/tests/session_coverage.rs`).
#[test]
fn reference_table_rows_for_one_and_three_trials() {
    let dir = tempfile::tempdir().unwrap();
    let o = surae(
        &[
            "design",
            "--protocol",
            "knee0@30",
            "--protocol",
            "knee0@30,knee90@30,knee0@60",
            "--out",
            "d",
        ],
        dir.path(),
    );
    ok(&o);
    let stdout = String::from_utf8_lossy(&o.stdout);
    assert!(stdout.contains("knee0@30,knee90@30,knee0@60"), "{stdout}");
    assert!(
        stdout.contains("sol LST") && stdout.contains("gl α0"),
        "{stdout}"
    );
    let d = json(&dir.path().join("d/design.json"));
    assert_eq!(d["params"], "nominal");
    assert_eq!(d["noise"]["source"], "synthetic");
    assert_eq!(d["noise"]["ar1_sd_nm"], 1.2);
    let rows = d["protocols"].as_array().unwrap();
    assert_eq!(rows.len(), 2);
    assert_eq!(rows[1]["trials"].as_array().unwrap().len(), 3);
    let svg = std::fs::read_to_string(dir.path().join("d/design.svg")).unwrap();
    assert!(svg.contains("<svg") && svg.contains("knee0@30,knee90@30,knee0@60"));

    for (row, table, label) in [
        (&rows[0], TABLE_ONE, "knee0@30"),
        (&rows[1], TABLE_THREE, "3 trials"),
    ] {
        for (p, t) in PARAMS.iter().zip(table) {
            eprintln!(
                "{label} {p}: {:.3} vs table {t} ({:.2}x)",
                sd(row, "sd_pct", p),
                sd(row, "sd_pct", p) / t
            );
        }
    }
    // Three trials constrain every parameter better than one.
    for p in PARAMS {
        assert!(sd(&rows[1], "sd_pct", p) < sd(&rows[0], "sd_pct", p), "{p}");
        // The prior only narrows, and the offset nuisance only widens.
        assert!(sd(&rows[1], "sd_pct_with_prior", p) <= sd(&rows[1], "sd_pct", p) * (1.0 + 1e-12));
        assert!(
            sd(&rows[1], "sd_pct_offset_known", p) <= sd(&rows[1], "sd_pct", p) * (1.0 + 1e-12)
        );
    }
    for p in ["sol.lst_m", "sol.fom_n", "sol.alpha_deg"] {
        assert_eq!(rows[1]["identifiable"][p], true, "{p}");
    }
    for p in ["gm.alpha_deg", "gl.alpha_deg"] {
        assert_eq!(rows[0]["identifiable"][p], false, "{p}");
        assert_eq!(rows[1]["identifiable"][p], false, "{p}");
    }
}

/// The noise fitted to the seed fixture's unloaded run (the synthetic dynamometer) is close to
/// the synthetic noise, and so are the sds.
#[test]
fn noise_from_an_unloaded_run() {
    let dir = tempfile::tempdir().unwrap();
    let u = fixture("unloaded.csv");
    let run = |extra: &[&str], out: &str| {
        let mut args = vec![
            "design",
            "--protocol",
            "knee0@30",
            "--emg-draws",
            "2",
            "--out",
            out,
        ];
        args.extend_from_slice(extra);
        let o = surae(&args, dir.path());
        ok(&o);
        json(&dir.path().join(out).join("design.json"))
    };
    let fitted = run(&["--unloaded", u.to_str().unwrap()], "u");
    let synthetic = run(&[], "s");
    assert_eq!(fitted["noise"]["source"], u.display().to_string());
    let sd = fitted["noise"]["ar1_sd_nm"].as_f64().unwrap();
    let tc = fitted["noise"]["ar1_corr_time_s"].as_f64().unwrap();
    assert!((0.9..1.5).contains(&sd), "σ_AR {sd}");
    assert!((0.015..0.06).contains(&tc), "τc {tc}");
    for p in PARAMS {
        let r = fitted["protocols"][0]["sd_pct"][p].as_f64().unwrap()
            / synthetic["protocols"][0]["sd_pct"][p].as_f64().unwrap();
        assert!((0.7..1.4).contains(&r), "{p}: {r}");
    }
}

#[test]
fn bad_input_is_one_line_and_exit_2() {
    let dir = tempfile::tempdir().unwrap();
    let cases: [(&[&str], &str); 4] = [
        (&["--protocol", "knee0@30,elbow"], "elbow"),
        (
            &["--protocol", "knee0@30,,knee90@30"],
            "knee0@30,,knee90@30",
        ),
        (
            &["--protocol", "knee0@30", "--unloaded", "missing.csv"],
            "missing.csv",
        ),
        (
            &["--protocol", "knee0@30", "--offset-sd", "-1"],
            "--offset-sd",
        ),
    ];
    for (args, named) in cases {
        let mut a = vec!["design", "--out", "o"];
        a.extend_from_slice(args);
        let o = surae(&a, dir.path());
        let err = stderr_of(&o);
        assert_eq!(o.status.code(), Some(2), "{args:?}: {err}");
        assert_eq!(err.trim().lines().count(), 1, "{err}");
        assert!(err.contains(named), "{args:?}: {err}");
        assert!(!dir.path().join("o/design.json").exists());
    }
    std::fs::write(dir.path().join("bad.csv"), "time_s,ankle_angle_deg\n0,1\n").unwrap();
    let o = surae(
        &[
            "design",
            "--protocol",
            "knee0@30",
            "--unloaded",
            "bad.csv",
            "--out",
            "o",
        ],
        dir.path(),
    );
    let err = stderr_of(&o);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(
        err.contains("bad.csv") && err.trim().lines().count() == 1,
        "{err}"
    );
}
