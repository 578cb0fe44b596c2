//! The one bridge from a trial file to the model's inputs: degrees → radians, raw EMG → envelopes (docs/model.md, section 1).
//!
//! Every consumer (CLI `simulate` / `identify` / `diagnose`, `cargo xtask gen-fixtures`, the
//! tests) turns a [`Trial`] into [`muscle_model::TrialInputs`] through [`model_inputs`], so
//! that a fixture's "true" torque is computed from exactly what a user's program reads:
//!
//! * angle: `q = ankle_angle_deg · π/180` (rad, dorsiflexion > 0);
//! * each EMG channel (`emg_sol`, `emg_gm`, `emg_gl`, and `emg_ta` when present): band-pass
//!   10–350 Hz zero-phase, `|·|`, low-pass 2 Hz zero-phase (crate `signal`,
//!   [`EnvelopeSettings::default`]), then divided by the channel's trial maximum or by a
//!   user-given MVC reference, and clamped to `[0, 1]`;
//! * with [`InputOptions::emg_is_envelope`] the columns are taken as envelopes already: no
//!   filtering, only the optional MVC division and the clamp to `[0, 1]`.

use muscle_model::TrialInputs;
use signal::{normalise, EnvelopeFilter, EnvelopeSettings, Normalisation, SignalError};

use crate::emg::EmgMuscle;
use crate::error::{ErrorKind, ExperimentError, Result};
use crate::files::Trial;

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
}

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
}

/// 1-based index of an EMG column in the canonical (written) column order.
fn canonical_column(m: EmgMuscle) -> usize {
    match m {
        EmgMuscle::Sol => 4,
        EmgMuscle::Gm => 5,
        EmgMuscle::Gl => 6,
        EmgMuscle::Ta => 7,
    }
}

fn column_error(path: &str, m: EmgMuscle, kind: ErrorKind, reason: String) -> ExperimentError {
    ExperimentError::Column {
        path: path.to_string(),
        column: canonical_column(m),
        name: m.column().to_string(),
        kind,
        reason,
    }
}

fn signal_error(path: &str, m: EmgMuscle, e: &SignalError) -> ExperimentError {
    let kind = match e {
        SignalError::NonPositiveMaximum { .. } => ErrorKind::ZeroChannel,
        SignalError::SignalTooShort { .. } => ErrorKind::TooShort,
        SignalError::NonFiniteSample { .. } => ErrorKind::NotFinite,
        _ => ErrorKind::InvalidSettings,
    };
    column_error(path, m, kind, format!("cannot make the EMG envelope: {e}"))
}

/// One channel → normalised envelope.
fn channel_envelope(
    raw: &[f64],
    m: EmgMuscle,
    filter: Option<&EnvelopeFilter>,
    opts: &InputOptions,
    path: &str,
) -> Result<Vec<f64>> {
    if let Some(i) = raw.iter().position(|x| !x.is_finite()) {
        return Err(column_error(
            path,
            m,
            ErrorKind::NotFinite,
            format!("sample {i} is not a finite number"),
        ));
    }
    if raw.iter().all(|&x| x == 0.0) {
        return Err(column_error(
            path,
            m,
            ErrorKind::ZeroChannel,
            "EMG channel is all zeros (disconnected electrode?)".into(),
        ));
    }
    let mvc = opts.mvc_of(m);
    match filter {
        Some(f) => {
            let mut env = f.envelope(raw).map_err(|e| signal_error(path, m, &e))?;
            // A constant (DC-only) or slowly drifting channel has nothing in the
            // 10–350 Hz band: normalising its numerical noise would fake activity.
            let raw_amp = raw.iter().fold(0.0f64, |a, x| a.max(x.abs()));
            let env_max = env.iter().fold(0.0f64, |a, x| a.max(*x));
            if env_max.is_nan() || env_max <= 1e-9 * raw_amp {
                return Err(column_error(
                    path,
                    m,
                    ErrorKind::ZeroChannel,
                    "no EMG activity in the 10–350 Hz band (a constant or drifting channel?)"
                        .into(),
                ));
            }
            let reference = mvc.map_or(Normalisation::TrialMax, Normalisation::Mvc);
            normalise(&mut env, reference).map_err(|e| signal_error(path, m, &e))?;
            Ok(env)
        }
        None => {
            let mut env = raw.to_vec();
            match mvc {
                Some(v) => normalise(&mut env, Normalisation::Mvc(v))
                    .map_err(|e| signal_error(path, m, &e))?,
                None => env.iter_mut().for_each(|x| *x = x.clamp(0.0, 1.0)),
            }
            if env.iter().all(|&x| x == 0.0) {
                return Err(column_error(
                    path,
                    m,
                    ErrorKind::ZeroChannel,
                    "envelope is zero everywhere after clamping to [0, 1]".into(),
                ));
            }
            Ok(env)
        }
    }
}

/// Turns a trial into model inputs (see the module documentation). Errors name the trial as
/// `<trial>`; use [`model_inputs_named`] to name the file.
///
/// # Errors
/// A trial with fewer than 2 samples or non-uniform time; an EMG column that is all zeros
/// ([`ErrorKind::ZeroChannel`]), too short for the zero-phase filters ([`ErrorKind::TooShort`])
/// or not finite, each as an [`ExperimentError::Column`] naming the column; an invalid MVC.
pub fn model_inputs(trial: &Trial, opts: &InputOptions) -> Result<TrialInputs> {
    model_inputs_named(trial, opts, "<trial>")
}

/// [`model_inputs`] with the file name used in error messages. Column indices in errors are
/// those of the canonical column order (`emg_sol` 4, `emg_gm` 5, `emg_gl` 6, `emg_ta` 7).
///
/// # Errors
/// As [`model_inputs`].
pub fn model_inputs_named(trial: &Trial, opts: &InputOptions, path: &str) -> Result<TrialInputs> {
    let n = trial.len();
    if n < 2 {
        return Err(ExperimentError::File {
            path: path.to_string(),
            kind: ErrorKind::TooShort,
            reason: format!("{n} samples: at least 2 are needed"),
        });
    }
    let fs = trial.sample_rate_hz();
    let filter = if opts.emg_is_envelope {
        None
    } else {
        Some(
            EnvelopeFilter::new(fs, &EnvelopeSettings::default()).map_err(|e| {
                ExperimentError::File {
                    path: path.to_string(),
                    kind: ErrorKind::InvalidSettings,
                    reason: format!("cannot design the EMG filters at {fs} Hz: {e}"),
                }
            })?,
        )
    };
    let mut env: [Vec<f64>; 3] = Default::default();
    for (slot, (m, raw)) in env.iter_mut().zip([
        (EmgMuscle::Sol, &trial.emg_sol),
        (EmgMuscle::Gm, &trial.emg_gm),
        (EmgMuscle::Gl, &trial.emg_gl),
    ]) {
        *slot = channel_envelope(raw, m, filter.as_ref(), opts, path)?;
    }
    let env_ta = match &trial.emg_ta {
        Some(raw) => Some(channel_envelope(
            raw,
            EmgMuscle::Ta,
            filter.as_ref(),
            opts,
            path,
        )?),
        None => None,
    };
    let angle: Vec<f64> = trial
        .ankle_angle_deg
        .iter()
        .map(|d| d.to_radians())
        .collect();
    TrialInputs::new(fs, trial.time_s[0], angle, env, env_ta).map_err(|e| ExperimentError::File {
        path: path.to_string(),
        kind: ErrorKind::InvalidSettings,
        reason: format!("invalid model inputs: {e}"),
    })
}
