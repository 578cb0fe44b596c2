//! The session manifest: a JSON file naming the trials of one subject that share one set of
//! muscle parameters (`docs/formats.md`, "Session manifest").
//!
//! ```json
//! {"subject": "S01",
//!  "params": "model.json",
//!  "trials": [
//!    {"name": "knee0_30", "trial": "iso30_knee0.csv", "unloaded": "unloaded30.csv"},
//!    {"name": "knee90_30", "trial": "iso30_knee90.csv", "knee_angle_deg": 90},
//!    {"name": "walk", "recording": "walk_ceinms_folder"}]}
//! ```
//!
//! A trial CSV may name OpenSim MuscleAnalysis results for its geometry:
//! `"geometry": {"lengths": "S01_MuscleAnalysis_Length.sto", "moment_arms":
//! "S01_MuscleAnalysis_MomentArm_ankle_angle_r.sto"}`.
//!
//! A trial may carry a `condition` label (`"condition": "walk_3.6kmh"`): `surae validate`
//! leaves one condition out at a time.
//!
//! Optional keys: `osim_muscles` (names of sol, gm, gl in an `.osim`), `mvc`,
//! `emg_normalisation` (`"session"`, the default, or `"trial"`), `effects` (an
//! effects JSON every trial's model carries), `free` (the parameters identified, e.g.
//! `["sol.lst_m", "activation.shape_a"]`) and `bounds` (`{"sol.fom_n": [2000, 8000]}`).
//!
//! Paths are relative to the manifest's folder, never to the working directory. Every key is
//! checked: an unknown key, a trial with both or neither of `trial` and `recording`, two
//! trials of the same name or a knee angle outside [0°, 150°] is an error naming the key.

use crate::SessionError;
use serde::Deserialize;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// Largest accepted constant knee flexion (degrees).
pub const MAX_KNEE_ANGLE_DEG: f64 = 150.0;

/// A parsed session manifest with its paths resolved against the manifest's folder.
#[derive(Clone, Debug, PartialEq)]
pub struct SessionManifest {
    /// The manifest file itself.
    pub path: PathBuf,
    /// The subject's name, if given.
    pub subject: Option<String>,
    /// The model parameters: a parameters JSON, an OpenSim `.osim` model or a CEINMS subject
    /// XML; nominal parameters when absent.
    pub params: Option<PathBuf>,
    /// Names of sol, gm and gl in an `.osim` model when they are not gait2392's.
    pub osim_muscles: BTreeMap<String, String>,
    /// Maximal voluntary contraction trials (EMG normalisation).
    pub mvc: Vec<PathBuf>,
    /// Whether each EMG channel has one reference for the whole session or is divided by its
    /// own peak in every trial.
    pub emg_normalisation: EmgNormalisationScope,
    /// The effects JSON whose effects every trial's model carries, if given.
    pub effects: Option<PathBuf>,
    /// The parameters identified (`sol.lst_m`, `activation.shape_a`, …); the 9 of LST, F0 and
    /// α0 of sol, gm and gl when absent.
    pub free: Option<Vec<String>>,
    /// Bounds `[lower, upper]` of free parameters, by name, replacing their defaults.
    pub bounds: BTreeMap<String, (f64, f64)>,
    /// The trials, in the manifest's order.
    pub trials: Vec<SessionTrialEntry>,
    /// Strides the recording checks flag (an implausible inverse-dynamics moment against the
    /// other strides and the foot's ground force) are weighted 0 in every fit and score of the
    /// session (`exclude_flagged_strides`, default false: they are flagged but fitted).
    pub exclude_flagged_strides: bool,
}

impl SessionManifest {
    /// A session of one recording that needs no manifest (a CEINMS trial folder given as
    /// `--trial`): the folder's name is the trial's; nominal parameters, default free
    /// parameters.
    #[must_use]
    pub fn of_recording(path: &Path) -> Self {
        let name = path.file_name().map_or_else(
            || "recording".to_string(),
            |n| n.to_string_lossy().into_owned(),
        );
        Self {
            path: path.to_path_buf(),
            subject: None,
            params: None,
            osim_muscles: BTreeMap::new(),
            mvc: Vec::new(),
            emg_normalisation: EmgNormalisationScope::Session,
            effects: None,
            free: None,
            bounds: BTreeMap::new(),
            exclude_flagged_strides: false,
            trials: vec![SessionTrialEntry {
                name,
                source: TrialSource::Recording(path.to_path_buf()),
                unloaded: None,
                knee_angle_deg: None,
                condition: None,
                geometry: None,
            }],
        }
    }
}

/// How a session's EMG channels are normalised (`emg_normalisation`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum EmgNormalisationScope {
    /// One reference per channel for all the trials (the MVC trials' peak, or the largest
    /// envelope over the session), so that a weaker trial stays weaker.
    #[default]
    Session,
    /// Every trial's channel divided by its own peak over that trial, so that each reaches 1:
    /// what a trial alone gets. Chosen when the EMG-to-moment gain differs between trials
    /// (electrodes re-placed, a trial of another speed); `surae validate` on both manifests
    /// says which predicts held-out trials better.
    Trial,
}

/// One trial of a session.
#[derive(Clone, Debug, PartialEq)]
pub struct SessionTrialEntry {
    /// The trial's name (unique in the session).
    pub name: String,
    /// Where its data are.
    pub source: TrialSource,
    /// Its unloaded run, if recorded.
    pub unloaded: Option<PathBuf>,
    /// A constant knee flexion (degrees) for a trial file without a `knee_angle_deg` column.
    pub knee_angle_deg: Option<f64>,
    /// The subject's own musculotendon lengths and moment arms for a trial CSV (OpenSim
    /// MuscleAnalysis storage files), if given.
    pub geometry: Option<GeometryFiles>,
    /// The condition the trial was recorded in (e.g. `walk_3.6kmh`, `knee90`): `surae
    /// validate` leaves one condition out at a time.
    pub condition: Option<String>,
}

/// OpenSim MuscleAnalysis results of a trial: musculotendon lengths (`*_Length.sto`) and ankle
/// moment arms (`*_MomentArm_ankle_angle_r.sto`), one column per muscle, on their own clock.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct GeometryFiles {
    /// The lengths file.
    pub lengths: PathBuf,
    /// The moment-arms file.
    pub moment_arms: PathBuf,
}

/// Where a trial's data are.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum TrialSource {
    /// A trial CSV (`docs/formats.md`).
    Csv(PathBuf),
    /// A recording in another format: a CEINMS trial folder, or a recording map (`.json`) of a
    /// lab's files.
    Recording(PathBuf),
}

impl TrialSource {
    /// The path, whatever the kind.
    pub fn path(&self) -> &Path {
        match self {
            TrialSource::Csv(p) | TrialSource::Recording(p) => p,
        }
    }
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawManifest {
    subject: Option<String>,
    params: Option<String>,
    #[serde(default)]
    osim_muscles: BTreeMap<String, String>,
    #[serde(default)]
    mvc: Vec<String>,
    /// Taken as any JSON value so that a wrong one is refused naming its key.
    emg_normalisation: Option<serde_json::Value>,
    effects: Option<String>,
    free: Option<Vec<String>>,
    #[serde(default)]
    bounds: BTreeMap<String, (f64, f64)>,
    trials: Vec<RawTrial>,
    #[serde(default)]
    exclude_flagged_strides: bool,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawTrial {
    name: String,
    trial: Option<String>,
    recording: Option<String>,
    unloaded: Option<String>,
    knee_angle_deg: Option<f64>,
    geometry: Option<RawGeometry>,
    /// Taken as any JSON value so a label that is not a string is refused naming its key and
    /// trial, not only a line and column.
    condition: Option<serde_json::Value>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawGeometry {
    lengths: String,
    moment_arms: String,
}

/// Reads and checks a session manifest.
///
/// # Errors
/// An unreadable file, invalid JSON or an unknown key (with line and column), or an
/// unacceptable value naming its key.
pub fn read_session_manifest(path: &Path) -> Result<SessionManifest, SessionError> {
    let text = std::fs::read_to_string(path).map_err(|e| SessionError::Io {
        path: path.display().to_string(),
        reason: e.to_string(),
    })?;
    parse_session_manifest(&text, path)
}

/// Parses manifest `text` as if read from `path` (paths resolve against its folder).
///
/// # Errors
/// As [`read_session_manifest`].
pub fn parse_session_manifest(text: &str, path: &Path) -> Result<SessionManifest, SessionError> {
    let name = path.display().to_string();
    let raw: RawManifest = serde_json::from_str(text).map_err(|e| SessionError::Syntax {
        path: name.clone(),
        line: e.line(),
        column: e.column(),
        reason: e
            .to_string()
            .split(" at line ")
            .next()
            .unwrap_or("")
            .to_string(),
    })?;
    let invalid = |key: String, reason: String| SessionError::Invalid {
        path: name.clone(),
        key,
        reason,
    };
    let dir = path.parent().unwrap_or(Path::new(""));
    let resolve = |p: &str| dir.join(p);
    if raw.trials.is_empty() {
        return Err(invalid("trials".into(), "lists no trial".into()));
    }
    for (k, v) in &raw.osim_muscles {
        if !matches!(k.as_str(), "sol" | "gm" | "gl") {
            return Err(invalid(
                format!("osim_muscles.{k}"),
                "only sol, gm and gl are renamed".into(),
            ));
        }
        if v.is_empty() {
            return Err(invalid(format!("osim_muscles.{k}"), "is empty".into()));
        }
    }
    let emg_normalisation = match &raw.emg_normalisation {
        None => EmgNormalisationScope::Session,
        Some(serde_json::Value::String(v)) if v == "session" => EmgNormalisationScope::Session,
        Some(serde_json::Value::String(v)) if v == "trial" => EmgNormalisationScope::Trial,
        Some(v) => {
            return Err(invalid(
                "emg_normalisation".into(),
                format!("{v} is neither \"session\" nor \"trial\""),
            ))
        }
    };
    if emg_normalisation == EmgNormalisationScope::Trial && !raw.mvc.is_empty() {
        return Err(invalid(
            "emg_normalisation".into(),
            "\"trial\" divides each trial by its own peak, so the mvc trials would go unused: \
             give one or the other"
                .into(),
        ));
    }
    if let Some(free) = &raw.free {
        if free.is_empty() {
            return Err(invalid("free".into(), "lists no parameter".into()));
        }
        for (i, f) in free.iter().enumerate() {
            muscle_model::ParamId::parse(f)
                .map_err(|e| invalid(format!("free[{i}]"), e.to_string()))?;
            if free[..i].contains(f) {
                return Err(invalid(
                    format!("free[{i}]"),
                    format!("{f} is listed twice"),
                ));
            }
        }
    }
    for (k, &(lo, hi)) in &raw.bounds {
        muscle_model::ParamId::parse(k)
            .map_err(|e| invalid(format!("bounds.{k}"), e.to_string()))?;
        if !(lo.is_finite() && hi.is_finite() && lo < hi) {
            return Err(invalid(
                format!("bounds.{k}"),
                format!("[{lo}, {hi}] is not an interval (lower < upper)"),
            ));
        }
    }
    let mut trials = Vec::with_capacity(raw.trials.len());
    for (i, t) in raw.trials.into_iter().enumerate() {
        let key = |k: &str| format!("trials[{i}].{k}");
        if t.name.trim().is_empty() {
            return Err(invalid(key("name"), "is empty".into()));
        }
        if trials.iter().any(|o: &SessionTrialEntry| o.name == t.name) {
            return Err(invalid(key("name"), format!("{} names two trials", t.name)));
        }
        let source = match (t.trial, t.recording) {
            (Some(p), None) => TrialSource::Csv(resolve(&p)),
            (None, Some(p)) => TrialSource::Recording(resolve(&p)),
            (Some(_), Some(_)) => {
                return Err(invalid(
                    key("trial"),
                    "give either trial or recording, not both".into(),
                ))
            }
            (None, None) => {
                return Err(invalid(
                    key("trial"),
                    "missing: give a trial CSV (trial) or a recording (recording)".into(),
                ))
            }
        };
        if let Some(k) = t.knee_angle_deg {
            if !(k.is_finite() && (0.0..=MAX_KNEE_ANGLE_DEG).contains(&k)) {
                return Err(invalid(
                    key("knee_angle_deg"),
                    format!("{k}° is outside [0°, {MAX_KNEE_ANGLE_DEG}°] (0 = extended)"),
                ));
            }
        }
        if t.geometry.is_some() && matches!(source, TrialSource::Recording(_)) {
            return Err(invalid(
                key("geometry"),
                "a recording carries its own lengths and moment arms".into(),
            ));
        }
        let condition = match t.condition {
            None => None,
            Some(serde_json::Value::String(c)) if c.trim().is_empty() => {
                return Err(invalid(
                    key("condition"),
                    format!("is empty (trial {}): give a label or leave it out", t.name),
                ));
            }
            Some(serde_json::Value::String(c)) => Some(c),
            Some(v) => {
                return Err(invalid(
                    key("condition"),
                    format!(
                        "{v} is not a text label (trial {}): give a string such as \"walk_3.6kmh\"",
                        t.name
                    ),
                ));
            }
        };
        trials.push(SessionTrialEntry {
            condition,
            name: t.name,
            source,
            unloaded: t.unloaded.as_deref().map(resolve),
            knee_angle_deg: t.knee_angle_deg,
            geometry: t.geometry.map(|g| GeometryFiles {
                lengths: resolve(&g.lengths),
                moment_arms: resolve(&g.moment_arms),
            }),
        });
    }
    Ok(SessionManifest {
        path: path.to_path_buf(),
        subject: raw.subject,
        params: raw.params.as_deref().map(resolve),
        osim_muscles: raw.osim_muscles,
        mvc: raw.mvc.iter().map(|p| resolve(p)).collect(),
        emg_normalisation,
        effects: raw.effects.as_deref().map(resolve),
        free: raw.free,
        bounds: raw.bounds,
        trials,
        exclude_flagged_strides: raw.exclude_flagged_strides,
    })
}
