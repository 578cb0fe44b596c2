//! `surae diagnose --session`: the session diagnosed jointly (shared muscle parameters, the
//! subject's effects shared, each trial's setup effects its own, the held-out gain by leaving
//! one trial out; `diagnose::diagnose_session`), and every trial of it diagnosed on its own
//! with the session's model, into `DIR/<trial>/` (`diagnosis.json`, figures, `report.html`).
//! `DIR/diagnosis_session.json` holds the session's verdict, causes with their scope and
//! values, per-trial fits and held-out errors, and each trial's own verdict, causes and
//! held-out gain (docs/diagnosis-method.md, "Sessions").
//!
//! A trial CSV is diagnosed as `--trial` (with its `--unloaded` run and knee angle) is; a
//! CEINMS trial folder as prepared model inputs: its own lengths, moment arms and fixed
//! muscles, no ankle angle (the effects that need one are not tested), no unloaded run (the
//! noise model is fitted to the baseline's residual), and only the samples where the moment
//! file has data compared. The joint diagnosis reads the trials as the session prepared them
//! (its inputs, the measured torque as recorded, each trial's unloaded run). Everything is
//! diagnosed before anything is written.

use super::super::session::{file_stem, load_session, LoadedSession, SessionTrial};
use super::super::ModelSettings;
use super::window::{diagnosis_window, DiagnosisWindow};
use super::{diagnosis_json, trial_args, write_figures, Closing, DiagnoseJob, PLANNED};
use crate::error::{AppError, AppResult};
use crate::output::OutDir;
use crate::Reporter;
use diagnose::{
    DiagnoseSettings, Diagnosis, DiagnosisRecording, GivenParamsFit, HeldOutShapeCheck,
    HeldOutShapePart, SessionDiagnosis, SessionMember,
};
use muscle_model::TrialInputs;
use std::ops::Range;
use std::path::{Path, PathBuf};

/// The file listing every trial's diagnosis.
const SESSION_FILE: &str = "diagnosis_session.json";

/// One trial diagnosed, with what its files need.
struct Diagnosed {
    stem: String,
    d: Diagnosis,
    /// The measured torque as recorded, on the inputs' grid.
    measured: Vec<f64>,
    inputs: TrialInputs,
    /// The unloaded run's file, when the trial has one.
    unloaded: Option<String>,
    /// The dynamometer correction fitted to it.
    correction: Option<experiment::UnloadedCorrection>,
    /// Sampling rate of the recording the noise model was fitted on (Hz).
    fitted_on_hz: f64,
    /// The samples compared with the model (figures are drawn over them).
    span: Range<usize>,
    /// The part of a long trial diagnosed (`None`: all of it).
    window: Option<DiagnosisWindow>,
}

/// Runs `diagnose --session`.
pub(super) fn run(args: &DiagnoseJob, session_path: &Path, rep: &Reporter) -> AppResult {
    let model = ModelSettings {
        params: args.params.clone(),
        params_data: args.params_data.clone(),
        emg_is_envelope: args.emg_is_envelope,
        ..ModelSettings::default()
    };
    let session = load_session(session_path, &model, None, rep)?;
    let out_dir = args
        .out
        .clone()
        .unwrap_or_else(|| crate::default_out("diagnose"));
    let stems = trial_stems(&session)?;
    let mut planned = vec![SESSION_FILE.to_string()];
    for stem in &stems {
        planned.extend(PLANNED.iter().map(|f| format!("{stem}/{f}")));
    }
    let planned_refs: Vec<&str> = planned.iter().map(String::as_str).collect();
    let input_refs: Vec<&Path> = session.inputs_read.iter().map(|p| p.as_path()).collect();
    let out = OutDir::prepare_or_discard(&out_dir, &input_refs, &planned_refs, args.discard_files)?;

    let show = rep.show();
    let mut done = Vec::with_capacity(session.trials.len());
    for (k, (t, stem)) in session.trials.iter().zip(&stems).enumerate() {
        let label = format!("diag {}/{}", k + 1, session.trials.len());
        done.push(diagnose_trial(&session, k, t, stem, &label, rep)?);
    }
    let mut joint = diagnose_jointly(&session, &done, rep)?;
    judge_held_out_shape(&session, &mut done, &mut joint, rep)?;
    if args.params.is_some() || args.params_data.is_some() {
        judge_given_params(&session, &mut done, &mut joint)?;
    }

    // every trial's report ends with the command that identifies the session with the causes
    // of its joint diagnosis
    let closing = Closing::of_session(&joint.causes, &trial_args(args), session.trials.len());

    // every trial diagnosed: now the files
    let mut rows = Vec::with_capacity(done.len());
    for (t, r) in session.trials.iter().zip(&done) {
        let dir = out.sub(&r.stem, &input_refs, PLANNED)?;
        let text = diagnosis_json(
            &r.d,
            &t.name,
            r.unloaded.as_deref(),
            r.fitted_on_hz,
            Some(&t.source),
            t.checks.as_ref(),
        )?;
        dir.write("diagnosis.json", text.as_bytes())?;
        write_figures(
            &dir,
            &t.name,
            &r.measured,
            &r.inputs,
            &r.d,
            r.span.clone(),
            &closing,
            rep,
        )?;
        rows.push(session_row(t, r)?);
    }
    let doc = SessionDiagnosisReport {
        session: session_path.display().to_string(),
        params: args
            .params
            .as_ref()
            .or(session.manifest.params.as_ref())
            .map(|p| p.display().to_string()),
        joint: &joint,
        trials: rows,
    };
    let text = serde_json::to_string_pretty(&doc).map_err(AppError::internal)? + "\n";
    let path = out.write(SESSION_FILE, text.as_bytes())?;

    rep.print_json(&text);
    if show {
        let say = |s: &str| rep.say(s);
        for l in session.emg.summary_lines() {
            say(&l);
        }
        for (t, r) in session.trials.iter().zip(&done) {
            say(&format!("diagnose: {} ({})", t.name, t.source));
            if t.ceinms.is_some() {
                say("  (inverse-dynamics moment: no noise reference, the noise model is fitted to the baseline's residual)");
            } else if r.unloaded.is_none() {
                say("  (no unloaded run: the dynamometer's own error cannot be told from a torque offset)");
            }
            if let Some(w) = &r.window {
                say(&format!("  ({})", w.describe(r.fitted_on_hz)));
            }
            for l in r.d.summary_lines() {
                say(&l);
            }
        }
        if session.trials.len() > 1 {
            say(&format!(
                "diagnose: session of {} trials, diagnosed jointly",
                session.trials.len()
            ));
        }
        for l in joint.summary_lines() {
            say(&l);
        }
        if joint
            .held_out_shape
            .as_ref()
            .is_some_and(|h| h.reproducible)
        {
            // the diagnosis names causes from its catalogue; which extension of the model
            // lowers the held-out error is validate's measurement
            say(&format!(
                "  which extension of the model lowers the held-out error: surae validate \
                 --session {} --extensions",
                session.manifest.path.display()
            ));
        }
        say(&format!(
            "wrote {} and a folder per trial in {}",
            path.display(),
            out_dir.display()
        ));
        say(&closing.terminal_line());
    }
    Ok(())
}

/// The trials' folder names; two names that become the same folder are an error.
fn trial_stems(session: &LoadedSession) -> AppResult<Vec<String>> {
    let mut stems: Vec<String> = Vec::with_capacity(session.trials.len());
    for t in &session.trials {
        let stem = file_stem(&t.name);
        if let Some(other) = session
            .trials
            .iter()
            .zip(&stems)
            .find(|(_, s)| **s == stem)
            .map(|(o, _)| o)
        {
            return Err(AppError::bad(format!(
                "{}: trials `{}` and `{}` would share the output folder {stem}/",
                session.manifest.path.display(),
                other.name,
                t.name
            )));
        }
        stems.push(stem);
    }
    Ok(stems)
}

/// Diagnoses trial `k` of the session with the session's parameters and effects.
fn diagnose_trial(
    session: &LoadedSession,
    k: usize,
    t: &SessionTrial,
    stem: &str,
    label: &str,
    rep: &Reporter,
) -> AppResult<Diagnosed> {
    let entry = &session.manifest.trials[k];
    let window = diagnosis_window(t)?;
    let progress = rep.progress(0, label);
    let mut observer = |p: &diagnose::DiagnosisProgress| {
        progress.message(format!(
            "{}: {} ({} simulations)",
            t.name, p.message, p.evaluations
        ));
        progress.flow()
    };
    let fail = |e: diagnose::DiagnoseError, progress: &crate::ProgressDisplay| {
        if progress.stop_requested() {
            AppError::Interrupted
        } else {
            AppError::bad(format!("{}: {e}", t.source))
        }
    };
    let diagnosed = match &t.ceinms {
        Some(c) => {
            let rec = DiagnosisRecording::new(c.inputs.clone(), c.torque_nm.clone())
                .with_weights(c.weights.clone())
                .with_model(session.params, session.effects);
            let d = diagnose::run_prepared(&rec, &DiagnoseSettings::default(), &mut observer)
                .map_err(|e| fail(e, &progress))?;
            Diagnosed {
                stem: stem.to_string(),
                d,
                measured: c.torque_nm.clone(),
                inputs: c.inputs.clone(),
                unloaded: None,
                correction: None,
                fitted_on_hz: c.inputs.fs(),
                span: weighted_span(&c.weights),
                window: None,
            }
        }
        None if window.is_some() => {
            let w = window.expect("checked");
            let rec = windowed_recording(session, t, &w)?;
            let d = diagnose::run_prepared(&rec, &DiagnoseSettings::default(), &mut observer)
                .map_err(|e| fail(e, &progress))?;
            let weights = rec.weights.clone().unwrap_or_default();
            Diagnosed {
                stem: stem.to_string(),
                d,
                measured: rec.torque_nm.clone(),
                inputs: rec.inputs.clone(),
                unloaded: None,
                correction: None,
                fitted_on_hz: rec.inputs.fs(),
                span: weighted_span(&weights),
                window: Some(w),
            }
        }
        None => {
            // the trial as the session prepared it: its crosstalk decision, its EMG by the
            // session's references (a session of one: its own maxima, exactly as `--trial`)
            // and its unloaded run's correction
            let prepared = t.prepared.as_ref().ok_or_else(|| {
                AppError::internal(format!("{}: trial file not prepared", t.source))
            })?;
            let d = diagnose::run_trial(
                prepared,
                &session.params,
                &session.effects,
                &DiagnoseSettings {
                    input_options: prepared.options,
                    ..DiagnoseSettings::default()
                },
                &mut observer,
            )
            .map_err(|e| fail(e, &progress))?;
            let fitted_on_hz = prepared
                .unloaded
                .as_ref()
                .map_or(prepared.trial.sample_rate_hz(), |u| u.rate_hz);
            let inputs = t.problem.inputs().clone();
            let n = inputs.len();
            Diagnosed {
                stem: stem.to_string(),
                d,
                measured: prepared.raw_torque().to_vec(),
                inputs,
                unloaded: entry.unloaded.as_ref().map(|p| p.display().to_string()),
                correction: prepared.unloaded,
                fitted_on_hz,
                span: 0..n,
                window: None,
            }
        }
    };
    progress.finish();
    Ok(diagnosed)
}

/// The joint diagnosis of the session from its trials as the session prepared them (a session
/// of one trial is that trial's diagnosis in `done`, as `--trial` gives it).
fn diagnose_jointly(
    session: &LoadedSession,
    done: &[Diagnosed],
    rep: &Reporter,
) -> AppResult<SessionDiagnosis> {
    if let ([t], [r]) = (session.trials.as_slice(), done) {
        // the trial's diagnosis as `--trial` gives it
        return Ok(SessionDiagnosis::of_one_trial(&t.name, &r.d));
    }
    let members: Vec<SessionMember<'_>> = session
        .trials
        .iter()
        .zip(done)
        .map(|(t, r)| {
            let rec = match (&t.ceinms, &r.window) {
                (Some(c), _) => {
                    DiagnosisRecording::new(t.problem.inputs().clone(), t.raw_torque.clone())
                        .with_model(session.params, session.effects)
                        .with_weights(c.weights.clone())
                }
                (None, Some(w)) => windowed_recording(session, t, w)?,
                (None, None) => {
                    DiagnosisRecording::new(t.problem.inputs().clone(), t.raw_torque.clone())
                        .with_model(session.params, session.effects)
                }
            };
            Ok(SessionMember {
                name: t.name.clone(),
                recording: rec,
                unloaded: r.correction.as_ref(),
            })
        })
        .collect::<AppResult<_>>()?;
    let progress = rep.progress(0, "diag session");
    let mut observer = |p: &diagnose::DiagnosisProgress| {
        progress.message(format!("{} ({} simulations)", p.message, p.evaluations));
        progress.flow()
    };
    let d = diagnose::diagnose_session(&members, &DiagnoseSettings::default(), &mut observer)
        .map_err(|e| {
            if progress.stop_requested() {
                AppError::Interrupted
            } else {
                AppError::bad(format!("{}: {e}", session.manifest.path.display()))
            }
        })?;
    progress.finish();
    Ok(d)
}

/// Judges every trial, and the session, by the residual `validate`'s folds leave on the data
/// they did not calibrate on (`diagnose`'s `held_out_shape` module), when a trial has no
/// unloaded run: its noise model is then fitted to its own residual and cannot grade the model.
fn judge_held_out_shape(
    session: &LoadedSession,
    done: &mut [Diagnosed],
    joint: &mut SessionDiagnosis,
    rep: &Reporter,
) -> AppResult {
    if done.iter().all(|r| r.correction.is_some()) {
        return Ok(());
    }
    let progress = rep.progress(0, "held out");
    progress.message(
        "validate's folds: calibrating on part of the session, predicting the rest".into(),
    );
    let validation = super::super::validate::validate_with_defaults(session)?;
    progress.finish();
    let Some(v) = validation else {
        return Ok(());
    };
    let mut per_trial = Vec::new();
    for (t, r) in session.trials.iter().zip(done.iter_mut()) {
        // a trial with an unloaded run is judged by the noise its unloaded run measured
        if r.correction.is_some() {
            continue;
        }
        let parts: Vec<HeldOutShapePart> = v
            .folds
            .iter()
            .flat_map(|f| {
                f.held_out
                    .iter()
                    .filter(|h| h.trial == t.name)
                    .map(move |h| {
                        HeldOutShapePart::new(
                            if f.name == f.scheme.name() {
                                f.name.clone()
                            } else {
                                format!("{} {}", f.scheme.name(), f.name)
                            },
                            h.shape.segments,
                            h.model.rms_nm,
                            h.model.r2,
                            h.shape.p_value,
                        )
                        .with_scale(h.scale)
                    })
            })
            .collect();
        if parts.is_empty() {
            continue;
        }
        let check = HeldOutShapeCheck::of_parts(parts);
        r.d.judge_held_out_shape(check.clone());
        per_trial.push((t.name.clone(), check));
    }
    joint.judge_held_out_shape(per_trial);
    Ok(())
}

/// How the parameters given (`--params`: a calibration made elsewhere) predict every trial as
/// they are, and the scale of their moment each asks for (`diagnose`'s `given_params`
/// module): a trial to which the calibration's gain does not carry is not adequate.
fn judge_given_params(
    session: &LoadedSession,
    done: &mut [Diagnosed],
    joint: &mut SessionDiagnosis,
) -> AppResult {
    let mut per_trial = Vec::with_capacity(done.len());
    for (t, r) in session.trials.iter().zip(done.iter_mut()) {
        let torque = t.simulate_at(&session.params, &session.effects)?;
        let (rms, r2) = t.fit_of(&torque)?;
        let fit = GivenParamsFit::new(rms, r2, t.moment_scale(&torque));
        r.d.judge_given_params(fit);
        per_trial.push((t.name.clone(), fit));
    }
    joint.judge_given_params(per_trial);
    Ok(())
}

/// The window `w` of trial `t` as the diagnosis fits it: its inputs, measured moment and the
/// trial's weights over it, the lead-in weighted 0.
fn windowed_recording(
    session: &LoadedSession,
    t: &SessionTrial,
    w: &DiagnosisWindow,
) -> AppResult<DiagnosisRecording> {
    let inputs = t
        .problem
        .inputs()
        .window(w.range.clone())
        .map_err(|e| AppError::internal(format!("{}: diagnosis window: {e}", t.source)))?;
    Ok(
        DiagnosisRecording::new(inputs, t.raw_torque[w.range.clone()].to_vec())
            .with_weights(w.weights(t.problem.weights()))
            .with_model(session.params, session.effects),
    )
}

/// From the first to the last sample of positive weight.
fn weighted_span(w: &[f64]) -> Range<usize> {
    let first = w.iter().position(|v| *v > 0.0).unwrap_or(0);
    let last = w.iter().rposition(|v| *v > 0.0).map_or(w.len(), |i| i + 1);
    first..last.max(first)
}

/// The trial's line of `diagnosis_session.json`. For a CEINMS trial it adds the moment's RMS
/// error and R² of the baseline and final models at the moment file's own samples, the
/// numbers `identify` and `simulate` report.
fn session_row(t: &SessionTrial, r: &Diagnosed) -> AppResult<SessionTrialDiagnosisRow> {
    let d = &r.d;
    let moment_fit = match &t.ceinms {
        Some(_) => {
            let s = &d.residual_analysis.series;
            let pred = |res: &[f64]| -> Vec<f64> {
                r.measured.iter().zip(res).map(|(m, e)| m - e).collect()
            };
            let (rb, r2b) = t.fit_of(&pred(&s.baseline_residual_nm))?;
            let (re, r2e) = t.fit_of(&pred(&s.extended_residual_nm))?;
            Some(MomentFitReport {
                baseline: FitFigures {
                    rms_nm: rb,
                    r2: r2b,
                },
                extended: FitFigures {
                    rms_nm: re,
                    r2: r2e,
                },
            })
        }
        None => None,
    };
    let folder: PathBuf = PathBuf::from(&r.stem);
    // the AR(1) correlation time of the noise model, `−Δt/ln φ` (s)
    let phi = d.noise.phi;
    let corr_time_s = (phi > 0.0 && phi < 1.0).then(|| -1.0 / (r.fitted_on_hz * phi.ln()));
    Ok(SessionTrialDiagnosisRow {
        name: t.name.clone(),
        source: t.source.clone(),
        folder: folder.display().to_string(),
        verdict: d.verdict,
        causes: d.causes.clone(),
        unexplained_structure: d.unexplained_structure,
        structure_p_value: d.residual_analysis.structure_p_value,
        not_testable: d.not_testable.iter().map(|x| x.effect.clone()).collect(),
        baseline_rms_nm: d.baseline.rms_nm,
        baseline_heldout_rms_nm: d.baseline.heldout_rms_nm,
        extended_heldout_rms_nm: d.extended.heldout_rms_nm,
        heldout_rms_reduction_pct: d.gain.heldout_rms_reduction_pct,
        heldout_deviance_reduction: d.gain.heldout_deviance_reduction,
        delta_bic: d.gain.delta_bic,
        noise_source: d.noise.source,
        noise_corr_time_s: corr_time_s,
        moment_fit,
    })
}

/// `diagnosis_session.json`: the session's joint diagnosis, with one row per trial (each
/// trial's full diagnosis is in its folder).
#[derive(Debug, Clone, serde::Serialize)]
#[non_exhaustive]
pub struct SessionDiagnosisReport<'a> {
    /// The session manifest (or CEINMS trial folder).
    pub session: String,
    /// The parameters file the session was diagnosed with (`null`: the manifest's own).
    pub params: Option<String>,
    /// The joint diagnosis, its members at the top level of the JSON.
    #[serde(flatten)]
    pub joint: &'a diagnose::SessionDiagnosis,
    /// One row per trial.
    pub trials: Vec<SessionTrialDiagnosisRow>,
}

/// A trial's row in `diagnosis_session.json`.
#[derive(Debug, Clone, serde::Serialize)]
#[non_exhaustive]
pub struct SessionTrialDiagnosisRow {
    /// The trial's name.
    pub name: String,
    /// Where it was read from.
    pub source: String,
    /// The folder of its `diagnosis.json`, inside the output folder.
    pub folder: String,
    /// Its verdict.
    pub verdict: diagnose::Verdict,
    /// The causes named for it.
    pub causes: Vec<String>,
    /// Structure left that no catalogued effect explains.
    pub unexplained_structure: bool,
    /// p-value of the residual structure test.
    pub structure_p_value: f64,
    /// Effects it could not test.
    pub not_testable: Vec<String>,
    /// The baseline's RMS (N·m).
    pub baseline_rms_nm: f64,
    /// The baseline's held-out RMS (N·m).
    pub baseline_heldout_rms_nm: f64,
    /// The extended model's held-out RMS (N·m).
    pub extended_heldout_rms_nm: f64,
    /// Held-out RMS reduction by the extension (%).
    pub heldout_rms_reduction_pct: f64,
    /// Held-out deviance reduction by the extension.
    pub heldout_deviance_reduction: f64,
    /// ΔBIC of the extension.
    pub delta_bic: f64,
    /// Where the noise model comes from.
    pub noise_source: diagnose::NoiseModelSource,
    /// The noise model's AR(1) correlation time (s; `null` when φ is outside (0, 1)).
    pub noise_corr_time_s: Option<f64>,
    /// A CEINMS trial's moment fit at its own samples (`null` otherwise).
    pub moment_fit: Option<MomentFitReport>,
}

/// The moment's fit of the baseline and the extended model.
#[derive(Debug, Clone, Copy, serde::Serialize)]
#[non_exhaustive]
pub struct MomentFitReport {
    /// The baseline model's.
    pub baseline: FitFigures,
    /// The extended model's.
    pub extended: FitFigures,
}

/// RMS and R² of a fit.
#[derive(Debug, Clone, Copy, serde::Serialize)]
#[non_exhaustive]
pub struct FitFigures {
    /// RMS (N·m).
    pub rms_nm: f64,
    /// R².
    pub r2: f64,
}
