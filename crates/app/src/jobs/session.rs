//! `--session`: the trials of one subject read from a session manifest (docs/formats.md,
//! "Session manifest"), each turned into its identification problem with the session's shared
//! muscle parameters.
//!
//! A trial is a trial CSV (with its unloaded run, whose dynamometer correction is subtracted
//! from that trial alone, and its knee angle) or a CEINMS trial folder (envelopes, the
//! subject's own musculotendon lengths and moment arms, and the inverse-dynamics ankle moment,
//! compared where the moment file has samples). The parameters are a parameters JSON, an
//! OpenSim `.osim` model or a CEINMS subject XML, whose muscles other than sol, gm and gl
//! become fixed muscles; `--params` replaces them, or, given an `identify.json`, sets its
//! identified values over them.

use super::{read_text, ModelSettings};
use crate::error::{AppError, AppResult};
use crate::Reporter;
use experiment::CeinmsModelTrial;
use muscle_model::{Effects, ModelParams, ParamId, Problem, ProblemSet};
use session::{SessionManifest, TrialSource};
use std::path::{Path, PathBuf};

mod defaults;
mod emg;
mod params;
mod read;
mod strides;

use defaults::maps_say_envelopes;
pub use defaults::{recording_annealing, recording_bounds, recording_free};
use emg::session_emg_references;
pub use emg::{EmgNormalisationReport, SessionEmgNormalisation};
pub use params::{load_params_file, params_of_json};
use params::{session_params, SessionParams};
pub use read::read_session_trial;
use strides::exclude_flagged_strides;

/// One trial of a session, ready to fit or to predict.
pub struct SessionTrial {
    /// The trial's name in the manifest.
    pub name: String,
    /// Where it was read from (for messages).
    pub source: String,
    /// Its problem: the session's parameters, effects and free parameters on this trial's
    /// inputs and (corrected) measured torque.
    pub problem: Problem,
    /// The measured torque as recorded, on the inputs' grid.
    pub raw_torque: Vec<f64>,
    /// A trial file prepared once (crosstalk decision, inputs by the session's EMG references,
    /// dynamometer correction); `None` for a CEINMS folder.
    pub prepared: Option<experiment::PreparedTrial>,
    /// For a CEINMS trial: the moment file's own times and values, where fits are judged.
    pub ceinms: Option<CeinmsModelTrial>,
    /// The recording checks of a trial file or map (docs/formats.md); none for a CEINMS
    /// folder, whose moment comes from inverse dynamics.
    pub checks: Option<recording::checks::TrialChecks>,
    /// The raw-EMG crosstalk tests of the triceps channels against `emg_ta` (empty without
    /// one, for envelopes and for a CEINMS folder); a corrected channel is already corrected
    /// in `problem`, as `surae identify --trial` and `surae diagnose` correct it.
    pub crosstalk: Vec<experiment::CrosstalkCheck>,
}

impl SessionTrial {
    /// The measured torque and a prediction on the inputs' grid, brought to the samples where
    /// the fit is judged: the moment file's own samples for a CEINMS trial, otherwise every
    /// sample of positive weight (corrected torque; all of them unless the manifest excludes
    /// the flagged strides).
    pub fn judged(&self, prediction: &[f64]) -> AppResult<(Vec<f64>, Vec<f64>)> {
        match (&self.ceinms, self.problem.weights()) {
            (Some(c), _) => {
                let p = c
                    .at_torque_samples(prediction)
                    .map_err(|e| AppError::internal(e.to_string()))?;
                Ok((c.torque_at_samples.clone(), p))
            }
            (None, None) => Ok((self.problem.measured().to_vec(), prediction.to_vec())),
            (None, Some(w)) => {
                let kept = |v: &[f64]| -> Vec<f64> {
                    v.iter()
                        .zip(w)
                        .filter(|(_, w)| **w > 0.0)
                        .map(|(x, _)| *x)
                        .collect()
                };
                Ok((kept(self.problem.measured()), kept(prediction)))
            }
        }
    }

    /// The model's moment on the trial's grid at `params` and `effects` (default settings).
    pub fn simulate_at(&self, params: &ModelParams, effects: &Effects) -> AppResult<Vec<f64>> {
        muscle_model::simulate(
            self.problem.inputs(),
            params,
            effects,
            &muscle_model::SimSettings::default(),
        )
        .map(|s| s.torque)
        .map_err(|e| AppError::bad(format!("{}: simulation failed: {e}", self.source)))
    }

    /// RMS error (N·m) and R² of `prediction` where the fit is judged.
    pub fn fit_of(&self, prediction: &[f64]) -> AppResult<(f64, f64)> {
        let (m, p) = self.judged(prediction)?;
        Ok(experiment::moment_fit(&m, &p))
    }

    /// The trial's dynamometer correction, when it has an unloaded run.
    pub fn correction(&self) -> Option<&experiment::UnloadedCorrection> {
        self.prepared.as_ref().and_then(|p| p.unloaded.as_ref())
    }

    /// The trial's dynamometer report (`null` without an unloaded run).
    pub fn dynamometer(&self) -> Option<experiment::DynamometerReport> {
        self.correction().map(|c| c.correction.report())
    }
}

/// A session read and prepared.
pub struct LoadedSession {
    /// The manifest.
    pub manifest: SessionManifest,
    /// The shared muscle parameters (base values of the free ones).
    pub params: ModelParams,
    /// The effects every trial's model carries.
    pub effects: Effects,
    /// The free parameters.
    pub free: Vec<ParamId>,
    /// The trials, in the manifest's order.
    pub trials: Vec<SessionTrial>,
    /// How the trial CSVs' EMG was normalised.
    pub emg: SessionEmgNormalisation,
    /// Every file read (outputs never overwrite them).
    pub inputs_read: Vec<PathBuf>,
    /// The free parameters and bounds are the recording defaults (no trial has a dynamometer
    /// correction and none were given): calibrations then take the recording annealing (4 chains, 4 more when
    /// the best two disagree, 3 000 evaluations each; docs/validation.md).
    pub recording_defaults: bool,
}

impl LoadedSession {
    /// The summary's crosstalk line of every trial that has an `emg_ta` channel, as
    /// `surae identify --trial` prints it, led by the trial's name.
    pub fn crosstalk_lines(&self) -> Vec<String> {
        self.trials
            .iter()
            .filter_map(|t| {
                diagnose::crosstalk_summary_line(&t.crosstalk, None)
                    .map(|l| format!("{}: {l}", t.name))
            })
            .collect()
    }

    /// What the joint MCMC samples: each trial's problem on its torque as recorded (the
    /// sampler subtracts the systematic part itself) and its noise side: the unloaded run's
    /// correction and AR(1)+white noise, or, without one, AR(1)+white fitted to the trial's own
    /// residual.
    pub fn mcmc_trials(&self) -> AppResult<(Vec<Problem>, Vec<identify_mcmc::NoiseSpec>)> {
        use identify_mcmc::{NoiseKind, NoiseSpec};
        let mut problems = Vec::with_capacity(self.trials.len());
        let mut noises = Vec::with_capacity(self.trials.len());
        for t in &self.trials {
            let bad = |e: &dyn std::fmt::Display| AppError::bad(format!("{}: {e}", t.source));
            let p = &t.problem;
            let mut raw = Problem::new(
                p.inputs().clone(),
                t.raw_torque.clone(),
                *p.base_params(),
                *p.base_effects(),
                p.free().to_vec(),
            )
            .and_then(|q| q.with_bounds(p.bounds().to_vec()))
            .map_err(|e| bad(&e))?
            .with_settings(*p.settings());
            if let Some(w) = p.weights() {
                raw = raw.with_weights(w.to_vec()).map_err(|e| bad(&e))?;
            }
            // the correction placed at the trial's own motion events when it was prepared
            let noise = match &t.prepared {
                Some(prepared) => {
                    NoiseSpec::from_prepared(prepared, NoiseKind::Ar1White).map_err(|e| bad(&e))?
                }
                None => NoiseSpec::from_residual(NoiseKind::Ar1White),
            };
            problems.push(raw);
            noises.push(noise);
        }
        Ok((problems, noises))
    }

    /// The trials' problems as one set.
    pub fn problem_set(&self) -> AppResult<ProblemSet> {
        ProblemSet::new(self.trials.iter().map(|t| t.problem.clone()).collect())
            .map_err(|e| AppError::bad(format!("{}: {e}", self.manifest.path.display())))
    }

    /// Where every trial's strides start (`None` for a trial without a ground force).
    pub fn stride_starts(&self) -> AppResult<Vec<Option<Vec<usize>>>> {
        self.trials
            .iter()
            .map(SessionTrial::stride_starts)
            .collect()
    }

    /// The search set of a calibration of `set` (this session's trials, in order): windows of
    /// strides spread over a long gait session ([`identify_sa::search_set`]); `None` when no
    /// trial has strides or the session is short enough to search as it is. Dynamometer
    /// sessions are always searched as they are.
    pub fn search_set(&self, set: &ProblemSet) -> AppResult<Option<ProblemSet>> {
        let starts = self.stride_starts()?;
        if starts.iter().all(Option::is_none) {
            return Ok(None);
        }
        let cycles: Vec<Option<&[usize]>> = starts.iter().map(|s| s.as_deref()).collect();
        identify_sa::search_set(set, &cycles, &identify_sa::SearchSettings::default())
            .map_err(|e| AppError::internal(format!("{}: {e}", self.manifest.path.display())))
    }
}

/// The model every trial of a session shares: its parameters and effects, the free parameters
/// with their bounds, and the OpenSim names of its muscles.
struct SessionModel<'a> {
    params: ModelParams,
    effects: Effects,
    free: &'a [ParamId],
    bounds: &'a [(f64, f64)],
    osim: &'a opensim_files::OsimMuscleNames,
}

/// A free parameter's lower and upper bound.
type Bounds = (f64, f64);

/// The free parameters (`--free`, else the manifest's, else LST, F0 and α0 of the triceps)
/// and their bounds (the manifest's, else each parameter's default); a manifest bound of a
/// parameter that is not free is an error.
fn free_and_bounds(
    manifest: &SessionManifest,
    free: Option<&[String]>,
    params: &ModelParams,
    effects: &Effects,
    reference_fom_n: [f64; 3],
) -> AppResult<(Vec<ParamId>, Vec<Bounds>, bool)> {
    // `--free +a,+b` adds to the set the session would calibrate without it (and keeps its
    // bounds), so that an extension is compared against the same calibration
    let added: Vec<&str> = free
        .unwrap_or_default()
        .iter()
        .filter_map(|n| n.strip_prefix('+'))
        .collect();
    if !added.is_empty() && added.len() != free.map_or(0, <[String]>::len) {
        return Err(AppError::bad(
            "--free: give every name with a leading + (added to the default set) or none",
        ));
    }
    let free_names: Option<Vec<String>> = if added.is_empty() {
        free.map(|f| f.to_vec())
    } else {
        None
    }
    .or_else(|| manifest.free.clone());
    // a session with no dynamometer correction (gait, CEINMS folders) takes the recording
    // defaults, chosen on held-out real recordings (docs/validation.md)
    let recording = free_names.is_none() && manifest.trials.iter().all(|t| t.unloaded.is_none());
    let parse = |n: &str| ParamId::parse(n).map_err(|e| AppError::bad(format!("--free {n}: {e}")));
    let mut free: Vec<ParamId> = match free_names {
        Some(names) => names.iter().map(|n| parse(n)).collect::<AppResult<_>>()?,
        None if recording => recording_free(),
        None => ParamId::identified().to_vec(),
    };
    for n in added {
        let id = parse(n)?;
        if !free.contains(&id) {
            free.push(id);
        }
    }
    let bounds: Vec<(f64, f64)> = free
        .iter()
        .map(|id| {
            let name = id.name();
            match manifest.bounds.get(&name) {
                Some(&b) => b,
                None if recording => recording_bounds(*id, params, effects, reference_fom_n),
                None => id.default_bounds(params, effects),
            }
        })
        .collect();
    for name in manifest.bounds.keys() {
        if !free.iter().any(|id| &id.name() == name) {
            return Err(AppError::bad(format!(
                "{}: bounds.{name}: not a free parameter of this identification",
                manifest.path.display()
            )));
        }
    }
    Ok((free, bounds, recording))
}

/// A session's trial file as a trial of the session: its model inputs (EMG by the session's
/// references, its geometry), its torque corrected by its unloaded run, and its problem.
fn session_csv_trial(
    entry: &session::SessionTrialEntry,
    csv: LoadedCsv,
    model: &ModelSettings,
    emg: &SessionEmgNormalisation,
    m: &SessionModel<'_>,
) -> AppResult<SessionTrial> {
    let source = entry.source.path().display().to_string();
    let bad = |e: &dyn std::fmt::Display| AppError::bad(format!("{source}: {e}"));
    let LoadedCsv {
        trial,
        as_recorded,
        unloaded,
        geometry: mapped_geometry,
        checks,
        crosstalk,
    } = csv;
    let opts = experiment::InputOptions {
        emg_is_envelope: model.emg_is_envelope,
        knee_angle_deg: entry.knee_angle_deg,
        ..experiment::InputOptions::default()
    };
    let mut prepared = experiment::PreparedTrial::referenced(
        &trial,
        as_recorded.as_ref(),
        crosstalk,
        unloaded.as_ref(),
        &opts,
        &emg.references,
        &source,
    )
    .map_err(|e| match e.path() {
        Some(_) => AppError::bad(e),
        None => bad(&e),
    })?;
    prepared.inputs = emg.apply(prepared.inputs);
    let mut inputs = prepared.inputs.clone();
    if let Some(g) = &entry.geometry {
        inputs = with_muscle_analysis(inputs, g, &m.params, m.osim)?;
    }
    for g in mapped_geometry {
        let muscle = g.muscle.clone();
        inputs = inputs
            .with_geometry(
                &muscle,
                muscle_model::GeometrySeries {
                    lmt_m: g.lmt_m,
                    moment_arm_m: g.moment_arm_m,
                },
            )
            .map_err(|e| bad(&format!("lmt_{muscle}_m / ma_{muscle}_m: {e}")))?;
    }
    let problem = Problem::new(
        inputs,
        prepared.measured().to_vec(),
        m.params,
        m.effects,
        m.free.to_vec(),
    )
    .and_then(|p| p.with_bounds(m.bounds.to_vec()))
    .map_err(|e| bad(&e))?;
    Ok(SessionTrial {
        name: entry.name.clone(),
        source,
        problem,
        raw_torque: prepared.raw_torque().to_vec(),
        ceinms: None,
        checks: Some(checks),
        crosstalk: prepared.crosstalk.clone(),
        prepared: Some(prepared),
    })
}

/// A CEINMS trial folder as a trial of the session (its moment weighted where it is judged).
fn session_ceinms_trial(
    entry: &session::SessionTrialEntry,
    mut c: CeinmsModelTrial,
    emg: &SessionEmgNormalisation,
    m: &SessionModel<'_>,
) -> AppResult<SessionTrial> {
    c.inputs = emg.apply(c.inputs);
    let source = entry.source.path().display().to_string();
    let bad = |e: &dyn std::fmt::Display| AppError::bad(format!("{source}: {e}"));
    let problem = Problem::new(
        c.inputs.clone(),
        c.torque_nm.clone(),
        m.params,
        m.effects,
        m.free.to_vec(),
    )
    .and_then(|p| p.with_bounds(m.bounds.to_vec()))
    .and_then(|p| p.with_weights(c.weights.clone()))
    .map_err(|e| bad(&e))?;
    Ok(SessionTrial {
        name: entry.name.clone(),
        source,
        problem,
        raw_torque: c.torque_nm.clone(),
        prepared: None,
        ceinms: Some(c),
        checks: None,
        crosstalk: Vec::new(),
    })
}

/// A session's trial as read: a trial file (CSV or recording map) or a CEINMS trial folder.
enum Loaded {
    Csv(Box<LoadedCsv>),
    Ceinms(Box<CeinmsModelTrial>),
}

/// Reads every trial of `manifest` (adding the files read to `read`), and the muscles of its
/// CEINMS trials.
fn load_recordings(
    manifest: &SessionManifest,
    model: &ModelSettings,
    read: &mut Vec<PathBuf>,
    rep: &Reporter,
) -> AppResult<(Vec<Loaded>, Vec<String>)> {
    let mut loaded = Vec::with_capacity(manifest.trials.len());
    let mut ceinms_muscles: Vec<String> = Vec::new();
    for t in &manifest.trials {
        let p = t.source.path();
        read.push(p.to_path_buf());
        match &t.source {
            TrialSource::Recording(_) if p.is_dir() => {
                if t.unloaded.is_some() || t.knee_angle_deg.is_some() {
                    return Err(AppError::bad(format!(
                        "{}: trial {}: a CEINMS recording has no unloaded run or knee angle \
                         (its lengths and moment arms already hold the knee's)",
                        manifest.path.display(),
                        t.name
                    )));
                }
                let c = experiment::read_ceinms_trial(p, ceinms_files::DEFAULT_JOINT)
                    .map_err(AppError::bad)?;
                for m in &c.muscles {
                    if !ceinms_muscles.contains(m) {
                        ceinms_muscles.push(m.clone());
                    }
                }
                loaded.push(Loaded::Ceinms(Box::new(c)));
            }
            TrialSource::Recording(_) if recording::file_kind(p) != recording::FileKind::Map => {
                return Err(AppError::bad(format!(
                    "{}: trial {}: recording {} is not a CEINMS trial folder (a folder with \
                     emg.txt, lmt.txt, R_ankle_feMa.txt and R_ankle_feTorque.txt) nor a \
                     recording map (.json)",
                    manifest.path.display(),
                    t.name,
                    p.display()
                )));
            }
            TrialSource::Csv(_) | TrialSource::Recording(_) => {
                let csv = load_csv_trial(manifest, t, model, read, rep)?;
                loaded.push(Loaded::Csv(Box::new(csv)));
            }
        }
    }
    Ok((loaded, ceinms_muscles))
}

/// Reads a session's trial file (a CSV or recording map) with its unloaded run, checks it as
/// recorded, and removes the TA's crosstalk from its raw triceps EMG.
fn load_csv_trial(
    manifest: &SessionManifest,
    t: &session::SessionTrialEntry,
    model: &ModelSettings,
    read: &mut Vec<PathBuf>,
    rep: &Reporter,
) -> AppResult<LoadedCsv> {
    let p = t.source.path();
    let (mut trial, geometry) = read_session_trial(p, model, rep)?;
    // the recording as recorded is what its checks judge
    let checks = super::inspect::trial_checks(
        &super::LoadedTrial {
            trial: trial.clone(),
            name: p.display().to_string(),
            path: Some(p.to_path_buf()),
            data_files: Vec::new(),
            emg_is_envelope: model.emg_is_envelope,
            bundled: false,
        },
        model.emg_is_envelope,
    );
    // the TA's crosstalk leaves the raw triceps EMG before the session's EMG
    // references are taken from it, as it leaves a single trial's
    let settings = diagnose::DiagnoseSettings {
        input_options: experiment::InputOptions {
            emg_is_envelope: model.emg_is_envelope,
            ..experiment::InputOptions::default()
        },
        ..diagnose::DiagnoseSettings::default()
    };
    let crosstalk = experiment::emg_crosstalk(
        &trial,
        &settings.crosstalk_settings(),
        settings.input_options.emg_is_envelope,
        &p.display().to_string(),
    )
    .map_err(|e| {
        AppError::bad(format!(
            "{}: trial {}: {e}",
            manifest.path.display(),
            t.name
        ))
    })?;
    let mut as_recorded = None;
    if let Some(c) = experiment::remove_crosstalk(&trial, &crosstalk) {
        as_recorded = Some(std::mem::replace(&mut trial, c));
    }
    let unloaded = match &t.unloaded {
        Some(u) => {
            read.push(u.clone());
            let un = super::read_unloaded_any(u, rep)?;
            super::check_unloaded(
                &trial,
                &p.display().to_string(),
                &un,
                &u.display().to_string(),
            )?;
            Some(un)
        }
        None => None,
    };
    Ok(LoadedCsv {
        trial,
        as_recorded,
        unloaded,
        geometry,
        checks,
        crosstalk,
    })
}

/// A session's trial file as read: the recording (its TA crosstalk removed), its unloaded
/// run, the geometry its recording map carries, its recording checks (of the file as
/// recorded) and its crosstalk tests.
struct LoadedCsv {
    trial: experiment::Trial,
    /// The trial before its crosstalk was removed, when a channel carried it.
    as_recorded: Option<experiment::Trial>,
    unloaded: Option<experiment::Unloaded>,
    geometry: Vec<recording::MappedGeometry>,
    checks: recording::checks::TrialChecks,
    crosstalk: Vec<experiment::CrosstalkCheck>,
}

/// Warns of a trial file whose EMG scale against its moment differs from the session's other
/// trials far more than a change of task explains (a changed gain, electrode or
/// normalisation; `recording::checks::check_envelope_scales` on the EMG as recorded).
fn warn_envelope_scales(manifest: &SessionManifest, loaded: &[Loaded], rep: &Reporter) {
    let trials: Vec<recording::checks::ScaleTrial<'_>> = manifest
        .trials
        .iter()
        .zip(loaded)
        .filter_map(|(entry, l)| match l {
            Loaded::Csv(csv) => {
                let recorded = csv.as_recorded.as_ref().unwrap_or(&csv.trial);
                Some(recording::checks::ScaleTrial {
                    name: &entry.name,
                    moment_nm: &recorded.torque_nm,
                    emg: recorded.emg_channels(),
                })
            }
            Loaded::Ceinms(_) => None,
        })
        .collect();
    if trials.len() < 2 {
        return;
    }
    let check = recording::checks::check_envelope_scales(
        &trials,
        &recording::checks::CheckSettings::default(),
    );
    for w in check.warnings {
        rep.warn(format!("{}: {w}", manifest.path.display()));
    }
}

/// Reads a session and prepares its trials. `model` may override the session's parameters
/// (`--params`), effects (`--effects`) and EMG handling; `free` overrides its free parameters.
pub fn load_session(
    path: &Path,
    model: &ModelSettings,
    free: Option<&[String]>,
    rep: &Reporter,
) -> AppResult<LoadedSession> {
    // a CEINMS trial folder given as `--trial` is a session of one
    let mut manifest = if path.is_dir() {
        SessionManifest::of_recording(path)
    } else {
        session::read_session_manifest(path).map_err(AppError::bad)?
    };
    if let Some(scope) = model.emg_normalisation {
        if scope == session::EmgNormalisationScope::Trial && !manifest.mvc.is_empty() {
            return Err(AppError::bad(format!(
                "{}: mvc: EMG normalised per trial leaves the MVC trials unused",
                manifest.path.display()
            )));
        }
        manifest.emg_normalisation = scope;
    }
    let mut read = if path.is_dir() {
        Vec::new()
    } else {
        vec![path.to_path_buf()]
    };
    // a session whose every trial is a recording map of envelopes is read as envelopes
    let maps_of_envelopes = maps_say_envelopes(&manifest)?;
    let model_of_maps;
    let model = if maps_of_envelopes && !model.emg_is_envelope {
        model_of_maps = ModelSettings {
            emg_is_envelope: true,
            ..model.clone()
        };
        &model_of_maps
    } else {
        model
    };
    // the recordings first: a CEINMS subject's fixed muscles are those of its trials
    let (loaded, ceinms_muscles) = load_recordings(&manifest, model, &mut read, rep)?;

    let csv_trials: Vec<(&str, &experiment::Trial)> = manifest
        .trials
        .iter()
        .zip(&loaded)
        .filter_map(|(entry, l)| match l {
            Loaded::Csv(csv) => Some((entry.name.as_str(), &csv.trial)),
            Loaded::Ceinms(_) => None,
        })
        .collect();
    let emg = session_emg_references(&manifest, &csv_trials, model, &mut read, rep)?;
    warn_envelope_scales(&manifest, &loaded, rep);

    // parameters: the session's, replaced by --params or with an identify.json over them
    let SessionParams {
        osim,
        params,
        effects,
        reference_fom_n,
    } = session_params(&manifest, model, &ceinms_muscles, &mut read)?;
    let (free, bounds, recording_defaults) =
        free_and_bounds(&manifest, free, &params, &effects, reference_fom_n)?;
    let shared = SessionModel {
        params,
        effects,
        free: &free,
        bounds: &bounds,
        osim: &osim,
    };
    let mut trials = Vec::with_capacity(loaded.len());
    for (entry, l) in manifest.trials.iter().zip(loaded) {
        trials.push(match l {
            Loaded::Csv(csv) => session_csv_trial(entry, *csv, model, &emg, &shared)?,
            Loaded::Ceinms(c) => session_ceinms_trial(entry, *c, &emg, &shared)?,
        });
    }
    if manifest.exclude_flagged_strides {
        for t in &mut trials {
            exclude_flagged_strides(t)?;
        }
    }
    Ok(LoadedSession {
        manifest,
        params,
        effects,
        free,
        trials,
        emg,
        inputs_read: read,
        recording_defaults,
    })
}

/// `inputs` with the musculotendon lengths and ankle moment arms of OpenSim MuscleAnalysis
/// results (`g`) for every muscle of the model that has a column in both files (sol, gm, gl
/// under their `.osim` names, fixed muscles under their own), resampled linearly onto the
/// trial's samples. OpenSim's moment arm about `ankle_angle_r` is positive towards
/// dorsiflexion, surae's towards plantarflexion: it is negated.
fn with_muscle_analysis(
    mut inputs: muscle_model::TrialInputs,
    g: &session::GeometryFiles,
    params: &ModelParams,
    osim: &opensim_files::OsimMuscleNames,
) -> AppResult<muscle_model::TrialInputs> {
    let read = |p: &Path| -> AppResult<opensim_files::StoTable> {
        let text = read_text(p)?;
        opensim_files::read_sto(&text, &p.display().to_string()).map_err(AppError::bad)
    };
    let (lengths, arms) = (read(&g.lengths)?, read(&g.moment_arms)?);
    let times = inputs.times().to_vec();
    let (t0, t1) = (times[0], times[times.len() - 1]);
    let mut names: Vec<(String, String)> = muscle_model::Muscle::ALL
        .iter()
        .map(|&m| (m.name().to_string(), osim.get(m).to_string()))
        .collect();
    names.extend(
        params
            .fixed
            .iter()
            .map(|f| (f.name.to_string(), f.name.to_string())),
    );
    let mut found = 0;
    for (model_name, column) in names {
        let (Some(l), Some(r)) = (lengths.column(&column), arms.column(&column)) else {
            continue;
        };
        let series = |file: &Path, table: &opensim_files::StoTable, v: &[f64]| {
            let t = table
                .time()
                .ok_or_else(|| AppError::bad(format!("{}: no time column", file.display())))?;
            if t.first().is_none_or(|&a| a > t0 + 1e-9) || t.last().is_none_or(|&b| b < t1 - 1e-9) {
                return Err(AppError::bad(format!(
                    "{}: covers {:.3}–{:.3} s, the trial {t0:.3}–{t1:.3} s",
                    file.display(),
                    t.first().copied().unwrap_or(f64::NAN),
                    t.last().copied().unwrap_or(f64::NAN)
                )));
            }
            numerics::interpolate::resample_linear(t, v, &times)
                .map_err(|e| AppError::bad(format!("{}: {column}: {e}", file.display())))
        };
        let lmt_m = series(&g.lengths, &lengths, l)?;
        let moment_arm_m = series(&g.moment_arms, &arms, r)?
            .into_iter()
            .map(|x| -x)
            .collect();
        inputs = inputs
            .with_geometry(
                &model_name,
                muscle_model::GeometrySeries {
                    lmt_m,
                    moment_arm_m,
                },
            )
            .map_err(|e| AppError::bad(format!("{}: {column}: {e}", g.lengths.display())))?;
        found += 1;
    }
    if found == 0 {
        return Err(AppError::bad(format!(
            "{}: no column for any muscle of the model (looked for {}, {}, {} and the fixed \
             muscles' names)",
            g.lengths.display(),
            osim.get(muscle_model::Muscle::Sol),
            osim.get(muscle_model::Muscle::Gm),
            osim.get(muscle_model::Muscle::Gl)
        )));
    }
    Ok(inputs)
}

/// A trial name as part of a file name (letters, digits, `-`, `_`; others become `_`).
pub fn file_stem(name: &str) -> String {
    name.chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() || c == '-' || c == '_' {
                c
            } else {
                '_'
            }
        })
        .collect()
}
