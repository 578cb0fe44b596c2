//! `surae identify --session`: the session's trials identified together, by simulated
//! annealing (the cost is the sum of the trials' squared torque errors) or by MCMC (the
//! log-likelihood is the sum of the trials', each with its own dynamometer correction, noise
//! model and offset nuisance), with each trial's fit reported where it is judged. `--with`
//! adds the parameters of catalogued effects to the session's free parameters (shared by the
//! trials), and every trial's residual is tested for structure the model leaves
//! (`"adequacy"`).

use super::super::session::{file_stem, load_session, LoadedSession, SessionTrial};
use super::super::validate::{ENSEMBLE_MIN_STRIDES, ENSEMBLE_POINTS};
use super::{
    AdequacyReport, IdentifyJob, McmcTrialReport, SaChainsReport, SessionAdequacyReport,
    SessionContextReport, SessionIdentifyReport, SessionSaChainsReport, SessionTrialReport,
};
use crate::error::{AppError, AppResult};
use crate::figures::{self, FigureSet};
use crate::output::OutDir;
use crate::Reporter;
use muscle_model::{EffectKind, Effects, ModelParams, ParamId};
use std::collections::BTreeMap;
use std::path::Path;

/// True parameters and effects.
type Truth = (ModelParams, Effects);

/// Runs `identify --session`.
pub(super) fn run(
    args: &IdentifyJob,
    session_path: &Path,
    with: &[EffectKind],
    rep: &Reporter,
) -> AppResult {
    let truth = session_truth(args)?;
    let free = free_names(args, session_path, with)?;
    if args.method.samples() {
        return run_mcmc(
            args,
            session_path,
            truth.as_ref(),
            free.as_deref(),
            with,
            rep,
        );
    }
    let session = load_session(session_path, &args.model, free.as_deref(), rep)?;
    let set = session.problem_set()?;
    let out_dir = args
        .out
        .clone()
        .unwrap_or_else(|| crate::default_out("identify"));
    let input_refs: Vec<&Path> = session.inputs_read.iter().map(|p| p.as_path()).collect();
    let planned = planned_outputs(
        &session,
        &["identify.json", "report.html", "identified.osim"],
    );
    let planned_refs: Vec<&str> = planned.iter().map(String::as_str).collect();
    let out = OutDir::prepare_or_discard(&out_dir, &input_refs, &planned_refs, args.discard_files)?;

    let mut settings = identify_sa::SaIdentifySettings::default().with_seed(args.seed);
    if session.recording_defaults {
        settings = super::super::session::recording_annealing(settings);
    }
    // chains asked for are run as asked, none added
    if let Some(c) = args.chains {
        settings = settings
            .with_chains(c)
            .with_extra_chains(0, settings.agreement_rel);
    }
    let show = rep.show();
    let total = u64::from(settings.chains) * settings.annealer.max_evaluations;
    let progress = rep.progress(total, "SA");
    let observer = |ev: &identify_sa::IdentifyEvent| {
        progress.on_sa_event(ev);
        progress.flow()
    };
    let search = session.search_set(&set)?;
    let fit = match &search {
        Some(search) => identify_sa::identify_set_with_search(&set, search, &settings, &observer),
        None => identify_sa::identify_set(&set, &settings, &observer),
    }
    .map_err(|e| {
        AppError::bad(format!(
            "{}: identification failed: {e}",
            session_path.display()
        ))
    })?;
    progress.finish();
    if progress.stop_requested() {
        return Err(AppError::Interrupted);
    }

    let (params, effects) = set
        .params_from_vector(&fit.x)
        .map_err(|e| AppError::internal(e.to_string()))?;
    let adequacy = trials_adequacy(&session, &params, &effects, set.free());
    let (trials, predictions) = sa_trials(&session, &set, &fit.x, &adequacy)?;
    let adequacy_lines = adequacy_lines(&session, &adequacy);
    let (errors_pct, truth_lines) = session_errors(&fit.params, truth.as_ref());
    let doc = SessionIdentifyReport {
        method: "sa",
        params: fit.params.iter().map(|(k, v)| (k.clone(), *v)).collect(),
        rms_nm: fit.rms_nm,
        rms_raw_nm: None,
        trials,
        evaluations: fit.evaluations,
        wall_s: fit.wall_s,
        sa: Some(SessionSaChainsReport {
            chains: SaChainsReport {
                chains: fit.chains.len(),
                best_chain: fit.best_chain,
                chain_costs: fit.chains.iter().map(|c| c.cost).collect(),
            },
            chain_rms_nm: fit
                .chains
                .iter()
                .map(|c| (c.cost / set.weight_sum()).sqrt())
                .collect(),
        }),
        mcmc: None,
        context: session_context(
            &session,
            session_path.display().to_string(),
            args,
            &set,
            (&params, &effects),
            with,
            &adequacy,
        ),
        errors_pct,
    };
    let text = serde_json::to_string_pretty(&doc).map_err(AppError::internal)? + "\n";
    let path = out.write("identify.json", text.as_bytes())?;
    let mut files = write_figures(
        &out,
        &session,
        &predictions,
        session_path,
        &doc,
        truth.as_ref(),
        None,
        rep,
    )?;
    files.extend(session_osim_copy(&out, args, &session, &params)?);

    rep.print_json(&text);
    if show {
        let say = |s: &str| rep.say(s);
        for l in sa_summary_lines(session_path, &session, &fit, &set, &doc) {
            say(&l);
        }
        for l in truth_lines.iter().chain(&adequacy_lines) {
            say(l);
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

/// Each trial's prediction at the estimate `x` and at the session's own parameters (the
/// figures draw both), with the fit of each.
type Predictions = Vec<(Vec<f64>, Vec<f64>)>;

/// Each trial's fit at the SA estimate `x`, against its fit at the session's own parameters,
/// with its structure test; and the predictions drawn.
fn sa_trials(
    session: &LoadedSession,
    set: &muscle_model::ProblemSet,
    x: &[f64],
    adequacy: &[Result<diagnose::Adequacy, String>],
) -> AppResult<(Vec<SessionTrialReport>, Predictions)> {
    let mut trials = Vec::with_capacity(session.trials.len());
    let mut predictions = Vec::with_capacity(session.trials.len());
    let start = set.base_vector();
    for (t, a) in session.trials.iter().zip(adequacy) {
        let failed = |e: muscle_model::ModelError| {
            AppError::bad(format!("{}: simulation of the fit failed: {e}", t.source))
        };
        let pred = t.problem.predict(x).map_err(failed)?;
        let (rms, r2) = t.fit_of(&pred)?;
        // the session's own parameters, for comparison (e.g. a CEINMS calibration)
        let base = t.problem.predict(&start).map_err(failed)?;
        let (rms0, r20) = t.fit_of(&base)?;
        trials.push(SessionTrialReport {
            name: t.name.clone(),
            source: t.source.clone(),
            rms_nm: rms,
            r2,
            start_rms_nm: Some(rms0),
            start_r2: Some(r20),
            rms_raw_nm: None,
            noise_model: None,
            dynamometer: t.dynamometer(),
            checks: t.checks.clone(),
            emg_crosstalk: t.crosstalk.clone(),
            adequacy: AdequacyReport::of(a),
        });
        predictions.push((pred, base));
    }
    Ok((trials, predictions))
}

/// Each trial's fit at the posterior mean (as a session's trial and as the sampler's), with its
/// structure test; and the predictions drawn, at the mean and at the session's own parameters.
fn mcmc_trials(
    session: &LoadedSession,
    m: &identify_mcmc::McmcIdentification,
    (mean, start): (&[f64], &[f64]),
    adequacy: &[Result<diagnose::Adequacy, String>],
) -> AppResult<(Vec<SessionTrialReport>, Vec<McmcTrialReport>, Predictions)> {
    let mut fits = Vec::with_capacity(session.trials.len());
    let mut trials = Vec::with_capacity(session.trials.len());
    let mut predictions = Vec::with_capacity(session.trials.len());
    for ((t, fit), a) in session.trials.iter().zip(&m.trials).zip(adequacy) {
        let failed = |e: muscle_model::ModelError| {
            AppError::bad(format!(
                "{}: simulation of the posterior mean failed: {e}",
                t.source
            ))
        };
        let pred = t.problem.predict(mean).map_err(failed)?;
        let entry = super::mcmc::trial_entry(&t.name, fit, t.fit_of(&pred)?);
        trials.push(SessionTrialReport {
            name: entry.name.clone(),
            source: t.source.clone(),
            rms_nm: entry.rms_nm,
            r2: entry.r2,
            start_rms_nm: None,
            start_r2: None,
            rms_raw_nm: Some(entry.rms_raw_nm),
            noise_model: Some(entry.noise_model),
            dynamometer: t.dynamometer(),
            checks: t.checks.clone(),
            emg_crosstalk: t.crosstalk.clone(),
            adequacy: AdequacyReport::of(a),
        });
        fits.push(entry);
        let base = t.problem.predict(start).map_err(failed)?;
        predictions.push((pred, base));
    }
    Ok((trials, fits, predictions))
}

/// The summary of a session's SA identification: the run, the EMG, the chains, each trial's
/// fit and the estimate against its bounds.
fn sa_summary_lines(
    session_path: &Path,
    session: &LoadedSession,
    fit: &identify_sa::Identification,
    set: &muscle_model::ProblemSet,
    doc: &SessionIdentifyReport,
) -> Vec<String> {
    let mut lines = Vec::new();
    lines.push(format!(
        "identify (sa): session {} — {} trials, {} evaluations in {:.1} s",
        session_path.display(),
        session.trials.len(),
        fit.evaluations,
        fit.wall_s
    ));
    for l in session
        .emg
        .summary_lines()
        .into_iter()
        .chain(session.crosstalk_lines())
    {
        lines.push(l);
    }
    lines.push(format!(
        "  chains' RMS: {} N·m (best: chain {})",
        fit.chains
            .iter()
            .map(|c| format!("{:.2}", (c.cost / set.weight_sum()).sqrt()))
            .collect::<Vec<_>>()
            .join(", "),
        fit.best_chain
    ));
    lines.push("  trial                     RMS (N·m)     R²   at the session's parameters".into());
    for t in &doc.trials {
        lines.push(format!(
            "  {:<24} {:>9.2} {:>8.3}   {:>9.2} {:>8.3}",
            t.name,
            t.rms_nm,
            t.r2,
            t.start_rms_nm.unwrap_or(f64::NAN),
            t.start_r2.unwrap_or(f64::NAN)
        ));
    }
    lines.push("  parameter                      estimate    bounds".into());
    for (i, name) in set.names().iter().enumerate() {
        let (lo, hi) = set.bounds()[i];
        let v = fit.x[i];
        let at_bound = (v - lo).abs() <= 1e-6 * (hi - lo) || (hi - v).abs() <= 1e-6 * (hi - lo);
        lines.push(format!(
            "  {name:<30} {v:>12.5}    [{lo:.5}, {hi:.5}]{}",
            if at_bound { "  at bound" } else { "" }
        ));
    }
    lines
}

/// The per-trial fit figures (and, for MCMC, the posterior's) and `report.html`.
// every figure of the report draws from its own series
#[allow(clippy::too_many_arguments)]
fn write_figures(
    out: &OutDir,
    session: &LoadedSession,
    predictions: &[(Vec<f64>, Vec<f64>)],
    session_path: &Path,
    doc: &SessionIdentifyReport,
    truth: Option<&Truth>,
    mcmc: Option<&identify_mcmc::McmcIdentification>,
    rep: &Reporter,
) -> AppResult<Vec<std::path::PathBuf>> {
    let method = match mcmc {
        Some(m) if m.nuts.is_some() => "nuts",
        Some(_) => "mcmc",
        None => "sa",
    };
    let mut set = FigureSet::new(
        out,
        &format!(
            "surae identify ({method}) — session {}",
            session_path.display()
        ),
        rep,
    );
    set.page().paragraph(
        if mcmc.is_some() {
            "The session's trials identified together: one posterior of the muscle parameters \
             for every trial, from the sum of the trials' log-likelihoods (each trial with its \
             own dynamometer correction and noise model). Each figure shows one trial's \
             measured torque (after its dynamometer correction, when it has an unloaded run), \
             the model at the posterior mean, and the model at the session's own parameters."
        } else {
            "The session's trials identified together: one set of muscle parameters for every \
             trial, fitted to the sum of the trials' squared torque errors. Each figure shows one \
             trial's measured torque (after its dynamometer correction, when it has an unloaded \
             run), the model at the identified parameters, and the model at the session's own \
             parameters (where the identification started)."
        }
        .to_string(),
    );
    session_tables(&mut set, session, doc, mcmc.is_none())?;
    for (t, (pred, base)) in session.trials.iter().zip(predictions) {
        let label = if mcmc.is_some() {
            "posterior mean"
        } else {
            "fit"
        };
        stride_ensemble_figure(&mut set, t, pred, label)?;
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
                &[
                    (
                        if mcmc.is_some() {
                            "posterior mean"
                        } else {
                            "fit"
                        },
                        &pred,
                    ),
                    ("session's parameters", &base),
                ],
                &angle,
                &env_refs,
            ),
        )?;
    }
    if let Some(m) = mcmc {
        let truth_values =
            truth.map(|t| super::extended::truth_values(session.trials[0].problem.free(), t));
        super::mcmc::posterior_figures(&mut set, truth_values, m)?;
    }
    set.finish()
}

/// A gait trial's measured and fitted moment over its strides, by % of the gait cycle (mean ±
/// sd), the strides its recording checks flag left out: a long walk drawn end to end is
/// dozens of strides no one can read. Nothing for a trial without strides or with fewer than
/// [`ENSEMBLE_MIN_STRIDES`] kept.
fn stride_ensemble_figure(
    set: &mut FigureSet<'_>,
    t: &SessionTrial,
    pred: &[f64],
    label: &str,
) -> AppResult {
    let Some(strides) = t.strides()? else {
        return Ok(());
    };
    let flags = t.stride_flags(&strides);
    let left_out = flags.iter().filter(|f| **f).count();
    let kept = experiment::Strides {
        strides: strides
            .strides
            .iter()
            .zip(&flags)
            .filter(|(_, f)| !**f)
            .map(|(s, _)| *s)
            .collect(),
        source: strides.source,
    };
    if kept.len() < ENSEMBLE_MIN_STRIDES {
        return Ok(());
    }
    let cycle = |x: &[f64]| kept.normalised_part(x, ENSEMBLE_POINTS, experiment::StridePart::Cycle);
    let (m, p) = (cycle(t.problem.measured()), cycle(pred));
    let whole: Vec<usize> = (0..m.len())
        .filter(|&k| !m[k].is_empty() && !p[k].is_empty())
        .collect();
    let pick = |c: &[Vec<f64>]| -> Vec<Vec<f64>> { whole.iter().map(|&k| c[k].clone()).collect() };
    let (m, p) = (pick(&m), pick(&p));
    set.add(
        &format!("strides_{}", file_stem(&t.name)),
        &format!(
            "{}: measured and {label} moment by % of the gait cycle, mean ± sd over {} of its {} \
             strides ({left_out} flagged by the recording checks left out), and the residual",
            t.name,
            m.len(),
            strides.len()
        ),
        report::figures::stride_ensemble(
            &experiment::stride_percent(ENSEMBLE_POINTS),
            &m,
            &[(label, &p)],
            "gait cycle",
        ),
    )
}

/// The report's tables: each trial's fit, and (for SA) the shared parameters with their bounds
/// and, with `--truth`, their errors.
fn session_tables(
    set: &mut FigureSet<'_>,
    session: &LoadedSession,
    doc: &SessionIdentifyReport,
    with_params: bool,
) -> AppResult {
    let num = |v: Option<f64>, digits: usize| {
        v.map_or_else(|| "—".to_string(), |x| report::format_sig(x, digits))
    };
    let rows: Vec<Vec<String>> = doc
        .trials
        .iter()
        .map(|t| {
            vec![
                t.name.clone(),
                t.source.clone(),
                num(Some(t.rms_nm), 3),
                num(Some(t.r2), 3),
                num(t.start_rms_nm, 3),
            ]
        })
        .collect();
    set.page()
        .table(
            "Trials",
            &[
                "trial",
                "recording",
                "RMS (N·m)",
                "R²",
                "RMS at the session's parameters",
            ],
            &rows,
        )
        .map_err(|e| AppError::internal(e.to_string()))?;
    set.page().paragraph(format!(
        "EMG normalisation: {} ({} trials; one reference per channel for the whole session).",
        match doc.context.emg_normalisation.source {
            "mvc" => "each channel by its largest envelope over the MVC trials",
            "session_maximum" => "each channel by its largest envelope over all the trials",
            _ => "envelopes as given",
        },
        session.trials.len()
    ));
    if !with_params {
        return Ok(());
    }
    let errors = doc.errors_pct.as_ref();
    let mut headers = vec!["parameter", "estimate", "lower bound", "upper bound"];
    if errors.is_some() {
        headers.push("error vs truth (%)");
    }
    let rows: Vec<Vec<String>> = doc
        .params
        .iter()
        .map(|(k, v)| {
            let b = doc.context.bounds.get(k);
            let mut row = vec![
                report::param_label(k),
                num(Some(*v), 5),
                num(b.map(|b| b[0]), 5),
                num(b.map(|b| b[1]), 5),
            ];
            if let Some(e) = errors {
                row.push(num(e.get(k).copied(), 3));
            }
            row
        })
        .collect();
    set.page()
        .table("Shared parameters", &headers, &rows)
        .map_err(|e| AppError::internal(e.to_string()))?;
    Ok(())
}

/// What a session's `identify.json` says of the session: `what` names it, `model` is the
/// estimate's parameters and effects, `adequacy` each trial's structure test.
fn session_context(
    session: &LoadedSession,
    what: String,
    args: &IdentifyJob,
    set: &muscle_model::ProblemSet,
    (params, effects): (&ModelParams, &Effects),
    with: &[EffectKind],
    adequacy: &[Result<diagnose::Adequacy, String>],
) -> SessionContextReport {
    SessionContextReport {
        session: what,
        subject: session.manifest.subject.clone(),
        seed: args.seed,
        bounds: bounds_of(set),
        dynamometer: session.trials.iter().map(|t| t.dynamometer()).collect(),
        model: params.to_json_value(),
        effects: (!effects.enabled().is_empty()).then(|| effects.to_json_value()),
        with: with.iter().map(|k| k.name()).collect(),
        adequacy: SessionAdequacyReport::worst(
            session.trials.iter().map(|t| t.name.as_str()).zip(adequacy),
        ),
        emg_normalisation: session.emg.report(),
    }
}

/// Each free parameter's bounds, by name.
fn bounds_of(set: &muscle_model::ProblemSet) -> BTreeMap<String, [f64; 2]> {
    set.names()
        .iter()
        .zip(set.bounds())
        .map(|(k, (lo, hi))| (k.clone(), [*lo, *hi]))
        .collect()
}

/// Runs `identify --method mcmc --session`: each trial on its torque as measured, corrected by
/// its own unloaded run's systematic error inside the sampler, with its own noise model (from
/// that run, or fitted to the trial's residual without one).
/// The files an identification of `session` may write: `fixed` and one fit figure per trial.
fn planned_outputs(session: &LoadedSession, fixed: &[&str]) -> Vec<String> {
    let mut planned: Vec<String> = fixed.iter().map(|s| s.to_string()).collect();
    planned.extend(
        session
            .trials
            .iter()
            .map(|t| format!("torque_fit_{}.svg", file_stem(&t.name))),
    );
    planned
}

/// The identified values written into a copy of the session's OpenSim model (`--params` or
/// the manifest's), if it has one.
fn session_osim_copy(
    out: &OutDir,
    args: &IdentifyJob,
    session: &LoadedSession,
    params: &muscle_model::ModelParams,
) -> AppResult<Option<std::path::PathBuf>> {
    let osim = [args.model.params.as_ref(), session.manifest.params.as_ref()]
        .into_iter()
        .flatten()
        .find(|p| super::super::is_osim(p));
    let Some(path) = osim else {
        return Ok(None);
    };
    let names = opensim_files::OsimMuscleNames::renamed(
        session
            .manifest
            .osim_muscles
            .iter()
            .map(|(k, v)| (k.as_str(), v.as_str())),
    )
    .map_err(AppError::bad)?;
    super::exports::write_osim_copy(out, path, &names, params).map(Some)
}

/// `--truth` (a parameters JSON or a fixture's `truth.json`), read before anything runs.
fn session_truth(args: &IdentifyJob) -> AppResult<Option<Truth>> {
    match (&args.truth_data, &args.truth) {
        (Some(d), _) => super::truth_of_json(&d.value, &d.label).map(Some),
        (None, Some(p)) => {
            let text = super::super::read_text(p)?;
            super::read_truth_model(p, &text).map(Some)
        }
        (None, None) => Ok(None),
    }
}

/// The free parameters' names when `--with` adds effects: `--free`, or the manifest's `free`,
/// followed by the effects' parameters; without either (or with `--free +name`), the effects'
/// parameters added as `+name` to the set the session calibrates by default; `--free` as given (`None`:
/// the manifest's) otherwise. A per-trial effect in a session of several trials is refused.
fn free_names(
    args: &IdentifyJob,
    session_path: &Path,
    with: &[EffectKind],
) -> AppResult<Option<Vec<String>>> {
    if with.is_empty() {
        return Ok(args.free.clone());
    }
    let manifest = if session_path.is_dir() {
        ::session::SessionManifest::of_recording(session_path)
    } else {
        ::session::read_session_manifest(session_path).map_err(AppError::bad)?
    };
    super::extended::check_session_scope(with, manifest.trials.len())?;
    let adding = args
        .free
        .as_ref()
        .is_some_and(|f| f.iter().any(|n| n.starts_with('+')));
    if adding || (args.free.is_none() && manifest.free.is_none()) {
        // added to the set the session calibrates by default (a recording's defaults with
        // their bounds, else the 9 muscle parameters), as `--free +name` adds
        let mut names = args.free.clone().unwrap_or_default();
        for id in super::extended::with_free(Vec::new(), with) {
            names.push(format!("+{}", id.name()));
        }
        return Ok(Some(names));
    }
    let base: Vec<ParamId> = match args.free.as_ref().or(manifest.free.as_ref()) {
        Some(names) => names
            .iter()
            .map(|n| ParamId::parse(n).map_err(|e| AppError::bad(format!("--free {n}: {e}"))))
            .collect::<AppResult<_>>()?,
        None => ParamId::identified().to_vec(),
    };
    Ok(Some(
        super::extended::with_free(base, with)
            .iter()
            .map(ParamId::name)
            .collect(),
    ))
}

/// The structure test of every trial at the identified model (`params`, `effects`), with the
/// free parameters projected out: each trial as the session prepared it (its inputs, its torque
/// as recorded corrected by its own unloaded run, a CEINMS trial where its moment has samples).
fn trials_adequacy(
    session: &LoadedSession,
    params: &ModelParams,
    effects: &Effects,
    free: &[ParamId],
) -> Vec<Result<diagnose::Adequacy, String>> {
    session
        .trials
        .iter()
        .map(|t| {
            let mut rec =
                diagnose::DiagnosisRecording::new(t.problem.inputs().clone(), t.raw_torque.clone())
                    .with_model(*params, *effects);
            // a CEINMS trial's moment-file span, or the strides the manifest excludes
            if let Some(w) = t.problem.weights() {
                rec = rec.with_weights(w.to_vec());
            }
            diagnose::adequacy_of_recording(
                &rec,
                t.correction(),
                free,
                &diagnose::DiagnoseSettings::default(),
            )
            .map_err(|e| e.to_string())
        })
        .collect()
}

/// The summary's lines on each trial's structure test.
fn adequacy_lines(
    session: &LoadedSession,
    adequacy: &[Result<diagnose::Adequacy, String>],
) -> Vec<String> {
    session
        .trials
        .iter()
        .zip(adequacy)
        .flat_map(|(t, a)| super::extended::adequacy_lines(a, Some(&t.name)))
        .collect()
}

/// `errors_pct` (% error of every identified parameter against the truth, when known) and
/// its lines for the summary.
fn session_errors(
    params: &BTreeMap<String, f64>,
    truth: Option<&Truth>,
) -> (Option<BTreeMap<String, f64>>, Vec<String>) {
    let Some(truth) = truth else {
        return (None, Vec::new());
    };
    let errors = super::errors_pct(params, truth);
    let mut lines = vec!["  errors vs truth (%):".to_string()];
    lines.extend(errors.iter().map(|(k, e)| format!("    {k:<28} {e:>8.2}")));
    (Some(errors), lines)
}

fn run_mcmc(
    args: &IdentifyJob,
    session_path: &Path,
    truth: Option<&Truth>,
    free: Option<&[String]>,
    with: &[EffectKind],
    rep: &Reporter,
) -> AppResult {
    use identify_mcmc::SessionTrialLikelihood;
    let session = load_session(session_path, &args.model, free, rep)?;
    let set = session.problem_set()?;
    let out_dir = args
        .out
        .clone()
        .unwrap_or_else(|| crate::default_out("identify"));
    let input_refs: Vec<&Path> = session.inputs_read.iter().map(|p| p.as_path()).collect();
    let planned = planned_outputs(
        &session,
        &[
            "identify.json",
            "chains.csv",
            "chains",
            "report.html",
            "identified.osim",
            "traces.svg",
            "rhat.svg",
            "histograms.svg",
            "corner.svg",
        ],
    );
    let planned_refs: Vec<&str> = planned.iter().map(String::as_str).collect();

    let (problems, noises) = session.mcmc_trials()?;
    let likelihoods: Vec<SessionTrialLikelihood<'_>> = problems
        .iter()
        .zip(&noises)
        .map(|(problem, noise)| SessionTrialLikelihood { problem, noise })
        .collect();
    let out = OutDir::prepare_or_discard(&out_dir, &input_refs, &planned_refs, args.discard_files)?;
    let show = rep.show();
    let what = session_path.display().to_string();
    let m = super::mcmc::sample_with(
        args.method,
        &likelihoods,
        args.seed,
        args.max_iterations,
        &what,
        rep,
    )?;

    let mean = m.mean();
    let start = set.base_vector();
    let (params, effects) = set
        .params_from_vector(&mean)
        .map_err(|e| AppError::internal(e.to_string()))?;
    let adequacy = trials_adequacy(&session, &params, &effects, set.free());
    let (trials, fits, predictions) = mcmc_trials(&session, &m, (&mean, &start), &adequacy)?;
    let lines = super::mcmc::summary_lines(
        &format!("session {what}, {} trials", session.trials.len()),
        &m,
        &fits,
        session.trials.iter().any(|t| t.correction().is_some()),
    );
    let adequacy_lines = adequacy_lines(&session, &adequacy);
    let estimate = super::mcmc::posterior_means(&m);
    let (errors_pct, truth_lines) = session_errors(&estimate, truth);
    // a session's per-trial fits are its own `trials`, with each trial's source and checks
    let posterior = super::mcmc::mcmc_report(&m, Vec::new());
    let doc = SessionIdentifyReport {
        method: args.method.name(),
        params: estimate,
        rms_nm: m.rms_corrected_nm,
        rms_raw_nm: Some(m.rms_nm),
        trials,
        evaluations: m.evaluations,
        wall_s: m.wall_s,
        sa: None,
        mcmc: Some(posterior),
        context: session_context(
            &session,
            what.clone(),
            args,
            &set,
            (&params, &effects),
            with,
            &adequacy,
        ),
        errors_pct,
    };
    let text = serde_json::to_string_pretty(&doc).map_err(AppError::internal)? + "\n";
    let path = out.write("identify.json", text.as_bytes())?;
    let mut csv = Vec::new();
    m.write_chains_csv(&mut csv).map_err(AppError::internal)?;
    let mut files = vec![out.write("chains.csv", &csv)?];
    let names: Vec<&str> = session.trials.iter().map(|t| t.name.as_str()).collect();
    let chain_files = super::exports::write_chains(&out, &m, args.seed, &names.join(", "))?;
    files.extend(write_figures(
        &out,
        &session,
        &predictions,
        session_path,
        &doc,
        truth,
        Some(&m),
        rep,
    )?);
    files.extend(session_osim_copy(&out, args, &session, &params)?);

    rep.print_json(&text);
    if show {
        let say = |s: &str| rep.say(s);
        for l in lines.iter().chain(&truth_lines).chain(&adequacy_lines) {
            say(l);
        }
        for l in session
            .emg
            .summary_lines()
            .into_iter()
            .chain(session.crosstalk_lines())
        {
            say(&l);
        }
        say(&format!(
            "wrote {} and {} figures/report files in {}",
            path.display(),
            files.len(),
            out_dir.display()
        ));
        say(&format!(
            "wrote {} chains in CmdStan's CSV layout in {} (arviz.from_cmdstan)",
            chain_files.len(),
            out.path("chains").display()
        ));
    }
    Ok(())
}
