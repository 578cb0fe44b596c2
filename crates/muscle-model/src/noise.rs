//! AR(1)-plus-white torque noise: parameters, moment fit, Kalman whitening (with skipped samples) and exact likelihood.
//!
//! The model of a zero-mean residual `y_t` is a stationary AR(1) state seen through white
//! measurement noise:
//!
//! ```text
//! y_t = x_t + v_t,        v_t ~ N(0, σ_w²)
//! x_t = φ·x_{t−1} + w_t,  w_t ~ N(0, σ_a²(1 − φ²)),   x_0 ~ N(0, σ_a²)   (Var x = σ_a²)
//! γ_0 = σ_a² + σ_w²,      γ_k = σ_a²·φ^k  (k ≥ 1),     ρ_k = φ^k·σ_a²/(σ_a² + σ_w²)
//! ```
//!
//! **Exact likelihood** (scalar Kalman filter, prediction `x̂_t`, variance `P_t`, from
//! `x̂_0 = 0`, `P_0 = σ_a²`):
//!
//! ```text
//! ν_t = y_t − x̂_t,   F_t = P_t + σ_w²,   K_t = P_t/F_t
//! x̂_{t+1} = φ·(x̂_t + K_t·ν_t),   P_{t+1} = φ²·P_t·σ_w²/F_t + σ_a²(1 − φ²)
//! ℓ(y) = −½ Σ_t (ln 2π + ln F_t + ν_t²/F_t)
//! ```
//!
//! **Whitening**: `ν_t/√F_t` are i.i.d. `N(0, 1)` under the model. The gains `K_t` and
//! variances `F_t` do not depend on the data, so a [`WhitenPlan`] tabulates them once and the
//! whitening is linear (it also whitens a Jacobian column). A *skipped* (masked, held-out)
//! sample is a prediction step only — `x̂ ← φx̂`, `P ← φ²P + σ_a²(1 − φ²)`, output 0 — which
//! keeps the likelihood of the remaining samples exact. [`GaussianIid`] (`φ = 0`, `σ_a = 0`)
//! and [`Ar1Gaussian`] (`σ_w = 0`) are special cases with plans of their own.
//!
//! **Moment fit** ([`Ar1White::fit`]): with `γ̂_k = (1/n)Σ_t (y_t − ȳ)(y_{t+k} − ȳ)` (or about
//! zero), least squares of `ln γ̂_k = ln σ_a² + k·ln φ` over the lags `k = 1, 2, …` until the
//! first `γ̂_k ≤ c·γ̂_1` (the white part only adds to `γ̂_0`); then `φ = min(e^slope, 0.9999)`
//! (slope capped at `−10⁻⁶`), `σ_a² = min(e^intercept, γ̂_0)`, `σ_w² = max(γ̂_0 − σ_a², floors)`.
//!
//! ```
//! use muscle_model::{Ar1Gaussian, Ar1White, NoiseLikelihood};
//!
//! let e = [0.3, -0.1, 0.4, 0.2, -0.5];
//! // Without white noise it is the exact AR(1) likelihood.
//! let a = Ar1White::new(0.8, 1.5, 0.0).unwrap();
//! let b = Ar1Gaussian::from_marginal(0.8, 1.5).unwrap();
//! assert!((a.log_likelihood(&e) - b.log_likelihood(&e)).abs() < 1e-12);
//! // Whitening reproduces it: ℓ = log_norm − ½Σ w².
//! let m = Ar1White::new(0.8, 1.5, 0.4).unwrap();
//! let plan = m.plan(e.len(), None);
//! let mut w = [0.0; 5];
//! plan.whiten(&e, &mut w);
//! let ss: f64 = w.iter().map(|v| v * v).sum();
//! assert!((plan.log_likelihood(ss) - m.log_likelihood(&e)).abs() < 1e-12);
//! ```

use serde::{Deserialize, Serialize};

use crate::error::ModelError;
use crate::likelihood::{Ar1Gaussian, GaussianIid, NoiseLikelihood};

const LN_2PI: f64 = 1.837_877_066_409_345_5;

/// AR(1) plus independent white noise (see the module docs): `y_t = x_t + v_t`,
/// `x_t = φ·x_{t−1} + w_t`, `Var x = σ_a²`, `Var v = σ_w²`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Ar1White {
    /// AR coefficient φ, `|φ| < 1`.
    pub phi: f64,
    /// Stationary standard deviation σ_a of the AR(1) part (N·m).
    pub sigma_ar: f64,
    /// Standard deviation σ_w of the white part (N·m).
    pub sigma_white: f64,
}

/// Options of the moment fit [`Ar1White::fit`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MomentFit {
    /// Largest lag used (must be below the record length).
    pub max_lag: usize,
    /// Autocovariances about the sample mean (`true`) or about zero (`false`).
    pub demean: bool,
    /// The lags end at the first `γ̂_k ≤ stop_fraction·γ̂_1` (0: at the first `γ̂_k ≤ 0`).
    pub stop_fraction: f64,
    /// Fewest lags the log-linear fit needs (at least 2).
    pub min_lags: usize,
    /// Floor of `σ_w²` as a fraction of `γ̂_0`.
    pub min_white_fraction: f64,
    /// Absolute floor of `σ_w²` (N·m²).
    pub min_white_var: f64,
}

impl MomentFit {
    /// Lags `1..=max_lag` about zero, ending at the first non-positive autocovariance, at
    /// least two lags, no floor on `σ_w²`.
    pub fn new(max_lag: usize) -> Self {
        MomentFit {
            max_lag,
            demean: false,
            stop_fraction: 0.0,
            min_lags: 2,
            min_white_fraction: 0.0,
            min_white_var: 0.0,
        }
    }
}

/// Biased lag-`k` autocovariance `(1/n)Σ_{t<n−k}(e_t − mean)(e_{t+k} − mean)` (0 for `k ≥ n`).
pub fn autocovariance(e: &[f64], mean: f64, k: usize) -> f64 {
    let n = e.len();
    if k >= n {
        return 0.0;
    }
    e.iter()
        .zip(&e[k..])
        .map(|(a, b)| (a - mean) * (b - mean))
        .sum::<f64>()
        / n as f64
}

impl Ar1White {
    /// Validated constructor: `|φ| < 1`, `σ_a ≥ 0`, `σ_w ≥ 0`, not both zero.
    ///
    /// # Errors
    /// [`ModelError::InvalidValue`] naming the field.
    pub fn new(phi: f64, sigma_ar: f64, sigma_white: f64) -> Result<Self, ModelError> {
        if !(phi.is_finite() && phi.abs() < 1.0) {
            return Err(ModelError::invalid(
                "phi",
                format!("{phi} must be in (-1, 1)"),
            ));
        }
        if !(sigma_ar.is_finite() && sigma_ar >= 0.0) {
            return Err(ModelError::invalid(
                "sigma_ar",
                format!("{sigma_ar} must be finite and non-negative"),
            ));
        }
        if !(sigma_white.is_finite() && sigma_white >= 0.0 && sigma_ar + sigma_white > 0.0) {
            return Err(ModelError::invalid(
                "sigma_white",
                format!("{sigma_white} must be finite, non-negative, and not zero with sigma_ar"),
            ));
        }
        Ok(Self {
            phi,
            sigma_ar,
            sigma_white,
        })
    }

    /// Marginal standard deviation `sqrt(σ_a² + σ_w²)`.
    pub fn marginal_sd(&self) -> f64 {
        self.sigma_ar.hypot(self.sigma_white)
    }

    /// Autocorrelation at lag `k` (1 at `k = 0`): `φ^k·σ_a²/(σ_a² + σ_w²)`.
    pub fn autocorrelation(&self, k: u32) -> f64 {
        if k == 0 {
            return 1.0;
        }
        let v = self.sigma_ar * self.sigma_ar;
        let g0 = v + self.sigma_white * self.sigma_white;
        if g0 > 0.0 {
            self.phi.powi(k as i32) * v / g0
        } else {
            0.0
        }
    }

    /// Moment fit of `(φ, σ_a, σ_w)` to a residual (see the module docs).
    ///
    /// # Errors
    /// [`ModelError::InvalidValue`] (key `residual`) when the record is not longer than
    /// `max_lag`, not finite, has zero variance, or has fewer than `min_lags` usable lags.
    pub fn fit(e: &[f64], opts: &MomentFit) -> Result<Self, ModelError> {
        let n = e.len();
        let bad = |reason: &str| ModelError::invalid("residual", reason);
        if n <= opts.max_lag.max(2) || e.iter().any(|v| !v.is_finite()) {
            return Err(bad("the record is too short for the lags or not finite"));
        }
        let mean = if opts.demean {
            e.iter().sum::<f64>() / n as f64
        } else {
            0.0
        };
        let g = |k: usize| autocovariance(e, mean, k);
        let g0 = g(0);
        if g0 <= 0.0 {
            return Err(bad("the record has zero variance"));
        }
        let threshold = opts.stop_fraction * g(1);
        let mut logs = Vec::with_capacity(opts.max_lag);
        for k in 1..=opts.max_lag.max(2) {
            let gk = g(k);
            if gk <= threshold {
                break;
            }
            logs.push(gk.ln());
        }
        if logs.len() < opts.min_lags.max(2) {
            return Err(bad("too few positive autocovariances"));
        }
        let m = logs.len() as f64;
        let mx = (m + 1.0) / 2.0;
        let my = logs.iter().sum::<f64>() / m;
        let (mut sxy, mut sxx) = (0.0, 0.0);
        for (i, y) in logs.iter().enumerate() {
            let dx = (i + 1) as f64 - mx;
            sxy += dx * (y - my);
            sxx += dx * dx;
        }
        let slope = (sxy / sxx).min(-1e-6);
        let phi = slope.exp().min(0.9999);
        let var_ar = (my - slope * mx).exp().min(g0);
        let var_w = (g0 - var_ar)
            .max(opts.min_white_fraction * g0)
            .max(opts.min_white_var);
        Ar1White::new(phi, var_ar.sqrt(), var_w.sqrt())
    }

    fn filter(&self) -> Filter {
        let va = self.sigma_ar * self.sigma_ar;
        Filter {
            phi: self.phi,
            p: va,
            q: va * (1.0 - self.phi * self.phi),
            r: self.sigma_white * self.sigma_white,
        }
    }

    /// The whitening plan for records of up to `n` samples; `mask[t] == false` skips sample
    /// `t` (samples beyond the mask are observed).
    pub fn plan(&self, n: usize, mask: Option<&[bool]>) -> WhitenPlan {
        WhitenPlan::new(self.filter(), n, mask)
    }
}

impl NoiseLikelihood for Ar1White {
    fn log_likelihood(&self, residual: &[f64]) -> f64 {
        let mut kf = self.filter();
        let (mut xh, mut ll) = (0.0, 0.0);
        for &e in residual {
            let (k, f) = kf.observe();
            let v = e - xh;
            ll -= 0.5 * (LN_2PI + f.ln() + v * v / f);
            xh = kf.phi * (xh + k * v);
        }
        ll
    }
}

impl GaussianIid {
    /// The whitening plan (`e_t/σ`; see [`Ar1White::plan`] for `mask`).
    pub fn plan(&self, n: usize, mask: Option<&[bool]>) -> WhitenPlan {
        let filter = Filter {
            phi: 0.0,
            p: 0.0,
            q: 0.0,
            r: self.sigma * self.sigma,
        };
        WhitenPlan::new(filter, n, mask)
    }
}

impl Ar1Gaussian {
    /// The whitening plan (`e_0/σ_0`, then `(e_t − φe_{t−1})/σw`; see [`Ar1White::plan`] for
    /// `mask`).
    pub fn plan(&self, n: usize, mask: Option<&[bool]>) -> WhitenPlan {
        let q = self.sigma_innov * self.sigma_innov;
        let filter = Filter {
            phi: self.phi,
            p: q / (1.0 - self.phi * self.phi),
            q,
            r: 0.0,
        };
        WhitenPlan::new(filter, n, mask)
    }
}

/// The variance recursion of the scalar Kalman filter (state prediction variance `p`).
struct Filter {
    phi: f64,
    p: f64,
    q: f64,
    r: f64,
}

impl Filter {
    /// Observe one sample: returns `(K_t, F_t)` and advances `P`.
    fn observe(&mut self) -> (f64, f64) {
        let f = self.p + self.r;
        let k = self.p / f;
        self.p = self.phi * self.phi * (self.p * self.r / f) + self.q;
        (k, f)
    }

    /// Skip one sample (prediction only).
    fn skip(&mut self) {
        self.p = self.phi * self.phi * self.p + self.q;
    }
}

/// A tabulated whitening filter: from `x̂ = 0`, `ν = e_t − x̂`, `out_t = ν/√F_t`,
/// `x̂ ← φ(x̂ + K_t·ν)`; at a skipped sample `out_t = 0`, `x̂ ← φx̂`. Then
/// `ℓ(e) = log_norm(n) − ½Σ out_t²`.
#[derive(Clone, Debug, PartialEq)]
pub struct WhitenPlan {
    phi: f64,
    gain: Vec<f64>,
    inv_sqrt_f: Vec<f64>,
    observed: Vec<bool>,
    log_norm: Vec<f64>,
    n_obs: usize,
}

impl WhitenPlan {
    fn new(mut filter: Filter, n: usize, mask: Option<&[bool]>) -> Self {
        let mut gain = Vec::with_capacity(n);
        let mut inv_sqrt_f = Vec::with_capacity(n);
        let mut observed = Vec::with_capacity(n);
        let mut log_norm = Vec::with_capacity(n + 1);
        let mut acc = 0.0;
        log_norm.push(acc);
        for t in 0..n {
            let obs = mask.and_then(|m| m.get(t).copied()).unwrap_or(true);
            if obs {
                let (k, f) = filter.observe();
                gain.push(k);
                inv_sqrt_f.push(1.0 / f.sqrt());
                acc -= 0.5 * (LN_2PI + f.ln());
            } else {
                filter.skip();
                gain.push(0.0);
                inv_sqrt_f.push(0.0);
            }
            observed.push(obs);
            log_norm.push(acc);
        }
        let n_obs = observed.iter().filter(|o| **o).count();
        WhitenPlan {
            phi: filter.phi,
            gain,
            inv_sqrt_f,
            observed,
            log_norm,
            n_obs,
        }
    }

    /// Longest record it handles.
    pub fn len(&self) -> usize {
        self.gain.len()
    }

    /// Whether it handles no sample at all.
    pub fn is_empty(&self) -> bool {
        self.gain.is_empty()
    }

    /// Number of observed (not skipped) samples.
    pub fn n_obs(&self) -> usize {
        self.n_obs
    }

    /// Whether each sample is observed.
    pub fn observed(&self) -> &[bool] {
        &self.observed
    }

    /// Whitens `e` into `out` (`ν_t/√F_t`; 0 at skipped samples), over the shortest of `e`,
    /// `out` and the plan.
    pub fn whiten(&self, e: &[f64], out: &mut [f64]) {
        let mut xh = 0.0;
        let steps = out
            .iter_mut()
            .zip(e)
            .zip(&self.gain)
            .zip(&self.inv_sqrt_f)
            .zip(&self.observed);
        for ((((o, &x), &k), &s), &obs) in steps {
            if obs {
                let v = x - xh;
                *o = s * v;
                xh = self.phi * (xh + k * v);
            } else {
                *o = 0.0;
                xh *= self.phi;
            }
        }
    }

    /// The whitened unit impulse at sample `at` into `out` (cleared first): samples
    /// `at, at+1, …` of the whitening of the record that is 1 at `at` and 0 elsewhere (before
    /// `at` the whitened record is 0), up to where the filter's state has decayed below `tol`
    /// or to the plan's end. Whitening is linear, so a step's whitened column at every onset
    /// follows from these by suffix sums at a cost of their length, not the record's.
    pub fn whitened_impulse(&self, at: usize, tol: f64, out: &mut Vec<f64>) {
        out.clear();
        let mut xh = 0.0;
        for t in at..self.len() {
            let x = if t == at { 1.0 } else { 0.0 };
            if self.observed[t] {
                let v = x - xh;
                out.push(self.inv_sqrt_f[t] * v);
                xh = self.phi * (xh + self.gain[t] * v);
            } else {
                out.push(0.0);
                xh *= self.phi;
            }
            if xh.abs() < tol {
                break;
            }
        }
    }

    /// Whitens `N` records at once without storing them and returns the inner products of
    /// the whitened records, `G[i][j] = Σ_t w_i(t)·w_j(t)` (`i ≤ j` filled, the rest 0).
    /// `row(t)` gives sample `t` of every record, for `t` in `0..n` (`n` at most
    /// [`WhitenPlan::len`]). The `N` filter recursions are independent, so running them side
    /// by side overlaps their latency: one pass costs about what one record's
    /// [`WhitenPlan::whiten`] does, and no whitened vector is written to memory.
    pub fn whitened_gram<const N: usize, F: FnMut(usize) -> [f64; N]>(
        &self,
        n: usize,
        mut row: F,
    ) -> [[f64; N]; N] {
        let mut xh = [0.0; N];
        let mut g = [[0.0; N]; N];
        let n = n.min(self.len());
        for t in 0..n {
            let e = row(t);
            if self.observed[t] {
                let (k, s) = (self.gain[t], self.inv_sqrt_f[t]);
                let mut w = [0.0; N];
                for j in 0..N {
                    let v = e[j] - xh[j];
                    w[j] = s * v;
                    xh[j] = self.phi * (xh[j] + k * v);
                }
                for i in 0..N {
                    for j in i..N {
                        g[i][j] += w[i] * w[j];
                    }
                }
            } else {
                for x in xh.iter_mut() {
                    *x *= self.phi;
                }
            }
        }
        g
    }

    /// `−½Σ(ln 2π + ln F_t)` over the observed samples among the first `n`: the part of the
    /// log-likelihood of an `n`-sample record that does not depend on the data.
    pub fn log_norm(&self, n: usize) -> f64 {
        self.log_norm[n.min(self.len())]
    }

    /// Exact log-likelihood of a whole record (all [`WhitenPlan::len`] samples) given the sum
    /// of squares of its whitened residual.
    pub fn log_likelihood(&self, whitened_ss: f64) -> f64 {
        self.log_norm(self.len()) - 0.5 * whitened_ss
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    /// Dense `log N(e; 0, Σ)` by Cholesky.
    fn dense_loglik(s: &[f64], e: &[f64]) -> f64 {
        let n = e.len();
        let mut l = vec![0.0; n * n];
        for i in 0..n {
            for j in 0..=i {
                let mut v = s[i * n + j];
                for k in 0..j {
                    v -= l[i * n + k] * l[j * n + k];
                }
                l[i * n + j] = if i == j { v.sqrt() } else { v / l[j * n + j] };
            }
        }
        let mut z = vec![0.0; n];
        for i in 0..n {
            let mut v = e[i];
            for k in 0..i {
                v -= l[i * n + k] * z[k];
            }
            z[i] = v / l[i * n + i];
        }
        let logdet: f64 = (0..n).map(|i| 2.0 * l[i * n + i].ln()).sum();
        -0.5 * (n as f64 * LN_2PI + logdet + z.iter().map(|v| v * v).sum::<f64>())
    }

    fn covariance(m: &Ar1White, idx: &[usize]) -> Vec<f64> {
        let n = idx.len();
        let mut s = vec![0.0; n * n];
        for (a, &i) in idx.iter().enumerate() {
            for (b, &j) in idx.iter().enumerate() {
                s[a * n + b] = m.sigma_ar.powi(2) * m.phi.powi((i as i32 - j as i32).abs())
                    + if i == j { m.sigma_white.powi(2) } else { 0.0 };
            }
        }
        s
    }

    fn simulate(m: &Ar1White, n: usize, seed: u64) -> Vec<f64> {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let mut normal = move || {
            // Box–Muller from two uniforms.
            let u1: f64 = rng.random::<f64>().max(1e-300);
            let u2: f64 = rng.random();
            (-2.0 * u1.ln()).sqrt() * (2.0 * std::f64::consts::PI * u2).cos()
        };
        let mut x = m.sigma_ar * normal();
        let s_innov = m.sigma_ar * (1.0 - m.phi * m.phi).sqrt();
        (0..n)
            .map(|_| {
                x = m.phi * x + s_innov * normal();
                x + m.sigma_white * normal()
            })
            .collect()
    }

    #[test]
    fn kalman_likelihood_equals_dense_gaussian() {
        let m = Ar1White::new(0.7, 1.1, 0.5).unwrap();
        let e = [0.4, -0.2, 0.9, 0.1, -0.6, 0.3];
        let idx: Vec<usize> = (0..e.len()).collect();
        let dense = dense_loglik(&covariance(&m, &idx), &e);
        let kf = m.log_likelihood(&e);
        assert!((dense - kf).abs() < 1e-10, "{dense} vs {kf}");
        let plan = m.plan(e.len(), None);
        let mut w = [0.0; 6];
        plan.whiten(&e, &mut w);
        let ll = plan.log_likelihood(w.iter().map(|v| v * v).sum());
        assert!((dense - ll).abs() < 1e-10, "{dense} vs plan {ll}");
    }

    #[test]
    fn no_white_noise_is_the_ar1_model() {
        let e = simulate(&Ar1White::new(0.9, 1.3, 0.2).unwrap(), 300, 4);
        for phi in [0.0, 0.5, 0.95] {
            let a = Ar1White::new(phi, 1.3, 0.0).unwrap();
            let b = Ar1Gaussian::from_marginal(phi, 1.3).unwrap();
            let (la, lb) = (a.log_likelihood(&e), b.log_likelihood(&e));
            assert!((la - lb).abs() < 1e-9, "phi {phi}: {la} vs {lb}");
            // And the AR(1) plan whitens like the AR(1)+white one.
            let (pa, pb) = (a.plan(e.len(), None), b.plan(e.len(), None));
            let (mut wa, mut wb) = (vec![0.0; e.len()], vec![0.0; e.len()]);
            pa.whiten(&e, &mut wa);
            pb.whiten(&e, &mut wb);
            for (x, y) in wa.iter().zip(&wb) {
                assert!((x - y).abs() < 1e-9, "{x} vs {y}");
            }
            assert!((pa.log_norm(e.len()) - pb.log_norm(e.len())).abs() < 1e-9);
        }
        // φ = 0, σ_a = 0 is the i.i.d. model.
        let a = Ar1White::new(0.0, 0.0, 0.8).unwrap();
        let b = GaussianIid::new(0.8).unwrap();
        assert!((a.log_likelihood(&e) - b.log_likelihood(&e)).abs() < 1e-9);
    }

    #[test]
    fn masked_whitening_is_the_likelihood_of_the_observed_samples() {
        let m = Ar1White::new(0.85, 0.9, 0.35).unwrap();
        let e = [0.2, -0.4, 0.7, 1.1, f64::NAN, -0.3, 0.5, 0.0, -0.8];
        let mask = [true, true, false, true, false, false, true, true, true];
        let plan = m.plan(e.len(), Some(&mask));
        assert_eq!(plan.n_obs(), 6);
        assert_eq!(plan.observed(), &mask);
        let mut w = vec![1.0; e.len()];
        plan.whiten(&e, &mut w);
        for (v, &obs) in w.iter().zip(&mask) {
            assert!(v.is_finite());
            if !obs {
                assert_eq!(*v, 0.0);
            }
        }
        let idx: Vec<usize> = (0..e.len()).filter(|&t| mask[t]).collect();
        let kept: Vec<f64> = idx.iter().map(|&t| e[t]).collect();
        let dense = dense_loglik(&covariance(&m, &idx), &kept);
        let ll = plan.log_likelihood(w.iter().map(|v| v * v).sum());
        assert!((dense - ll).abs() < 1e-10, "{dense} vs {ll}");
        // A full mask is the unmasked plan; a short mask leaves the tail observed.
        let full = m.plan(e.len(), Some(&[true; 9]));
        assert_eq!(full, m.plan(e.len(), None));
        assert_eq!(m.plan(e.len(), Some(&[true; 3])), full);
    }

    #[test]
    fn moment_fit_recovers_the_generating_process() {
        let truth = Ar1White::new(0.98, 1.2, 0.4).unwrap();
        let e = simulate(&truth, 200_000, 3);
        let m = Ar1White::fit(&e, &MomentFit::new(20)).unwrap();
        assert!((m.phi - 0.98).abs() < 0.003, "phi {}", m.phi);
        assert!((m.sigma_ar - 1.2).abs() < 0.06, "sigma_ar {}", m.sigma_ar);
        assert!(
            (m.sigma_white - 0.4).abs() < 0.06,
            "sigma_w {}",
            m.sigma_white
        );
        let opts = MomentFit {
            max_lag: 80,
            demean: true,
            stop_fraction: 0.1,
            min_lags: 3,
            min_white_fraction: 1e-4,
            min_white_var: 1e-8,
        };
        let d = Ar1White::fit(&e, &opts).unwrap();
        assert!((d.phi - 0.98).abs() < 0.003, "phi {}", d.phi);
        assert!((d.marginal_sd() - truth.marginal_sd()).abs() < 0.06);
        assert!((m.autocorrelation(1) - truth.autocorrelation(1)).abs() < 0.02);
    }

    #[test]
    fn bad_inputs_are_errors() {
        assert!(Ar1White::new(1.0, 1.0, 0.1).is_err());
        assert!(Ar1White::new(0.5, 0.0, 0.0).is_err());
        assert!(Ar1White::new(0.5, -1.0, 0.1).is_err());
        assert!(Ar1White::new(f64::NAN, 1.0, 0.1).is_err());
        let opts = MomentFit::new(5);
        assert!(Ar1White::fit(&[0.0; 100], &opts).is_err());
        assert!(Ar1White::fit(&[1.0, -1.0, 1.0], &opts).is_err());
        // Alternating signs: γ̂_1 < 0, no usable lag.
        let alt: Vec<f64> = (0..100)
            .map(|t| if t % 2 == 0 { 1.0 } else { -1.0 })
            .collect();
        assert!(Ar1White::fit(&alt, &opts).is_err());
    }

    #[test]
    fn whitened_gram_matches_whitening_each_record() {
        let m = Ar1White::new(0.95, 1.1, 0.4).unwrap();
        let n = 500;
        let mask: Vec<bool> = (0..n).map(|t| t % 37 != 5).collect();
        let plan = m.plan(n, Some(&mask));
        let recs: Vec<Vec<f64>> = (0..3)
            .map(|j| {
                (0..n)
                    .map(|t| ((t * (j + 2)) as f64 * 0.013).sin() + j as f64)
                    .collect()
            })
            .collect();
        let mut w = vec![vec![0.0; n]; 3];
        for j in 0..3 {
            plan.whiten(&recs[j], &mut w[j]);
        }
        let g = plan.whitened_gram::<3, _>(n, |t| [recs[0][t], recs[1][t], recs[2][t]]);
        for i in 0..3 {
            for j in i..3 {
                let want: f64 = w[i].iter().zip(&w[j]).map(|(a, b)| a * b).sum();
                assert!(
                    (g[i][j] - want).abs() <= 1e-12 * want.abs().max(1.0),
                    "{i}{j}"
                );
            }
        }
    }

    #[test]
    fn whitened_impulses_sum_to_the_whitened_step() {
        let m = Ar1White::new(0.984, 1.2, 0.4).unwrap();
        let n = 400;
        let mask: Vec<bool> = (0..n).map(|t| t % 53 != 7).collect();
        let plan = m.plan(n, Some(&mask));
        let mut d = Vec::new();
        for at in [0, 7, 120, 399] {
            plan.whitened_impulse(at, 1e-14, &mut d);
            assert!(!d.is_empty() && at + d.len() <= n);
            let mut imp = vec![0.0; n];
            imp[at] = 1.0;
            let mut w = vec![0.0; n];
            plan.whiten(&imp, &mut w);
            assert!(w[..at].iter().all(|v| *v == 0.0));
            for (i, v) in w[at..].iter().enumerate() {
                let got = d.get(i).copied().unwrap_or(0.0);
                assert!(
                    (got - v).abs() < 1e-12,
                    "impulse at {at}, sample {i}: {got} vs {v}"
                );
            }
        }
        // the step at s is the sum of the impulses at s, s + 1, …
        let s0 = 150;
        let step: Vec<f64> = (0..n).map(|t| if t >= s0 { 1.0 } else { 0.0 }).collect();
        let mut w = vec![0.0; n];
        plan.whiten(&step, &mut w);
        let mut sum = vec![0.0; n];
        for at in s0..n {
            plan.whitened_impulse(at, 1e-14, &mut d);
            for (i, v) in d.iter().enumerate() {
                sum[at + i] += v;
            }
        }
        for i in 0..n {
            assert!(
                (sum[i] - w[i]).abs() < 1e-10,
                "sample {i}: {} vs {}",
                sum[i],
                w[i]
            );
        }
    }
}
