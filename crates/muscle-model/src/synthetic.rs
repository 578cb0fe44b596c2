//! Synthetic trial inputs (seed-like protocol, isometric steps) for examples, tests and benches.
//!
//! These are smooth stand-ins for recorded envelopes; the `experiment` crate owns the real
//! protocol and EMG synthesis.

use crate::error::ModelError;
use crate::inputs::TrialInputs;

/// Position along a trapezoidal-velocity sweep of `dist` (deg) at `speed` (deg/s) with
/// constant-acceleration ramps of `ramp` s, at time `tau` since its start. Returns the
/// distance covered.
fn trapezoid(tau: f64, dist: f64, speed: f64, ramp: f64) -> f64 {
    let cruise = (dist - speed * ramp) / speed;
    let total = 2.0 * ramp + cruise;
    let acc = speed / ramp;
    if tau <= 0.0 {
        0.0
    } else if tau <= ramp {
        0.5 * acc * tau * tau
    } else if tau <= ramp + cruise {
        0.5 * speed * ramp + speed * (tau - ramp)
    } else if tau < total {
        let r = total - tau;
        dist - 0.5 * acc * r * r
    } else {
        dist
    }
}

/// Duration (s) of one trapezoidal sweep.
pub fn sweep_duration(dist_deg: f64, speed_deg_s: f64, ramp_s: f64) -> f64 {
    2.0 * ramp_s + (dist_deg - speed_deg_s * ramp_s) / speed_deg_s
}

/// Raised-cosine step from 0 at `t0` to 1 at `t1`.
fn smoothstep(t: f64, t0: f64, t1: f64) -> f64 {
    if t <= t0 {
        0.0
    } else if t >= t1 {
        1.0
    } else {
        0.5 - 0.5 * (std::f64::consts::PI * (t - t0) / (t1 - t0)).cos()
    }
}

/// Phase boundaries of the seed-like trial (s).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SeedTimes {
    /// End of the initial hold / start of the concentric sweep.
    pub concentric_start: f64,
    /// Reversal (end of concentric / start of eccentric sweep).
    pub reversal: f64,
    /// End of the eccentric sweep / start of the final hold.
    pub eccentric_end: f64,
    /// End of the trial.
    pub end: f64,
}

/// Phase times of the `seed` protocol (`docs/formats.md`, "Synthetic trials"): 0.5 s hold, 35° sweeps at 30 °/s with 50 ms
/// ramps, 0.4 s final hold.
pub fn seed_times() -> SeedTimes {
    let sweep = sweep_duration(35.0, 30.0, 0.05);
    SeedTimes {
        concentric_start: 0.5,
        reversal: 0.5 + sweep,
        eccentric_end: 0.5 + 2.0 * sweep,
        end: 0.5 + 2.0 * sweep + 0.4,
    }
}

/// Ankle angle of the `seed` protocol at time `t` (deg): +15° hold, trapezoidal sweep to −20°
/// and back, hold.
pub fn seed_angle_deg_at(t: f64) -> f64 {
    let st = seed_times();
    if t < st.reversal {
        15.0 - trapezoid(t - st.concentric_start, 35.0, 30.0, 0.05)
    } else {
        -20.0 + trapezoid(t - st.reversal, 35.0, 30.0, 0.05)
    }
}

/// Drive (envelope) shape of the seed-like trial at `t`: 0 at rest, ramps to 1 over 0.1–0.4 s,
/// back to 0 over the final hold (from 0.05 s to 0.3 s after the eccentric sweep).
pub fn seed_drive_at(t: f64) -> f64 {
    let st = seed_times();
    smoothstep(t, 0.1, 0.4) * (1.0 - smoothstep(t, st.eccentric_end + 0.05, st.eccentric_end + 0.3))
}

/// Rest level of the synthetic envelopes.
pub const REST_LEVEL: f64 = 0.02;

/// The seed-like trial sampled at `fs`: the `seed` protocol's angle, envelopes `0.02 → level → 0.02`
/// with levels 1.0 (sol), 0.9 (gm), 0.85 (gl); the TA envelope is 0.05 plus 0.1 during the
/// sweeps.
pub fn seed_like_trial(fs: f64) -> Result<TrialInputs, ModelError> {
    let st = seed_times();
    let n = (st.end * fs).round() as usize + 1;
    let t: Vec<f64> = (0..n).map(|i| i as f64 / fs).collect();
    let angle = t
        .iter()
        .map(|&t| seed_angle_deg_at(t).to_radians())
        .collect();
    let levels = [1.0, 0.9, 0.85];
    let env = levels.map(|lv| {
        t.iter()
            .map(|&t| REST_LEVEL + (lv - REST_LEVEL) * seed_drive_at(t))
            .collect::<Vec<f64>>()
    });
    let ta = t
        .iter()
        .map(|&t| {
            0.05 + 0.1
                * smoothstep(t, st.concentric_start, st.concentric_start + 0.1)
                * (1.0 - smoothstep(t, st.eccentric_end - 0.1, st.eccentric_end))
        })
        .collect();
    TrialInputs::new(fs, 0.0, angle, env, Some(ta))
}

/// An isometric trial at `angle_deg`: all three envelopes at [`REST_LEVEL`] until `onset_s`, then
/// a step to `level` (between two samples) held to `duration_s`.
pub fn isometric_trial(
    fs: f64,
    duration_s: f64,
    angle_deg: f64,
    level: f64,
    onset_s: f64,
) -> Result<TrialInputs, ModelError> {
    let n = (duration_s * fs).round() as usize + 1;
    let angle = vec![angle_deg.to_radians(); n];
    let e: Vec<f64> = (0..n)
        .map(|i| {
            if (i as f64) / fs < onset_s {
                REST_LEVEL
            } else {
                level
            }
        })
        .collect();
    TrialInputs::new(fs, 0.0, angle, [e.clone(), e.clone(), e], None)
}

/// A constant-velocity trial through `angle_deg` at `speed_deg_s` (negative = plantarflexion =
/// concentric for the triceps surae) with constant envelopes `level`: the angle is
/// `angle_deg + speed·(t − t_mid)`, so it passes `angle_deg` at `t_mid = duration/2`.
pub fn constant_velocity_trial(
    fs: f64,
    duration_s: f64,
    angle_deg: f64,
    speed_deg_s: f64,
    level: f64,
) -> Result<TrialInputs, ModelError> {
    let n = (duration_s * fs).round() as usize + 1;
    let tm = 0.5 * duration_s;
    let angle = (0..n)
        .map(|i| (angle_deg + speed_deg_s * (i as f64 / fs - tm)).to_radians())
        .collect();
    let e = vec![level; n];
    TrialInputs::new(fs, 0.0, angle, [e.clone(), e.clone(), e], None)
}

/// Stride period of [`gait_like_trial`] (s).
pub const GAIT_STRIDE_S: f64 = 1.1;

/// A periodic bump of the gait phase `phi` (cycles) centred on `centre` with concentration
/// `kappa` (a von Mises shape, 1 at its centre, smooth and periodic).
fn bump(phi: f64, centre: f64, kappa: f64) -> f64 {
    (kappa * ((std::f64::consts::TAU * (phi - centre)).cos() - 1.0)).exp()
}

/// A treadmill-walking-like trial of `duration_s` sampled at `fs`, for tests and benchmarks of
/// long recordings: strides of about [`GAIT_STRIDE_S`] (the phase drifts by ±2 % and the
/// envelopes' amplitude by ±10 % over several strides, so no two strides are the same), the
/// ankle between about 12° of dorsiflexion and 15° of plantarflexion, the knee flexed 5–70°
/// (a knee-angle series), and smooth normalised envelopes with bursts where the muscles of
/// walking are active (soleus and gastrocnemii in mid to late stance, peaks 0.15, 0.6 and
/// 0.3; tibialis anterior in swing and at heel strike). The shapes are those of normal gait
/// only roughly (no subject's data): what matters is that every input changes throughout,
/// as in a recorded gait trial.
pub fn gait_like_trial(fs: f64, duration_s: f64) -> Result<TrialInputs, ModelError> {
    use std::f64::consts::TAU;
    let n = (duration_s * fs).round() as usize + 1;
    let t: Vec<f64> = (0..n).map(|i| i as f64 / fs).collect();
    let phase = |t: f64| t / GAIT_STRIDE_S + 0.02 * (TAU * t / 7.3).sin();
    let gain = |t: f64| 1.0 + 0.1 * (TAU * t / 13.1).sin();
    let angle = t
        .iter()
        .map(|&t| {
            let p = phase(t);
            (2.0 + 8.0 * (TAU * p - 1.2).sin() - 18.0 * bump(p, 0.63, 12.0)).to_radians()
        })
        .collect();
    let knee = t
        .iter()
        .map(|&t| {
            let p = phase(t);
            (5.0 + 15.0 * bump(p, 0.15, 20.0) + 65.0 * bump(p, 0.73, 7.0)).to_radians()
        })
        .collect();
    let env = |level: f64, centre: f64, kappa: f64, rest: f64| -> Vec<f64> {
        t.iter()
            .map(|&t| rest + gain(t) * level * bump(phase(t), centre, kappa))
            .collect()
    };
    let sol = env(0.15, 0.40, 6.0, 0.02);
    let gm = env(0.6, 0.42, 8.0, 0.03);
    let gl = env(0.3, 0.42, 8.0, 0.02);
    let ta: Vec<f64> = t
        .iter()
        .map(|&t| {
            let p = phase(t);
            0.03 + gain(t) * (0.3 * bump(p, 0.8, 6.0) + 0.2 * bump(p, 0.02, 25.0))
        })
        .collect();
    TrialInputs::new(fs, 0.0, angle, [sol, gm, gl], Some(ta))?.with_knee_angle(knee)
}
