//! The dynamometer correction: what the dynamometer adds to the measured torque, estimated
//! from a recording without muscle torque (the unloaded run), and subtracted from a trial.
//!
//! The dynamometer's error is modelled as
//!
//! ```text
//! ε(t) = c + Σ_e h(t − e) + x_t + v_t,   h(s) = e^{−s/τ}·(B sin 2πfs + C cos 2πfs), s ≥ 0,
//! x_t = φ·x_{t−1} + w_t,   w ~ N(0, σ_ar²(1 − φ²)),   v ~ N(0, σ_w²),
//! ```
//!
//! `c` the offset, `e` every motion start, reversal and stop ([`crate::detect_events`]), `x`
//! an AR(1) of stationary SD `σ_ar` and correlation time `τ_c = −dt/ln φ`, `v` white noise
//! (with the ADC's quantisation). [`DynamometerCorrection::fit`] estimates the systematic
//! part `(c, B, C, τ, f)` (module [`crate::transient`]) and the random part `(φ, σ_ar, σ_w)`
//! ([`fit_ar1_white`], from the remainder's autocorrelation at lag 1 and near the correlation
//! time) in turn:
//!
//! 1. least squares over a grid of `(τ, f)` (linear in `c, B, C`), then the random part from
//!    the remainder `r = y − c − Σ h`;
//! 2. twice: generalised least squares on the recording whitened by that random part, around
//!    the previous optimum, and the random part again;
//! 3. the coarse grid once more, whitened, in case the AR(1) wander pulled step 1 into
//!    another basin;
//! 4. the transient is kept only when it lowers the whitened sum of squares by at least
//!    [`TRANSIENT_MIN_EVIDENCE`] against the offset alone.
//!
//! [`DynamometerCorrection::systematic_for`] places `c + Σ h(t − e)` at another recording's
//! events, and [`DynamometerCorrection::correct`] subtracts it from a trial's torque at the
//! trial's own detected events. [`DynamometerCorrection::report`] is the summary written to
//! `identify.json` and `diagnosis.json` (`docs/dynamometer.md`).
//!
//! ```
//! use experiment::{unloaded_run, DynamometerCorrection, DynamometerSettings, Protocol};
//!
//! let s = DynamometerSettings::default();
//! let unloaded = unloaded_run(&s, 3)?;
//! let c = DynamometerCorrection::from_unloaded(&unloaded)?;
//! assert!((c.offset_nm - s.offset_nm).abs() < 0.5);
//! assert!((c.transient.freq_hz - s.transient_freq_hz).abs() < 1.0);
//! let trace = Protocol::Seed.trace()?;
//! let sys = c.systematic_for(&trace.time_s, &trace.events);
//! assert_eq!(sys.len(), trace.len());
//! # Ok::<(), experiment::ExperimentError>(())
//! ```

use muscle_model::noise::autocovariance;
use muscle_model::Ar1White;
use serde::{Deserialize, Serialize};

use crate::error::{ErrorKind, ExperimentError, Result};
use crate::events::{check_series, detect_events};
use crate::files::{Trial, Unloaded};
use crate::protocol::Events;
use crate::transient::{
    coarse_grid, fit_linear, grid_around, grid_search, refine, Gls, Transient,
    TRANSIENT_MIN_EVIDENCE,
};

/// The dynamometer's error as estimated from one recording (see the module doc).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct DynamometerCorrection {
    /// Offset `c` (N·m); 0 when fitted without one.
    pub offset_nm: f64,
    /// Event transient; [`Transient::none`] when the recording shows none.
    pub transient: Transient,
    /// Random part `(φ, σ_ar, σ_w)`, `φ` per sample of the recording it was fitted on.
    pub random: Ar1White,
    /// Sampling interval of that recording (s).
    pub dt_s: f64,
    /// RMS of the remainder `y − c − Σ h` (N·m).
    pub remainder_rms_nm: f64,
}

/// A trial's torque with the dynamometer correction subtracted
/// ([`DynamometerCorrection::correct`]).
#[derive(Clone, Debug, PartialEq)]
pub struct CorrectedTorque {
    /// Measured torque minus the systematic part (N·m).
    pub torque_nm: Vec<f64>,
    /// The systematic part subtracted at each sample (N·m).
    pub systematic_nm: Vec<f64>,
    /// The trial's motion events the transients were placed at.
    pub events: Events,
}

impl DynamometerCorrection {
    /// Fits the correction to an unloaded run: its events from its angle
    /// ([`crate::detect_events`]), then [`DynamometerCorrection::fit`] with the offset.
    ///
    /// # Errors
    /// A torque or angle series that is too short, not finite or not increasing in time, or
    /// an angle without motion.
    pub fn from_unloaded(unloaded: &Unloaded) -> Result<Self> {
        check_series("unloaded torque", &unloaded.time_s, &unloaded.torque_nm)?;
        let events = detect_events(&unloaded.time_s, &unloaded.ankle_angle_deg)?;
        let t0 = unloaded.time_s[0];
        let rel: Vec<f64> = events.all().iter().map(|e| e - t0).collect();
        Self::fit(&unloaded.torque_nm, unloaded.sample_rate_hz(), &rel, true)
    }

    /// Fits the systematic and random parts to a recording `y` (an unloaded run, or a trial's
    /// residual) sampled at `fs`, with motion events `events` (s from the first sample);
    /// `with_offset` fits the constant `c` (otherwise `c = 0`). See the module doc.
    ///
    /// # Errors
    /// Fewer than 16 samples, a sampling rate that is not positive and finite, or non-finite
    /// values.
    pub fn fit(y: &[f64], fs: f64, events: &[f64], with_offset: bool) -> Result<Self> {
        if y.len() < 16 {
            return Err(ExperimentError::invalid(
                "dynamometer recording",
                ErrorKind::TooShort,
                format!("needs at least 16 samples, got {}", y.len()),
            ));
        }
        if !(fs > 0.0 && fs.is_finite()) || y.iter().chain(events).any(|v| !v.is_finite()) {
            return Err(ExperimentError::invalid(
                "dynamometer recording",
                ErrorKind::NotFinite,
                "non-finite value, event time or sampling rate",
            ));
        }
        let n = y.len();
        let times: Vec<f64> = (0..n).map(|i| i as f64 / fs).collect();
        let mut best = (f64::INFINITY, 0.0, Transient::none());
        let try_grid = |taus: &[f64], freqs: &[f64], best: &mut (f64, f64, Transient)| {
            grid_search(taus, freqs, best, |tau, f| {
                fit_linear(y, &times, events, tau, f, with_offset)
            });
        };
        let (coarse_taus, coarse_freqs) = coarse_grid();
        if !events.is_empty() {
            try_grid(&coarse_taus, &coarse_freqs, &mut best);
            for _ in 0..2 {
                let (taus, freqs) = grid_around(best.2.tau_s, 1.04, 6, best.2.freq_hz, 0.05, 10);
                try_grid(&taus, &freqs, &mut best);
            }
        } else {
            let c = if with_offset {
                y.iter().sum::<f64>() / n.max(1) as f64
            } else {
                0.0
            };
            best = (0.0, c, Transient::none());
        }
        let (_, mut offset, mut transient) = best;
        // the remainder after a systematic part, and the random part fitted to it
        let random_part = |offset: f64, transient: &Transient| {
            let mut rem: Vec<f64> = y.iter().map(|v| v - offset).collect();
            transient.add_to(&mut rem, &times, events, -1.0);
            let ar = fit_ar1_white(&rem);
            (rem, (ar.phi, ar.sigma_ar, ar.sigma_white))
        };
        let (mut rem, (mut phi, mut sd_ar, mut sd_white)) = random_part(offset, &transient);
        // Generalised least squares: the random part is strongly autocorrelated (AR(1) with a
        // correlation time of tens of ms, like the transient itself), so ordinary least squares
        // weighs its low frequencies as if they were independent and misplaces τ and f. Refit
        // the grid on the whitened recording (the exact Gaussian likelihood of the model), then
        // the random part on the new remainder; twice.
        if !events.is_empty() {
            for round in 0..2 {
                let Ok(ar) = Ar1White::new(phi, sd_ar, sd_white) else {
                    break;
                };
                let gls = Gls::new(y, &times, events, ar.plan(n, None), with_offset);
                let mut best = (f64::INFINITY, offset, transient);
                let try_grid = |taus: &[f64], freqs: &[f64], best: &mut (f64, f64, Transient)| {
                    grid_search(taus, freqs, best, |tau, f| gls.fit(tau, f));
                };
                // round 0: around the least-squares optimum (τ × 1.3^±3, f ± 4 Hz), then
                // two finer grids (τ × 1.06^±3 and f ± 0.5 Hz; τ × 1.02^±3 and f ± 0.15 Hz)
                if round == 0 {
                    let f0 = best.2.freq_hz.round();
                    let (taus, freqs) = grid_around(best.2.tau_s, 1.3, 3, f0, 1.0, 4);
                    try_grid(&taus, &freqs, &mut best);
                }
                refine(&mut best, |tau, f| gls.fit(tau, f));
                if !best.0.is_finite() {
                    break;
                }
                (offset, transient) = (best.1, best.2);
                (rem, (phi, sd_ar, sd_white)) = random_part(offset, &transient);
            }
            // The rounds above search near the least-squares optimum. The AR(1) wander can
            // pull that into another basin (on one simulated unloaded run, seed 1100712, to 2.5 Hz
            // against the true 12 Hz), so the whole coarse grid is searched again, whitened;
            // a better basin found there is refined and replaces the result. When the result
            // is already the whitened optimum, no coarse point beats it and nothing changes.
            if let Ok(ar) = Ar1White::new(phi, sd_ar, sd_white) {
                let gls = Gls::new(y, &times, events, ar.plan(n, None), with_offset);
                let (ss, ..) = gls.fit(transient.tau_s, transient.freq_hz);
                let mut best = (ss, offset, transient);
                // every other point of the first grid (a quarter of its cost), then a step
                // of that grid around the best before the fine grids
                let taus: Vec<f64> = coarse_taus.iter().copied().step_by(2).collect();
                let freqs: Vec<f64> = coarse_freqs.iter().copied().skip(1).step_by(2).collect();
                grid_search(&taus, &freqs, &mut best, |tau, f| gls.fit(tau, f));
                if best.2 != transient {
                    let (taus, freqs) = grid_around(best.2.tau_s, 1.3, 1, best.2.freq_hz, 1.0, 1);
                    grid_search(&taus, &freqs, &mut best, |tau, f| gls.fit(tau, f));
                    refine(&mut best, |tau, f| gls.fit(tau, f));
                    (offset, transient) = (best.1, best.2);
                    (rem, (phi, sd_ar, sd_white)) = random_part(offset, &transient);
                }
            }
            // keep the transient only when the recording has one: without it, the grid
            // search fits the slow AR(1) wander instead (τ near 1 s, B and C large and nearly
            // cancelling), and that shape would be subtracted after every event of the trial
            if let Ok(ar) = Ar1White::new(phi, sd_ar, sd_white) {
                let gls = Gls::new(y, &times, events, ar.plan(n, None), with_offset);
                let with = gls.fit(transient.tau_s, transient.freq_hz).0;
                let (without, c) = gls.without_transient();
                if with.is_finite() && without - with < TRANSIENT_MIN_EVIDENCE {
                    (offset, transient) = (c, Transient::none());
                    (rem, (phi, sd_ar, sd_white)) = random_part(offset, &transient);
                }
            }
        }
        let rms = (rem.iter().map(|e| e * e).sum::<f64>() / n.max(1) as f64).sqrt();
        Ok(DynamometerCorrection {
            offset_nm: offset,
            transient,
            random: Ar1White {
                phi,
                sigma_ar: sd_ar,
                sigma_white: sd_white,
            },
            dt_s: 1.0 / fs,
            remainder_rms_nm: rms,
        })
    }

    /// The systematic part `c + Σ_e h(t − e)` at `time_s` (uniformly sampled), with the
    /// events `events` of that recording (for a trial, [`crate::detect_events`] on its angle;
    /// times on the same clock as `time_s`).
    #[must_use]
    pub fn systematic_for(&self, time_s: &[f64], events: &Events) -> Vec<f64> {
        let mut out = vec![self.offset_nm; time_s.len()];
        self.transient.add_to(&mut out, time_s, &events.all(), 1.0);
        out
    }

    /// The trial's torque minus the systematic part at the trial's own events, detected from
    /// its angle.
    ///
    /// # Errors
    /// An angle trace without motion or otherwise unusable (see [`crate::detect_events`]).
    pub fn correct(&self, trial: &Trial) -> Result<CorrectedTorque> {
        let events = detect_events(&trial.time_s, &trial.ankle_angle_deg)?;
        let systematic_nm = self.systematic_for(&trial.time_s, &events);
        let torque_nm = trial
            .torque_nm
            .iter()
            .zip(&systematic_nm)
            .map(|(m, s)| m - s)
            .collect();
        Ok(CorrectedTorque {
            torque_nm,
            systematic_nm,
            events,
        })
    }

    /// The summary reported as `"dynamometer"` in the JSON outputs.
    #[must_use]
    pub fn report(&self) -> DynamometerReport {
        DynamometerReport::new(self.offset_nm, &self.transient, &self.random, self.dt_s)
    }
}

/// The event transient as reported: `A·e^{−s/τ}·sin(2πfs + ψ)`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct TransientReport {
    /// Amplitude `A = √(B² + C²)` (N·m).
    pub amplitude_nm: f64,
    /// Frequency `f` (Hz).
    pub freq_hz: f64,
    /// Decay time `τ` (s).
    pub tau_s: f64,
    /// Phase `ψ = atan2(C, B)` (rad; 0 for a pure sine starting at the event).
    pub phase_rad: f64,
}

/// The dynamometer correction as written to `identify.json` and `diagnosis.json`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct DynamometerReport {
    /// Offset `c` subtracted (N·m).
    pub offset_nm: f64,
    /// The transient subtracted after every event; `None` (JSON `null`) when none was kept.
    pub transient: Option<TransientReport>,
    /// Stationary SD of the AR(1) part (N·m).
    pub ar1_sd_nm: f64,
    /// Correlation time `τ_c = −dt/ln φ` of the AR(1) part (s; 0 when `φ ≤ 0`).
    pub ar1_corr_time_s: f64,
    /// SD of the white part (N·m).
    pub white_sd_nm: f64,
}

impl DynamometerReport {
    /// The report of offset `c`, `transient`, random part `random` (`φ` per sample) and
    /// sampling interval `dt_s`.
    #[must_use]
    pub fn new(offset_nm: f64, transient: &Transient, random: &Ar1White, dt_s: f64) -> Self {
        let transient = (!transient.is_none()).then(|| TransientReport {
            amplitude_nm: transient.amplitude_nm(),
            freq_hz: transient.freq_hz,
            tau_s: transient.tau_s,
            phase_rad: transient.phase_rad(),
        });
        let ar1_corr_time_s = if random.phi > 0.0 {
            -dt_s / random.phi.ln()
        } else {
            0.0
        };
        DynamometerReport {
            offset_nm,
            transient,
            ar1_sd_nm: random.sigma_ar,
            ar1_corr_time_s,
            white_sd_nm: random.sigma_white,
        }
    }
}

/// The random part `(φ, σ_ar, σ_w)` of a remainder `u` from two of its autocorrelations.
///
/// With `γ_k` the (biased) autocovariances about the mean and `ρ_k = γ_k/γ_0`, the
/// AR(1)+white model has `ρ_k = c_a·φ^k` for `k ≥ 1`, `c_a = σ_ar²/γ_0`. Two lags fix it:
///
/// ```text
/// φ = (ρ_K/ρ_1)^{1/(K−1)},   σ_ar² = γ_0·ρ_1/φ,   σ_w² = γ_0 − σ_ar²,
/// ```
///
/// `K` the lag at which an AR(1) with lag-one correlation `ρ_1` would have decayed to ½
/// (`K = ln ½ / ln ρ_1`, rounded, at least 2, at most `n/4`): near the correlation time, far
/// enough from lag 1 for the ratio to pin `φ` and early enough for `ρ_K` to stand above its
/// sampling noise. The white share is `1 − ρ_1/φ`, so lag 1 (where the white noise is absent
/// from the covariance) carries it. On 52 simulated 8 s unloaded runs (`docs/dynamometer.md`)
/// this gives `σ_w` to a median 0.7 % and the correlation time to 7 %; a log-linear fit over
/// the lags up to where the autocovariance falls below a tenth of `γ_1` gave 7 % and 10 %.
///
/// `σ_w² ≥ max(10⁻⁴γ_0, 10⁻⁸)` and `φ ≤ 0.9999` keep the model valid for whitening. A
/// remainder without positive lag-one correlation is white noise alone; one shorter than 16
/// samples or with a non-finite value is white noise of its mean square.
pub fn fit_ar1_white(u: &[f64]) -> Ar1White {
    let n = u.len();
    let white = |var: f64| Ar1White {
        phi: 0.0,
        sigma_ar: 0.0,
        sigma_white: var.max(1e-12).sqrt(),
    };
    if n < 16 || u.iter().any(|v| !v.is_finite()) {
        let v = u.iter().map(|x| x * x).sum::<f64>() / n.max(1) as f64;
        return Ar1White {
            phi: 0.0,
            sigma_ar: 0.0,
            sigma_white: v.sqrt().max(1e-6),
        };
    }
    let mean = u.iter().sum::<f64>() / n as f64;
    let g0 = autocovariance(u, mean, 0);
    if g0 <= 0.0 {
        return white(g0);
    }
    let rho1 = autocovariance(u, mean, 1) / g0;
    if rho1 <= 0.0 {
        return white(g0);
    }
    let k = if rho1 < 1.0 {
        ((0.5f64.ln() / rho1.ln()).round() as usize).clamp(2, (n / 4).max(2))
    } else {
        2
    };
    let rk = autocovariance(u, mean, k) / g0;
    let phi = if rk > 0.0 && rk < rho1 {
        (rk / rho1).powf(1.0 / (k - 1) as f64)
    } else {
        rho1
    }
    .min(0.9999);
    let share = (rho1 / phi).clamp(0.0, 1.0);
    let var_w = (g0 * (1.0 - share)).max(1e-4 * g0).max(1e-8);
    Ar1White {
        phi,
        sigma_ar: (g0 * share).sqrt(),
        sigma_white: var_w.sqrt(),
    }
}
