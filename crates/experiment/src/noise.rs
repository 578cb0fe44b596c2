//! The dynamometer's error estimated from an unloaded run: motion events detected from the
//! angle, the cycle-locked (systematic) part, and the AR(1)+white remainder.
//!
//! # Events ([`detect_events`])
//!
//! The angular velocity is the central difference of the angle over `±smooth_s` (5 ms), in
//! °/s. A sample is *moving* when `|v| > moving_fraction · max|v|` (0.7). Each moving run is
//! one sweep (runs of the same direction less than `min_hold_s` apart are merged, so noise
//! near the threshold cannot split a sweep). Its start is found by extrapolating the acceleration ramp to zero speed: with
//! `t_lo`, `t_hi` the (linearly interpolated) times at which `|v|` crosses `ramp_low` (20 %)
//! and `ramp_high` (60 %) of the sweep's median moving speed, `t₀ = t_lo − (t_hi − t_lo) ·
//! ramp_low/(ramp_high − ramp_low)`; the end is found the same way on the falling edge. Two
//! consecutive sweeps of opposite direction with less than `min_hold_s` (50 ms) between the
//! end of one and the start of the other form a **reversal**, placed at the zero crossing of
//! the velocity between them; otherwise the first ends with a **stop** and the second begins
//! with a **start**. The first sweep begins with a start and the last ends with a stop.
//! For a trapezoidal profile with ramps longer than `2·smooth_s/(1 − ramp_high)` this is
//! exact (both crossings lie on the straight part of the smoothed ramp): the 2048 Hz
//! protocols' events are reproduced to 10⁻⁶ s, and with a 0.01° encoder to about 1 ms
//! (`tests/noise.rs`).
//!
//! # Systematic part ([`NoiseEstimate::from_unloaded`])
//!
//! With the events `e` of the unloaded run, its torque is modelled as
//!
//! ```text
//! τ_u(t) = c + Σ_e h(t − e) + n(t),   h(s) = 0 outside [0, W),
//! ```
//!
//! `c` the offset, `h` one transient response shared by every start, reversal and stop, `W`
//! the window, `n` the random remainder. `c` is the mean torque over the
//! samples farther than `W` after every event; `h` on the grid `s_k = k·dt` is the mean over
//! the events of `τ_u(e + s_k) − c`, with `τ_u` linearly interpolated between samples (so
//! events between samples are aligned to a fraction of a sample). Where windows of two events
//! overlap, the later event's window is truncated.
//!
//! The window starts at `window_s` (0.5 s) and is then shortened (`adaptive_window`): with
//! `σ²` the remainder's variance and `N_k` the events averaged at lag `k`, the template's own
//! noise has variance `σ²/N_k`; `W` ends at the first lag whose following block of `block_s`
//! (50 ms) has a mean square of `h` below twice that noise variance. Beyond it, subtracting
//! `h` would add more noise than it removes (7 events and the SPEC §4 noise: `W ≈ 0.1 s`).
//! The offset is then re-estimated outside the shortened windows (and `h` shifted so that
//! `c + h` is unchanged), and the statistics below use the shortened template. The remainder `n = τ_u − c − Σ h` gives the
//! marginal `σ`, the autocorrelation `ρ_k`, and the AR(1)+white decomposition
//! `ρ_k = c_a·φ^k` (k ≥ 1): `φ = (ρ_K/ρ_1)^{1/(K−1)}` with `K` the lag where the AR(1) with
//! lag-one `ρ_1` would have decayed to ½ (at least 2), `σ_AR² = σ²·ρ_1/φ`, `σ_w² = σ² − σ_AR²`.
//! [`NoiseEstimate::autocorrelation_check`] compares the measured `ρ_k` with that model at
//! several lags.
//!
//! [`NoiseEstimate::systematic_for`] places `c + Σ h(t − e)` at another recording's events
//! (e.g. a trial's, from [`detect_events`] on its angle) so it can be subtracted from the
//! measured torque; the averaging leaves in `h` the remainder's noise divided by
//! `√(number of events)`, which [`NoiseEstimate::template_se_nm`] reports.
//!
//! ```
//! use experiment::{detect_events, unloaded_run, DynamometerSettings, NoiseEstimate, Protocol};
//!
//! let s = DynamometerSettings::default();
//! let unloaded = unloaded_run(&s, 3)?;
//! let est = NoiseEstimate::from_unloaded(&unloaded)?;
//! assert!((est.offset_nm - s.offset_nm).abs() < 0.5);
//! let trace = Protocol::Seed.trace()?;
//! let events = detect_events(&trace.time_s, &trace.angle_deg)?;
//! assert_eq!(events.reversals.len(), 1);
//! let sys = est.systematic_for(&trace.time_s, &events);
//! assert_eq!(sys.len(), trace.len());
//! # Ok::<(), experiment::ExperimentError>(())
//! ```

use serde::{Deserialize, Serialize};

use crate::error::{ErrorKind, ExperimentError, Result};
use crate::files::Unloaded;
use crate::protocol::Events;

/// Settings of [`detect_events_with`]. `Default` is documented in the module doc.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct EventSettings {
    /// Half-width of the central difference giving the velocity (s). Default 0.005.
    pub smooth_s: f64,
    /// A sample is moving when `|v|` exceeds this fraction of the peak speed; must exceed
    /// `ramp_high`. Default 0.7.
    pub moving_fraction: f64,
    /// Lower ramp crossing, fraction of the sweep's speed. Default 0.2.
    pub ramp_low: f64,
    /// Upper ramp crossing, fraction of the sweep's speed. Default 0.6.
    pub ramp_high: f64,
    /// Shortest pause between sweeps that counts as a stop and a start (s). Default 0.05.
    pub min_hold_s: f64,
}

impl Default for EventSettings {
    fn default() -> Self {
        Self {
            smooth_s: 0.005,
            moving_fraction: 0.7,
            ramp_low: 0.2,
            ramp_high: 0.6,
            min_hold_s: 0.05,
        }
    }
}

fn invalid(what: &str, reason: impl Into<String>) -> ExperimentError {
    ExperimentError::invalid(what, ErrorKind::InvalidSettings, reason)
}

fn check_series(what: &str, time_s: &[f64], values: &[f64]) -> Result<f64> {
    if time_s.len() != values.len() {
        return Err(ExperimentError::invalid(
            what,
            ErrorKind::LengthMismatch,
            format!("{} times but {} values", time_s.len(), values.len()),
        ));
    }
    if time_s.len() < 16 {
        return Err(ExperimentError::invalid(
            what,
            ErrorKind::TooShort,
            format!("needs at least 16 samples, got {}", time_s.len()),
        ));
    }
    if time_s.iter().chain(values).any(|v| !v.is_finite()) {
        return Err(ExperimentError::invalid(
            what,
            ErrorKind::NotFinite,
            "non-finite time or value",
        ));
    }
    let dt = (time_s[time_s.len() - 1] - time_s[0]) / (time_s.len() - 1) as f64;
    if dt.is_nan() || dt <= 0.0 {
        return Err(ExperimentError::invalid(
            what,
            ErrorKind::TimeNotIncreasing,
            "time does not increase",
        ));
    }
    Ok(dt)
}

/// Detect the motion events with the default [`EventSettings`].
///
/// # Errors
/// See [`detect_events_with`].
pub fn detect_events(time_s: &[f64], angle_deg: &[f64]) -> Result<Events> {
    detect_events_with(time_s, angle_deg, &EventSettings::default())
}

/// Detect motion starts, reversals and stops from a measured angle trace (uniform sampling);
/// see the module doc for the method.
///
/// # Errors
/// Length mismatch, fewer than 16 samples, non-finite values, non-increasing time, invalid
/// settings, or no motion at all.
pub fn detect_events_with(time_s: &[f64], angle_deg: &[f64], s: &EventSettings) -> Result<Events> {
    let dt = check_series("angle trace", time_s, angle_deg)?;
    if !(s.smooth_s >= 0.0
        && s.smooth_s.is_finite()
        && s.moving_fraction < 1.0
        && s.ramp_low > 0.0
        && s.ramp_low < s.ramp_high
        && s.ramp_high < s.moving_fraction
        && s.min_hold_s >= 0.0
        && s.min_hold_s.is_finite())
    {
        return Err(invalid(
            "event settings",
            "need smooth_s ≥ 0, 0 < moving_fraction < 1, 0 < ramp_low < ramp_high < moving_fraction, min_hold_s ≥ 0",
        ));
    }
    let n = time_s.len();
    let k = ((s.smooth_s / dt).round() as usize).max(1);
    // Velocity at every sample (one-sided windows shrink at the ends).
    let v: Vec<f64> = (0..n)
        .map(|i| {
            let a = i.saturating_sub(k);
            let b = (i + k).min(n - 1);
            (angle_deg[b] - angle_deg[a]) / (time_s[b] - time_s[a])
        })
        .collect();
    let peak = v.iter().fold(0.0f64, |m, x| m.max(x.abs()));
    if peak.is_nan() || peak <= 0.0 {
        return Err(ExperimentError::invalid(
            "angle trace",
            ErrorKind::InvalidSettings,
            "the angle never changes: no motion to detect",
        ));
    }
    let thr = s.moving_fraction * peak;
    // Moving runs [a, b).
    let mut runs: Vec<(usize, usize)> = Vec::new();
    let mut i = 0;
    while i < n {
        if v[i].abs() > thr {
            let a = i;
            let sign = v[i].signum();
            while i < n && v[i].abs() > thr && v[i].signum() == sign {
                i += 1;
            }
            match runs.last_mut() {
                Some(last)
                    if v[last.0].signum() == sign
                        && time_s[a] - time_s[last.1 - 1] < s.min_hold_s =>
                {
                    last.1 = i;
                }
                _ => runs.push((a, i)),
            }
        } else {
            i += 1;
        }
    }
    // Crossing time of |v| through `level` between samples j and j+1 (linear interpolation).
    let cross = |j: usize, level: f64| -> f64 {
        let (x0, x1) = (v[j].abs(), v[j + 1].abs());
        let f = if x1 != x0 {
            (level - x0) / (x1 - x0)
        } else {
            0.5
        };
        time_s[j] + f.clamp(0.0, 1.0) * (time_s[j + 1] - time_s[j])
    };
    let mut bounds = Vec::with_capacity(runs.len());
    for &(a, b) in &runs {
        let mut speeds: Vec<f64> = v[a..b].iter().map(|x| x.abs()).collect();
        speeds.sort_by(f64::total_cmp);
        let speed = speeds[speeds.len() / 2];
        let (lo, hi) = (s.ramp_low * speed, s.ramp_high * speed);
        let sign = v[a].signum();
        let same = |j: usize| v[j].signum() == sign;
        // Rising edge: walk back from `a` while |v| ≥ hi, then while |v| ≥ lo.
        let mut j = a;
        while j > 0 && same(j - 1) && v[j - 1].abs() >= hi {
            j -= 1;
        }
        let t_hi = if j > 0 { cross(j - 1, hi) } else { time_s[0] };
        while j > 0 && same(j - 1) && v[j - 1].abs() >= lo {
            j -= 1;
        }
        let t_lo = if j > 0 { cross(j - 1, lo) } else { time_s[0] };
        let start = t_lo - (t_hi - t_lo) * s.ramp_low / (s.ramp_high - s.ramp_low);
        // Falling edge.
        let mut j = b - 1;
        while j + 1 < n && same(j + 1) && v[j + 1].abs() >= hi {
            j += 1;
        }
        let t_hi2 = if j + 1 < n {
            cross(j, hi)
        } else {
            time_s[n - 1]
        };
        while j + 1 < n && same(j + 1) && v[j + 1].abs() >= lo {
            j += 1;
        }
        let t_lo2 = if j + 1 < n {
            cross(j, lo)
        } else {
            time_s[n - 1]
        };
        let end = t_lo2 + (t_lo2 - t_hi2) * s.ramp_low / (s.ramp_high - s.ramp_low);
        bounds.push((start, end, sign, a, b));
    }
    let mut ev = Events::default();
    for (r, &(start, end, sign, _, b)) in bounds.iter().enumerate() {
        if r == 0 {
            ev.starts.push(start);
        }
        match bounds.get(r + 1) {
            None => ev.stops.push(end),
            Some(&(next_start, _, next_sign, next_a, _)) => {
                if next_sign != sign && next_start - end < s.min_hold_s {
                    // Reversal: the zero crossing of v between the two runs.
                    let mut t = 0.5 * (end + next_start);
                    for j in (b.saturating_sub(1))..next_a.min(n - 1) {
                        if v[j].signum() == sign && v[j + 1].signum() != sign {
                            let f = v[j] / (v[j] - v[j + 1]);
                            t = time_s[j] + f * (time_s[j + 1] - time_s[j]);
                            break;
                        }
                    }
                    ev.reversals.push(t);
                } else {
                    ev.stops.push(end);
                    ev.starts.push(next_start);
                }
            }
        }
    }
    Ok(ev)
}

/// Settings of [`NoiseEstimate::from_unloaded_with`].
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct NoiseSettings {
    /// Longest window `W` of the transient template after each event (s). Default 0.5.
    pub window_s: f64,
    /// Shorten the window where the template is no longer above its own noise (see the
    /// module doc). Default true.
    pub adaptive_window: bool,
    /// Block length of the adaptive-window test (s). Default 0.05.
    pub block_s: f64,
    /// Event detection.
    pub events: EventSettings,
}

impl Default for NoiseSettings {
    fn default() -> Self {
        Self {
            window_s: 0.5,
            adaptive_window: true,
            block_s: 0.05,
            events: EventSettings::default(),
        }
    }
}

/// One lag of [`NoiseEstimate::autocorrelation_check`].
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct LagCheck {
    /// Lag (samples).
    pub lag: usize,
    /// Measured autocorrelation of the remainder.
    pub measured: f64,
    /// `c_a·φ^lag` of the fitted AR(1)+white model.
    pub ar1_white: f64,
    /// `ρ₁^lag` of a pure AR(1) with the measured lag-one autocorrelation.
    pub ar1: f64,
}

/// The dynamometer error estimated from an unloaded run (see the module doc).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct NoiseEstimate {
    /// Sampling interval of the unloaded run (s); the template grid spacing.
    pub dt_s: f64,
    /// Offset `c` (N·m).
    pub offset_nm: f64,
    /// Transient template `h(k·dt)`, `k = 0 … ⌈W/dt⌉ − 1` (N·m), without the offset.
    pub template_nm: Vec<f64>,
    /// Number of events averaged at each template lag (events whose window is truncated by
    /// the next event or the end of the run count only where they contribute).
    pub template_count: Vec<u32>,
    /// The events detected in the unloaded run.
    pub events: Events,
    /// Marginal standard deviation of the remainder (N·m).
    pub sigma_nm: f64,
    /// Lag-one autocorrelation `ρ₁` of the remainder.
    pub lag1: f64,
    /// AR(1) coefficient `φ` of the AR(1)+white decomposition.
    pub ar1_phi: f64,
    /// Standard deviation of the AR(1) component (N·m).
    pub ar1_sd_nm: f64,
    /// Standard deviation of the white component (N·m).
    pub white_sd_nm: f64,
    /// Autocorrelation of the remainder at lags 0, 1, … (up to ~4 correlation times).
    pub autocorrelation: Vec<f64>,
}

impl NoiseEstimate {
    /// Estimate with the default [`NoiseSettings`].
    ///
    /// # Errors
    /// See [`NoiseEstimate::from_unloaded_with`].
    pub fn from_unloaded(unloaded: &Unloaded) -> Result<Self> {
        Self::from_unloaded_with(unloaded, &NoiseSettings::default())
    }

    /// Estimate the offset, the transient template and the remainder's statistics from an
    /// unloaded run (see the module doc).
    ///
    /// # Errors
    /// Bad series (see [`detect_events_with`]), a window that is not positive, no motion, or
    /// no sample outside the event windows to estimate the offset from.
    pub fn from_unloaded_with(unloaded: &Unloaded, s: &NoiseSettings) -> Result<Self> {
        let t = &unloaded.time_s;
        let y = &unloaded.torque_nm;
        let dt = check_series("unloaded torque", t, y)?;
        if !(s.window_s > 0.0 && s.window_s.is_finite()) {
            return Err(invalid("noise settings", "window_s must be positive"));
        }
        let events = detect_events_with(t, &unloaded.ankle_angle_deg, &s.events)?;
        let all = events.all();
        let t0 = t[0];
        let n = t.len();
        let len = ((s.window_s / dt).ceil() as usize).max(1);
        // Offset: mean over samples outside every window.
        let inside = |ti: f64| all.iter().any(|&e| ti >= e && ti < e + s.window_s);
        let (mut sum, mut cnt) = (0.0, 0usize);
        for (&ti, &yi) in t.iter().zip(y) {
            if !inside(ti) {
                sum += yi;
                cnt += 1;
            }
        }
        if cnt == 0 {
            return Err(ExperimentError::invalid(
                "unloaded torque",
                ErrorKind::TooShort,
                "no sample lies outside the event windows; cannot estimate the offset",
            ));
        }
        let offset = sum / cnt as f64;
        // Linear interpolation of the torque at time tt (None outside the run).
        let interp = |tt: f64| -> Option<f64> {
            let x = (tt - t0) / dt;
            if x < 0.0 || x > (n - 1) as f64 {
                return None;
            }
            let i = (x.floor() as usize).min(n - 2);
            let f = x - i as f64;
            Some(y[i] * (1.0 - f) + y[i + 1] * f)
        };
        let mut acc = vec![0.0; len];
        let mut count = vec![0u32; len];
        for (q, &e) in all.iter().enumerate() {
            let limit = all.get(q + 1).copied().unwrap_or(f64::INFINITY);
            for k in 0..len {
                let tt = e + k as f64 * dt;
                if tt >= limit {
                    break;
                }
                match interp(tt) {
                    Some(v) => {
                        acc[k] += v - offset;
                        count[k] += 1;
                    }
                    None => break,
                }
            }
        }
        let template: Vec<f64> = acc
            .iter()
            .zip(&count)
            .map(|(a, &c)| if c > 0 { a / f64::from(c) } else { 0.0 })
            .collect();
        let mut est = NoiseEstimate {
            dt_s: dt,
            offset_nm: offset,
            template_nm: template,
            template_count: count,
            events,
            sigma_nm: 0.0,
            lag1: 0.0,
            ar1_phi: 0.0,
            ar1_sd_nm: 0.0,
            white_sd_nm: 0.0,
            autocorrelation: Vec::new(),
        };
        let remainder = |est: &NoiseEstimate| -> (Vec<f64>, f64, f64) {
            let sys = est.systematic_for(t, &est.events);
            let rem: Vec<f64> = y.iter().zip(&sys).map(|(a, b)| a - b).collect();
            let mean = rem.iter().sum::<f64>() / n as f64;
            let c0 = rem.iter().map(|r| (r - mean) * (r - mean)).sum::<f64>() / n as f64;
            (rem, mean, c0)
        };
        let (mut rem, mut mean, mut c0) = remainder(&est);
        if s.adaptive_window && c0 > 0.0 {
            // Cut at the first block whose mean square is below twice the averaging noise.
            let nb = ((s.block_s / dt).round() as usize).max(1);
            let h = &est.template_nm;
            let cnt = &est.template_count;
            let cut = (0..h.len())
                .find(|&k| {
                    let end = (k + nb).min(h.len());
                    let ms = h[k..end].iter().map(|v| v * v).sum::<f64>();
                    let se2 = cnt[k..end]
                        .iter()
                        .map(|&c| c0 / f64::from(c.max(1)))
                        .sum::<f64>();
                    ms < 2.0 * se2
                })
                .unwrap_or(h.len());
            est.template_nm.truncate(cut);
            est.template_count.truncate(cut);
            // Re-estimate the offset outside the shortened windows (more samples); `c + h`
            // inside the windows is unchanged.
            let w = cut as f64 * dt;
            let (mut sum, mut cnt) = (0.0, 0usize);
            for (&ti, &yi) in t.iter().zip(y) {
                if !all.iter().any(|&e| ti >= e && ti < e + w) {
                    sum += yi;
                    cnt += 1;
                }
            }
            if cnt > 0 {
                let c_new = sum / cnt as f64;
                for v in &mut est.template_nm {
                    *v += est.offset_nm - c_new;
                }
                est.offset_nm = c_new;
            }
            (rem, mean, c0) = remainder(&est);
        }
        if c0.is_nan() || c0 <= 0.0 {
            est.sigma_nm = 0.0;
            est.autocorrelation = vec![1.0];
            return Ok(est);
        }
        let acf = |k: usize| -> f64 {
            if k >= n {
                return 0.0;
            }
            rem.windows(k + 1)
                .map(|w| (w[0] - mean) * (w[k] - mean))
                .sum::<f64>()
                / n as f64
                / c0
        };
        let rho1 = acf(1);
        // Lag where a pure AR(1) with ρ₁ would reach ½, at least 2.
        let kh = if rho1 > 0.0 && rho1 < 1.0 {
            ((0.5f64.ln() / rho1.ln()).round() as usize).clamp(2, n / 4)
        } else {
            2
        };
        let max_lag = (8 * kh).max(64).min(n / 2).max(2);
        est.autocorrelation = (0..=max_lag).map(acf).collect();
        let rk = est.autocorrelation[kh];
        let phi = if rho1 > 0.0 && rk > 0.0 && rk < rho1 {
            (rk / rho1).powf(1.0 / (kh - 1) as f64)
        } else {
            rho1.clamp(0.0, 0.999)
        };
        let share = if phi > 0.0 {
            (rho1 / phi).clamp(0.0, 1.0)
        } else {
            0.0
        };
        est.sigma_nm = c0.sqrt();
        est.lag1 = rho1;
        est.ar1_phi = phi;
        est.ar1_sd_nm = (c0 * share).sqrt();
        est.white_sd_nm = (c0 * (1.0 - share)).sqrt();
        Ok(est)
    }

    /// The template's standard error from the remainder, `σ·√(number of averaged
    /// events)⁻¹` at lag 0 (N·m): the noise the subtraction of the template adds near each
    /// event.
    #[must_use]
    pub fn template_se_nm(&self) -> f64 {
        let c = self.template_count.first().copied().unwrap_or(0).max(1);
        self.sigma_nm / f64::from(c).sqrt()
    }

    /// The systematic part `c + Σ_e h(t − e)` at `time_s`, with `h` linearly interpolated on
    /// its grid and zero outside `[0, W)`; events are the given recording's own (for a trial,
    /// [`detect_events`] on its angle). A later event truncates an earlier one's window, as
    /// in the estimation.
    #[must_use]
    pub fn systematic_for(&self, time_s: &[f64], events: &Events) -> Vec<f64> {
        let all = events.all();
        let len = self.template_nm.len();
        let w = len as f64 * self.dt_s;
        let h = |s: f64| -> f64 {
            let x = s / self.dt_s;
            if x.is_nan() || x < 0.0 || len == 0 {
                return 0.0;
            }
            let i = x.floor() as usize;
            if i + 1 < len {
                let f = x - i as f64;
                self.template_nm[i] * (1.0 - f) + self.template_nm[i + 1] * f
            } else if i < len {
                self.template_nm[i]
            } else {
                0.0
            }
        };
        time_s
            .iter()
            .map(|&ti| {
                let mut v = self.offset_nm;
                for (q, &e) in all.iter().enumerate() {
                    let next = all.get(q + 1).copied().unwrap_or(f64::INFINITY);
                    if ti >= e && ti < e + w && ti < next {
                        v += h(ti - e);
                    }
                }
                v
            })
            .collect()
    }

    /// The remainder as a stationary AR(1) for a likelihood: `φ = ρ₁` (the measured lag-one
    /// autocorrelation) and marginal σ, i.e. [`muscle_model::Ar1Gaussian::from_marginal`].
    /// The white share is folded into the AR(1): exact at lag one, it overstates the
    /// correlation at longer lags by `1/c_a` (see [`NoiseEstimate::autocorrelation_check`]).
    ///
    /// # Errors
    /// A remainder with zero variance or `|ρ₁| ≥ 1`.
    pub fn ar1(&self) -> Result<muscle_model::Ar1Gaussian> {
        muscle_model::Ar1Gaussian::from_marginal(self.lag1, self.sigma_nm)
            .map_err(|e| invalid("noise estimate", e.to_string()))
    }

    /// Measured autocorrelation of the remainder against the AR(1)+white and the pure AR(1)
    /// models at the given lags (lags beyond [`NoiseEstimate::autocorrelation`] are skipped).
    #[must_use]
    pub fn autocorrelation_check(&self, lags: &[usize]) -> Vec<LagCheck> {
        let var = self.sigma_nm * self.sigma_nm;
        let ca = if var > 0.0 {
            self.ar1_sd_nm * self.ar1_sd_nm / var
        } else {
            0.0
        };
        lags.iter()
            .filter_map(|&lag| {
                self.autocorrelation.get(lag).map(|&m| LagCheck {
                    lag,
                    measured: m,
                    ar1_white: if lag == 0 {
                        1.0
                    } else {
                        ca * self.ar1_phi.powi(lag as i32)
                    },
                    ar1: self.lag1.powi(lag as i32),
                })
            })
            .collect()
    }
}
