//! Torque-noise models for the likelihood (i.i.d., AR(1), AR(1) + white) and their moment fits.
//!
//! The dynamometer's random error is an AR(1) process plus white noise (SPEC §4). Their sum is
//! an ARMA(1,1) process whose lag-one autocorrelation `ρ₁ = φ·σ_a²/(σ_a² + σ_w²)` is much
//! smaller than the AR coefficient `φ` that governs the long-lag correlation, so an AR(1)
//! fitted on lag one misstates the correlation that sets the width of the posterior.
//! [`Ar1White`] models the sum exactly (state-space form, scalar Kalman filter).

use muscle_model::{Ar1Gaussian, GaussianIid, NoiseModel};
use serde::{Deserialize, Serialize};

use crate::McmcError;

const LN_2PI: f64 = 1.837_877_066_409_345_5;

/// AR(1) plus independent white noise: `e_t = x_t + w_t`, `x_t = φ·x_{t−1} + η_t`,
/// `η_t ~ N(0, σ_a²(1 − φ²))` (so `Var x = σ_a²`), `w_t ~ N(0, σ_w²)`.
///
/// The exact Gaussian log-likelihood comes from the scalar Kalman filter started at the
/// stationary law `x₀ ~ N(0, σ_a²)`: with prediction `x̂`, variance `P`, innovation
/// `v = e_t − x̂`, `F = P + σ_w²`, `ℓ = −½ Σ (ln 2π + ln F + v²/F)`; update `x̂ += (P/F)·v`,
/// `P ← P·σ_w²/F`; predict `x̂ ← φx̂`, `P ← φ²P + σ_a²(1 − φ²)`.
///
/// ```
/// use identify_mcmc::Ar1White;
/// use muscle_model::{Ar1Gaussian, NoiseModel};
/// // Without white noise it is the exact AR(1) likelihood.
/// let e = [0.3, -0.1, 0.4, 0.2, -0.5];
/// let a = Ar1White::new(0.8, 1.5, 0.0).unwrap();
/// let b = Ar1Gaussian::from_marginal(0.8, 1.5).unwrap();
/// assert!((a.log_likelihood(&e) - b.log_likelihood(&e)).abs() < 1e-12);
/// ```
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Ar1White {
    /// AR coefficient φ, `|φ| < 1`.
    pub phi: f64,
    /// Stationary standard deviation σ_a of the AR(1) part (N·m).
    pub sigma_ar: f64,
    /// Standard deviation σ_w of the white part (N·m).
    pub sigma_white: f64,
}

impl Ar1White {
    /// Validated constructor: `|φ| < 1`, `σ_a ≥ 0`, `σ_w ≥ 0`, not both zero.
    ///
    /// # Errors
    /// [`McmcError::InvalidNoise`] naming the field.
    pub fn new(phi: f64, sigma_ar: f64, sigma_white: f64) -> Result<Self, McmcError> {
        if !(phi.is_finite() && phi.abs() < 1.0) {
            return Err(McmcError::InvalidNoise {
                field: "phi",
                value: phi,
            });
        }
        if !(sigma_ar.is_finite() && sigma_ar >= 0.0) {
            return Err(McmcError::InvalidNoise {
                field: "sigma_ar",
                value: sigma_ar,
            });
        }
        if !(sigma_white.is_finite() && sigma_white >= 0.0 && sigma_ar + sigma_white > 0.0) {
            return Err(McmcError::InvalidNoise {
                field: "sigma_white",
                value: sigma_white,
            });
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

    /// Autocorrelation at lag `k ≥ 1`: `φ^k·σ_a²/(σ_a² + σ_w²)`.
    pub fn autocorrelation(&self, k: u32) -> f64 {
        let v = self.sigma_ar * self.sigma_ar;
        self.phi.powi(k as i32) * v / (v + self.sigma_white * self.sigma_white)
    }
}

impl NoiseModel for Ar1White {
    fn log_likelihood(&self, residual: &[f64]) -> f64 {
        let va = self.sigma_ar * self.sigma_ar;
        let r = self.sigma_white * self.sigma_white;
        let q = va * (1.0 - self.phi * self.phi);
        let mut xh = 0.0;
        let mut p = va;
        let mut ll = 0.0;
        for &e in residual {
            let v = e - xh;
            let f = p + r;
            ll -= 0.5 * (LN_2PI + f.ln() + v * v / f);
            let k = p / f;
            xh = self.phi * (xh + k * v);
            p = self.phi * self.phi * (p * r / f) + q;
        }
        ll
    }
}

/// Which noise model the likelihood uses.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum NoiseKind {
    /// Independent Gaussian errors (the dissertation's eq. 17).
    Iid,
    /// AR(1) with φ the lag-one autocorrelation.
    Ar1,
    /// AR(1) plus white noise ([`Ar1White`]), fitted on lags `1..=max_lag` (default).
    #[default]
    Ar1White,
}

/// A fitted noise model (any of [`NoiseKind`]).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum NoiseParams {
    /// [`GaussianIid`].
    Iid {
        /// Standard deviation (N·m).
        sigma: f64,
    },
    /// [`Ar1Gaussian`] (stationary start).
    Ar1 {
        /// Lag-one coefficient.
        phi: f64,
        /// Innovation standard deviation (N·m).
        sigma_innov: f64,
    },
    /// [`Ar1White`].
    Ar1White {
        /// AR coefficient.
        phi: f64,
        /// Stationary sd of the AR part (N·m).
        sigma_ar: f64,
        /// Sd of the white part (N·m).
        sigma_white: f64,
    },
}

impl NoiseParams {
    /// The kind of this model.
    pub fn kind(&self) -> NoiseKind {
        match self {
            NoiseParams::Iid { .. } => NoiseKind::Iid,
            NoiseParams::Ar1 { .. } => NoiseKind::Ar1,
            NoiseParams::Ar1White { .. } => NoiseKind::Ar1White,
        }
    }

    /// Fit a model of `kind` to a zero-mean noise record by moments.
    ///
    /// * `Iid`: `σ² = mean e²`.
    /// * `Ar1`: `φ = γ̂₁/γ̂₀`, innovation sd from `e_t − φe_{t−1}` ([`Ar1Gaussian::estimate`]).
    /// * `Ar1White`: least squares of `ln γ̂_k = ln σ_a² + k·ln φ` over `k = 1..=max_lag`
    ///   (the white part only adds to `γ̂₀`), then `σ_w² = max(γ̂₀ − σ_a², 0)`. With
    ///   `γ̂_k = (1/n)Σ e_t e_{t+k}` (biased autocovariances). Lags whose `γ̂_k ≤ 0` end the fit.
    ///
    /// # Errors
    /// [`McmcError::NoiseFit`] when the record is too short or degenerate.
    pub fn fit(kind: NoiseKind, e: &[f64], max_lag: usize) -> Result<Self, McmcError> {
        let n = e.len();
        let fail = |reason: &'static str| McmcError::NoiseFit { samples: n, reason };
        if n < 3 * max_lag.max(2) || e.iter().any(|v| !v.is_finite()) {
            return Err(fail("the noise record is too short or not finite"));
        }
        let gamma = |k: usize| e.iter().zip(&e[k..]).map(|(a, b)| a * b).sum::<f64>() / n as f64;
        let g0 = gamma(0);
        if g0 <= 0.0 {
            return Err(fail("the noise record has zero variance"));
        }
        match kind {
            NoiseKind::Iid => Ok(NoiseParams::Iid { sigma: g0.sqrt() }),
            NoiseKind::Ar1 => {
                let a = Ar1Gaussian::estimate(e).map_err(|_| fail("AR(1) moment fit failed"))?;
                Ok(NoiseParams::Ar1 {
                    phi: a.phi,
                    sigma_innov: a.sigma_innov,
                })
            }
            NoiseKind::Ar1White => {
                let (mut sk, mut sy, mut skk, mut sky, mut m) = (0.0, 0.0, 0.0, 0.0, 0.0);
                for k in 1..=max_lag.max(2) {
                    let g = gamma(k);
                    if g <= 0.0 {
                        break;
                    }
                    let (kf, y) = (k as f64, g.ln());
                    sk += kf;
                    sy += y;
                    skk += kf * kf;
                    sky += kf * y;
                    m += 1.0;
                }
                if m < 2.0 {
                    return Err(fail("fewer than two positive autocovariances"));
                }
                let slope = (m * sky - sk * sy) / (m * skk - sk * sk);
                let intercept = (sy - slope * sk) / m;
                let phi = slope.exp().min(0.9999);
                let va = intercept.exp().min(g0);
                let vw = (g0 - va).max(0.0);
                Ok(NoiseParams::Ar1White {
                    phi,
                    sigma_ar: va.sqrt(),
                    sigma_white: vw.sqrt(),
                })
            }
        }
    }

    /// Marginal standard deviation of the model (N·m).
    pub fn marginal_sd(&self) -> f64 {
        match *self {
            NoiseParams::Iid { sigma } => sigma,
            NoiseParams::Ar1 { phi, sigma_innov } => sigma_innov / (1.0 - phi * phi).sqrt(),
            NoiseParams::Ar1White {
                sigma_ar,
                sigma_white,
                ..
            } => sigma_ar.hypot(sigma_white),
        }
    }

    /// The model as a [`NoiseModel`] for [`muscle_model::Problem::log_likelihood_with`].
    ///
    /// # Errors
    /// [`McmcError::InvalidNoise`] for out-of-range values.
    pub fn model(&self) -> Result<Noise, McmcError> {
        let bad = |field: &'static str, value: f64| McmcError::InvalidNoise { field, value };
        Ok(match *self {
            NoiseParams::Iid { sigma } => {
                Noise::Iid(GaussianIid::new(sigma).map_err(|_| bad("sigma", sigma))?)
            }
            NoiseParams::Ar1 { phi, sigma_innov } => Noise::Ar1(
                Ar1Gaussian::new(phi, sigma_innov).map_err(|_| bad("phi/sigma_innov", phi))?,
            ),
            NoiseParams::Ar1White {
                phi,
                sigma_ar,
                sigma_white,
            } => Noise::Ar1White(Ar1White::new(phi, sigma_ar, sigma_white)?),
        })
    }
}

/// A validated noise model (what the likelihood evaluates).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Noise {
    /// Independent Gaussian.
    Iid(GaussianIid),
    /// AR(1).
    Ar1(Ar1Gaussian),
    /// AR(1) + white.
    Ar1White(Ar1White),
}

impl Noise {
    /// The whitened residual: `out[t] = v_t/√F_t`, the standardised one-step prediction errors,
    /// so that `ℓ(e) = −½Σ(ln 2π + ln F_t) − ½Σ out[t]²`. Linear in `e` (the gains do not depend
    /// on the data), so it also whitens a Jacobian column.
    pub fn whiten(&self, e: &[f64], out: &mut Vec<f64>) {
        out.clear();
        match *self {
            Noise::Iid(m) => out.extend(e.iter().map(|v| v / m.sigma)),
            Noise::Ar1(m) => {
                let s0 = m.sigma_innov / (1.0 - m.phi * m.phi).sqrt();
                if let Some(&e0) = e.first() {
                    out.push(e0 / s0);
                }
                out.extend(e.windows(2).map(|w| (w[1] - m.phi * w[0]) / m.sigma_innov));
            }
            Noise::Ar1White(m) => {
                let va = m.sigma_ar * m.sigma_ar;
                let r = m.sigma_white * m.sigma_white;
                let q = va * (1.0 - m.phi * m.phi);
                let (mut xh, mut p) = (0.0, va);
                for &v0 in e {
                    let v = v0 - xh;
                    let f = p + r;
                    out.push(v / f.sqrt());
                    xh = m.phi * (xh + p / f * v);
                    p = m.phi * m.phi * (p * r / f) + q;
                }
            }
        }
    }
}

impl Noise {
    /// The time-varying filter of [`Noise::whiten`] tabulated for records of up to `len`
    /// samples (its gains do not depend on the data).
    pub fn whitener(&self, len: usize) -> Whitener {
        let mut gains = Vec::with_capacity(len);
        let mut scales = Vec::with_capacity(len);
        let phi = match *self {
            Noise::Iid(m) => {
                gains.resize(len, 0.0);
                scales.resize(len, 1.0 / m.sigma);
                0.0
            }
            Noise::Ar1(m) => {
                let s0 = m.sigma_innov / (1.0 - m.phi * m.phi).sqrt();
                for t in 0..len {
                    gains.push(1.0);
                    scales.push(1.0 / if t == 0 { s0 } else { m.sigma_innov });
                }
                m.phi
            }
            Noise::Ar1White(m) => {
                let va = m.sigma_ar * m.sigma_ar;
                let r = m.sigma_white * m.sigma_white;
                let q = va * (1.0 - m.phi * m.phi);
                let mut p = va;
                for _ in 0..len {
                    let f = p + r;
                    gains.push(p / f);
                    scales.push(1.0 / f.sqrt());
                    p = m.phi * m.phi * (p * r / f) + q;
                }
                m.phi
            }
        };
        let mut log_norm = Vec::with_capacity(len + 1);
        let mut acc = 0.0;
        log_norm.push(0.0);
        for s in &scales {
            acc += s.ln() - 0.5 * LN_2PI;
            log_norm.push(acc);
        }
        Whitener {
            phi,
            gains,
            scales,
            log_norm,
        }
    }
}

/// A tabulated whitening filter: `v = e_t − x̂`, `out_t = s_t·v`, `x̂ ← φ(x̂ + k_t·v)` from
/// `x̂ = 0`, so that `ℓ(e) = log_norm(n) − ½Σ out_t²`.
#[derive(Clone, Debug, PartialEq)]
pub struct Whitener {
    phi: f64,
    gains: Vec<f64>,
    scales: Vec<f64>,
    log_norm: Vec<f64>,
}

impl Whitener {
    /// Longest record it handles.
    pub fn len(&self) -> usize {
        self.gains.len()
    }

    /// Whether it handles no sample at all.
    pub fn is_empty(&self) -> bool {
        self.gains.is_empty()
    }

    /// Whiten `e` (at most [`Whitener::len`] samples) into `out[..e.len()]`.
    pub fn apply(&self, e: &[f64], out: &mut [f64]) {
        let mut xh = 0.0;
        for (((o, &x), &k), &s) in out.iter_mut().zip(e).zip(&self.gains).zip(&self.scales) {
            let v = x - xh;
            *o = s * v;
            xh = self.phi * (xh + k * v);
        }
    }

    /// `−½Σ_{t<n}(ln 2π + ln F_t)`, the part of the log-likelihood that does not depend on the
    /// data.
    pub fn log_norm(&self, n: usize) -> f64 {
        self.log_norm[n.min(self.len())]
    }
}

impl NoiseModel for Noise {
    fn log_likelihood(&self, residual: &[f64]) -> f64 {
        match self {
            Noise::Iid(m) => m.log_likelihood(residual),
            Noise::Ar1(m) => m.log_likelihood(residual),
            Noise::Ar1White(m) => m.log_likelihood(residual),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;
    use rand_chacha::ChaCha8Rng;
    use rand_distr::{Distribution, StandardNormal};

    fn simulate(phi: f64, sa: f64, sw: f64, n: usize, seed: u64) -> Vec<f64> {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let z0: f64 = StandardNormal.sample(&mut rng);
        let mut x = sa * z0;
        (0..n)
            .map(|_| {
                let z: f64 = StandardNormal.sample(&mut rng);
                let w: f64 = StandardNormal.sample(&mut rng);
                x = phi * x + sa * (1.0 - phi * phi).sqrt() * z;
                x + sw * w
            })
            .collect()
    }

    #[test]
    fn ar1_white_fit_recovers_the_generating_process() {
        let e = simulate(0.98, 1.2, 0.4, 200_000, 3);
        let NoiseParams::Ar1White {
            phi,
            sigma_ar,
            sigma_white,
        } = NoiseParams::fit(NoiseKind::Ar1White, &e, 20).unwrap()
        else {
            panic!("wrong kind")
        };
        assert!((phi - 0.98).abs() < 0.003, "phi {phi}");
        assert!((sigma_ar - 1.2).abs() < 0.06, "sigma_ar {sigma_ar}");
        assert!(
            (sigma_white - 0.4).abs() < 0.06,
            "sigma_white {sigma_white}"
        );
        // The lag-one AR(1) fit sees a much smaller coefficient.
        let NoiseParams::Ar1 { phi: phi1, .. } = NoiseParams::fit(NoiseKind::Ar1, &e, 20).unwrap()
        else {
            panic!("wrong kind")
        };
        assert!(phi1 < 0.9, "lag-one phi {phi1}");
    }

    #[test]
    fn kalman_likelihood_matches_dense_gaussian() {
        // Dense covariance Σ_ij = σ_a² φ^|i−j| + σ_w² δ_ij, n = 4, via Cholesky.
        let (phi, sa, sw) = (0.7_f64, 1.1_f64, 0.5_f64);
        let e = [0.4, -0.2, 0.9, 0.1];
        let n = e.len();
        let mut s = vec![0.0; n * n];
        for i in 0..n {
            for j in 0..n {
                s[i * n + j] = sa * sa * phi.powi((i as i32 - j as i32).abs())
                    + if i == j { sw * sw } else { 0.0 };
            }
        }
        // Cholesky.
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
        let mut z = [0.0; 4];
        for i in 0..n {
            let mut v = e[i];
            for k in 0..i {
                v -= l[i * n + k] * z[k];
            }
            z[i] = v / l[i * n + i];
        }
        let logdet: f64 = (0..n).map(|i| 2.0 * l[i * n + i].ln()).sum();
        let dense = -0.5 * (n as f64 * LN_2PI + logdet + z.iter().map(|v| v * v).sum::<f64>());
        let kf = Ar1White::new(phi, sa, sw).unwrap().log_likelihood(&e);
        assert!((dense - kf).abs() < 1e-12, "{dense} vs {kf}");
    }

    #[test]
    fn whitening_reproduces_the_likelihood() {
        let e = simulate(0.95, 1.0, 0.3, 500, 9);
        let n = e.len() as f64;
        for p in [
            NoiseParams::Iid { sigma: 1.1 },
            NoiseParams::Ar1 {
                phi: 0.9,
                sigma_innov: 0.4,
            },
            NoiseParams::Ar1White {
                phi: 0.95,
                sigma_ar: 1.0,
                sigma_white: 0.3,
            },
        ] {
            let m = p.model().unwrap();
            let mut w = Vec::new();
            m.whiten(&e, &mut w);
            let mut z = Vec::new();
            m.whiten(&vec![0.0; e.len()], &mut z);
            assert!(z.iter().all(|v| *v == 0.0));
            // ℓ(e) − ℓ(0) = −½ Σ w², whatever the log-determinant.
            let d = m.log_likelihood(&e) - m.log_likelihood(&vec![0.0; e.len()]);
            let ss: f64 = w.iter().map(|v| v * v).sum();
            assert!(
                (d + 0.5 * ss).abs() < 1e-9 * n,
                "{p:?}: {d} vs {}",
                -0.5 * ss
            );
            let tab = m.whitener(e.len());
            let mut w2 = vec![0.0; e.len()];
            tab.apply(&e, &mut w2);
            for (a, b) in w.iter().zip(&w2) {
                assert!((a - b).abs() < 1e-12);
            }
            let ll = tab.log_norm(e.len()) - 0.5 * ss;
            assert!((ll - m.log_likelihood(&e)).abs() < 1e-9 * n);
        }
    }

    #[test]
    fn invalid_parameters_are_errors() {
        assert!(Ar1White::new(1.0, 1.0, 0.1).is_err());
        assert!(Ar1White::new(0.5, 0.0, 0.0).is_err());
        assert!(Ar1White::new(0.5, -1.0, 0.1).is_err());
        assert!(NoiseParams::fit(NoiseKind::Iid, &[0.0; 100], 5).is_err());
    }
}
