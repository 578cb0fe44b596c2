//! `surae identify --session`: the session's trials identified together by simulated
//! annealing (the cost is the sum of the trials' squared torque errors), with each trial's fit
//! reported where it is judged.

use super::super::session::{file_stem, load_session, LoadedSession};
use super::IdentifyArgs;
use crate::error::{CmdResult, Failure};
use crate::figures::{self, FigureSet};
use crate::output::OutDir;
use crate::progress::ProgressDisplay;
use serde_json::{json, Map, Value};
use std::path::Path;

/// Runs `identify --method sa --session`.
pub(super) fn run(args: &IdentifyArgs, session_path: &Path) -> CmdResult {
    let session = load_session(session_path, &args.model, args.free.as_deref())?;
    let set = session.problem_set()?;
    let out_dir = args
        .out
        .clone()
        .unwrap_or_else(|| crate::default_out("identify"));
    let input_refs: Vec<&Path> = session.inputs_read.iter().map(|p| p.as_path()).collect();
    let mut planned = vec![
        "identify.json".to_string(),
        "report.html".to_string(),
        "identified.osim".to_string(),
    ];
    planned.extend(
        session
            .trials
            .iter()
            .map(|t| format!("torque_fit_{}.svg", file_stem(&t.name))),
    );
    let planned_refs: Vec<&str> = planned.iter().map(String::as_str).collect();
    let out = OutDir::prepare(&out_dir, &input_refs, &planned_refs)?;

    let mut settings = identify_sa::SaIdentifySettings::default().with_seed(args.seed);
    if let Some(c) = args.chains {
        settings = settings.with_chains(c);
    }
    let show = args.report.show();
    let total = u64::from(settings.chains) * settings.annealer.max_evaluations;
    let progress = ProgressDisplay::new(show, total, "SA");
    let observer = |ev: &identify_sa::IdentifyEvent| {
        progress.on_sa_event(ev);
        progress.flow()
    };
    let fit = identify_sa::identify_set(&set, &settings, &observer).map_err(|e| {
        Failure::bad(format!(
            "{}: identification failed: {e}",
            session_path.display()
        ))
    })?;
    progress.finish();
    if progress.stop_requested() {
        return Err(Failure::Interrupted);
    }

    let (params, effects) = set
        .params_from_vector(&fit.x)
        .map_err(|e| Failure::internal(e.to_string()))?;
    let mut trials = Vec::with_capacity(session.trials.len());
    let mut predictions = Vec::with_capacity(session.trials.len());
    let start = set.base_vector();
    for t in &session.trials {
        let failed = |e: muscle_model::ModelError| {
            Failure::bad(format!("{}: simulation of the fit failed: {e}", t.source))
        };
        let pred = t.problem.predict(&fit.x).map_err(failed)?;
        let (rms, r2) = t.fit_of(&pred)?;
        // the session's own parameters, for comparison (e.g. a CEINMS calibration)
        let base = t.problem.predict(&start).map_err(failed)?;
        let (rms0, r20) = t.fit_of(&base)?;
        trials.push(json!({
            "name": t.name,
            "source": t.source,
            "rms_nm": rms,
            "r2": r2,
            "start_rms_nm": rms0,
            "start_r2": r20,
            "dynamometer": t.dynamometer(),
        }));
        predictions.push((pred, base));
    }
    let values: Map<String, Value> = fit
        .params
        .iter()
        .map(|(k, v)| (k.clone(), json!(v)))
        .collect();
    let bounds: Map<String, Value> = set
        .names()
        .iter()
        .zip(set.bounds())
        .map(|(k, (lo, hi))| (k.clone(), json!([lo, hi])))
        .collect();
    let mut doc = json!({
        "method": "sa",
        "session": session_path.display().to_string(),
        "subject": session.manifest.subject,
        "seed": args.seed,
        "params": values,
        "bounds": bounds,
        "rms_nm": fit.rms_nm,
        "trials": trials,
        "dynamometer": session.trials.iter().map(|t| t.dynamometer()).collect::<Vec<_>>(),
        "evaluations": fit.evaluations,
        "wall_s": fit.wall_s,
        "sa": {
            "chains": fit.chains.len(),
            "best_chain": fit.best_chain,
            "chain_costs": fit.chains.iter().map(|c| c.cost).collect::<Vec<_>>(),
            "chain_rms_nm": fit.chains.iter().map(|c| (c.cost / set.weight_sum()).sqrt()).collect::<Vec<_>>(),
        },
        "model": params.to_json_value(),
    });
    if !effects.enabled().is_empty() {
        doc["effects"] = effects.to_json_value();
    }
    let text = serde_json::to_string_pretty(&doc).map_err(Failure::internal)? + "\n";
    let path = out.write("identify.json", text.as_bytes())?;
    let mut files = write_figures(&out, &session, &predictions, session_path)?;
    // the identified values written into a copy of the session's OpenSim model, if it has one
    let osim = [args.model.params.as_ref(), session.manifest.params.as_ref()]
        .into_iter()
        .flatten()
        .find(|p| super::super::is_osim(p));
    if let Some(path) = osim {
        let names = opensim_files::OsimMuscleNames::renamed(
            session
                .manifest
                .osim_muscles
                .iter()
                .map(|(k, v)| (k.as_str(), v.as_str())),
        )
        .map_err(Failure::bad)?;
        files.push(super::other_tools::write_osim_copy(
            &out, path, &names, &params,
        )?);
    }

    args.report.print_json(&text);
    if show {
        let say = |s: &str| args.report.say(s);
        say(&format!(
            "identify (sa): session {} — {} trials, {} evaluations in {:.1} s",
            session_path.display(),
            session.trials.len(),
            fit.evaluations,
            fit.wall_s
        ));
        say(&format!(
            "  chains' RMS: {} N·m (best: chain {})",
            fit.chains
                .iter()
                .map(|c| format!("{:.2}", (c.cost / set.weight_sum()).sqrt()))
                .collect::<Vec<_>>()
                .join(", "),
            fit.best_chain
        ));
        say("  trial                     RMS (N·m)     R²   at the session's parameters");
        for t in doc["trials"].as_array().into_iter().flatten() {
            let f = |k: &str| t[k].as_f64().unwrap_or(f64::NAN);
            say(&format!(
                "  {:<24} {:>9.2} {:>8.3}   {:>9.2} {:>8.3}",
                t["name"].as_str().unwrap_or(""),
                f("rms_nm"),
                f("r2"),
                f("start_rms_nm"),
                f("start_r2")
            ));
        }
        say("  parameter                      estimate    bounds");
        for (i, name) in set.names().iter().enumerate() {
            let (lo, hi) = set.bounds()[i];
            let v = fit.x[i];
            let at_bound = (v - lo).abs() <= 1e-6 * (hi - lo) || (hi - v).abs() <= 1e-6 * (hi - lo);
            say(&format!(
                "  {name:<30} {v:>12.5}    [{lo:.5}, {hi:.5}]{}",
                if at_bound { "  at bound" } else { "" }
            ));
        }
        say(&format!(
            "wrote {} and {} figures/report files in {}",
            path.display(),
            files.len(),
            out_dir.display()
        ));
    }
    Ok(())
}

fn write_figures(
    out: &OutDir,
    session: &LoadedSession,
    predictions: &[(Vec<f64>, Vec<f64>)],
    session_path: &Path,
) -> CmdResult<Vec<std::path::PathBuf>> {
    let mut set = FigureSet::new(
        out,
        &format!("surae identify (sa) — session {}", session_path.display()),
    );
    set.page().paragraph(
        "The session's trials identified together: one set of muscle parameters for every \
         trial, fitted to the sum of the trials' squared torque errors. Each figure shows one \
         trial's measured torque (after its dynamometer correction, when it has an unloaded \
         run), the model at the identified parameters, and the model at the session's own \
         parameters (where the identification started)."
            .to_string(),
    );
    for (t, (pred, base)) in session.trials.iter().zip(predictions) {
        let inputs = t.problem.inputs();
        let angle = figures::angle_deg(inputs);
        let env = figures::envelopes(inputs);
        let measured = t.problem.measured();
        // a CEINMS trial's moment is measured only inside the moment file's span
        let keep: Vec<usize> = match t.problem.weights() {
            Some(w) => (0..w.len()).filter(|&i| w[i] > 0.0).collect(),
            None => (0..inputs.len()).collect(),
        };
        let pick = |v: &[f64]| keep.iter().map(|&i| v[i]).collect::<Vec<f64>>();
        let (time, measured, pred, base, angle) = (
            pick(inputs.times()),
            pick(measured),
            pick(pred),
            pick(base),
            pick(&angle),
        );
        let env: Vec<(&str, Vec<f64>)> = env.iter().map(|(n, e)| (*n, pick(e))).collect();
        let env_refs: Vec<(&str, &[f64])> = env.iter().map(|(n, e)| (*n, e.as_slice())).collect();
        set.add(
            &format!("torque_fit_{}", file_stem(&t.name)),
            &format!("{}: measured and fitted torque", t.name),
            report::figures::torque_fit(
                &time,
                &measured,
                &[("fit", &pred), ("session's parameters", &base)],
                &angle,
                &env_refs,
            ),
        )?;
    }
    set.finish()
}
