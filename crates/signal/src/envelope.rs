//! The EMG envelope pipeline: band-pass, rectify, low-pass, normalise (`docs/model.md`,
//! "EMG to envelope").

use crate::design::{butter, Band, Sos};
use crate::error::{check_finite, SignalError};
use crate::filter::{sosfiltfilt_inplace, sosfiltfilt_padlen};

/// Full-wave rectification `x ← |x|`, in place.
pub fn rectify(x: &mut [f64]) {
    for v in x {
        *v = v.abs();
    }
}

/// Filter settings of the envelope pipeline ([`Default`]: band-pass 10–350 Hz, low-pass 2 Hz).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct EnvelopeSettings {
    /// Order passed to `butter` for the band-pass (2 → a 4th-order band-pass).
    pub bandpass_order: usize,
    /// Band-pass edges `[low, high]` in Hz.
    pub bandpass_hz: [f64; 2],
    /// Order of the low-pass Butterworth.
    pub lowpass_order: usize,
    /// Low-pass cutoff in Hz.
    pub lowpass_hz: f64,
}

impl Default for EnvelopeSettings {
    /// `butter(2, [10, 350], 'bandpass')` and `butter(4, 2, 'lowpass')`.
    fn default() -> Self {
        Self {
            bandpass_order: 2,
            bandpass_hz: [10.0, 350.0],
            lowpass_order: 4,
            lowpass_hz: 2.0,
        }
    }
}

/// How to normalise an envelope before clamping to `[0, 1]`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Normalisation {
    /// Divide by the channel's maximum of the envelope over the trial.
    TrialMax,
    /// Divide by a user-given MVC reference (same units as the envelope).
    Mvc(f64),
}

/// The two designed filters of the pipeline for one sampling rate; reusable across
/// channels and trials (design once, filter many).
#[derive(Debug, Clone, PartialEq)]
pub struct EnvelopeFilter {
    fs: f64,
    settings: EnvelopeSettings,
    bandpass: Sos,
    lowpass: Sos,
}

impl EnvelopeFilter {
    /// Design the band-pass and low-pass filters for sampling rate `fs` (Hz).
    ///
    /// # Errors
    /// Any design error of [`butter`] (order 0, edges out of range or out of order, bad fs).
    pub fn new(fs: f64, settings: &EnvelopeSettings) -> Result<Self, SignalError> {
        let [lo, hi] = settings.bandpass_hz;
        let bandpass = butter(settings.bandpass_order, Band::Bandpass(lo, hi), fs)?;
        let lowpass = butter(
            settings.lowpass_order,
            Band::Lowpass(settings.lowpass_hz),
            fs,
        )?;
        Ok(Self {
            fs,
            settings: *settings,
            bandpass,
            lowpass,
        })
    }

    /// Sampling rate in Hz.
    pub fn fs(&self) -> f64 {
        self.fs
    }

    /// The settings this filter was designed with.
    pub fn settings(&self) -> &EnvelopeSettings {
        &self.settings
    }

    /// The band-pass sections.
    pub fn bandpass(&self) -> &Sos {
        &self.bandpass
    }

    /// The low-pass sections.
    pub fn lowpass(&self) -> &Sos {
        &self.lowpass
    }

    /// Minimum number of samples a raw signal needs (`len > padlen` for both filters).
    pub fn min_len(&self) -> usize {
        sosfiltfilt_padlen(&self.bandpass).max(sosfiltfilt_padlen(&self.lowpass)) + 1
    }

    /// Raw EMG → envelope into the caller's buffer `out` (same length as `raw`),
    /// reusing `scratch` for padding: `sosfiltfilt(bp)`, `|·|`, `sosfiltfilt(lp)`.
    ///
    /// # Errors
    /// [`SignalError::NonFiniteSample`], [`SignalError::SignalTooShort`],
    /// [`SignalError::LengthMismatch`] if `out.len() != raw.len()`.
    pub fn envelope_into(
        &self,
        raw: &[f64],
        out: &mut [f64],
        scratch: &mut Vec<f64>,
    ) -> Result<(), SignalError> {
        check_finite(raw)?;
        let need = self.min_len() - 1;
        if raw.len() <= need {
            return Err(SignalError::SignalTooShort {
                len: raw.len(),
                padlen: need,
            });
        }
        if out.len() != raw.len() {
            return Err(SignalError::LengthMismatch {
                what: "output buffer",
                expected: raw.len(),
                got: out.len(),
            });
        }
        out.copy_from_slice(raw);
        sosfiltfilt_inplace(&self.bandpass, out, scratch)?;
        rectify(out);
        sosfiltfilt_inplace(&self.lowpass, out, scratch)
    }

    /// Raw EMG → (un-normalised) envelope. See [`EnvelopeFilter::envelope_into`].
    ///
    /// # Errors
    /// As [`EnvelopeFilter::envelope_into`].
    pub fn envelope(&self, raw: &[f64]) -> Result<Vec<f64>, SignalError> {
        let mut out = vec![0.0; raw.len()];
        let mut scratch = Vec::with_capacity(raw.len() + 2 * self.min_len());
        self.envelope_into(raw, &mut out, &mut scratch)?;
        Ok(out)
    }
}

/// Raw EMG sampled at `fs` Hz → envelope (band-pass zero-phase, rectify, low-pass
/// zero-phase), not yet normalised. Designs the filters on every call; use
/// [`EnvelopeFilter`] to design once for many channels.
///
/// # Errors
/// Design errors of [`butter`], [`SignalError::NonFiniteSample`],
/// [`SignalError::SignalTooShort`].
pub fn envelope(
    raw: &[f64],
    fs: f64,
    settings: &EnvelopeSettings,
) -> Result<Vec<f64>, SignalError> {
    EnvelopeFilter::new(fs, settings)?.envelope(raw)
}

/// Normalise an envelope in place: divide by the trial maximum or by an MVC reference,
/// then clamp to `[0, 1]`.
///
/// # Errors
/// [`SignalError::NonFiniteSample`]; [`SignalError::InvalidMvc`] unless the MVC is finite
/// and `> 0`; [`SignalError::NonPositiveMaximum`] for [`Normalisation::TrialMax`] when the
/// envelope is empty or its maximum is `≤ 0` (e.g. an all-zero channel).
pub fn normalise(env: &mut [f64], reference: Normalisation) -> Result<(), SignalError> {
    check_finite(env)?;
    let divisor = match reference {
        Normalisation::Mvc(mvc) => {
            if !(mvc.is_finite() && mvc > 0.0) {
                return Err(SignalError::InvalidMvc { mvc });
            }
            mvc
        }
        Normalisation::TrialMax => {
            let max = env.iter().copied().fold(f64::NEG_INFINITY, f64::max);
            if max <= 0.0 {
                return Err(SignalError::NonPositiveMaximum {
                    max,
                    len: env.len(),
                });
            }
            max
        }
    };
    for v in env.iter_mut() {
        *v = (*v / divisor).clamp(0.0, 1.0);
    }
    Ok(())
}

/// Convenience: [`envelope`] followed by [`normalise`].
///
/// # Errors
/// Any error of [`envelope`] or [`normalise`].
pub fn normalised_envelope(
    raw: &[f64],
    fs: f64,
    settings: &EnvelopeSettings,
    reference: Normalisation,
) -> Result<Vec<f64>, SignalError> {
    let mut env = envelope(raw, fs, settings)?;
    normalise(&mut env, reference)?;
    Ok(env)
}
