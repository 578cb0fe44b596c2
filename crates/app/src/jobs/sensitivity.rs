//! `surae sensitivity`: one-at-a-time ±20 % sweeps (the dissertation's Fig. 6).

use super::{load_model_config, load_trial, trial_inputs, ModelSettings};
use crate::error::{AppError, AppResult};
use crate::figures::FigureSet;
use crate::output::OutDir;
use crate::Reporter;
use muscle_model::{sensitivity, SensitivitySettings};
use std::path::{Path, PathBuf};

/// Arguments of `surae sensitivity`.
#[derive(Debug)]
pub struct SensitivityJob {
    /// Trial: a trial CSV, a recording map (`.json`) of a lab's files (docs/formats.md);
    /// the bundled seed trial when omitted.
    pub trial: Option<PathBuf>,
    pub model: ModelSettings,
    /// Largest relative change in percent (the sweep goes from −MAX to +MAX).
    pub max_change: f64,
    /// Step of the sweep in percent.
    pub step: f64,
    /// Output folder (default `out/sensitivity`): `sensitivity.csv`, `sensitivity.json`.
    pub out: Option<PathBuf>,
}

/// Runs the command.
pub fn run(args: SensitivityJob, rep: &Reporter) -> AppResult {
    if !(args.step.is_finite() && args.step > 0.0) {
        return Err(AppError::bad(format!(
            "--step {}: must be positive",
            args.step
        )));
    }
    if !(args.max_change.is_finite() && args.max_change > 0.0 && args.max_change < 100.0) {
        return Err(AppError::bad(format!(
            "--max-change {}: must be in (0, 100)",
            args.max_change
        )));
    }
    let n_steps = (args.max_change / args.step).floor() as i64;
    if !(1..=1000).contains(&n_steps) {
        return Err(AppError::bad(
            "--step must be at most --max-change, and not tiny",
        ));
    }
    let (params, effects, cfg_inputs) = load_model_config(&args.model)?;
    let loaded = load_trial(args.trial.as_deref(), None, rep)?;
    let inputs = trial_inputs(&loaded, &args.model)?;
    let changes: Vec<f64> = (-n_steps..=n_steps)
        .filter(|&k| k != 0)
        .map(|k| k as f64 * args.step)
        .collect();
    let settings = SensitivitySettings {
        changes_pct: changes,
        ..SensitivitySettings::default()
    };
    let table = sensitivity(&inputs, &params, &effects, &settings)
        .map_err(|e| AppError::bad(format!("{}: nominal simulation failed: {e}", loaded.name)))?;

    let out_dir = args
        .out
        .clone()
        .unwrap_or_else(|| crate::default_out("sensitivity"));
    let mut input_paths: Vec<&Path> = loaded.path.iter().map(|p| p.as_path()).collect();
    input_paths.extend(loaded.data_files.iter().map(|p| p.as_path()));
    input_paths.extend(cfg_inputs.iter().map(|p| p.as_path()));
    let out = OutDir::prepare(
        &out_dir,
        &input_paths,
        &[
            "sensitivity.csv",
            "sensitivity.json",
            "sensitivity.svg",
            "report.html",
        ],
    )?;
    let csv = out.write("sensitivity.csv", table.to_csv().as_bytes())?;
    let json = out.write("sensitivity.json", table.to_json_string().as_bytes())?;
    let points: Vec<report::figures::SensitivityPoint<'_>> = table
        .rows
        .iter()
        .map(|r| report::figures::SensitivityPoint {
            param: &r.param,
            change_pct: r.change_pct,
            rms_change_nm: r.rms_change_nm,
        })
        .collect();
    let mut set = FigureSet::new(&out, &format!("surae sensitivity — {}", loaded.name), rep);
    set.page().paragraph(format!(
        "One-at-a-time sweeps of each identified parameter (dissertation Fig. 6): RMS change \
         of the ankle torque against the nominal simulation (nominal RMS torque {:.1} N·m).",
        table.nominal_rms_torque_nm
    ));
    set.add(
        "sensitivity",
        "RMS torque change per parameter change (dissertation Fig. 6)",
        report::figures::sensitivity_curves(&points),
    )?;
    set.finish()?;

    rep.say(&format!(
        "sensitivity: {} ({} samples), nominal RMS torque {:.2} N·m, changes ±{}% in {}% steps",
        loaded.name,
        loaded.trial.len(),
        table.nominal_rms_torque_nm,
        args.max_change,
        args.step
    ));
    rep.say("  parameter        max RMS change   (% of nominal RMS)");
    for r in &table.ranking {
        rep.say(&format!(
            "  {:<16} {:8.2} N·m      {:6.1} %{}",
            r.param,
            r.max_rms_change_nm,
            r.max_rms_change_pct,
            if r.matters { "   matters" } else { "" }
        ));
    }
    let important = table.important();
    rep.say(&format!(
        "parameters that matter (≥ {}% of the nominal RMS torque): {}",
        table.threshold_pct,
        if important.is_empty() {
            "none".to_string()
        } else {
            important.join(", ")
        }
    ));
    if table.failures() > 0 {
        rep.say(&format!(
            "  {} variations failed to simulate (see the table)",
            table.failures()
        ));
    }
    rep.say(&format!(
        "wrote {}, {}, sensitivity.svg and report.html",
        csv.display(),
        json.display()
    ));
    Ok(())
}
