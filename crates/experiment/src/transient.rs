//! The dynamometer's event transient: a damped sinusoid after every motion start, reversal and
//! stop, and the least-squares search that fits it (with the offset) to a recording.
//!
//! ```text
//! ε_sys(t) = c + Σ_e h(t − e),   h(s) = e^{−s/τ}·(B sin 2πfs + C cos 2πfs),   s ≥ 0
//! ```
//!
//! For fixed `(τ, f)` the model is linear in `(c, B, C)`, so the search is a grid over `τ`
//! and `f` with `(c, B, C)` from the normal equations at each point: ordinary least squares
//! (`fit_linear`) for the first guess, then generalised least squares on the recording
//! whitened by the random part's Kalman filter (`Gls`), which weighs the AR(1)'s strong low
//! frequencies correctly. The whole schedule (which grids, how often the random part is
//! refitted) is [`crate::correction::DynamometerCorrection::fit`]. The amplitude is
//! `A = √(B² + C²)` and `h(s) = A·e^{−s/τ}·sin(2πfs + ψ)` with `ψ = atan2(C, B)`.

use muscle_model::WhitenPlan;
use serde::{Deserialize, Serialize};

/// Event-locked transient `e^{−s/τ}(B sin 2πfs + C cos 2πfs)`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Transient {
    /// Sine amplitude `B` (N·m).
    pub b_nm: f64,
    /// Cosine amplitude `C` (N·m).
    pub c_nm: f64,
    /// Decay time `τ` (s).
    pub tau_s: f64,
    /// Frequency `f` (Hz).
    pub freq_hz: f64,
}

impl Transient {
    /// No transient.
    pub fn none() -> Self {
        Transient {
            b_nm: 0.0,
            c_nm: 0.0,
            tau_s: 0.05,
            freq_hz: 10.0,
        }
    }

    /// Value `s` seconds after an event (0 before it).
    pub fn at(&self, s: f64) -> f64 {
        if s < 0.0 || s > 12.0 * self.tau_s {
            return 0.0;
        }
        let w = 2.0 * std::f64::consts::PI * self.freq_hz * s;
        (-s / self.tau_s).exp() * (self.b_nm * w.sin() + self.c_nm * w.cos())
    }

    /// `‖self − truth‖ / ‖truth‖` over the first `window_s` seconds after an event, sampled
    /// at `fs` (1.0 for no transient against a real one).
    pub fn relative_error(&self, truth: &Transient, window_s: f64, fs: f64) -> f64 {
        let (mut num, mut den) = (0.0, 0.0);
        for i in 0..(window_s * fs).round() as usize {
            let s = i as f64 / fs;
            let t = truth.at(s);
            num += (self.at(s) - t).powi(2);
            den += t * t;
        }
        (num / den).sqrt()
    }

    /// Whether this is [`Transient::none`]'s zero shape (nothing is subtracted).
    #[must_use]
    pub fn is_none(&self) -> bool {
        self.b_nm == 0.0 && self.c_nm == 0.0
    }

    /// Amplitude `A = √(B² + C²)` (N·m).
    #[must_use]
    pub fn amplitude_nm(&self) -> f64 {
        self.b_nm.hypot(self.c_nm)
    }

    /// Phase `ψ = atan2(C, B)` of `A·e^{−s/τ}·sin(2πfs + ψ)` (rad).
    #[must_use]
    pub fn phase_rad(&self) -> f64 {
        self.c_nm.atan2(self.b_nm)
    }

    /// Adds `scale · Σ_e h(t − e)` to `out` at `times` (uniformly sampled; the windows reach
    /// 12τ after each event, where `h` has decayed to 6·10⁻⁶ of its amplitude).
    pub fn add_to(&self, out: &mut [f64], times: &[f64], events: &[f64], scale: f64) {
        add_scaled_transients(out, times, events, self, scale);
    }
}

/// Fewest units of whitened sum of squares (χ² units) by which the event transient must
/// improve on the offset alone, on the recording it is fitted to, to be kept.
///
/// The transient has four parameters, two of them (`τ`, `f`) searched over a grid, so the
/// improvement is not χ²(4) when there is no transient. Measured on 8 s unloaded runs
/// (`experiment::unloaded_run`, seeds 5000–5099) with the default `DynamometerSettings` random part and no transient:
/// median 6.7, largest 18.7. With the default transient (4 N·m, seeds 5000–5019): 78–216. A 1 N·m
/// transient (median 8.7) cannot be told from none by this or any rule on such a record.
/// (Test: diagnose's `components::a_recording_without_a_transient_gets_none`.)
pub const TRANSIENT_MIN_EVIDENCE: f64 = 30.0;

/// The first grid of the transient search: `τ` = 10 ms × 1.3^k up to 0.3 s, `f` = 1–40 Hz.
pub(crate) fn coarse_grid() -> (Vec<f64>, Vec<f64>) {
    let taus = (0..14).map(|k| 0.01 * 1.3f64.powi(k)).collect();
    let freqs = (1..=40).map(|k| k as f64).collect();
    (taus, freqs)
}

/// Two finer grids around `best` (`τ` × 1.06^±3 and `f` ± 0.5 Hz, then `τ` × 1.02^±3 and
/// `f` ± 0.15 Hz).
pub(crate) fn refine(
    best: &mut (f64, f64, Transient),
    fit: impl Fn(f64, f64) -> (f64, f64, f64, f64),
) {
    for (tf, fstep) in [(1.06f64, 0.1), (1.02, 0.03)] {
        let (taus, freqs) = grid_around(best.2.tau_s, tf, 3, best.2.freq_hz, fstep, 5);
        grid_search(&taus, &freqs, best, &fit);
    }
}

/// A grid around `(τ₀, f₀)`: `τ₀·ratio^k` for `|k| ≤ kt` and the positive `f₀ + fstep·k` for
/// `|k| ≤ kf`.
pub(crate) fn grid_around(
    t0: f64,
    ratio: f64,
    kt: i32,
    f0: f64,
    fstep: f64,
    kf: i32,
) -> (Vec<f64>, Vec<f64>) {
    let taus = (-kt..=kt).map(|k| t0 * ratio.powi(k)).collect();
    let freqs = (-kf..=kf)
        .map(|k| f0 + fstep * k as f64)
        .filter(|f| *f > 0.0)
        .collect();
    (taus, freqs)
}

/// Keeps in `best` = (SS, c, transient) the lowest-SS fit over the grid `taus × freqs`;
/// `fit(τ, f)` returns `(SS, c, B, C)`.
pub(crate) fn grid_search(
    taus: &[f64],
    freqs: &[f64],
    best: &mut (f64, f64, Transient),
    fit: impl Fn(f64, f64) -> (f64, f64, f64, f64),
) {
    for &tau in taus {
        for &f in freqs {
            let (ss, c, b, cc) = fit(tau, f);
            if ss < best.0 {
                *best = (
                    ss,
                    c,
                    Transient {
                        b_nm: b,
                        c_nm: cc,
                        tau_s: tau,
                        freq_hz: f,
                    },
                );
            }
        }
    }
}

/// `out += k·Σ_e h(t − e)`, visiting only the samples of each event's window (from the
/// first sample at or after `e` to 12τ after it).
fn add_scaled_transients(out: &mut [f64], times: &[f64], events: &[f64], tr: &Transient, k: f64) {
    if times.is_empty() {
        return;
    }
    let t0 = times[0];
    let fs = if times.len() > 1 {
        1.0 / (times[1] - t0)
    } else {
        1.0
    };
    for &e in events {
        let i0 = (((e - t0) * fs).ceil().max(0.0)) as usize;
        let i1 = (((e - t0 + 12.0 * tr.tau_s) * fs).ceil().max(0.0) as usize).min(times.len());
        for i in i0..i1 {
            out[i] += k * tr.at(times[i] - e);
        }
    }
}

/// Least squares of `y ≈ c + B·Xs + C·Xc` for one `(τ, f)`; returns (SS, c, B, C).
pub(crate) fn fit_linear(
    y: &[f64],
    times: &[f64],
    events: &[f64],
    tau: f64,
    f: f64,
    with_offset: bool,
) -> (f64, f64, f64, f64) {
    let n = y.len();
    let fs = 1.0 / (times[1] - times[0]);
    let w = 2.0 * std::f64::consts::PI * f;
    // sums over all samples for the constant; window sums for the transient columns
    let sy: f64 = y.iter().sum();
    let syy: f64 = y.iter().map(|v| v * v).sum();
    let (mut s_s, mut s_c, mut s_ss, mut s_cc, mut s_sc, mut s_ys, mut s_yc) =
        (0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0);
    // the event windows may overlap: accumulate both columns per sample (in event order)
    let mut xs = vec![0.0; n];
    let mut xc = vec![0.0; n];
    let (mut lo, mut hi) = (n, 0);
    for &e in events {
        let i0 = ((e * fs).ceil().max(0.0)) as usize;
        let i1 = (((e + 10.0 * tau) * fs).ceil() as usize).min(n);
        for i in i0..i1 {
            let s = times[i] - e;
            let d = (-s / tau).exp();
            let (sn, cs) = (w * s).sin_cos();
            xs[i] += d * sn;
            xc[i] += d * cs;
        }
        if i0 < i1 {
            lo = lo.min(i0);
            hi = hi.max(i1);
        }
    }
    for i in lo..hi {
        let (a, b) = (xs[i], xc[i]);
        s_s += a;
        s_c += b;
        s_ss += a * a;
        s_cc += b * b;
        s_sc += a * b;
        s_ys += y[i] * a;
        s_yc += y[i] * b;
    }
    let gram = [n as f64, s_s, s_c, s_ss, s_sc, s_cc];
    normal_equations(with_offset, gram, [sy, s_ys, s_yc], syy).unwrap_or((syy, 0.0, 0.0, 0.0))
}

/// Least squares `y ≈ c + B·Xs + C·Xc` from its sums: `gram` = `[1·1, 1·Xs, 1·Xc, Xs·Xs,
/// Xs·Xc, Xc·Xc]`, `rhs` = `[1·y, Xs·y, Xc·y]`, `syy` = `y·y`; without the offset the constant
/// column is left out (`c = 0`). Returns `(SS, c, B, C)`, `None` when the system is singular.
fn normal_equations(
    with_offset: bool,
    gram: [f64; 6],
    rhs: [f64; 3],
    syy: f64,
) -> Option<(f64, f64, f64, f64)> {
    let [a00, a01, a02, a11, a12, a22] = gram;
    let (m, rhs) = if with_offset {
        (
            nalgebra::Matrix3::new(a00, a01, a02, a01, a11, a12, a02, a12, a22),
            nalgebra::Vector3::new(rhs[0], rhs[1], rhs[2]),
        )
    } else {
        (
            nalgebra::Matrix3::new(1.0, 0.0, 0.0, 0.0, a11, a12, 0.0, a12, a22),
            nalgebra::Vector3::new(0.0, rhs[1], rhs[2]),
        )
    };
    let inv = m.try_inverse()?;
    let beta = inv * rhs;
    Some((syy - beta.dot(&rhs), beta[0], beta[1], beta[2]))
}

/// Whitened least squares of `y ≈ c + B·Xs + C·Xc` for one `(τ, f)` at a time.
pub(crate) struct Gls<'a> {
    times: &'a [f64],
    events: &'a [f64],
    plan: WhitenPlan,
    /// The recording.
    y: &'a [f64],
    /// Whitened recording.
    wy: Vec<f64>,
    /// `w1·w1`, `w1·wy`, `wy·wy` (the same at every grid point).
    w1_w1: f64,
    w1_wy: f64,
    wy_wy: f64,
    with_offset: bool,
}

fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum::<f64>()
}

impl<'a> Gls<'a> {
    pub(crate) fn new(
        y: &'a [f64],
        times: &'a [f64],
        events: &'a [f64],
        plan: WhitenPlan,
        with_offset: bool,
    ) -> Self {
        let n = y.len();
        let mut wy = vec![0.0; n];
        plan.whiten(y, &mut wy);
        let mut w1 = vec![0.0; n];
        plan.whiten(&vec![1.0; n], &mut w1);
        Gls {
            times,
            events,
            plan,
            y,
            w1_w1: dot(&w1, &w1),
            w1_wy: dot(&w1, &wy),
            wy_wy: dot(&wy, &wy),
            wy,
            with_offset,
        }
    }

    /// `(whitened SS, c)` of the offset alone (`c = 0` without the offset).
    pub(crate) fn without_transient(&self) -> (f64, f64) {
        if self.with_offset && self.w1_w1 > 0.0 {
            let c = self.w1_wy / self.w1_w1;
            (self.wy_wy - c * self.w1_wy, c)
        } else {
            (self.wy_wy, 0.0)
        }
    }

    /// `(whitened SS, c, B, C)`; a singular system scores an infinite SS.
    ///
    /// The two template columns are built in one pass over the event windows (one `exp`
    /// and one `sin`/`cos` per sample), and their whitened inner products with each other,
    /// the constant and the recording come from one pass of [`WhitenPlan::whitened_gram`]
    /// (the same recursions and sums as whitening each column and taking dot products).
    pub(crate) fn fit(&self, tau: f64, f: f64) -> (f64, f64, f64, f64) {
        let n = self.wy.len();
        let (xs, xc) = template_columns(self.times, self.events, tau, f);
        let g = self
            .plan
            .whitened_gram::<4, _>(n, |t| [1.0, xs[t], xc[t], self.y[t]]);
        let (one_xs, one_xc) = if self.with_offset {
            (g[0][1], g[0][2])
        } else {
            (0.0, 0.0)
        };
        let gram = [self.w1_w1, one_xs, one_xc, g[1][1], g[1][2], g[2][2]];
        let rhs = [self.w1_wy, g[1][3], g[2][3]];
        normal_equations(self.with_offset, gram, rhs, self.wy_wy).unwrap_or((
            f64::INFINITY,
            0.0,
            0.0,
            0.0,
        ))
    }
}

/// The template's columns `Σ_events e^{−s/τ}·sin 2πfs` and `… cos 2πfs` (`s` = time since the
/// event, windows of 12τ): the same numbers as [`Transient::add_to`] with `(B, C)` = (1, 0) and
/// (0, 1).
fn template_columns(times: &[f64], events: &[f64], tau: f64, f: f64) -> (Vec<f64>, Vec<f64>) {
    let n = times.len();
    let (mut xs, mut xc) = (vec![0.0; n], vec![0.0; n]);
    if n == 0 {
        return (xs, xc);
    }
    let fs = if n > 1 {
        1.0 / (times[1] - times[0])
    } else {
        1.0
    };
    let shape = Transient {
        b_nm: 1.0,
        c_nm: 0.0,
        tau_s: tau,
        freq_hz: f,
    };
    for &e in events {
        let i0 = ((e * fs).ceil().max(0.0)) as usize;
        let i1 = (((e + 12.0 * tau) * fs).ceil() as usize).min(n);
        for i in i0..i1 {
            let s = times[i] - e;
            if s < 0.0 || s > 12.0 * tau {
                continue;
            }
            let w = 2.0 * std::f64::consts::PI * shape.freq_hz * s;
            let d = (-s / shape.tau_s).exp();
            xs[i] += d * w.sin();
            xc[i] += d * w.cos();
        }
    }
    (xs, xc)
}
