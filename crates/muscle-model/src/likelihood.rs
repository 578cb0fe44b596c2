//! Log-likelihoods of a torque residual `e = measured − predicted` ([`NoiseLikelihood`]):
//! independent Gaussian errors (dissertation eq. 17),
//!
//! ```text
//! ln L = −n/2·ln(2πσ²) − Σ eᵢ² / (2σ²)
//! ```
//!
//! and the exact stationary Gaussian AR(1) likelihood (`e₀ ~ N(0, σw²/(1 − φ²))`),
//!
//! ```text
//! ln L = −½·ln(2π·σw²/(1 − φ²)) − e₀²(1 − φ²)/(2σw²)
//!        − (n − 1)/2·ln(2πσw²) − Σ_{i≥1} (eᵢ − φ·eᵢ₋₁)² / (2σw²)
//! ```
//!
//! The AR(1)-plus-white-noise model and its whitening are in [`crate::noise`]. A residual
//! with a 0/1 mask is scored as independent runs of the included samples
//! (`masked_log_likelihood`).

use crate::error::ModelError;
use serde::{Deserialize, Serialize};

/// A noise model of the torque residual (measured − predicted).
pub trait NoiseLikelihood {
    /// Log-likelihood of one contiguous run of residuals.
    fn log_likelihood(&self, residual: &[f64]) -> f64;
}

/// Independent Gaussian errors with standard deviation `sigma` (dissertation eq. 17).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct GaussianIid {
    /// Standard deviation (N·m).
    pub sigma: f64,
}

impl GaussianIid {
    /// Validated constructor (`sigma > 0`).
    pub fn new(sigma: f64) -> Result<Self, ModelError> {
        if sigma.is_finite() && sigma > 0.0 {
            Ok(GaussianIid { sigma })
        } else {
            Err(ModelError::invalid(
                "sigma",
                format!("{sigma} must be positive"),
            ))
        }
    }

    /// Maximum-likelihood estimate `σ = sqrt(mean e²)` from a residual.
    pub fn estimate(residual: &[f64]) -> Result<Self, ModelError> {
        let n = residual.len().max(1) as f64;
        GaussianIid::new((residual.iter().map(|e| e * e).sum::<f64>() / n).sqrt())
    }
}

const LN_2PI: f64 = 1.837_877_066_409_345_5;

impl NoiseLikelihood for GaussianIid {
    fn log_likelihood(&self, residual: &[f64]) -> f64 {
        let s2 = self.sigma * self.sigma;
        let ss: f64 = residual.iter().map(|e| e * e).sum();
        -0.5 * residual.len() as f64 * (LN_2PI + s2.ln()) - 0.5 * ss / s2
    }
}

/// Stationary Gaussian AR(1) errors `e_t = φ e_{t−1} + w_t`, `w_t ~ N(0, σw²)`; exact
/// likelihood (first sample from the stationary law `N(0, σw²/(1 − φ²))`).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Ar1Gaussian {
    /// Lag-one coefficient φ, `|φ| < 1`.
    pub phi: f64,
    /// Innovation standard deviation σw (N·m).
    pub sigma_innov: f64,
}

impl Ar1Gaussian {
    /// Validated constructor.
    pub fn new(phi: f64, sigma_innov: f64) -> Result<Self, ModelError> {
        if !(phi.is_finite() && phi.abs() < 1.0) {
            return Err(ModelError::invalid(
                "phi",
                format!("{phi} must be in (-1, 1)"),
            ));
        }
        if !(sigma_innov.is_finite() && sigma_innov > 0.0) {
            return Err(ModelError::invalid(
                "sigma_innov",
                format!("{sigma_innov} must be positive"),
            ));
        }
        Ok(Ar1Gaussian { phi, sigma_innov })
    }

    /// From the marginal (stationary) standard deviation: `σw = σ·sqrt(1 − φ²)`.
    pub fn from_marginal(phi: f64, sigma: f64) -> Result<Self, ModelError> {
        Ar1Gaussian::new(phi, sigma * (1.0 - phi * phi).max(0.0).sqrt())
    }

    /// Moment estimate from a residual: φ = lag-one autocorrelation (about zero), σw from
    /// the innovations.
    pub fn estimate(residual: &[f64]) -> Result<Self, ModelError> {
        let n = residual.len();
        if n < 3 {
            return Err(ModelError::invalid("residual", "needs at least 3 samples"));
        }
        let c0: f64 = residual.iter().map(|e| e * e).sum();
        let c1: f64 = residual.windows(2).map(|w| w[0] * w[1]).sum();
        let phi = if c0 > 0.0 {
            (c1 / c0).clamp(-0.999, 0.999)
        } else {
            0.0
        };
        let ss: f64 = residual
            .windows(2)
            .map(|w| (w[1] - phi * w[0]).powi(2))
            .sum();
        Ar1Gaussian::new(phi, (ss / (n - 1) as f64).sqrt())
    }
}

impl NoiseLikelihood for Ar1Gaussian {
    fn log_likelihood(&self, residual: &[f64]) -> f64 {
        let Some(&e0) = residual.first() else {
            return 0.0;
        };
        let s2 = self.sigma_innov * self.sigma_innov;
        let v0 = s2 / (1.0 - self.phi * self.phi);
        let mut ll = -0.5 * (LN_2PI + v0.ln()) - 0.5 * e0 * e0 / v0;
        let mut ss = 0.0;
        for w in residual.windows(2) {
            let d = w[1] - self.phi * w[0];
            ss += d * d;
        }
        ll += -0.5 * (residual.len() - 1) as f64 * (LN_2PI + s2.ln()) - 0.5 * ss / s2;
        ll
    }
}

/// `noise`'s log-likelihood of `residual`: one run without weights; with weights, samples of
/// zero weight are excluded and every maximal run of included samples is an independent
/// segment (weights act as a mask here, not as precisions).
pub(crate) fn masked_log_likelihood<N: NoiseLikelihood + ?Sized>(
    noise: &N,
    residual: &[f64],
    weights: Option<&[f64]>,
) -> f64 {
    let r = residual;
    match weights {
        None => noise.log_likelihood(r),
        Some(w) => {
            let mut ll = 0.0;
            let mut i = 0;
            let n = r.len();
            while i < n {
                if w[i] > 0.0 {
                    let start = i;
                    while i < n && w[i] > 0.0 {
                        i += 1;
                    }
                    ll += noise.log_likelihood(&r[start..i]);
                } else {
                    i += 1;
                }
            }
            ll
        }
    }
}
