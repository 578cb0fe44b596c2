//! One module per `surae` subcommand.

pub mod design;
pub mod diagnose;
pub mod envelope;
pub mod identify;
pub mod inspect;
pub mod sensitivity;
pub mod session;
pub mod simulate;
pub mod validate;

use crate::bundled;
use crate::error::{AppError, AppResult};
use crate::memory::InMemory;
use crate::Reporter;
use experiment::{Trial, Unloaded};
use std::path::{Path, PathBuf};

/// A trial and where it came from (for messages and output checks).
pub struct LoadedTrial {
    /// The parsed trial.
    pub trial: Trial,
    /// Name used in messages: the path, or `bundled:fixtures/seed/trial.csv`.
    pub name: String,
    /// The file, when it came from disk (a trial CSV or a recording map).
    pub path: Option<PathBuf>,
    /// The data files a recording map read (outputs never overwrite them).
    pub data_files: Vec<PathBuf>,
    /// The recording map says its EMG channels are envelopes already.
    pub emg_is_envelope: bool,
    /// The bundled seed trial (its errors are ours, not the user's).
    pub bundled: bool,
}

/// What `--trial` and `--unloaded` take (docs/formats.md): a trial CSV or a recording map
/// (`.json`) of a lab's files; any other data file needs a map.
fn not_a_trial(p: &Path, kind: recording::FileKind, option: &str) -> Option<AppError> {
    let what = match kind {
        recording::FileKind::C3d => "a C3D file",
        recording::FileKind::Storage => "an OpenSim storage file",
        recording::FileKind::CeinmsFolder => {
            return Some(AppError::bad(format!(
                "{}: a folder: a CEINMS trial folder is read by simulate, identify and diagnose \
                 (as a session of one) or as a session trial's \"recording\"",
                p.display()
            )))
        }
        _ => return None,
    };
    Some(AppError::bad(format!(
        "{}: {what}: give a recording map that names its channels (`surae inspect {}` prints \
         one) as {option}",
        p.display(),
        p.display()
    )))
}

/// A recording map read into a trial, with its data files and what the reader noted.
pub fn load_mapped_trial(p: &Path, rep: &Reporter) -> AppResult<LoadedTrial> {
    let map = recording::read_map(p).map_err(AppError::bad)?;
    let rec = recording::read_trial_recording(&map).map_err(AppError::bad)?;
    if !rec.geometry.is_empty() {
        return Err(AppError::bad(format!(
            "{}: channels lmt_<muscle>_m / ma_<muscle>_m: geometry series are read in a session \
             (--session, with this map as a trial's \"recording\")",
            p.display()
        )));
    }
    for n in &rec.notes {
        rep.warn(format!("{}: {n}", p.display()));
    }
    let mut data_files: Vec<PathBuf> = Vec::new();
    for s in &rec.sources {
        let f = PathBuf::from(&s.file);
        if !data_files.contains(&f) {
            data_files.push(f);
        }
    }
    Ok(LoadedTrial {
        trial: rec.trial,
        name: p.display().to_string(),
        path: Some(p.to_path_buf()),
        data_files,
        emg_is_envelope: rec.emg_is_envelope,
        bundled: false,
    })
}

/// Reads `--trial` (a trial CSV or a recording map), or takes the trial given in memory
/// (`data`, checked as the reader checks a file), or the bundled seed trial when neither is
/// given.
pub fn load_trial(
    path: Option<&Path>,
    data: Option<&InMemory<Trial>>,
    rep: &Reporter,
) -> AppResult<LoadedTrial> {
    if let Some(d) = data {
        d.value.validate(&d.label).map_err(AppError::bad)?;
        return Ok(LoadedTrial {
            trial: d.value.clone(),
            name: d.label.clone(),
            path: None,
            data_files: Vec::new(),
            emg_is_envelope: false,
            bundled: false,
        });
    }
    match path {
        Some(p) => {
            let kind = recording::file_kind(p);
            if let Some(f) = not_a_trial(p, kind, "--trial") {
                return Err(f);
            }
            if kind == recording::FileKind::Map {
                return load_mapped_trial(p, rep);
            }
            let trial = experiment::read_trial(p).map_err(AppError::bad)?;
            warn_ignored(&p.display().to_string(), &trial.ignored_columns, rep);
            Ok(LoadedTrial {
                trial,
                name: p.display().to_string(),
                path: Some(p.to_path_buf()),
                data_files: Vec::new(),
                emg_is_envelope: false,
                bundled: false,
            })
        }
        None => Ok(LoadedTrial {
            trial: bundled::seed_trial().map_err(AppError::internal)?,
            name: bundled::SEED_TRIAL_NAME.to_string(),
            path: None,
            data_files: Vec::new(),
            emg_is_envelope: false,
            bundled: true,
        }),
    }
}

/// Reads an unloaded run: an unloaded-run CSV or a recording map of its angle and torque.
pub fn read_unloaded_any(p: &Path, rep: &Reporter) -> AppResult<Unloaded> {
    let kind = recording::file_kind(p);
    if let Some(f) = not_a_trial(p, kind, "the unloaded run") {
        return Err(f);
    }
    if kind == recording::FileKind::Map {
        let map = recording::read_map(p).map_err(AppError::bad)?;
        return recording::read_unloaded_recording(&map).map_err(AppError::bad);
    }
    let u = experiment::read_unloaded(p).map_err(AppError::bad)?;
    warn_ignored(&p.display().to_string(), &u.ignored_columns, rep);
    Ok(u)
}

/// Reads `--unloaded` when given, or takes the run given in memory (`data`); with neither and
/// no trial of the user's (`trial_given`) the bundled seed unloaded run is the default, with a
/// user's trial it is never defaulted.
pub fn load_unloaded(
    path: Option<&Path>,
    data: Option<&InMemory<Unloaded>>,
    trial_given: bool,
    rep: &Reporter,
) -> AppResult<Option<(Unloaded, String)>> {
    if let Some(d) = data {
        d.value.validate(&d.label).map_err(AppError::bad)?;
        return Ok(Some((d.value.clone(), d.label.clone())));
    }
    match (path, trial_given) {
        (Some(p), _) => Ok(Some((read_unloaded_any(p, rep)?, p.display().to_string()))),
        (None, false) => Ok(Some((
            bundled::seed_unloaded().map_err(AppError::internal)?,
            bundled::SEED_UNLOADED_NAME.to_string(),
        ))),
        (None, true) => Ok(None),
    }
}

/// A trial file or in-memory trial with its unloaded run ([`load_trial`], [`load_unloaded`]),
/// the run checked against the trial ([`check_unloaded`]).
pub fn load_trial_pair(
    trial: (Option<&Path>, Option<&InMemory<Trial>>),
    unloaded: (Option<&Path>, Option<&InMemory<Unloaded>>),
    rep: &Reporter,
) -> AppResult<(LoadedTrial, Option<(Unloaded, String)>)> {
    let loaded = load_trial(trial.0, trial.1, rep)?;
    let run = load_unloaded(unloaded.0, unloaded.1, !loaded.bundled, rep)?;
    if let Some((u, name)) = &run {
        check_unloaded(&loaded.trial, &loaded.name, u, name)?;
    }
    Ok((loaded, run))
}

fn warn_ignored(name: &str, cols: &[String], rep: &Reporter) {
    if !cols.is_empty() {
        rep.warn(format!(
            "{name}: ignored unknown columns: {}",
            cols.join(", ")
        ));
    }
}

/// Checks that an unloaded run can describe the trial's dynamometer: the same
/// sampling rate.
pub fn check_unloaded(
    trial: &Trial,
    trial_name: &str,
    unloaded: &Unloaded,
    unloaded_name: &str,
) -> AppResult {
    let (ft, fu) = (trial.sample_rate_hz(), unloaded.sample_rate_hz());
    if ((ft - fu) / ft).abs() > 1e-6 {
        return Err(AppError::bad(format!(
            "{unloaded_name}: sampled at {fu:.3} Hz but {trial_name} at {ft:.3} Hz; the unloaded \
             run must be recorded like the trial"
        )));
    }
    Ok(())
}

/// Resolves an `--out` that may name a file (`*.csv`) or a folder; returns the
/// file to write. `default_file` is used inside a folder.
pub fn out_file(out: Option<&Path>, command: &str, default_file: &str) -> PathBuf {
    match out {
        Some(p) if p.extension().is_some_and(|e| e.eq_ignore_ascii_case("csv")) => p.to_path_buf(),
        Some(p) => p.join(default_file),
        None => crate::default_out(command).join(default_file),
    }
}

/// Model options shared by the commands that simulate.
#[derive(Debug, Clone, Default)]
pub struct ModelSettings {
    /// Parameters JSON (docs/formats.md; any subset, the rest is nominal), an OpenSim model
    /// (`.osim`) whose soleus and gastrocnemii give F0, LOM, LST, α0 and vmax, a CEINMS
    /// subject XML, or an `identify.json` whose identified values are set over the nominal
    /// ones.
    pub params: Option<PathBuf>,
    /// With an `.osim` `--params`: the model's names of sol, gm and gl when they are not
    /// gait2392's `soleus_r`, `med_gas_r`, `lat_gas_r` (e.g. `sol=soleus_l,gm=med_gas_l`).
    pub osim_muscles: Vec<String>,
    /// Effects JSON (effects and their parameters in docs/formats.md): `{"<effect>": {"<param>": value}}`.
    pub effects: Option<PathBuf>,
    /// Parameters given in memory (a parameters object or an `identify.json`'s), in place of
    /// `params`.
    pub params_data: Option<InMemory<serde_json::Value>>,
    /// Effects given in memory, in place of `effects`.
    pub effects_data: Option<InMemory<serde_json::Value>>,
    /// The EMG columns are already normalised envelopes in [0, 1] (skip the
    /// EMG filtering of docs/model.md).
    pub emg_is_envelope: bool,
    pub knee: KneeSettings,
    /// A session's EMG normalisation in place of its manifest's `emg_normalisation`.
    pub emg_normalisation: Option<::session::EmgNormalisationScope>,
}

/// The knee angle of a trial recorded without a `knee_angle_deg` column.
#[derive(Debug, Clone, Copy, Default)]
pub struct KneeSettings {
    /// Constant knee flexion of the trial, in degrees (0 extended, 90 flexed), when the
    /// file has no `knee_angle_deg` column; a file whose column holds other values is an
    /// error. Without either the knee is extended.
    pub knee_angle_deg: Option<f64>,
}

impl KneeSettings {
    /// The reader's options for the EMG given as raw signals or as envelopes, with this knee
    /// angle.
    pub fn input_options(&self, emg_is_envelope: bool) -> experiment::InputOptions {
        experiment::InputOptions {
            emg_is_envelope,
            knee_angle_deg: self.knee_angle_deg,
            ..experiment::InputOptions::default()
        }
    }
}

pub fn read_text(path: &Path) -> AppResult<String> {
    let bytes = std::fs::read(path).map_err(|e| {
        AppError::bad(format!(
            "{}: {}",
            path.display(),
            match e.kind() {
                std::io::ErrorKind::NotFound => "no such file".to_string(),
                _ => e.to_string(),
            }
        ))
    })?;
    String::from_utf8(bytes)
        .map_err(|_| AppError::bad(format!("{}: not UTF-8 text", path.display())))
}

/// Reads a JSON file; syntax errors name the file, line and column.
pub fn read_json(path: &Path) -> AppResult<serde_json::Value> {
    let text = read_text(path)?;
    serde_json::from_str(&text).map_err(|e| {
        AppError::bad(format!(
            "{}:{}:{}: invalid JSON: {e}",
            path.display(),
            e.line(),
            e.column()
        ))
    })
}

/// Reads `--params` (any file [`session::load_params_file`] takes) and `--effects` (nominal /
/// none when absent; an `identify.json`'s effects when it carries them and no `--effects` is
/// given); also returns the paths read, so outputs never overwrite them.
pub fn load_model_config(
    args: &ModelSettings,
) -> AppResult<(
    muscle_model::ModelParams,
    muscle_model::Effects,
    Vec<PathBuf>,
)> {
    let mut read = Vec::new();
    let names = osim_names(args)?;
    let nominal = muscle_model::ModelParams::nominal();
    let (params, effects_of_params) = match (&args.params_data, &args.params) {
        (Some(d), _) => session::params_of_json(&d.value, &nominal, &d.label)?,
        (None, Some(p)) => {
            read.push(p.clone());
            session::load_params_file(p, &names, &[], &nominal)?
        }
        (None, None) => (nominal, None),
    };
    let effects = match (&args.effects_data, &args.effects) {
        (Some(d), _) => effects_of_json(&d.value, &d.label)?,
        (None, Some(p)) => {
            read.push(p.clone());
            read_effects(p)?
        }
        (None, None) => effects_of_params.unwrap_or_else(muscle_model::Effects::none),
    };
    Ok((params, effects, read))
}

/// An effects JSON file (docs/formats.md).
pub fn read_effects(path: &Path) -> AppResult<muscle_model::Effects> {
    let value = read_json(path)?;
    effects_of_json(&value, &path.display().to_string())
}

/// An effects object (docs/formats.md), named `name` in errors.
pub fn effects_of_json(value: &serde_json::Value, name: &str) -> AppResult<muscle_model::Effects> {
    muscle_model::Effects::from_json(value).map_err(|e| AppError::bad(format!("{name}: {e}")))
}

/// Whether `path` names an OpenSim model (`.osim`).
pub fn is_osim(path: &Path) -> bool {
    path.extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("osim"))
}

/// The `--osim-muscles` map (gait2392's names for those not given); an error when it is
/// given without an `.osim` `--params`.
pub fn osim_names(args: &ModelSettings) -> AppResult<opensim_files::OsimMuscleNames> {
    if !args.osim_muscles.is_empty() && !args.params.as_deref().is_some_and(is_osim) {
        return Err(AppError::bad(
            "--osim-muscles applies to an OpenSim model given as --params model.osim",
        ));
    }
    let mut pairs = Vec::new();
    for item in &args.osim_muscles {
        let (k, v) = item.split_once('=').ok_or_else(|| {
            AppError::bad(format!(
                "--osim-muscles `{item}`: expected MUSCLE=NAME, e.g. sol=soleus_l"
            ))
        })?;
        pairs.push((k.trim(), v.trim()));
    }
    opensim_files::OsimMuscleNames::renamed(pairs).map_err(AppError::bad)
}

/// Refuses a constant knee angle outside the knee's range.
fn check_knee_angle(args: &ModelSettings) -> AppResult<()> {
    if let Some(k) = args.knee.knee_angle_deg {
        let (lo, hi) = experiment::KNEE_RANGE_DEG;
        if !(k.is_finite() && (lo..=hi).contains(&k)) {
            return Err(AppError::bad(format!(
                "--knee-angle-deg: {k} is outside the knee's range [{lo}, {hi}] degrees"
            )));
        }
    }
    Ok(())
}

/// An error of preparing `loaded`: a bad input when the trial is the user's, ours when it is
/// the bundled one.
fn input_error(loaded: &LoadedTrial, msg: String) -> AppError {
    if loaded.bundled {
        AppError::internal(msg)
    } else {
        AppError::bad(msg)
    }
}

/// The model inputs of a loaded trial (angle in rad, normalised envelopes, knee angle from
/// the file or `--knee-angle-deg`).
pub fn trial_inputs(
    loaded: &LoadedTrial,
    args: &ModelSettings,
) -> AppResult<muscle_model::TrialInputs> {
    check_knee_angle(args)?;
    let opts = args
        .knee
        .input_options(args.emg_is_envelope || loaded.emg_is_envelope);
    experiment::model_inputs_named(&loaded.trial, &opts, &loaded.name)
        .map_err(|e| input_error(loaded, e.to_string()))
}

/// A loaded trial prepared once for a job ([`experiment::PreparedTrial`]): the crosstalk test
/// `crosstalk`, the model inputs and, with an unloaded run (`unloaded`, its name for errors),
/// the dynamometer correction. Errors name the trial's file, and the unloaded run's when it is
/// the one at fault.
pub fn prepare_trial(
    loaded: &LoadedTrial,
    unloaded: Option<(&experiment::Unloaded, &str)>,
    args: &ModelSettings,
    crosstalk: &experiment::CrosstalkSettings,
) -> AppResult<experiment::PreparedTrial> {
    check_knee_angle(args)?;
    let opts = args
        .knee
        .input_options(args.emg_is_envelope || loaded.emg_is_envelope);
    experiment::PreparedTrial::prepare(
        &loaded.trial,
        unloaded.map(|(u, _)| u),
        &opts,
        crosstalk,
        &loaded.name,
    )
    .map_err(|e| match (e.path(), unloaded) {
        (Some(_), _) => input_error(loaded, e.to_string()),
        (None, Some((_, n))) => input_error(loaded, format!("{} / {n}: {e}", loaded.name)),
        (None, None) => input_error(loaded, format!("{}: {e}", loaded.name)),
    })
}
