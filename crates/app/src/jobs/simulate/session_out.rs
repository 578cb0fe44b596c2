//! `surae simulate --session`: the model on every trial of a session, one CSV per trial and
//! `simulate.json` with each trial's moment RMS error and R² (where the fit is judged: the
//! moment file's own samples for a CEINMS trial, every sample of a trial CSV after its
//! dynamometer correction).

use super::super::session::{file_stem, load_session};
use super::SimulateJob;
use crate::error::{AppError, AppResult};
use crate::output::OutDir;
use crate::Reporter;
use muscle_model::{simulate, SimSettings};
use serde_json::json;
use std::path::Path;

/// Runs `simulate --session`.
pub(super) fn run(args: &SimulateJob, session_path: &Path, rep: &Reporter) -> AppResult {
    let session = load_session(session_path, &args.model, None, rep)?;
    let out_dir = args
        .out
        .clone()
        .unwrap_or_else(|| crate::default_out("simulate"));
    if out_dir
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("csv") || e.eq_ignore_ascii_case("sto"))
    {
        return Err(AppError::bad(format!(
            "--out {}: with --session, --out is a folder (one CSV per trial and simulate.json)",
            out_dir.display()
        )));
    }
    let mut planned = vec!["simulate.json".to_string()];
    planned.extend(
        session
            .trials
            .iter()
            .map(|t| format!("{}.csv", file_stem(&t.name))),
    );
    let planned_refs: Vec<&str> = planned.iter().map(String::as_str).collect();
    let input_refs: Vec<&Path> = session.inputs_read.iter().map(|p| p.as_path()).collect();
    let out = OutDir::prepare(&out_dir, &input_refs, &planned_refs)?;

    let mut rows = Vec::with_capacity(session.trials.len());
    let mut texts = Vec::with_capacity(session.trials.len());
    for t in &session.trials {
        let inputs = t.problem.inputs();
        let sim = simulate(
            inputs,
            &session.params,
            &session.effects,
            &SimSettings::default(),
        )
        .map_err(|e| AppError::bad(format!("{}: simulation failed: {e}", t.source)))?;
        let (rms, r2) = t.fit_of(&sim.torque)?;
        rows.push(json!({"name": t.name, "source": t.source, "rms_nm": rms, "r2": r2}));
        let mut text = String::with_capacity(inputs.len() * 60);
        text.push_str("time_s,torque_nm,measured_nm,weight\n");
        let weights = t.problem.weights();
        for i in 0..inputs.len() {
            experiment::write_f64(&mut text, inputs.times()[i]);
            text.push(',');
            experiment::write_f64(&mut text, sim.torque[i]);
            text.push(',');
            experiment::write_f64(&mut text, t.problem.measured()[i]);
            text.push(',');
            experiment::write_f64(&mut text, weights.map_or(1.0, |w| w[i]));
            text.push('\n');
        }
        texts.push((format!("{}.csv", file_stem(&t.name)), text));
    }
    let n = rows.len() as f64;
    let mean = |k: &str| rows.iter().filter_map(|r| r[k].as_f64()).sum::<f64>() / n;
    let doc = json!({
        "session": session_path.display().to_string(),
        "trials": rows,
        "mean_rms_nm": mean("rms_nm"),
        "mean_r2": mean("r2"),
        "emg_normalisation": session.emg.to_json(),
    });
    let text = serde_json::to_string_pretty(&doc).map_err(AppError::internal)? + "\n";
    for (name, t) in &texts {
        out.write(name, t.as_bytes())?;
    }
    let path = out.write("simulate.json", text.as_bytes())?;
    rep.say(&format!(
        "simulate: session {} — {} trials",
        session_path.display(),
        session.trials.len()
    ));
    for l in session.emg.summary_lines() {
        rep.say(&l);
    }
    rep.say("  trial                     RMS (N·m)     R²");
    for r in doc["trials"].as_array().into_iter().flatten() {
        rep.say(&format!(
            "  {:<24} {:>9.2} {:>8.3}",
            r["name"].as_str().unwrap_or(""),
            r["rms_nm"].as_f64().unwrap_or(f64::NAN),
            r["r2"].as_f64().unwrap_or(f64::NAN)
        ));
    }
    rep.say(&format!(
        "  mean                     {:>9.2} {:>8.3}",
        doc["mean_rms_nm"].as_f64().unwrap_or(f64::NAN),
        doc["mean_r2"].as_f64().unwrap_or(f64::NAN)
    ));
    rep.say(&format!(
        "wrote {} and {} trial CSVs",
        path.display(),
        texts.len()
    ));
    Ok(())
}
