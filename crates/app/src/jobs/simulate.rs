//! `surae simulate`: the model's torque for a trial (docs/model.md; effects in docs/formats.md).
//!
//! The output is a CSV, or an OpenSim storage file when `--out` ends in `.sto` (columns in
//! docs/formats.md): the same columns with OpenSim's names for time and angle, plus
//! `ankle_angle_r_moment = −torque_nm`, since OpenSim's ankle moment is positive towards
//! dorsiflexion and surae's torque towards plantarflexion.

use super::{load_model_config, load_trial, out_file, trial_inputs, ModelSettings};
use crate::error::{AppError, AppResult};
use crate::output::write_file_checked;
use crate::Reporter;
use muscle_model::{simulate, SimSettings};
use std::path::PathBuf;

mod session_out;

pub use session_out::{SessionSimulationReport, SimulatedTrialReport};

/// Arguments of `surae simulate`.
#[derive(Debug)]
pub struct SimulateJob {
    /// Trial: a trial CSV, a recording map (`.json`) of a lab's files, or a CEINMS trial folder (a session of one) (docs/formats.md);
    /// the bundled seed trial when omitted.
    pub trial: Option<PathBuf>,
    /// Session manifest (docs/formats.md): the model on each of its trials; `--out` is then a
    /// folder (one CSV per trial and `simulate.json` with each trial's RMS error and R²).
    /// `--params` may be an `identify.json`, whose identified values are set over the
    /// session's parameters.
    pub session: Option<PathBuf>,
    pub model: ModelSettings,
    /// Output: a `.csv` file, an OpenSim storage file (`.sto`), or a folder to write
    /// `simulate.csv` into (default `out/simulate/simulate.csv`).
    pub out: Option<PathBuf>,
}

/// The CSV: `time_s, ankle_angle_deg, torque_nm`, then `torque_<muscle>_nm` for sol, gm, gl
/// and every fixed muscle of the model.
fn csv_text(trial: &experiment::Trial, sim: &muscle_model::SimOutput) -> String {
    let mut text = String::with_capacity(trial.len() * 100);
    text.push_str("time_s,ankle_angle_deg,torque_nm");
    for m in &sim.muscles {
        text.push_str(&format!(",torque_{}_nm", m.name));
    }
    text.push('\n');
    for i in 0..trial.len() {
        experiment::write_f64(&mut text, trial.time_s[i]);
        text.push(',');
        experiment::write_f64(&mut text, trial.ankle_angle_deg[i]);
        text.push(',');
        experiment::write_f64(&mut text, sim.torque[i]);
        for m in &sim.muscles {
            text.push(',');
            experiment::write_f64(&mut text, m.torque[i]);
        }
        text.push('\n');
    }
    text
}

/// The OpenSim storage file: `time`, `ankle_angle_r` (degrees), the CSV's torque columns and
/// `ankle_angle_r_moment` in OpenSim's sign.
fn sto_text(trial: &experiment::Trial, sim: &muscle_model::SimOutput) -> AppResult<String> {
    let mut labels: Vec<String> = ["time", "ankle_angle_r", "torque_nm"]
        .map(String::from)
        .to_vec();
    let mut columns = vec![
        trial.time_s.clone(),
        trial.ankle_angle_deg.clone(),
        sim.torque.clone(),
    ];
    for m in &sim.muscles {
        labels.push(format!("torque_{}_nm", m.name));
        columns.push(m.torque.clone());
    }
    labels.push("ankle_angle_r_moment".into());
    columns.push(sim.torque.iter().map(|t| -t).collect());
    opensim_files::write_sto(&opensim_files::StoTable {
        name: "surae_simulate".into(),
        version: 1,
        in_degrees: Some(true),
        labels,
        columns,
    })
    .map_err(AppError::internal)
}

/// Runs the command.
pub fn run(args: SimulateJob, rep: &Reporter) -> AppResult {
    if let Some(session) = &args.session {
        return session_out::run(&args, session, rep);
    }
    // a CEINMS trial folder is a session of one
    if let Some(folder) = args.trial.as_deref().filter(|p| p.is_dir()) {
        return session_out::run(&args, folder, rep);
    }
    let (params, effects, cfg_inputs) = load_model_config(&args.model)?;
    let loaded = load_trial(args.trial.as_deref(), None, rep)?;
    let inputs = trial_inputs(&loaded, &args.model)?;
    let sim = simulate(&inputs, &params, &effects, &SimSettings::default())
        .map_err(|e| AppError::bad(format!("{}: simulation failed: {e}", loaded.name)))?;
    let trial = &loaded.trial;
    let sto = args
        .out
        .as_deref()
        .filter(|p| p.extension().is_some_and(|e| e.eq_ignore_ascii_case("sto")));
    let (target, text) = match sto {
        Some(p) => (p.to_path_buf(), sto_text(trial, &sim)?),
        None => (
            out_file(args.out.as_deref(), "simulate", "simulate.csv"),
            csv_text(trial, &sim),
        ),
    };
    let mut inputs_paths: Vec<PathBuf> = loaded.path.iter().cloned().collect();
    inputs_paths.extend(loaded.data_files.iter().cloned());
    inputs_paths.extend(cfg_inputs);
    let inputs_paths: Vec<PathBuf> = inputs_paths
        .iter()
        .map(|p| std::fs::canonicalize(p).unwrap_or_else(|_| p.clone()))
        .collect();
    write_file_checked(&target, text.as_bytes(), &inputs_paths)?;

    let n = trial.len() as f64;
    let rms_diff = (trial
        .torque_nm
        .iter()
        .zip(&sim.torque)
        .map(|(m, s)| (m - s) * (m - s))
        .sum::<f64>()
        / n)
        .sqrt();
    let peak = sim.torque.iter().cloned().fold(f64::MIN, f64::max);
    let stats = sim.total_stats();
    rep.say(&format!(
        "simulate: {} ({} samples), effects: {}",
        loaded.name,
        trial.len(),
        if effects.enabled().is_empty() {
            "none".to_string()
        } else {
            effects
                .enabled()
                .iter()
                .map(|k| k.name())
                .collect::<Vec<_>>()
                .join(", ")
        }
    ));
    rep.say(&format!("  peak model torque      {peak:8.2} N·m"));
    for m in &sim.muscles {
        // a dorsiflexor's torque is negative: its largest pull is its minimum
        let (label, p) = if m.torque.iter().any(|&t| t < 0.0) {
            ("min ", m.torque.iter().cloned().fold(f64::MAX, f64::min))
        } else {
            ("peak", m.torque.iter().cloned().fold(f64::MIN, f64::max))
        };
        rep.say(&format!("    {:<4} {label}           {p:8.2} N·m", m.name));
    }
    rep.say(&format!("  RMS vs measured torque {rms_diff:8.2} N·m"));
    rep.say(&format!(
        "  integrator: {} steps ({} rejected), {} RHS calls over {} muscles",
        stats.accepted,
        stats.rejected,
        stats.rhs_calls,
        sim.muscles.len()
    ));
    rep.say(&format!("wrote {}", target.display()));
    Ok(())
}
