//! `surae validate`: the field's test of a calibrated model. The session's trials are split into
//! folds (leave one trial out, hold out the later strides of every trial, leave one condition
//! out); each fold calibrates the session's model on its training parts and predicts its
//! held-out parts, next to the linear EMG baseline calibrated on the same parts and to given
//! peer parameters (e.g. CEINMS's calibrated subject). Writes `validate.json`, a figure per
//! held-out part and `report.html`.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::time::Instant;

use serde::Serialize;
use validate::{FoldScheme, Peer, SchemeSummary, ValidateSettings, ValidationTrial};

use super::session::{file_stem, load_params_file, load_session, LoadedSession};
use super::ModelSettings;
use crate::error::{AppError, AppResult};
use crate::figures::FigureSet;
use crate::memory::InMemory;
use crate::output::OutDir;
use crate::Reporter;

mod extensions;
pub use extensions::{ExtensionHeldOut, ExtensionResult, ExtensionScheme, ExtensionStudy};

/// Arguments of `surae validate`.
#[derive(Debug)]
pub struct ValidateJob {
    /// Session manifest (docs/formats.md) of the trials validated; a trial's `condition`
    /// label groups it for leaving one condition out.
    pub session: PathBuf,
    /// Parameters over the session's (a parameters JSON, `.osim`, CEINMS subject XML or an
    /// `identify.json`): the start and bounds' centre of every calibration.
    pub params: Option<PathBuf>,
    /// The same given in memory.
    pub params_data: Option<InMemory<serde_json::Value>>,
    /// The parameters calibrated (default: the manifest's `free`, else the triceps' LST, F0
    /// and α0).
    pub free: Option<Vec<String>>,
    /// Parameter files predicted as they are on every held-out part (e.g. another tool's
    /// calibration of the subject), each named by its file name.
    pub peers: Vec<PathBuf>,
    /// The fold schemes (`trial`, `strides`, `condition`); empty: every scheme the session can
    /// form.
    pub folds: Vec<String>,
    /// Share of each trial that calibrates when the later strides are held out (0–1).
    pub later_fraction: f64,
    /// Annealing chains of each calibration (default 4; 8 with the recording defaults).
    pub chains: Option<u32>,
    /// Seed of every calibration.
    pub seed: u64,
    /// The EMG columns are already normalised envelopes in [0, 1].
    pub emg_is_envelope: bool,
    /// Also validate each extension for real recordings on the same folds (a compliant tendon,
    /// the eccentric plateau, activation dynamics, the EMG normalised the other way).
    pub extensions: bool,
    /// Output folder (default `out/validate`).
    pub out: Option<PathBuf>,
    /// Write no files: the result reaches the caller as [`crate::JobObserver::result_json`].
    pub discard_files: bool,
}

/// `validate.json`.
#[derive(Debug, Clone, Serialize)]
#[non_exhaustive]
pub struct ValidationReport {
    /// The session manifest.
    pub session: String,
    /// Its trials, with their condition labels.
    pub trials: Vec<ValidatedTrialReport>,
    /// The calibrated parameters' names.
    pub free: Vec<String>,
    /// The peers, by name, and the file each came from.
    pub peers: BTreeMap<String, String>,
    /// One summary per scheme: mean held-out RMS and R² of the model, the linear baseline and
    /// each peer.
    pub schemes: Vec<SchemeSummary>,
    /// Every fold: what calibrated it, its parameters, and each held-out part's scores.
    pub folds: Vec<validate::FoldResult>,
    /// Seed of the calibrations.
    pub seed: u64,
    /// Chains of each calibration.
    pub chains: u32,
    /// Share of each trial calibrated when the later strides are held out.
    pub later_fraction: f64,
    /// With `--extensions`: each extension's held-out scores beside the plain calibration's.
    pub extensions: Option<ExtensionStudy>,
    /// Wall-clock time of the whole validation (s).
    pub wall_s: f64,
}

/// A trial of the validated session.
#[derive(Debug, Clone, Serialize)]
#[non_exhaustive]
pub struct ValidatedTrialReport {
    /// Its name in the manifest.
    pub name: String,
    /// Its condition label, if any.
    pub condition: Option<String>,
    /// Samples.
    pub samples: usize,
}

/// The schemes asked for, or every scheme the session can form.
fn schemes_of(names: &[String], trials: &[ValidationTrial<'_>]) -> AppResult<Vec<FoldScheme>> {
    if names.is_empty() {
        let mut all = Vec::new();
        if trials.len() >= 2 {
            all.push(FoldScheme::LeaveOneTrialOut);
        }
        // holding out the later part of a trial asks whether a calibration carries forward
        // over strides; a trial of one stance (a CEINMS folder) has none to carry to
        if trials
            .iter()
            .any(|t| t.stride_starts.is_some_and(|s| s.len() >= 4))
        {
            all.push(FoldScheme::LaterStrides);
        }
        let mut conditions: Vec<&str> = trials.iter().filter_map(|t| t.condition).collect();
        conditions.sort_unstable();
        conditions.dedup();
        if trials.iter().all(|t| t.condition.is_some()) && conditions.len() >= 2 {
            all.push(FoldScheme::LeaveOneConditionOut);
        }
        return Ok(all);
    }
    names
        .iter()
        .map(|n| {
            FoldScheme::parse(n).ok_or_else(|| {
                AppError::bad(format!("--folds {n}: expected trial, strides or condition"))
            })
        })
        .collect()
}

/// A trial's strides (samples), from its vertical ground force, and which of them the
/// recording checks flagged: the held-out parts are scored stride by stride and drawn as
/// ensembles without the flagged ones.
struct TrialStrides {
    /// Each stride's foot strike.
    starts: Vec<usize>,
    /// Each stride's next foot strike (exclusive end).
    ends: Vec<usize>,
    /// Whether `checks.strides.flagged` holds the stride.
    flagged: Vec<bool>,
}

/// A trial's strides and the checks' flags ([`super::session::SessionTrial::strides`]).
fn trial_strides(t: &super::session::SessionTrial) -> AppResult<Option<TrialStrides>> {
    let Some(s) = t.strides()? else {
        return Ok(None);
    };
    Ok(Some(TrialStrides {
        starts: s.strides.iter().map(|x| x.start).collect(),
        ends: s.strides.iter().map(|x| x.end).collect(),
        flagged: t.stride_flags(&s),
    }))
}

/// Leaving one condition out needs every trial labelled and two labels at least: checked on
/// the manifest so the refusal names its key (`trials[k].condition`) before any calibration.
fn check_conditions(manifest: &Path, entries: &[session::SessionTrialEntry]) -> AppResult {
    let m = manifest.display();
    if let Some((k, e)) = entries
        .iter()
        .enumerate()
        .find(|(_, e)| e.condition.is_none())
    {
        return Err(AppError::bad(format!(
            "{m}: trials[{k}].condition: missing (trial {}): leaving one condition out \
             (--folds condition) needs every trial's condition label",
            e.name
        )));
    }
    let mut labels: Vec<&str> = entries
        .iter()
        .filter_map(|e| e.condition.as_deref())
        .collect();
    labels.sort_unstable();
    labels.dedup();
    if labels.len() < 2 {
        let keys: Vec<String> = (0..entries.len())
            .map(|k| format!("trials[{k}].condition"))
            .collect();
        return Err(AppError::bad(format!(
            "{m}: {}: every trial is labelled {:?}: leaving one condition out \
             (--folds condition) needs trials of at least two conditions",
            keys.join(", "),
            labels.first().copied().unwrap_or_default()
        )));
    }
    Ok(())
}

/// The peers' parameters, each over the session's (its fixed muscles from the session).
fn load_peers(job: &ValidateJob, session: &LoadedSession) -> AppResult<Vec<(Peer, String)>> {
    let fixed: Vec<String> = session
        .params
        .fixed
        .iter()
        .map(|f| f.name.to_string())
        .collect();
    let osim = opensim_files::OsimMuscleNames::default();
    job.peers
        .iter()
        .map(|p| {
            let (params, effects) = load_params_file(p, &osim, &fixed, &session.params)?;
            let name = p.file_stem().map_or_else(
                || p.display().to_string(),
                |s| s.to_string_lossy().into_owned(),
            );
            Ok((
                Peer {
                    name,
                    params,
                    effects: effects.unwrap_or(session.effects),
                },
                p.display().to_string(),
            ))
        })
        .collect()
}

/// The seed of `surae validate`'s calibrations when none is given.
pub const DEFAULT_VALIDATE_SEED: u64 = 42;

/// Every trial's strides and flags (`None` for a trial without a vertical ground force).
fn session_strides(session: &LoadedSession) -> AppResult<Vec<Option<TrialStrides>>> {
    session.trials.iter().map(trial_strides).collect()
}

/// The session's trials as `validate` takes them, with their `strides`.
fn validation_trials<'a>(
    session: &'a LoadedSession,
    strides: &'a [Option<TrialStrides>],
) -> Vec<ValidationTrial<'a>> {
    session
        .trials
        .iter()
        .zip(&session.manifest.trials)
        .zip(strides)
        .map(|((t, entry), s)| ValidationTrial {
            name: &t.name,
            condition: entry.condition.as_deref(),
            problem: &t.problem,
            stride_starts: s.as_ref().map(|s| s.starts.as_slice()),
            stride_ends: s.as_ref().map(|s| s.ends.as_slice()),
            stride_flagged: s.as_ref().map(|s| s.flagged.as_slice()),
        })
        .collect()
}

/// The calibration settings of every fold: `validate`'s defaults with `seed`, and the
/// recording defaults' annealing for a session that has them.
fn fold_settings(session: &LoadedSession, seed: u64) -> ValidateSettings {
    let mut settings = ValidateSettings::default();
    settings.sa = settings.sa.with_seed(seed);
    if session.recording_defaults {
        settings.sa = super::session::recording_annealing(settings.sa);
    }
    settings
}

/// The session validated with the default folds, seed and calibration and no peer: what
/// `surae validate --session` computes for it, for a job that judges a model by its held-out
/// residual (`diagnose --session`). `None` when the session can form no fold (one trial
/// without strides).
pub(crate) fn validate_with_defaults(
    session: &LoadedSession,
) -> AppResult<Option<validate::Validation>> {
    let strides = session_strides(session)?;
    let trials = validation_trials(session, &strides);
    let schemes = schemes_of(&[], &trials)?;
    if schemes.is_empty() {
        return Ok(None);
    }
    validate::validate(
        &trials,
        &schemes,
        &[],
        &fold_settings(session, DEFAULT_VALIDATE_SEED),
    )
    .map(Some)
    .map_err(|e| AppError::bad(format!("{}: {e}", session.manifest.path.display())))
}

/// Runs the command.
pub fn run(job: ValidateJob, rep: &Reporter) -> AppResult {
    let t0 = Instant::now();
    if !(job.later_fraction > 0.0 && job.later_fraction < 1.0) {
        return Err(AppError::bad(format!(
            "--later-fraction {}: must be within (0, 1)",
            job.later_fraction
        )));
    }
    if job.chains == Some(0) {
        return Err(AppError::bad("--chains: at least 1"));
    }
    let model = ModelSettings {
        params: job.params.clone(),
        params_data: job.params_data.clone(),
        emg_is_envelope: job.emg_is_envelope,
        ..ModelSettings::default()
    };
    let session = load_session(&job.session, &model, job.free.as_deref(), rep)?;
    let strides = session_strides(&session)?;
    let trials = validation_trials(&session, &strides);
    let schemes = schemes_of(&job.folds, &trials)?;
    if schemes.contains(&FoldScheme::LeaveOneConditionOut) {
        check_conditions(&job.session, &session.manifest.trials)?;
    }
    let peers = load_peers(&job, &session)?;
    let mut inputs_read = session.inputs_read.clone();
    inputs_read.extend(job.peers.iter().cloned());
    let out_dir = job
        .out
        .clone()
        .unwrap_or_else(|| crate::default_out("validate"));
    let input_refs: Vec<&Path> = inputs_read.iter().map(PathBuf::as_path).collect();
    let out = OutDir::prepare_or_discard(
        &out_dir,
        &input_refs,
        &["validate.json", "report.html"],
        job.discard_files,
    )?;

    let mut settings = fold_settings(&session, job.seed);
    settings.later_fraction = job.later_fraction;
    // chains asked for are run as asked, none added
    if let Some(c) = job.chains {
        settings.sa = settings
            .sa
            .with_chains(c)
            .with_extra_chains(0, settings.sa.agreement_rel);
    }
    let chains = settings.sa.chains;
    let progress = rep.progress(0, "validate");
    progress.message(format!(
        "{} scheme(s) on {} trial(s), {} chain(s) per calibration",
        schemes.len(),
        trials.len(),
        chains
    ));
    let peer_list: Vec<Peer> = peers.iter().map(|(p, _)| p.clone()).collect();
    let v = validate::validate(&trials, &schemes, &peer_list, &settings)
        .map_err(|e| AppError::bad(format!("{}: {e}", job.session.display())))?;
    progress.finish();
    let extensions = if job.extensions {
        let inputs = extensions::StudyInputs {
            session_path: &job.session,
            model: &model,
            free: job.free.as_deref(),
            plain: &session,
            schemes: &schemes,
            settings: &settings,
            plain_schemes: &v.schemes,
        };
        Some(extensions::study(&inputs, rep)?)
    } else {
        None
    };

    let doc = ValidationReport {
        session: job.session.display().to_string(),
        trials: session
            .trials
            .iter()
            .zip(&session.manifest.trials)
            .map(|(t, e)| ValidatedTrialReport {
                name: t.name.clone(),
                condition: e.condition.clone(),
                samples: t.problem.inputs().len(),
            })
            .collect(),
        free: session.free.iter().map(|p| p.name()).collect(),
        peers: peers
            .iter()
            .map(|(p, f)| (p.name.clone(), f.clone()))
            .collect(),
        schemes: v.schemes.clone(),
        folds: v.folds.clone(),
        seed: job.seed,
        chains,
        later_fraction: job.later_fraction,
        extensions,
        wall_s: t0.elapsed().as_secs_f64(),
    };
    let text = serde_json::to_string_pretty(&doc).map_err(AppError::internal)? + "\n";
    let path = out.write("validate.json", text.as_bytes())?;
    let files = write_figures(&out, &session, &v, rep)?;
    rep.print_json(&text);
    for line in summary_lines(&doc) {
        rep.say(&line);
    }
    rep.say(&format!(
        "wrote {} and {} figure/report files in {}",
        path.display(),
        files.len(),
        out_dir.display()
    ));
    Ok(())
}

/// The terminal summary: each scheme's mean held-out scores.
fn summary_lines(doc: &ValidationReport) -> Vec<String> {
    let mut lines = vec![format!(
        "validate: {} ({} trials; calibrated: {})",
        doc.session,
        doc.trials.len(),
        doc.free.join(", ")
    )];
    for s in &doc.schemes {
        let mut l = format!(
            "  {:24} held out ({} parts): model {:.2} N·m / R² {:.3}; linear {:.2} / {:.3}",
            s.scheme.name(),
            s.parts,
            s.model.rms_nm,
            s.model.r2,
            s.linear.rms_nm,
            s.linear.r2
        );
        for (name, p) in &s.peers {
            l.push_str(&format!("; {name} {:.2} / {:.3}", p.rms_nm, p.r2));
        }
        lines.push(l);
    }
    for f in &doc.folds {
        for h in &f.held_out {
            let s = &h.shape;
            let test = |t: &Option<numerics::cycle_shape::ShapeTestOutcome>| {
                t.map_or_else(|| "-".to_string(), |t| format!("{:.1e}", t.p_value))
            };
            lines.push(format!(
                "  {:24} {}: residual shape p = {:.1e} (across {} strides {}, against training {}): {}",
                f.name,
                h.trial,
                s.p_value,
                s.segments,
                test(&s.across_strides),
                test(&s.against_training),
                if s.reproducible {
                    "reproducible, the model is not adequate here"
                } else {
                    "no reproducible shape"
                }
            ));
            if let Some(k) = h.scale.filter(|k| k.differs) {
                lines.push(format!(
                    "  {:24} {}: the model's moment × {:.2} predicts half of it from the other \
                     {:.1} % better (RMS {:.2} → {:.2} N·m): the EMG reaches the moment with another \
                     gain here",
                    f.name,
                    h.trial,
                    k.factor,
                    k.cross_validated_gain_pct,
                    k.rms_nm,
                    k.cross_validated_rms_nm
                ));
            }
        }
    }
    if let Some(e) = &doc.extensions {
        lines.extend(extensions::summary_lines(e));
    }
    lines
}

/// One figure per held-out part: the measured moment, the calibrated model's and the linear
/// baseline's over the held-out samples; with its strides, their ensembles beside it
/// ([`add_ensembles`]).
fn write_figures(
    out: &OutDir,
    session: &LoadedSession,
    v: &validate::Validation,
    rep: &Reporter,
) -> AppResult<Vec<PathBuf>> {
    let mut set = FigureSet::new(out, "surae validate", rep);
    for f in &v.folds {
        for h in &f.held_out {
            let Some(t) = session.trials.iter().find(|t| t.name == h.trial) else {
                continue;
            };
            let r = h.samples_range.clone();
            let inputs = t.problem.inputs();
            let time = &inputs.times()[r.clone()];
            let measured = &t.problem.measured()[r.clone()];
            let angle: Vec<f64> = crate::figures::angle_deg(inputs)[r.clone()].to_vec();
            let name = format!(
                "{}_{}_{}",
                f.scheme.name(),
                file_stem(&f.name),
                file_stem(&h.trial)
            );
            set.add(
                &name,
                &format!(
                    "{} — {} held out: model {:.2} N·m (R² {:.3}), linear {:.2} N·m (R² {:.3})",
                    f.scheme.name(),
                    h.trial,
                    h.model.rms_nm,
                    h.model.r2,
                    h.linear.rms_nm,
                    h.linear.r2
                ),
                report::figures::torque_fit(
                    time,
                    measured,
                    &[("model", &h.model_nm), ("linear", &h.linear_nm)],
                    &angle,
                    &[],
                ),
            )?;
            add_ensembles(&mut set, &name, f.scheme, h, measured)?;
        }
    }
    set.finish()
}

/// Fewest strides in a held-out part for its ensembles: a mean ± sd over fewer says little.
pub(crate) const ENSEMBLE_MIN_STRIDES: usize = 4;
/// Points of a stride normalised to 0–100 % of the cycle (one per %).
pub(crate) const ENSEMBLE_POINTS: usize = 101;

/// The held-out part's ensembles over its strides (by % of the gait cycle), when it has at
/// least [`ENSEMBLE_MIN_STRIDES`]: the measured, model and linear moments' mean ± sd, and the
/// residuals alone. The strides the recording checks flagged are left out, so one bad stride
/// does not widen the bands; the caption counts them. `measured` is the measured moment over
/// the part's samples.
fn add_ensembles(
    set: &mut FigureSet<'_>,
    name: &str,
    scheme: FoldScheme,
    h: &validate::HeldOutScore,
    measured: &[f64],
) -> AppResult {
    if h.strides.len() < ENSEMBLE_MIN_STRIDES {
        return Ok(());
    }
    let r0 = h.samples_range.start;
    let kept: Vec<&validate::StrideScore> = h.strides.iter().filter(|s| !s.flagged).collect();
    let left_out = h.strides.len() - kept.len();
    let strides = experiment::Strides {
        strides: kept
            .iter()
            .map(|s| experiment::Stride {
                start: s.samples_range.start - r0,
                end: s.samples_range.end - r0,
                stance_end: None,
            })
            .collect(),
        source: experiment::StrideSource::GroundForce {
            threshold_n: experiment::STANCE_THRESHOLD_N,
        },
    };
    let cycle =
        |x: &[f64]| strides.normalised_part(x, ENSEMBLE_POINTS, experiment::StridePart::Cycle);
    let (m, model, linear) = (cycle(measured), cycle(&h.model_nm), cycle(&h.linear_nm));
    // a stride with a gap in any series is left out of all three, so they stay paired
    let whole: Vec<usize> = (0..m.len())
        .filter(|&k| !m[k].is_empty() && !model[k].is_empty() && !linear[k].is_empty())
        .collect();
    let pick = |c: &[Vec<f64>]| -> Vec<Vec<f64>> { whole.iter().map(|&k| c[k].clone()).collect() };
    let (m, model, linear) = (pick(&m), pick(&model), pick(&linear));
    if m.is_empty() {
        return Ok(());
    }
    let residual = |p: &[Vec<f64>]| -> Vec<Vec<f64>> {
        m.iter()
            .zip(p)
            .map(|(a, b)| a.iter().zip(b).map(|(x, y)| x - y).collect())
            .collect()
    };
    let (r_model, r_linear) = (residual(&model), residual(&linear));
    let percent = experiment::stride_percent(ENSEMBLE_POINTS);
    let left = match left_out {
        0 => "no stride flagged by the recording checks".to_string(),
        1 => "1 stride flagged by the recording checks left out".to_string(),
        n => format!("{n} strides flagged by the recording checks left out"),
    };
    let of = format!(
        "{} of its {} held-out strides; {left}",
        m.len(),
        h.strides.len()
    );
    set.add(
        &format!("{name}_strides"),
        &format!(
            "{} — {} held out, by % of the gait cycle: measured, model and linear moment, \
             mean ± sd over {of}",
            scheme.name(),
            h.trial
        ),
        report::figures::stride_ensemble(
            &percent,
            &m,
            &[("model", &model), ("linear", &linear)],
            "gait cycle",
        ),
    )?;
    set.add(
        &format!("{name}_residual"),
        &format!(
            "{} — {} held out, by % of the gait cycle: residual (measured − model), mean ± sd \
             over {of}",
            scheme.name(),
            h.trial
        ),
        report::figures::residual_ensemble(
            &percent,
            &[("model", &r_model), ("linear", &r_linear)],
            "gait cycle",
        ),
    )
}
