//! The dynamometer's own error (docs/dynamometer.md): offset, event transients, AR(1) and white noise, 12-bit ADC.

use rand::Rng;
use rand_distr::{Distribution, StandardNormal};
use serde::{Deserialize, Serialize};

use crate::error::{ErrorKind, ExperimentError, Result};
use crate::files::Unloaded;
use crate::protocol::{MotionSettings, Protocol, ProtocolTrace};
use crate::seeds::{rng, Stream};

/// Parameters of the dynamometer error. `Default` is the nominal error of docs/formats.md, "Synthetic trials".
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct DynamometerSettings {
    /// Constant offset (−1.5 N·m).
    pub offset_nm: f64,
    /// Amplitude `A` of the damped oscillation after each start/stop/reversal (4 N·m).
    pub transient_amplitude_nm: f64,
    /// Its frequency `f` (12 Hz).
    pub transient_freq_hz: f64,
    /// Its decay time `τr` (0.06 s).
    pub transient_tau_s: f64,
    /// Stationary standard deviation of the AR(1) coloured noise (1.2 N·m).
    pub ar1_sd_nm: f64,
    /// Correlation time of the AR(1) noise (0.03 s): `φ = exp(−dt/τc)`.
    pub ar1_corr_time_s: f64,
    /// Standard deviation of the white noise (0.4 N·m).
    pub white_sd_nm: f64,
    /// ADC resolution in bits (12).
    pub adc_bits: u32,
    /// ADC full scale: the range is ±`full_scale_nm` (678 N·m, Biodex).
    pub full_scale_nm: f64,
}

impl Default for DynamometerSettings {
    fn default() -> Self {
        Self {
            offset_nm: -1.5,
            transient_amplitude_nm: 4.0,
            transient_freq_hz: 12.0,
            transient_tau_s: 0.06,
            ar1_sd_nm: 1.2,
            ar1_corr_time_s: 0.03,
            white_sd_nm: 0.4,
            adc_bits: 12,
            full_scale_nm: 678.0,
        }
    }
}

impl DynamometerSettings {
    /// Checks every field is finite and in range.
    ///
    /// # Errors
    /// [`ErrorKind::InvalidSettings`] naming the offending field.
    pub fn validate(&self) -> Result<()> {
        let bad = |r: &str| {
            Err(ExperimentError::invalid(
                "dynamometer settings",
                ErrorKind::InvalidSettings,
                r.to_string(),
            ))
        };
        if !self.offset_nm.is_finite() || !self.transient_amplitude_nm.is_finite() {
            return bad("offset_nm and transient_amplitude_nm must be finite");
        }
        if !(self.transient_freq_hz.is_finite() && self.transient_freq_hz >= 0.0) {
            return bad("transient_freq_hz must be finite and ≥ 0");
        }
        if !(self.transient_tau_s.is_finite() && self.transient_tau_s > 0.0) {
            return bad("transient_tau_s must be finite and > 0");
        }
        let sd_ok = |x: f64| x.is_finite() && x >= 0.0;
        if !(sd_ok(self.ar1_sd_nm) && sd_ok(self.white_sd_nm)) {
            return bad("ar1_sd_nm and white_sd_nm must be finite and ≥ 0");
        }
        if !(self.ar1_corr_time_s.is_finite() && self.ar1_corr_time_s > 0.0) {
            return bad("ar1_corr_time_s must be finite and > 0");
        }
        if !(1..=32).contains(&self.adc_bits) {
            return bad("adc_bits must be 1..=32");
        }
        if !(self.full_scale_nm.is_finite() && self.full_scale_nm > 0.0) {
            return bad("full_scale_nm must be finite and > 0");
        }
        Ok(())
    }

    /// ADC step `2·full_scale/2^bits` (1356/4096 ≈ 0.331 N·m nominal).
    #[must_use]
    pub fn quantisation_step_nm(&self) -> f64 {
        2.0 * self.full_scale_nm / 2f64.powi(self.adc_bits as i32)
    }

    /// AR(1) coefficient `φ = exp(−dt/τc)` for sampling interval `dt`.
    #[must_use]
    pub fn ar1_phi(&self, dt: f64) -> f64 {
        (-dt / self.ar1_corr_time_s).exp()
    }

    /// Standard deviation of the whole random part, `sqrt(σ_AR² + σ_white²)` (1.265 N·m nominal).
    #[must_use]
    pub fn random_sd_nm(&self) -> f64 {
        self.ar1_sd_nm.hypot(self.white_sd_nm)
    }
}

/// Which recording the random part belongs to: each draws from its own RNG streams, so the
/// trial and its unloaded run share the systematic part and have independent noise.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum Recording {
    /// The measured trial.
    Trial,
    /// The unloaded run.
    Unloaded,
}

impl Recording {
    fn streams(self) -> (Stream, Stream) {
        match self {
            Self::Trial => (Stream::TrialAr1, Stream::TrialWhite),
            Self::Unloaded => (Stream::UnloadedAr1, Stream::UnloadedWhite),
        }
    }
}

/// The systematic part at one time:
/// `offset + Σ_{e ≤ t} A·e^{−(t−e)/τr}·sin(2πf·(t−e))` over the event times `e`.
#[must_use]
pub fn systematic_error_at(t: f64, events: &[f64], s: &DynamometerSettings) -> f64 {
    let w = 2.0 * std::f64::consts::PI * s.transient_freq_hz;
    let mut e = s.offset_nm;
    for &ev in events {
        let dt = t - ev;
        if dt >= 0.0 {
            e += s.transient_amplitude_nm * (-dt / s.transient_tau_s).exp() * (w * dt).sin();
        }
    }
    e
}

/// The systematic part at each time (see [`systematic_error_at`]); `events` are the times of
/// every start, reversal and stop ([`crate::Events::all`]).
#[must_use]
pub fn systematic_error(time_s: &[f64], events: &[f64], s: &DynamometerSettings) -> Vec<f64> {
    time_s
        .iter()
        .map(|&t| systematic_error_at(t, events, s))
        .collect()
}

/// The random part from two generators (AR(1) innovations, white noise):
/// `x_0 ~ N(0, σ²)` (stationary start), `x_i = φ·x_{i−1} + σ·sqrt(1−φ²)·ξ_i`, plus `σ_w·η_i`.
///
/// # Errors
/// Invalid settings or `dt` not finite and > 0.
pub fn random_error_with<R1: Rng, R2: Rng>(
    n: usize,
    dt: f64,
    s: &DynamometerSettings,
    ar_rng: &mut R1,
    white_rng: &mut R2,
) -> Result<Vec<f64>> {
    s.validate()?;
    if !(dt.is_finite() && dt > 0.0) {
        return Err(ExperimentError::invalid(
            "sampling interval",
            ErrorKind::InvalidSettings,
            format!("dt must be finite and > 0, got {dt}"),
        ));
    }
    let phi = s.ar1_phi(dt);
    let innov = s.ar1_sd_nm * (1.0 - phi * phi).sqrt();
    let mut out = Vec::with_capacity(n);
    let mut x = 0.0;
    for i in 0..n {
        let xi: f64 = StandardNormal.sample(ar_rng);
        x = if i == 0 {
            s.ar1_sd_nm * xi
        } else {
            phi * x + innov * xi
        };
        let eta: f64 = StandardNormal.sample(white_rng);
        out.push(x + s.white_sd_nm * eta);
    }
    Ok(out)
}

/// The random part for one recording, seeded (ChaCha8, one stream each for AR(1) and white noise).
///
/// # Errors
/// As [`random_error_with`].
pub fn random_error(
    n: usize,
    dt: f64,
    s: &DynamometerSettings,
    seed: u64,
    recording: Recording,
) -> Result<Vec<f64>> {
    let (sa, sw) = recording.streams();
    random_error_with(n, dt, s, &mut rng(seed, sa), &mut rng(seed, sw))
}

/// 12-bit (by default) mid-tread quantisation over ±full scale:
/// `step·clamp(round(x/step), −2^(b−1), 2^(b−1)−1)`.
#[must_use]
pub fn quantise(x: f64, s: &DynamometerSettings) -> f64 {
    let step = s.quantisation_step_nm();
    let half = 2f64.powi(s.adc_bits as i32 - 1);
    (x / step).round().clamp(-half, half - 1.0) * step
}

/// [`quantise`] every sample in place.
pub fn quantise_in_place(x: &mut [f64], s: &DynamometerSettings) {
    for v in x {
        *v = quantise(*v, s);
    }
}

/// Systematic plus random error for a sampled protocol, **not** quantised (add the model
/// torque first, then [`quantise_in_place`]).
///
/// # Errors
/// Invalid settings or an empty trace.
pub fn dynamometer_error(
    trace: &ProtocolTrace,
    s: &DynamometerSettings,
    seed: u64,
    recording: Recording,
) -> Result<Vec<f64>> {
    s.validate()?;
    let mut e = systematic_error(&trace.time_s, &trace.events.all(), s);
    let r = random_error(trace.len(), trace.dt(), s, seed, recording)?;
    for (a, b) in e.iter_mut().zip(&r) {
        *a += b;
    }
    Ok(e)
}

/// The unloaded run of the fixtures: [`Protocol::unloaded`] motion (3 cycles), torque =
/// quantised dynamometer error with the [`Recording::Unloaded`] noise streams.
///
/// # Errors
/// Invalid settings.
pub fn unloaded_run(s: &DynamometerSettings, seed: u64) -> Result<Unloaded> {
    unloaded_run_with(s, seed, &MotionSettings::default())
}

/// [`unloaded_run`] with the motion of a trial at another speed (the unloaded run of a session
/// trial is recorded at that trial's speed, so its transients are those of the trial).
///
/// # Errors
/// Invalid settings.
pub fn unloaded_run_with(
    s: &DynamometerSettings,
    seed: u64,
    motion: &MotionSettings,
) -> Result<Unloaded> {
    let trace = Protocol::unloaded().trace_with(motion)?;
    let mut torque = dynamometer_error(&trace, s, seed, Recording::Unloaded)?;
    quantise_in_place(&mut torque, s);
    Ok(Unloaded {
        time_s: trace.time_s,
        ankle_angle_deg: trace.angle_deg,
        torque_nm: torque,
        comments: Vec::new(),
        ignored_columns: Vec::new(),
    })
}
