//! OpenSim and ArviZ outputs of the `surae` binary: `simulate --out x.sto`, `identified.osim`
//! from an `.osim` `--params`, the CmdStan chain files, and bad OpenSim input.

use std::path::{Path, PathBuf};
mod common;
use common::{stderr_of, surae};

/// The test model of the opensim-files crate (six muscles, Thelen, Millard and Schutte).
fn leg6() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../opensim-files/tests/data/leg6.osim")
}

fn read_csv(path: &Path) -> (Vec<String>, Vec<Vec<f64>>) {
    let text = std::fs::read_to_string(path).unwrap();
    let mut lines = text.lines().filter(|l| !l.starts_with('#'));
    let header = lines.next().unwrap().split(',').map(String::from).collect();
    let rows = lines
        .map(|l| l.split(',').map(|v| v.parse().unwrap()).collect())
        .collect();
    (header, rows)
}

/// A storage file read the simplest way: skip to `endheader`, tab-separated labels and rows.
fn minimal_sto(text: &str) -> (Vec<String>, Vec<Vec<f64>>) {
    let mut lines = text.lines().skip_while(|l| l.trim() != "endheader").skip(1);
    let labels = lines
        .next()
        .unwrap()
        .split('\t')
        .map(String::from)
        .collect();
    let rows = lines
        .map(|l| l.split('\t').map(|v| v.parse().unwrap()).collect())
        .collect();
    (labels, rows)
}

#[test]
fn simulate_sto_holds_the_csv_columns_and_the_opensim_moment() {
    let dir = tempfile::tempdir().unwrap();
    for out in ["sim.csv", "sim.sto"] {
        let o = surae(&["simulate", "--out", out], dir.path());
        assert!(o.status.success(), "{}", stderr_of(&o));
    }
    let (csv_header, csv) = read_csv(&dir.path().join("sim.csv"));
    let text = std::fs::read_to_string(dir.path().join("sim.sto")).unwrap();
    let head: Vec<&str> = text.lines().take(6).collect();
    assert_eq!(
        head,
        [
            "surae_simulate",
            "version=1",
            &format!("nRows={}", csv.len()),
            "nColumns=7",
            "inDegrees=yes",
            "endheader"
        ]
    );
    let table = opensim_files::read_sto(&text, "sim.sto").unwrap();
    let (labels, rows) = minimal_sto(&text);
    assert_eq!(labels, table.labels);
    assert_eq!(
        labels,
        [
            "time",
            "ankle_angle_r",
            "torque_nm",
            "torque_sol_nm",
            "torque_gm_nm",
            "torque_gl_nm",
            "ankle_angle_r_moment"
        ]
    );
    assert_eq!(table.in_degrees, Some(true));
    assert_eq!(rows.len(), csv.len());
    assert_eq!(table.rows(), csv.len());
    for (i, (r, c)) in rows.iter().zip(&csv).enumerate() {
        // the CSV's six columns in order, then the moment in OpenSim's sign
        for j in 0..csv_header.len() {
            assert!((r[j] - c[j]).abs() <= 1e-9, "row {i} column {j}");
            assert!(
                (table.columns[j][i] - c[j]).abs() <= 1e-9,
                "row {i} column {j}"
            );
        }
        assert!((r[6] + c[2]).abs() <= 1e-9);
    }
    assert!(csv.iter().any(|c| c[2].abs() > 10.0));
}

#[test]
fn identify_with_an_osim_model_writes_identified_osim_and_cmdstan_chains() {
    let dir = tempfile::tempdir().unwrap();
    let model = leg6();
    let o = surae(
        &[
            "identify",
            "--method",
            "mcmc",
            "--max-iterations",
            "2200",
            "--quiet",
            "--params",
            model.to_str().unwrap(),
            "--out",
            "run",
        ],
        dir.path(),
    );
    assert!(o.status.success(), "{}", stderr_of(&o));
    let run = dir.path().join("run");
    let doc: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(run.join("identify.json")).unwrap()).unwrap();
    let names = opensim_files::OsimMuscleNames::default();
    let nominal = muscle_model::ModelParams::nominal();
    let text = std::fs::read_to_string(&model).unwrap();
    let given = opensim_files::osim_params(&text, "leg6.osim", &names, &nominal).unwrap();
    let identified = std::fs::read_to_string(run.join("identified.osim")).unwrap();
    let back =
        opensim_files::osim_params(&identified, "identified.osim", &names, &nominal).unwrap();
    for m in muscle_model::Muscle::ALL {
        let p = |f: &str| doc["params"][format!("{}.{f}", m.name())].as_f64().unwrap();
        let (b, g) = (back.muscle(m), given.muscle(m));
        assert_eq!(b.fom_n, p("fom_n"));
        assert_eq!(b.lst_m, p("lst_m"));
        assert!((b.alpha_deg - p("alpha_deg")).abs() < 1e-12);
        // the model's values are the nominal ones: F0 within ±20 % of the file's
        assert!((b.fom_n / g.fom_n - 1.0).abs() <= 0.2 + 1e-12);
        assert_eq!((b.lom_m, b.vmax_lom_per_s), (g.lom_m, g.vmax_lom_per_s));
    }

    // one CmdStan CSV per chain; their pooled means are identify.json's
    let n_chains = doc["chains"].as_u64().unwrap() as usize;
    let mut sums: std::collections::BTreeMap<String, (f64, usize)> = Default::default();
    for k in 1..=n_chains {
        let (header, rows) = read_csv(&run.join(format!("chains/chain_{k}.csv")));
        assert_eq!(header[0], "lp__");
        assert_eq!(header.last().unwrap(), "log_lik.1");
        assert_eq!(
            rows.len(),
            doc["sampling_iterations"].as_u64().unwrap() as usize
        );
        for (j, h) in header.iter().enumerate() {
            let e = sums.entry(h.clone()).or_default();
            for r in &rows {
                e.0 += r[j];
                e.1 += 1;
            }
        }
    }
    assert!(!run
        .join(format!("chains/chain_{}.csv", n_chains + 1))
        .exists());
    for (name, post) in doc["posterior"].as_object().unwrap() {
        let (s, n) = sums[&name.replace('.', "_")];
        let mean = post["mean"].as_f64().unwrap();
        assert!((s / n as f64 - mean).abs() <= 1e-9 * mean.abs(), "{name}");
    }
}

/// Runs `args` in a fresh folder holding `files`; asserts exit 2, one line containing every
/// needle, and no output folder.
fn assert_bad(args: &[&str], files: &[(&str, &str)], needles: &[&str]) {
    let dir = tempfile::tempdir().unwrap();
    for (name, text) in files {
        std::fs::write(dir.path().join(name), text).unwrap();
    }
    let o = surae(args, dir.path());
    let err = stderr_of(&o);
    assert_eq!(o.status.code(), Some(2), "{args:?}: {err}");
    assert_eq!(err.trim().lines().count(), 1, "{err}");
    for n in needles {
        assert!(err.contains(n), "{args:?}: `{n}` not in {err}");
    }
    assert!(!dir.path().join("out").exists());
}

#[test]
fn bad_opensim_input_exits_2_naming_the_place() {
    let model = std::fs::read_to_string(leg6()).unwrap();
    let broken = model.replace("<max_isometric_force>700<", "<max_isometric_force>7OO<");
    let line = broken[..broken.find("7OO").unwrap()].matches('\n').count() + 1;
    assert_bad(
        &["simulate", "--params", "m.osim"],
        &[("m.osim", &broken)],
        &[&format!("m.osim:{line}:"), "`7OO` is not a number"],
    );
    assert_bad(
        &[
            "simulate",
            "--params",
            "m.osim",
            "--osim-muscles",
            "gl=per_long_r",
        ],
        &[("m.osim", &model)],
        &["Schutte1993Muscle_Deprecated", "Thelen2003Muscle"],
    );
    assert_bad(
        &[
            "simulate",
            "--params",
            "m.osim",
            "--osim-muscles",
            "ta=tib_ant_r",
        ],
        &[("m.osim", &model)],
        &["osim_muscles: `ta` is not one of sol, gm, gl"],
    );
    assert_bad(
        &["simulate", "--osim-muscles", "sol=soleus_l"],
        &[],
        &["--osim-muscles applies to an OpenSim model"],
    );
    assert_bad(
        &["simulate", "--params", "m.osim"],
        &[("m.osim", "<OpenSimDocument><Model></Model")],
        &["m.osim:1:"],
    );
}

#[test]
fn renamed_osim_muscles_set_the_nominal_values() {
    let dir = tempfile::tempdir().unwrap();
    let model = leg6();
    let m = model.to_str().unwrap();
    let a = surae(&["simulate", "--params", m, "--out", "a.csv"], dir.path());
    let b = surae(
        &[
            "simulate",
            "--params",
            m,
            "--osim-muscles",
            "sol=soleus_l",
            "--out",
            "b.csv",
        ],
        dir.path(),
    );
    assert!(
        a.status.success() && b.status.success(),
        "{}",
        stderr_of(&b)
    );
    let (_, ra) = read_csv(&dir.path().join("a.csv"));
    let (_, rb) = read_csv(&dir.path().join("b.csv"));
    // soleus_l is a different soleus: the soleus torque differs, the gastrocnemii do not
    assert!(ra.iter().zip(&rb).any(|(x, y)| (x[3] - y[3]).abs() > 1e-3));
    assert!(ra
        .iter()
        .zip(&rb)
        .all(|(x, y)| x[4] == y[4] && x[5] == y[5]));
}
