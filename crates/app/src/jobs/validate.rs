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
    let starts: Vec<Option<Vec<usize>>> = session
        .trials
        .iter()
        .map(super::session::SessionTrial::stride_starts)
        .collect::<AppResult<_>>()?;
    let trials: Vec<ValidationTrial<'_>> = session
        .trials
        .iter()
        .zip(&session.manifest.trials)
        .zip(&starts)
        .map(|((t, entry), s)| ValidationTrial {
            name: &t.name,
            condition: entry.condition.as_deref(),
            problem: &t.problem,
            stride_starts: s.as_deref(),
        })
        .collect();
    let schemes = schemes_of(&job.folds, &trials)?;
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

    let mut settings = ValidateSettings::default();
    settings.later_fraction = job.later_fraction;
    settings.sa = settings.sa.with_seed(job.seed);
    if session.recording_defaults {
        settings.sa = super::session::recording_annealing(settings.sa);
    }
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
    lines
}

/// One figure per held-out part: the measured moment, the calibrated model's and the linear
/// baseline's over the held-out samples.
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
        }
    }
    set.finish()
}
