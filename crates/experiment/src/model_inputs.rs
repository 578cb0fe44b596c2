//! The one bridge from a trial file to the model's inputs: degrees → radians, raw EMG → envelopes (docs/model.md, section 1).
//!
//! Every consumer (CLI `simulate` / `identify` / `diagnose`, `cargo xtask gen-fixtures`, the
//! tests) turns a [`Trial`] into [`muscle_model::TrialInputs`] through [`model_inputs`], so
//! that a fixture's "true" torque is computed from exactly what a user's program reads:
//!
//! * angle: `q = ankle_angle_deg · π/180` (rad, dorsiflexion > 0);
//! * each EMG channel (`emg_sol`, `emg_gm`, `emg_gl`, and `emg_ta` and every further
//!   `emg_<name>` when present): band-pass 10–350 Hz zero-phase, `|·|`, low-pass 2 Hz
//!   zero-phase (crate `signal`, [`EnvelopeSettings::default`]), then divided by the channel's
//!   trial maximum or by a user-given MVC reference (sol, gm, gl, ta), and clamped to `[0, 1]`;
//!   a further channel becomes the envelope named `<name>` of the inputs, which drives the
//!   model's fixed muscle of that name;
//! * with [`InputOptions::emg_is_envelope`] the columns are taken as envelopes already: no
//!   filtering, only the optional MVC division and the clamp to `[0, 1]`;
//! * knee flexion: `k = knee_angle_deg · π/180` from the trial's column, or the constant
//!   [`InputOptions::knee_angle_deg`] at every sample when the trial has no column (a trial
//!   with both must agree within [`KNEE_AGREEMENT_DEG`] at every sample); with neither the
//!   inputs carry no knee angle, which the model takes as the extended knee.

use muscle_model::TrialInputs;
use signal::{normalise, EnvelopeFilter, EnvelopeSettings, Normalisation, SignalError};

use crate::emg::EmgMuscle;
use crate::error::{ErrorKind, ExperimentError, Result};
use crate::files::{Trial, EMG_PREFIX};
use crate::protocol::KNEE_RANGE_DEG;

/// How to turn the EMG columns into normalised envelopes. `Default`: raw EMG, every channel
/// normalised by its trial maximum.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct InputOptions {
    /// Per-channel MVC reference (same unit as the envelope of that column), in the order
    /// sol, gm, gl, ta ([`EmgMuscle::ALL`]); `None` normalises by the trial maximum.
    pub mvc: [Option<f64>; 4],
    /// The EMG columns already hold envelopes in `[0, 1]`: skip the filters, just divide by
    /// the MVC reference when one is given and clamp to `[0, 1]`.
    pub emg_is_envelope: bool,
    /// Constant knee flexion (degrees; 0 extended, > 0 flexed) of a trial recorded without a
    /// `knee_angle_deg` column; within [`KNEE_RANGE_DEG`].
    pub knee_angle_deg: Option<f64>,
}

/// How far a trial's knee-angle column may be from a constant knee angle given with it
/// (degrees): a column that holds the same constant, written with fewer digits, agrees.
pub const KNEE_AGREEMENT_DEG: f64 = 1e-6;

impl InputOptions {
    /// The MVC reference of one channel, if any.
    #[must_use]
    pub fn mvc_of(&self, m: EmgMuscle) -> Option<f64> {
        self.mvc[m as usize]
    }

    /// The same options with an MVC reference for one channel.
    #[must_use]
    pub fn with_mvc(mut self, m: EmgMuscle, mvc: f64) -> Self {
        self.mvc[m as usize] = Some(mvc);
        self
    }

    /// The same options with a constant knee angle (degrees) for a trial without a knee column.
    #[must_use]
    pub fn with_knee_angle_deg(mut self, deg: f64) -> Self {
        self.knee_angle_deg = Some(deg);
        self
    }
}

/// A column of the trial as errors name it: the file, its 1-based index in the canonical
/// (written) column order and its name.
struct ColumnRef<'a> {
    path: &'a str,
    column: usize,
    name: String,
}

impl ColumnRef<'_> {
    fn error(&self, kind: ErrorKind, reason: String) -> ExperimentError {
        ExperimentError::Column {
            path: self.path.to_string(),
            column: self.column,
            name: self.name.clone(),
            kind,
            reason,
        }
    }

    fn signal_error(&self, e: &SignalError) -> ExperimentError {
        let kind = match e {
            SignalError::NonPositiveMaximum { .. } => ErrorKind::ZeroChannel,
            SignalError::SignalTooShort { .. } => ErrorKind::TooShort,
            SignalError::NonFiniteSample { .. } => ErrorKind::NotFinite,
            _ => ErrorKind::InvalidSettings,
        };
        self.error(kind, format!("cannot make the EMG envelope: {e}"))
    }
}

/// One channel → its envelope before normalisation (the filters, or the column itself when
/// it already holds an envelope), after the checks every channel gets.
fn raw_envelope(
    raw: &[f64],
    col: &ColumnRef<'_>,
    filter: Option<&EnvelopeFilter>,
) -> Result<Vec<f64>> {
    if let Some(i) = raw.iter().position(|x| !x.is_finite()) {
        return Err(col.error(
            ErrorKind::NotFinite,
            format!("sample {i} is not a finite number"),
        ));
    }
    if raw.iter().all(|&x| x == 0.0) {
        return Err(col.error(
            ErrorKind::ZeroChannel,
            "EMG channel is all zeros (disconnected electrode?)".into(),
        ));
    }
    match filter {
        Some(f) => {
            let env = f.envelope(raw).map_err(|e| col.signal_error(&e))?;
            // A constant (DC-only) or slowly drifting channel has nothing in the
            // 10–350 Hz band: normalising its numerical noise would fake activity.
            let raw_amp = raw.iter().fold(0.0f64, |a, x| a.max(x.abs()));
            let env_max = env.iter().fold(0.0f64, |a, x| a.max(*x));
            if env_max.is_nan() || env_max <= 1e-9 * raw_amp {
                return Err(col.error(
                    ErrorKind::ZeroChannel,
                    "no EMG activity in the 10–350 Hz band (a constant or drifting channel?)"
                        .into(),
                ));
            }
            Ok(env)
        }
        None => Ok(raw.to_vec()),
    }
}

/// One channel → normalised envelope; `mvc` its reference (an MVC value or the session's
/// largest envelope), if any, else the trial maximum.
fn channel_envelope(
    raw: &[f64],
    col: &ColumnRef<'_>,
    mvc: Option<f64>,
    filter: Option<&EnvelopeFilter>,
) -> Result<Vec<f64>> {
    let mut env = raw_envelope(raw, col, filter)?;
    if filter.is_some() {
        let reference = mvc.map_or(Normalisation::TrialMax, Normalisation::Mvc);
        normalise(&mut env, reference).map_err(|e| col.signal_error(&e))?;
        return Ok(env);
    }
    match mvc {
        Some(v) => {
            normalise(&mut env, Normalisation::Mvc(v)).map_err(|e| col.signal_error(&e))?;
        }
        None => env.iter_mut().for_each(|x| *x = x.clamp(0.0, 1.0)),
    }
    if env.iter().all(|&x| x == 0.0) {
        return Err(col.error(
            ErrorKind::ZeroChannel,
            "envelope is zero everywhere after clamping to [0, 1]".into(),
        ));
    }
    Ok(env)
}

/// Normalisation references of EMG channels by name (`sol`, `gm`, `gl`, `ta`, or a further
/// channel's `<name>`): the value each channel's envelope is divided by.
///
/// A session normalises every trial's channel by one reference, so that a weaker trial stays
/// weaker: the largest envelope of that channel over the session's MVC trials when it has
/// them, else over all its trials ([`EmgReferences::largest`] of [`envelope_peaks`]). Per-trial
/// normalisation would scale every trial's peak to 1 and erase, for instance, the lower
/// gastrocnemius drive of a flexed knee.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct EmgReferences {
    by_channel: std::collections::BTreeMap<String, f64>,
}

impl EmgReferences {
    /// The reference of one channel, if any.
    #[must_use]
    pub fn get(&self, channel: &str) -> Option<f64> {
        self.by_channel.get(channel).copied()
    }

    /// Sets one channel's reference.
    pub fn set(&mut self, channel: &str, value: f64) {
        self.by_channel.insert(channel.to_string(), value);
    }

    /// The channels and their references, by name.
    pub fn iter(&self) -> impl Iterator<Item = (&str, f64)> {
        self.by_channel.iter().map(|(k, v)| (k.as_str(), *v))
    }

    /// True when no channel has a reference.
    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.by_channel.is_empty()
    }

    /// Per channel, the largest reference over `sets` (a channel present in any set).
    #[must_use]
    pub fn largest<'a>(sets: impl IntoIterator<Item = &'a EmgReferences>) -> Self {
        let mut out = Self::default();
        for s in sets {
            for (k, v) in s.iter() {
                let e = out.by_channel.entry(k.to_string()).or_insert(v);
                if v > *e {
                    *e = v;
                }
            }
        }
        out
    }
}

/// The largest envelope of each of the trial's EMG channels before normalisation (the value
/// [`model_inputs`] divides by without a reference). With
/// [`InputOptions::emg_is_envelope`] the columns' own maxima.
///
/// # Errors
/// As [`model_inputs`] for the EMG columns.
pub fn envelope_peaks(trial: &Trial, opts: &InputOptions, path: &str) -> Result<EmgReferences> {
    let filter = envelope_filter(trial, opts, path)?;
    let mut out = EmgReferences::default();
    for (col, raw) in emg_columns(trial, path) {
        let env = raw_envelope(raw, &col, filter.as_ref())?;
        let max = env.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        let name = col.name.strip_prefix(EMG_PREFIX).unwrap_or(&col.name);
        out.set(name, max);
    }
    Ok(out)
}

/// The EMG filter of a trial (none when the columns hold envelopes).
fn envelope_filter(
    trial: &Trial,
    opts: &InputOptions,
    path: &str,
) -> Result<Option<EnvelopeFilter>> {
    let n = trial.len();
    if n < 2 {
        return Err(ExperimentError::File {
            path: path.to_string(),
            kind: ErrorKind::TooShort,
            reason: format!("{n} samples: at least 2 are needed"),
        });
    }
    if opts.emg_is_envelope {
        return Ok(None);
    }
    let fs = trial.sample_rate_hz();
    EnvelopeFilter::new(fs, &EnvelopeSettings::default())
        .map(Some)
        .map_err(|e| ExperimentError::File {
            path: path.to_string(),
            kind: ErrorKind::InvalidSettings,
            reason: format!("cannot design the EMG filters at {fs} Hz: {e}"),
        })
}

/// The trial's EMG columns with the names and 1-based indices errors use (the canonical
/// column order: `emg_sol` 4, `emg_gm` 5, `emg_gl` 6, `emg_ta` 7, then the further channels).
fn emg_columns<'a>(trial: &'a Trial, path: &'a str) -> Vec<(ColumnRef<'a>, &'a [f64])> {
    let mut out = Vec::with_capacity(4 + trial.emg_other.len());
    for (m, raw) in [
        (EmgMuscle::Sol, &trial.emg_sol),
        (EmgMuscle::Gm, &trial.emg_gm),
        (EmgMuscle::Gl, &trial.emg_gl),
    ] {
        out.push((muscle_column(m, path), raw.as_slice()));
    }
    if let Some(raw) = &trial.emg_ta {
        out.push((muscle_column(EmgMuscle::Ta, path), raw.as_slice()));
    }
    let ta_cols = usize::from(trial.emg_ta.is_some());
    for (i, (name, raw)) in trial.emg_other.iter().enumerate() {
        out.push((
            ColumnRef {
                path,
                column: 7 + ta_cols + i,
                name: format!("{EMG_PREFIX}{name}"),
            },
            raw.as_slice(),
        ));
    }
    out
}

fn muscle_column(m: EmgMuscle, path: &str) -> ColumnRef<'_> {
    ColumnRef {
        path,
        column: match m {
            EmgMuscle::Sol => 4,
            EmgMuscle::Gm => 5,
            EmgMuscle::Gl => 6,
            EmgMuscle::Ta => 7,
        },
        name: m.column().to_string(),
    }
}

/// Turns a trial into model inputs (see the module documentation). Errors name the trial as
/// `<trial>`; use [`model_inputs_named`] to name the file.
///
/// # Errors
/// A trial with fewer than 2 samples or non-uniform time; an EMG column that is all zeros
/// ([`ErrorKind::ZeroChannel`]), too short for the zero-phase filters ([`ErrorKind::TooShort`])
/// or not finite, each as an [`ExperimentError::Column`] naming the column; an invalid MVC; a
/// constant knee angle outside [`KNEE_RANGE_DEG`], or one that disagrees with the trial's
/// knee-angle column ([`ErrorKind::Conflict`]).
pub fn model_inputs(trial: &Trial, opts: &InputOptions) -> Result<TrialInputs> {
    model_inputs_named(trial, opts, "<trial>")
}

/// [`model_inputs`] with the file name used in error messages. Column indices in errors are
/// those of the canonical column order (`emg_sol` 4, `emg_gm` 5, `emg_gl` 6, `emg_ta` 7, then
/// the further EMG channels and `knee_angle_deg`).
///
/// # Errors
/// As [`model_inputs`].
pub fn model_inputs_named(trial: &Trial, opts: &InputOptions, path: &str) -> Result<TrialInputs> {
    model_inputs_referenced(trial, opts, &EmgReferences::default(), path)
}

/// [`model_inputs_named`] with normalisation references: a channel with a reference in
/// `refs` is divided by it (in place of its MVC option or its trial maximum), then clamped to
/// `[0, 1]`. A reference equal to the trial's own maximum gives exactly [`model_inputs`]'s
/// envelopes.
///
/// # Errors
/// As [`model_inputs`]; a reference that is not finite and > 0.
pub fn model_inputs_referenced(
    trial: &Trial,
    opts: &InputOptions,
    refs: &EmgReferences,
    path: &str,
) -> Result<TrialInputs> {
    let filter = envelope_filter(trial, opts, path)?;
    let fs = trial.sample_rate_hz();
    let mut env: [Vec<f64>; 3] = Default::default();
    let mut env_ta = None;
    let mut others = Vec::with_capacity(trial.emg_other.len());
    for (i, (col, raw)) in emg_columns(trial, path).into_iter().enumerate() {
        let name = col
            .name
            .strip_prefix(EMG_PREFIX)
            .unwrap_or(&col.name)
            .to_string();
        let muscle = EmgMuscle::ALL
            .iter()
            .copied()
            .find(|m| m.column() == col.name);
        let reference = refs
            .get(&name)
            .or_else(|| muscle.and_then(|m| opts.mvc_of(m)));
        let e = channel_envelope(raw, &col, reference, filter.as_ref())?;
        match (i, muscle) {
            (0..=2, _) => env[i] = e,
            (_, Some(EmgMuscle::Ta)) => env_ta = Some(e),
            _ => others.push((name, e)),
        }
    }
    let ta_cols = usize::from(trial.emg_ta.is_some());
    let knee_col = ColumnRef {
        path,
        column: 7 + ta_cols + trial.emg_other.len(),
        name: "knee_angle_deg".into(),
    };
    let knee = knee_angle_rad(trial, opts, &knee_col)?;
    let angle: Vec<f64> = trial
        .ankle_angle_deg
        .iter()
        .map(|d| d.to_radians())
        .collect();
    let invalid = |e: muscle_model::ModelError| ExperimentError::File {
        path: path.to_string(),
        kind: ErrorKind::InvalidSettings,
        reason: format!("invalid model inputs: {e}"),
    };
    let mut inputs = TrialInputs::new(fs, trial.time_s[0], angle, env, env_ta).map_err(invalid)?;
    for (name, env) in others {
        inputs = inputs.with_envelope(&name, env).map_err(invalid)?;
    }
    if let Some(k) = knee {
        inputs = inputs.with_knee_angle(k).map_err(invalid)?;
    }
    Ok(inputs)
}

/// The knee flexion of the inputs (rad): the trial's column, else the constant of the options,
/// else none (the extended knee).
fn knee_angle_rad(
    trial: &Trial,
    opts: &InputOptions,
    col: &ColumnRef<'_>,
) -> Result<Option<Vec<f64>>> {
    let (lo, hi) = KNEE_RANGE_DEG;
    if let Some(c) = opts.knee_angle_deg {
        if !(c.is_finite() && (lo..=hi).contains(&c)) {
            return Err(ExperimentError::invalid(
                "constant knee angle",
                ErrorKind::InvalidSettings,
                format!("{c}° is outside the knee's range [{lo}, {hi}] degrees"),
            ));
        }
    }
    match (&trial.knee_angle_deg, opts.knee_angle_deg) {
        (Some(column), Some(c)) => {
            if let Some((i, k)) = column
                .iter()
                .enumerate()
                .find(|(_, k)| (*k - c).abs() > KNEE_AGREEMENT_DEG)
            {
                return Err(col.error(
                    ErrorKind::Conflict,
                    format!(
                        "the trial's knee angle ({k}° at sample {i}) differs from the constant \
                         knee angle {c}° given with it; give one or the other"
                    ),
                ));
            }
            Ok(Some(column.iter().map(|d| d.to_radians()).collect()))
        }
        (Some(column), None) => Ok(Some(column.iter().map(|d| d.to_radians()).collect())),
        (None, Some(c)) => Ok(Some(vec![c.to_radians(); trial.len()])),
        (None, None) => Ok(None),
    }
}
