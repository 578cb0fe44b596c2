//! Motion events (starts, reversals, stops) detected from a measured angle trace.
//!
//! The angular velocity is the central difference of the angle over `±smooth_s` (5 ms), in
//! °/s. A sample is *moving* when `|v| > moving_fraction · max|v|` (0.7). Each moving run is
//! one sweep (runs of the same direction less than `min_hold_s` apart are merged, so noise
//! near the threshold cannot split a sweep). Its start is found by extrapolating the
//! acceleration ramp to zero speed: with `t_lo`, `t_hi` the (linearly interpolated) times at
//! which `|v|` crosses `ramp_low` (20 %) and `ramp_high` (60 %) of the sweep's median moving
//! speed,
//!
//! ```text
//! t₀ = t_lo − (t_hi − t_lo) · ramp_low / (ramp_high − ramp_low);
//! ```
//!
//! the end is found the same way on the falling edge. Two consecutive sweeps of opposite
//! direction with less than `min_hold_s` (50 ms) between the end of one and the start of the
//! other form a **reversal**, placed at the zero crossing of the velocity between them;
//! otherwise the first ends with a **stop** and the second begins with a **start**. The first
//! sweep begins with a start and the last ends with a stop.
//!
//! For a trapezoidal profile with ramps longer than `2·smooth_s/(1 − ramp_high)` this is
//! exact (both crossings lie on the straight part of the smoothed ramp): the 2048 Hz
//! protocols' events are reproduced to 10⁻⁶ s, and with a 0.01° encoder to about 1 ms
//! (`tests/noise.rs`). The two thresholds well above the noise floor of the velocity are what
//! make the timing robust to encoder quantisation (`docs/dynamometer.md` compares it with a
//! low-threshold detector).
//!
//! ```
//! use experiment::{detect_events, Protocol};
//!
//! let trace = Protocol::Seed.trace()?;
//! let events = detect_events(&trace.time_s, &trace.angle_deg)?;
//! assert_eq!(events.reversals.len(), 1);
//! assert!((events.starts[0] - trace.events.starts[0]).abs() < 1e-6);
//! # Ok::<(), experiment::ExperimentError>(())
//! ```

use serde::{Deserialize, Serialize};

use crate::error::{ErrorKind, ExperimentError, Result};
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

pub(crate) fn invalid(what: &str, reason: impl Into<String>) -> ExperimentError {
    ExperimentError::invalid(what, ErrorKind::InvalidSettings, reason)
}

/// The sampling interval of a uniformly sampled series `(time_s, values)` after checking it:
/// equal lengths, at least 16 samples, finite values, increasing time.
pub(crate) fn check_series(what: &str, time_s: &[f64], values: &[f64]) -> Result<f64> {
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
