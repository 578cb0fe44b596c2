//! The dynamometer noise model: systematic part (offset + event transients) and an AR(1)-plus-white random part, with its exact whitening filter.
//!
//! Systematic part, fitted by least squares on the unloaded run (grid over `τ`, `f`, linear in
//! the rest):
//!
//! ```text
//! ε_sys(t) = c + Σ_e e^{−(t−e)/τ}·(B sin 2πf(t−e) + C cos 2πf(t−e)),   t ≥ e
//! ```
//!
//! Random part: `y_t = x_t + v_t`, `x_t = φ x_{t−1} + w_t`, `w ~ N(0, σ_ar²(1−φ²))`,
//! `v ~ N(0, σ_w²)` (the SPEC §4 AR(1) + white noise + quantisation). Its autocovariance is
//! `γ_0 = σ_ar² + σ_w²`, `γ_k = σ_ar² φ^k` (k ≥ 1), fitted log-linearly over lags 1…40 ms.
//!
//! Whitening: a scalar Kalman filter on that state-space model gives the innovations
//! `ν_t = y_t − φ x̂_{t−1}` with variances `S_t`; `ν_t/√S_t` are i.i.d. N(0, 1) under the model,
//! and `log L = −½ Σ_t (ln 2π S_t + ν_t²/S_t)` is the exact Gaussian log-likelihood.
//! Masked (held-out) samples are skipped by the filter (prediction only), which keeps the
//! likelihood of the remaining samples exact. The random part, its moment fit, whitening and
//! likelihood are the shared [`muscle_model::Ar1White`] (module `muscle_model::noise`).

use muscle_model::noise::autocovariance;
use muscle_model::{Ar1White, MomentFit};
use serde::Serialize;

/// Where the noise model came from.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum NoiseSource {
    /// Fitted on the unloaded run (offset, transients and random part).
    Unloaded,
    /// Estimated from the baseline residual of the trial itself (no unloaded run): the
    /// dynamometer offset cannot be told from `torque_offset` then.
    TrialResidual,
}

/// Event-locked transient `e^{−s/τ}(B sin 2πfs + C cos 2πfs)`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
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
}

/// The noise model of the torque residual.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct NoiseModel {
    /// Where it was estimated.
    pub source: NoiseSource,
    /// Dynamometer offset `c` (N·m; 0 without an unloaded run).
    pub offset_nm: f64,
    /// Event transient.
    pub transient: Transient,
    /// AR(1) coefficient per sample at the trial's rate.
    pub phi: f64,
    /// Stationary SD of the AR(1) part (N·m).
    pub sd_ar_nm: f64,
    /// SD of the white part (N·m).
    pub sd_white_nm: f64,
    /// RMS of the remainder after the systematic part (N·m).
    pub remainder_rms_nm: f64,
}

impl NoiseModel {
    /// Systematic part at times `t` (s from the first sample) given the event times.
    pub fn systematic(&self, times: &[f64], events: &[f64]) -> Vec<f64> {
        let mut out = vec![self.offset_nm; times.len()];
        add_transients(&mut out, times, events, &self.transient);
        out
    }

    /// Whitening plan for a mask (`None`: every sample observed).
    pub fn plan(&self, n: usize, mask: Option<&[bool]>) -> WhitenPlan {
        self.random_part().plan(n, mask)
    }

    /// The random part as the shared AR(1)-plus-white model (white SD at least `10⁻⁵`).
    pub fn random_part(&self) -> Ar1White {
        Ar1White {
            phi: self.phi,
            sigma_ar: self.sd_ar_nm,
            sigma_white: self.sd_white_nm.max(1e-5),
        }
    }

    /// Lag-`k` autocorrelation of the random part (for comparison with the residual's).
    pub fn autocorrelation(&self, k: usize) -> f64 {
        let m = Ar1White {
            phi: self.phi,
            sigma_ar: self.sd_ar_nm,
            sigma_white: self.sd_white_nm,
        };
        m.autocorrelation(k.min(i32::MAX as usize) as u32)
    }

    /// Fits the systematic and random parts to a recording `y` (the unloaded run, or a
    /// residual) with motion events `events` sampled at `fs`; `with_offset` fits the constant.
    pub fn fit(y: &[f64], fs: f64, events: &[f64], with_offset: bool, source: NoiseSource) -> Self {
        let n = y.len();
        let times: Vec<f64> = (0..n).map(|i| i as f64 / fs).collect();
        let mut best = (f64::INFINITY, 0.0, Transient::none());
        let try_grid = |taus: &[f64], freqs: &[f64], best: &mut (f64, f64, Transient)| {
            for &tau in taus {
                for &f in freqs {
                    let (ss, c, b, cc) = fit_linear(y, &times, events, tau, f, with_offset);
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
        };
        if !events.is_empty() {
            let taus: Vec<f64> = (0..14).map(|k| 0.01 * 1.3f64.powi(k)).collect();
            let freqs: Vec<f64> = (1..=40).map(|k| k as f64).collect();
            try_grid(&taus, &freqs, &mut best);
            for _ in 0..2 {
                let t0 = best.2.tau_s;
                let f0 = best.2.freq_hz;
                let taus: Vec<f64> = (-6..=6).map(|k| t0 * 1.04f64.powi(k)).collect();
                let freqs: Vec<f64> = (-10..=10)
                    .map(|k| f0 + 0.05 * k as f64)
                    .filter(|f| *f > 0.0)
                    .collect();
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
        let (_, offset, transient) = best;
        let mut rem: Vec<f64> = y.iter().map(|v| v - offset).collect();
        add_scaled_transients(&mut rem, &times, events, &transient, -1.0);
        let (phi, sd_ar, sd_white) = fit_ar1_white(&rem);
        let rms = (rem.iter().map(|e| e * e).sum::<f64>() / n.max(1) as f64).sqrt();
        NoiseModel {
            source,
            offset_nm: offset,
            transient,
            phi,
            sd_ar_nm: sd_ar,
            sd_white_nm: sd_white,
            remainder_rms_nm: rms,
        }
    }
}

fn add_transients(out: &mut [f64], times: &[f64], events: &[f64], tr: &Transient) {
    add_scaled_transients(out, times, events, tr, 1.0);
}

fn add_scaled_transients(out: &mut [f64], times: &[f64], events: &[f64], tr: &Transient, k: f64) {
    if times.is_empty() {
        return;
    }
    let fs = if times.len() > 1 {
        1.0 / (times[1] - times[0])
    } else {
        1.0
    };
    for &e in events {
        let i0 = ((e * fs).ceil().max(0.0)) as usize;
        let i1 = (((e + 12.0 * tr.tau_s) * fs).ceil() as usize).min(times.len());
        for i in i0..i1 {
            out[i] += k * tr.at(times[i] - e);
        }
    }
}

/// Least squares of `y ≈ c + B·Xs + C·Xc` for one `(τ, f)`; returns (SS, c, B, C).
fn fit_linear(
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
    // columns may overlap between events only if the windows overlap; accumulate per sample
    let mut xs = vec![0.0; 0];
    let mut xc = vec![0.0; 0];
    let mut idx: Vec<usize> = Vec::new();
    for &e in events {
        let i0 = ((e * fs).ceil().max(0.0)) as usize;
        let i1 = (((e + 10.0 * tau) * fs).ceil() as usize).min(n);
        for i in i0..i1 {
            let s = times[i] - e;
            let d = (-s / tau).exp();
            let (sn, cs) = (w * s).sin_cos();
            idx.push(i);
            xs.push(d * sn);
            xc.push(d * cs);
        }
    }
    // merge overlapping contributions by sorting on index
    let mut order: Vec<usize> = (0..idx.len()).collect();
    order.sort_by_key(|&k| idx[k]);
    let mut k = 0;
    while k < order.len() {
        let i = idx[order[k]];
        let (mut a, mut b) = (0.0, 0.0);
        while k < order.len() && idx[order[k]] == i {
            a += xs[order[k]];
            b += xc[order[k]];
            k += 1;
        }
        s_s += a;
        s_c += b;
        s_ss += a * a;
        s_cc += b * b;
        s_sc += a * b;
        s_ys += y[i] * a;
        s_yc += y[i] * b;
    }
    let nf = n as f64;
    let (m, rhs) = if with_offset {
        (
            nalgebra::Matrix3::new(nf, s_s, s_c, s_s, s_ss, s_sc, s_c, s_sc, s_cc),
            nalgebra::Vector3::new(sy, s_ys, s_yc),
        )
    } else {
        (
            nalgebra::Matrix3::new(1.0, 0.0, 0.0, 0.0, s_ss, s_sc, 0.0, s_sc, s_cc),
            nalgebra::Vector3::new(0.0, s_ys, s_yc),
        )
    };
    match m.try_inverse() {
        Some(inv) => {
            let beta = inv * rhs;
            let ss = syy - beta.dot(&rhs);
            (ss, beta[0], beta[1], beta[2])
        }
        None => (syy, 0.0, 0.0, 0.0),
    }
}

/// `(φ, σ_ar, σ_w)` from the autocovariances of `u` (see the module docs): the shared moment fit
/// [`muscle_model::Ar1White::fit`] about the mean over lags up to `min(80, n/4)`, ending below
/// `0.1·γ̂_1`, with at least 3 lags and `σ_w² ≥ max(10⁻⁴γ̂_0, 10⁻⁸)`; white noise alone when
/// the record is shorter than 16 samples or the fit fails.
pub fn fit_ar1_white(u: &[f64]) -> (f64, f64, f64) {
    let n = u.len();
    if n < 16 {
        let v = u.iter().map(|x| x * x).sum::<f64>() / n.max(1) as f64;
        return (0.0, 0.0, v.sqrt().max(1e-6));
    }
    let opts = MomentFit {
        max_lag: 80.min(n / 4),
        demean: true,
        stop_fraction: 0.1,
        min_lags: 3,
        min_white_fraction: 1e-4,
        min_white_var: 1e-8,
    };
    match Ar1White::fit(u, &opts) {
        Ok(m) => (m.phi, m.sigma_ar, m.sigma_white),
        Err(_) => {
            let mean = u.iter().sum::<f64>() / n as f64;
            let g0 = autocovariance(u, mean, 0);
            (0.0, 0.0, g0.max(1e-12).sqrt())
        }
    }
}

/// Precomputed Kalman gains for one mask ([`muscle_model::WhitenPlan`]): whitening is then one
/// pass per vector.
pub type WhitenPlan = muscle_model::WhitenPlan;
