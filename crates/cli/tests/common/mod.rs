//! What the command-line tests share: running the `surae` binary and reading its output.
// each test file uses its own subset
#![allow(dead_code)]

use ceinms_files::format_table;
use experiment::{random_error, synthesize, DynamometerSettings, Recording, SynthConfig};
use muscle_model::{simulate, Effects, GeometrySeries, ModelParams, Muscle, SimSettings};
use serde_json::Value;
use std::path::Path;
use std::process::{Command, Output};

/// Runs `surae` with `args` in `cwd`.
pub fn surae(args: &[&str], cwd: &Path) -> Output {
    Command::new(env!("CARGO_BIN_EXE_surae"))
        .args(args)
        .current_dir(cwd)
        .output()
        .expect("the surae binary runs")
}

/// Standard error as text.
pub fn stderr_of(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// Asserts that a run succeeded, showing its output when it did not.
pub fn ok(o: &Output) {
    assert!(
        o.status.success(),
        "exit {:?}\nstdout: {}\nstderr: {}",
        o.status.code(),
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr)
    );
}

/// A JSON file.
/// Writes `session.json` in `dir`: a session of one trial named `name`, `trial.csv` with its
/// `unloaded.csv`.
pub fn one_trial_session(dir: &Path, name: &str) {
    let text = format!(
        r#"{{"trials": [{{"name": "{name}", "trial": "trial.csv", "unloaded": "unloaded.csv"}}]}}"#
    );
    std::fs::write(dir.join("session.json"), text).unwrap();
}

pub fn json(path: &Path) -> Value {
    serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap()
}

/// CEINMS names of the muscles written, surae's name of each.
pub const MUSCLES: [(&str, &str); 4] = [
    ("sol_r", "sol"),
    ("gasmed_r", "gm"),
    ("gaslat_r", "gl"),
    ("tibant_r", "tibant_r"),
];

/// What [`ceinms_folder`] writes.
pub struct CeinmsFolder<'a> {
    /// Seed of the synthetic seed-protocol trial (and of the noise).
    pub seed: u64,
    /// How much of the trial (s).
    pub seconds: f64,
    /// The model whose moment is written (sol, gm, gl and a fixed `tibant_r`).
    pub truth: &'a ModelParams,
    /// Its effects.
    pub effects: &'a Effects,
    /// Whether the dynamometer's seeded random error is added to the moment.
    pub noise: bool,
    /// EMG lead-in before the moment file's first sample (s); CEINMS's trials have about 0.13.
    pub lead_in_s: f64,
}

/// The first `seconds` of a synthetic trial written as a CEINMS folder: envelopes at the
/// trial's rate, lengths and moment arms at 250 Hz (CEINMS's sign, plantarflexion negative),
/// and the moment of `truth` with `effects` (plus, if asked, the dynamometer's random error)
/// from `lead_in_s` on, at 250 Hz.
pub fn ceinms_folder(dir: &Path, spec: &CeinmsFolder<'_>) {
    let CeinmsFolder {
        seed,
        seconds,
        truth,
        effects,
        noise,
        lead_in_s,
    } = *spec;
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
    let error = if noise {
        random_error(
            n,
            1.0 / fs,
            &DynamometerSettings::default(),
            seed,
            Recording::Trial,
        )
        .unwrap()
    } else {
        vec![0.0; n]
    };
    let measured: Vec<f64> = sim.torque.iter().zip(&error).map(|(a, b)| a + b).collect();
    let moment_t: Vec<f64> = grid
        .iter()
        .copied()
        .filter(|&s| s >= t[0] + lead_in_s)
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
pub fn subject_xml(p: &ModelParams) -> String {
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
pub fn truth_with_tibialis() -> ModelParams {
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

/// Every file under `dir` (relative path → content; folders as `None`), to check that a failed
/// run changed nothing.
pub fn snapshot(dir: &Path) -> std::collections::BTreeMap<std::path::PathBuf, Option<Vec<u8>>> {
    let mut out = std::collections::BTreeMap::new();
    let mut stack = vec![dir.to_path_buf()];
    while let Some(d) = stack.pop() {
        for e in std::fs::read_dir(&d).unwrap() {
            let p = e.unwrap().path();
            let rel = p.strip_prefix(dir).unwrap().to_path_buf();
            if p.is_dir() {
                stack.push(p.clone());
                out.insert(rel, None);
            } else {
                out.insert(rel, Some(std::fs::read(&p).unwrap()));
            }
        }
    }
    out
}

/// What is wrong with a run that should have refused bad input: exit code 2, one line on
/// standard error starting with `error: ` and holding every needle, no panic.
pub fn refusal_problems(o: &Output, needles: &[String]) -> Vec<String> {
    let err = String::from_utf8_lossy(&o.stderr);
    let mut problems = Vec::new();
    if o.status.code() != Some(2) {
        problems.push(format!("exit code {:?}, expected 2", o.status.code()));
    }
    if err.contains("panicked") {
        problems.push("panicked".into());
    }
    if err.trim_end().lines().count() != 1 || err.trim_end().contains('\r') {
        problems.push("stderr is not exactly one line".into());
    }
    if !err.starts_with("error: ") {
        problems.push("stderr does not start with 'error: '".into());
    }
    for n in needles {
        if !err.contains(n.as_str()) {
            problems.push(format!("message lacks '{n}'"));
        }
    }
    problems
}
