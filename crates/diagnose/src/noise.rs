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
//! likelihood of the remaining samples exact.

use serde::Serialize;

const LN_2PI: f64 = 1.837_877_066_409_345_5;

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
        WhitenPlan::new(self, n, mask)
    }

    /// Lag-`k` autocorrelation of the random part (for comparison with the residual's).
    pub fn autocorrelation(&self, k: usize) -> f64 {
        let g0 = self.sd_ar_nm.powi(2) + self.sd_white_nm.powi(2);
        if k == 0 {
            1.0
        } else if g0 > 0.0 {
            self.sd_ar_nm.powi(2) * self.phi.powi(k as i32) / g0
        } else {
            0.0
        }
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

/// `(φ, σ_ar, σ_w)` from the autocovariances of `u` (see the module docs).
pub fn fit_ar1_white(u: &[f64]) -> (f64, f64, f64) {
    let n = u.len();
    if n < 16 {
        let v = u.iter().map(|x| x * x).sum::<f64>() / n.max(1) as f64;
        return (0.0, 0.0, v.sqrt().max(1e-6));
    }
    let mean = u.iter().sum::<f64>() / n as f64;
    let g = |k: usize| -> f64 {
        (0..n - k)
            .map(|i| (u[i] - mean) * (u[i + k] - mean))
            .sum::<f64>()
            / n as f64
    };
    let g0 = g(0);
    let kmax = 80.min(n / 4);
    let mut pts = Vec::new();
    let g1 = g(1);
    for k in 1..=kmax {
        let gk = g(k);
        if gk <= 0.1 * g1 {
            break;
        }
        pts.push((k as f64, gk.ln()));
    }
    if pts.len() < 3 || g1 <= 0.0 {
        return (0.0, 0.0, g0.max(1e-12).sqrt());
    }
    let m = pts.len() as f64;
    let mx = pts.iter().map(|p| p.0).sum::<f64>() / m;
    let my = pts.iter().map(|p| p.1).sum::<f64>() / m;
    let sxy: f64 = pts.iter().map(|p| (p.0 - mx) * (p.1 - my)).sum();
    let sxx: f64 = pts.iter().map(|p| (p.0 - mx) * (p.0 - mx)).sum();
    let slope = (sxy / sxx).min(-1e-6);
    let phi = slope.exp().clamp(0.0, 0.9999);
    let var_ar = (my - slope * mx).exp().min(g0);
    let var_w = (g0 - var_ar).max(1e-4 * g0).max(1e-8);
    (phi, var_ar.sqrt(), var_w.sqrt())
}

/// Precomputed Kalman gains for one mask: whitening is then one pass per vector.
#[derive(Clone, Debug)]
pub struct WhitenPlan {
    phi: f64,
    gain: Vec<f64>,
    inv_sqrt_s: Vec<f64>,
    observed: Vec<bool>,
    log_det: f64,
    n_obs: usize,
}

impl WhitenPlan {
    fn new(m: &NoiseModel, n: usize, mask: Option<&[bool]>) -> Self {
        let phi = m.phi;
        let var_ar = m.sd_ar_nm * m.sd_ar_nm;
        let q = var_ar * (1.0 - phi * phi);
        let r = (m.sd_white_nm * m.sd_white_nm).max(1e-10);
        let mut p = var_ar;
        let mut gain = vec![0.0; n];
        let mut inv_sqrt_s = vec![0.0; n];
        let mut observed = vec![true; n];
        let mut log_det = 0.0;
        let mut n_obs = 0;
        for t in 0..n {
            let pp = if t == 0 { var_ar } else { phi * phi * p + q };
            let obs = mask.is_none_or(|mk| mk[t]);
            observed[t] = obs;
            if obs {
                let s = pp + r;
                let k = pp / s;
                gain[t] = k;
                inv_sqrt_s[t] = 1.0 / s.sqrt();
                log_det += s.ln();
                n_obs += 1;
                p = (1.0 - k) * pp;
            } else {
                p = pp;
            }
        }
        WhitenPlan {
            phi,
            gain,
            inv_sqrt_s,
            observed,
            log_det,
            n_obs,
        }
    }

    /// Number of observed samples.
    pub fn n_obs(&self) -> usize {
        self.n_obs
    }

    /// Whether sample `t` is observed.
    pub fn observed(&self) -> &[bool] {
        &self.observed
    }

    /// Whitens `e` into `out` (`ν_t/√S_t`; 0 at unobserved samples).
    pub fn whiten(&self, e: &[f64], out: &mut [f64]) {
        let mut x = 0.0;
        for t in 0..e.len() {
            let xp = self.phi * x;
            if self.observed[t] {
                let nu = e[t] - xp;
                out[t] = nu * self.inv_sqrt_s[t];
                x = xp + self.gain[t] * nu;
            } else {
                out[t] = 0.0;
                x = xp;
            }
        }
    }

    /// Exact log-likelihood given the whitened residual's sum of squares.
    pub fn log_likelihood(&self, whitened_ss: f64) -> f64 {
        -0.5 * (self.n_obs as f64 * LN_2PI + self.log_det + whitened_ss)
    }
}
