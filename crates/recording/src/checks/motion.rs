//! The velocity and plateau check: is the isokinetic test isokinetic?
//!
//! The velocity is the slope of a local least-squares line through the angle over a centred
//! window of **50 ms** (half-width `k = round(0.025·fs)` samples, shrunk near the ends):
//!
//! `v_i = Σ_{j=1..k} j·(θ_{i+j} − θ_{i−j}) / (dt · 2Σ_{j=1..k} j²)`
//!
//! This is a Savitzky–Golay first derivative of order 1. A plain two-point difference of a
//! quantised encoder is useless (a 0.1° step over one 0.5 ms sample is 200 °/s); over the
//! window, a quantisation error of step `q` (sd `q/√12`) leaves a velocity sd of
//! `q/√12 / (dt·√(2Σj²)) ≈ 2q` per second at 2048 Hz, i.e. 0.2 °/s for `q = 0.1°`, an order
//! below the ±10 % tolerance at 30 °/s. The window smears each 50 ms speed ramp over about
//! 100 ms, which costs a few percent of the moving time, not the verdict.
//!
//! The ankle **moves** where `|v| > max(2 °/s, 0.2·v₉₉)`, `v₉₉` the 99th percentile of `|v|`
//! (the cruise speed of any test that moves for more than 1 % of its duration). A **sweep**
//! is a maximal run of moving samples of one sign: `v < 0` (plantarflexing) is
//! [`SweepDirection::Concentric`] for the triceps surae, `v > 0` is
//! [`SweepDirection::Eccentric`].
//!
//! A sweep's **plateau velocity** is the speed `c` that the most samples of the sweep lie
//! within `tol(c) = max(10 %·c, 1 °/s)` of (found exactly over the sorted speeds with two
//! pointers); those samples are "on the plateau". A sweep has a [`Plateau`] when they add up
//! to at least **50 ms**. The plateau's span runs from its first to its last on-plateau
//! sample; its mean velocity and relative sd (`sd/|mean|`) are taken over the whole span.
//!
//! The test is **isokinetic** when it has a plateau and at least **60 %** of the moving time
//! is on a plateau. A trapezoidal ±30 °/s protocol with 50 ms ramps (the seed fixture) scores 94 %; a
//! sinusoidal motion scores at most 45 % (`cos θ ∈ [0.82, 1]` over `|θ| < acos 0.2`), a
//! triangular (constant-acceleration) one about 23 %. No motion at all is a warning too (an
//! isokinetic test that does not move is not one).

use serde::{Deserialize, Serialize};

use super::settings::CheckSettings;
use super::values::num;

/// Direction of a sweep, from the triceps surae's point of view.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum SweepDirection {
    /// Plantarflexing (velocity < 0): the triceps shortens.
    Concentric,
    /// Dorsiflexing (velocity > 0): the triceps lengthens.
    Eccentric,
}

/// A constant-velocity part of one sweep.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Plateau {
    /// Direction of the sweep.
    pub direction: SweepDirection,
    /// Time of the first on-plateau sample, s.
    pub start_s: f64,
    /// Time of the last on-plateau sample, s.
    pub end_s: f64,
    /// Length of the span, `end − start + dt`, s.
    pub duration_s: f64,
    /// Angle at the first on-plateau sample, degrees.
    pub start_angle_deg: f64,
    /// Angle at the last on-plateau sample, degrees.
    pub end_angle_deg: f64,
    /// Mean velocity over the span, °/s (negative for concentric).
    pub mean_velocity_deg_s: f64,
    /// Standard deviation of the velocity over the span divided by |mean|.
    pub relative_sd: f64,
    /// Share of the sweep's moving samples that are on the plateau.
    pub fraction_of_sweep: f64,
}

/// Velocity, sweeps and plateaus.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct MotionCheck {
    /// Width of the velocity window actually used, s (`null` without a sampling rate).
    pub velocity_window_s: Option<f64>,
    /// 99th percentile of |velocity|, °/s.
    pub peak_speed_deg_s: Option<f64>,
    /// Speed above which the ankle counts as moving, °/s.
    pub moving_threshold_deg_s: Option<f64>,
    /// Number of sweeps (runs of moving samples of one sign).
    pub sweeps: usize,
    /// Total moving time, s.
    pub moving_s: f64,
    /// Total on-plateau time of the plateaus, s.
    pub plateau_s: f64,
    /// `plateau_s / moving_s` (`null` when nothing moves).
    pub plateau_fraction: Option<f64>,
    /// The plateaus, in time order (at most one per sweep).
    pub plateaus: Vec<Plateau>,
    /// Whether the test is plateau-dominated (module documentation).
    pub isokinetic: bool,
}

/// Centred least-squares slope of `angle` over `2k + 1` samples (shrunk near the ends; NaN at
/// the first and last sample and wherever the window holds a non-finite value).
fn smoothed_velocity(angle: &[f64], dt: f64, k: usize) -> Vec<f64> {
    let n = angle.len();
    (0..n)
        .map(|i| {
            let kk = k.min(i).min(n - 1 - i);
            if kk == 0 {
                return f64::NAN;
            }
            let num: f64 = (1..=kk)
                .map(|j| j as f64 * (angle[i + j] - angle[i - j]))
                .sum();
            let kf = kk as f64;
            let den = kf * (kf + 1.0) * (2.0 * kf + 1.0) / 3.0; // 2 Σ j²
            num / (den * dt)
        })
        .collect()
}

/// The velocity of an angle trace and its sweeps (module documentation), shared by the
/// plateau check and the trial-kind inference.
pub(super) struct Sweeps {
    /// Width of the velocity window used, s.
    pub window_s: f64,
    /// The smoothed velocity, °/s (NaN where it cannot be computed).
    pub velocity: Vec<f64>,
    /// 99th percentile of |velocity|, °/s.
    pub p99: f64,
    /// The moving threshold, °/s.
    pub threshold: f64,
    /// Maximal runs `(first, end, sign)` of moving samples of one sign.
    pub runs: Vec<(usize, usize, i8)>,
}

/// The sweeps of `angle` sampled every `dt`; `Err(window_s)` when no velocity is finite.
pub(super) fn sweeps(angle: &[f64], dt: f64, s: &CheckSettings) -> Result<Sweeps, f64> {
    let half = 0.5 * s.velocity_window_s / dt;
    let k = if half.is_finite() {
        (half.round().max(1.0) as usize).min(1 << 14)
    } else {
        1
    };
    let window_s = 2.0 * k as f64 * dt;
    let v = smoothed_velocity(angle, dt, k);
    let mut speeds: Vec<f64> = v
        .iter()
        .filter(|x| x.is_finite())
        .map(|x| x.abs())
        .collect();
    if speeds.is_empty() {
        return Err(window_s);
    }
    speeds.sort_by(f64::total_cmp);
    let p99 = speeds[((speeds.len() - 1) as f64 * 0.99).floor() as usize];
    let threshold = s
        .min_moving_speed_deg_s
        .max(s.moving_fraction_of_peak * p99);
    let moving_sign = |x: f64| -> i8 {
        if x.is_finite() && x.abs() > threshold {
            if x < 0.0 {
                -1
            } else {
                1
            }
        } else {
            0
        }
    };
    let mut runs: Vec<(usize, usize, i8)> = Vec::new();
    let mut i = 0;
    while i < v.len() {
        let sg = moving_sign(v[i]);
        if sg == 0 {
            i += 1;
            continue;
        }
        let start = i;
        while i < v.len() && moving_sign(v[i]) == sg {
            i += 1;
        }
        runs.push((start, i, sg));
    }
    Ok(Sweeps {
        window_s,
        velocity: v,
        p99,
        threshold,
        runs,
    })
}

pub(super) fn motion_check(
    angle: &[f64],
    dt: Option<f64>,
    t0: f64,
    s: &CheckSettings,
    warnings: &mut Vec<String>,
) -> MotionCheck {
    let mut out = MotionCheck {
        velocity_window_s: None,
        peak_speed_deg_s: None,
        moving_threshold_deg_s: None,
        sweeps: 0,
        moving_s: 0.0,
        plateau_s: 0.0,
        plateau_fraction: None,
        plateaus: Vec::new(),
        isokinetic: false,
    };
    let Some(dt) = dt else {
        return out;
    };
    let sw = match sweeps(angle, dt, s) {
        Ok(sw) => sw,
        Err(window_s) => {
            out.velocity_window_s = Some(window_s);
            warnings.push(
                "ankle_angle_deg: too few finite samples for a velocity: not an isokinetic test"
                    .to_string(),
            );
            return out;
        }
    };
    out.velocity_window_s = Some(sw.window_s);
    out.peak_speed_deg_s = Some(sw.p99);
    out.moving_threshold_deg_s = Some(sw.threshold);
    let (v, threshold, sweeps) = (&sw.velocity, sw.threshold, &sw.runs);
    out.sweeps = sweeps.len();
    let moving: usize = sweeps.iter().map(|(a, b, _)| b - a).sum();
    out.moving_s = moving as f64 * dt;
    if moving == 0 {
        warnings.push(format!(
            "ankle_angle_deg: no motion faster than {} °/s: not an isokinetic test",
            num(threshold, 1)
        ));
        return out;
    }

    let tol = |c: f64| (s.plateau_tolerance * c).max(s.plateau_tolerance_min_deg_s);
    let mut on_total = 0usize;
    for &(a, b, sg) in sweeps {
        let seg = &v[a..b];
        let mut mags: Vec<f64> = seg.iter().map(|x| x.abs()).collect();
        mags.sort_by(f64::total_cmp);
        let c = plateau_speed(&mags, &tol);
        let on = |x: f64| (x.abs() - c).abs() <= tol(c);
        let count = seg.iter().filter(|x| on(**x)).count();
        if (count as f64) * dt < s.min_plateau_s || count == 0 {
            continue;
        }
        let first = a + seg.iter().position(|x| on(*x)).unwrap_or(0);
        let last = a + seg.iter().rposition(|x| on(*x)).unwrap_or(0);
        let span = &v[first..=last];
        let mean = span.iter().sum::<f64>() / span.len() as f64;
        let var = span.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / span.len() as f64;
        on_total += count;
        out.plateaus.push(Plateau {
            direction: if sg < 0 {
                SweepDirection::Concentric
            } else {
                SweepDirection::Eccentric
            },
            start_s: t0 + first as f64 * dt,
            end_s: t0 + last as f64 * dt,
            duration_s: (last - first + 1) as f64 * dt,
            start_angle_deg: angle[first],
            end_angle_deg: angle[last],
            mean_velocity_deg_s: mean,
            relative_sd: var.sqrt() / mean.abs(),
            fraction_of_sweep: count as f64 / (b - a) as f64,
        });
    }
    out.plateau_s = on_total as f64 * dt;
    let frac = on_total as f64 / moving as f64;
    out.plateau_fraction = Some(frac);
    out.isokinetic = !out.plateaus.is_empty() && frac >= s.min_plateau_fraction;
    if !out.isokinetic {
        warnings.push(format!(
            "ankle_angle_deg: not isokinetic: {} % of the moving time ({} s) within ±{} % of a plateau velocity (at least {} % expected)",
            num(100.0 * frac, 0),
            num(out.moving_s, 2),
            num(100.0 * s.plateau_tolerance, 0),
            num(100.0 * s.min_plateau_fraction, 0)
        ));
    }
    out
}

/// The speed `c` (one of the sorted speeds `a`) with the most speeds within `tol(c)` of it.
fn plateau_speed(a: &[f64], tol: &dyn Fn(f64) -> f64) -> f64 {
    let m = a.len();
    if m == 0 {
        return f64::NAN;
    }
    let (mut lo, mut hi) = (0usize, 0usize);
    let (mut best, mut best_count) = (a[0], 0usize);
    for (i, &c) in a.iter().enumerate() {
        let t = tol(c);
        while lo < i && a[lo] < c - t {
            lo += 1;
        }
        hi = hi.max(i);
        while hi + 1 < m && a[hi + 1] <= c + t {
            hi += 1;
        }
        let count = hi - lo + 1;
        if count > best_count {
            best_count = count;
            best = c;
        }
    }
    best
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn plateau_speed_finds_the_mode() {
        let mut a = vec![1.0, 2.0, 3.0, 29.0, 30.0, 30.0, 30.5, 31.0, 50.0];
        a.sort_by(f64::total_cmp);
        let tol = |c: f64| 0.1 * c;
        let c = plateau_speed(&a, &tol);
        assert!((c - 29.0).abs() < 2.5, "{c}");
    }

    #[test]
    fn velocity_of_a_ramp() {
        let dt = 0.001;
        let x: Vec<f64> = (0..200).map(|i| -30.0 * i as f64 * dt).collect();
        let v = smoothed_velocity(&x, dt, 25);
        assert!(v[0].is_nan() && v[199].is_nan());
        for w in &v[1..199] {
            assert!((w + 30.0).abs() < 1e-9);
        }
    }
}
