//! `surae simulate`: the model's torque for a trial (docs/model.md; effects in docs/formats.md).

use super::{load_model_config, load_trial, out_file, trial_inputs, ModelArgs};
use crate::error::{CmdResult, Failure};
use crate::output::write_file_checked;
use muscle_model::{simulate, Muscle, SimSettings};
use std::path::PathBuf;

/// Arguments of `surae simulate`.
#[derive(clap::Args, Debug)]
pub struct SimulateArgs {
    /// Trial CSV (format in docs/formats.md); the bundled seed trial when omitted.
    #[arg(long)]
    pub trial: Option<PathBuf>,
    #[command(flatten)]
    pub model: ModelArgs,
    /// Output: a `.csv` file, or a folder to write `simulate.csv` into
    /// (default `out/simulate/simulate.csv`).
    #[arg(long)]
    pub out: Option<PathBuf>,
}

/// Runs the command.
pub fn run(args: SimulateArgs) -> CmdResult {
    let (params, effects, cfg_inputs) = load_model_config(&args.model)?;
    let loaded = load_trial(args.trial.as_deref())?;
    let inputs = trial_inputs(&loaded, &args.model)?;
    let sim = simulate(&inputs, &params, &effects, &SimSettings::default())
        .map_err(|e| Failure::bad(format!("{}: simulation failed: {e}", loaded.name)))?;
    let trial = &loaded.trial;
    let mut text = String::with_capacity(trial.len() * 100);
    text.push_str("time_s,ankle_angle_deg,torque_nm,torque_sol_nm,torque_gm_nm,torque_gl_nm\n");
    for i in 0..trial.len() {
        experiment::write_f64(&mut text, trial.time_s[i]);
        text.push(',');
        experiment::write_f64(&mut text, trial.ankle_angle_deg[i]);
        text.push(',');
        experiment::write_f64(&mut text, sim.torque[i]);
        for m in Muscle::ALL {
            text.push(',');
            experiment::write_f64(&mut text, sim.torque_of(m)[i]);
        }
        text.push('\n');
    }
    let target = out_file(args.out.as_deref(), "simulate", "simulate.csv");
    let mut inputs_paths: Vec<PathBuf> = loaded.path.iter().cloned().collect();
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
    println!(
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
    );
    println!("  peak model torque      {peak:8.2} N·m");
    for m in Muscle::ALL {
        let p = sim.torque_of(m).iter().cloned().fold(f64::MIN, f64::max);
        println!("    {:<4} peak           {p:8.2} N·m", m.name());
    }
    println!("  RMS vs measured torque {rms_diff:8.2} N·m");
    println!(
        "  integrator: {} steps ({} rejected), {} RHS calls over 3 muscles",
        stats.accepted, stats.rejected, stats.rhs_calls
    );
    println!("wrote {}", target.display());
    Ok(())
}
