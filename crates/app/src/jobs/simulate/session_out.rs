//! `surae simulate --session`: the model on every trial of a session, one CSV per trial and
//! `simulate.json` with each trial's moment RMS error and R² (where the fit is judged: the
//! moment file's own samples for a CEINMS trial, every sample of a trial CSV after its
//! dynamometer correction).

use super::super::session::{file_stem, load_session};
use super::SimulateJob;
use crate::error::{AppError, AppResult};
use crate::output::OutDir;
use crate::Reporter;
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
        let torque = t.simulate_at(&session.params, &session.effects)?;
        let (rms, r2) = t.fit_of(&torque)?;
        rows.push(SimulatedTrialReport {
            name: t.name.clone(),
            source: t.source.clone(),
            rms_nm: rms,
            r2,
            scale: t.moment_scale(&torque),
        });
        let mut text = String::with_capacity(inputs.len() * 60);
        text.push_str("time_s,torque_nm,measured_nm,weight\n");
        let weights = t.problem.weights();
        for i in 0..inputs.len() {
            experiment::write_f64(&mut text, inputs.times()[i]);
            text.push(',');
            experiment::write_f64(&mut text, torque[i]);
            text.push(',');
            experiment::write_f64(&mut text, t.problem.measured()[i]);
            text.push(',');
            experiment::write_f64(&mut text, weights.map_or(1.0, |w| w[i]));
            text.push('\n');
        }
        texts.push((format!("{}.csv", file_stem(&t.name)), text));
    }
    let n = rows.len() as f64;
    // a fit that is not a number (a trial of constant torque has no R²) counts as 0 in the mean
    let mean = |f: fn(&SimulatedTrialReport) -> f64| {
        rows.iter().map(f).filter(|v| v.is_finite()).sum::<f64>() / n
    };
    let doc = SessionSimulationReport {
        session: session_path.display().to_string(),
        mean_rms_nm: mean(|r| r.rms_nm),
        mean_r2: mean(|r| r.r2),
        trials: rows,
        emg_normalisation: session.emg.report(),
    };
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
    rep.say("  trial                     RMS (N·m)     R²   moment × k̂ (RMS, half from half)");
    for r in &doc.trials {
        let scale = r.scale.map_or_else(String::new, |k| {
            format!(
                "   × {:.2} ({:.2} → {:.2}){}",
                k.factor,
                k.rms_nm,
                k.cross_validated_rms_nm,
                if k.differs {
                    ": the parameters' EMG-to-moment gain does not fit this trial"
                } else {
                    ""
                }
            )
        });
        rep.say(&format!(
            "  {:<24} {:>9.2} {:>8.3}{scale}",
            r.name, r.rms_nm, r.r2
        ));
    }
    rep.say(&format!(
        "  mean                     {:>9.2} {:>8.3}",
        doc.mean_rms_nm, doc.mean_r2
    ));
    rep.say(&format!(
        "wrote {} and {} trial CSVs",
        path.display(),
        texts.len()
    ));
    Ok(())
}

/// `simulate.json` of a session: each trial's fit at the session's parameters.
#[derive(Debug, Clone, serde::Serialize)]
#[non_exhaustive]
pub struct SessionSimulationReport {
    /// The session manifest (or CEINMS trial folder).
    pub session: String,
    /// Each trial's fit.
    pub trials: Vec<SimulatedTrialReport>,
    /// Mean RMS over the trials (N·m).
    pub mean_rms_nm: f64,
    /// Mean R² over the trials.
    pub mean_r2: f64,
    /// How the session's EMG was normalised.
    pub emg_normalisation: super::super::session::EmgNormalisationReport,
}

/// One trial's fit in a session's `simulate.json`.
#[derive(Debug, Clone, serde::Serialize)]
#[non_exhaustive]
pub struct SimulatedTrialReport {
    /// The trial's name.
    pub name: String,
    /// Where it was read from.
    pub source: String,
    /// RMS where the trial is judged (N·m).
    pub rms_nm: f64,
    /// R² where the trial is judged.
    pub r2: f64,
    /// The scale of the model's moment the trial asks for, judged by predicting one half of
    /// it from the other (`validate`'s `MomentScale`; `null` when it cannot be cut in two):
    /// `differs` when the parameters' EMG-to-moment gain does not fit the trial.
    pub scale: Option<validate::MomentScale>,
}
