//! Torque-noise models for the likelihood (i.i.d., AR(1), AR(1) + white) and their moment fits.
//!
//! The dynamometer's random error is an AR(1) process plus white noise (docs/dynamometer.md). Their sum is
//! an ARMA(1,1) process whose lag-one autocorrelation `ρ₁ = φ·σ_a²/(σ_a² + σ_w²)` is much
//! smaller than the AR coefficient `φ` that governs the long-lag correlation, so an AR(1)
//! fitted on lag one misstates the correlation that sets the width of the posterior.
//! [`Ar1White`] models the sum exactly (state-space form, scalar Kalman filter).

use muscle_model::noise::autocovariance;
use muscle_model::{Ar1Gaussian, GaussianIid, MomentFit, NoiseLikelihood};
use serde::{Deserialize, Serialize};

use crate::McmcError;

/// AR(1) plus white noise: [`muscle_model::Ar1White`] (the model, its exact Kalman likelihood
/// and whitening live in `muscle_model::noise`).
pub use muscle_model::Ar1White;

/// The tabulated whitening filter of a [`Noise`] ([`muscle_model::WhitenPlan`]).
pub type Whitener = muscle_model::WhitenPlan;

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
        let g0 = autocovariance(e, 0.0, 0);
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
                let m = Ar1White::fit(e, &MomentFit::new(max_lag.max(2)))
                    .map_err(|_| fail("fewer than two positive autocovariances"))?;
                Ok(NoiseParams::Ar1White {
                    phi: m.phi,
                    sigma_ar: m.sigma_ar,
                    sigma_white: m.sigma_white,
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

    /// The model as a [`NoiseLikelihood`] for [`muscle_model::Problem::log_likelihood_with`].
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
            } => Noise::Ar1White(Ar1White::new(phi, sigma_ar, sigma_white).map_err(
                |e| match e {
                    muscle_model::ModelError::InvalidValue { key, .. } if key == "phi" => {
                        bad("phi", phi)
                    }
                    muscle_model::ModelError::InvalidValue { key, .. } if key == "sigma_ar" => {
                        bad("sigma_ar", sigma_ar)
                    }
                    _ => bad("sigma_white", sigma_white),
                },
            )?),
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
        out.resize(e.len(), 0.0);
        self.whitener(e.len()).whiten(e, out);
    }

    /// The time-varying filter of [`Noise::whiten`] tabulated for records of up to `len`
    /// samples (its gains do not depend on the data).
    pub fn whitener(&self, len: usize) -> Whitener {
        match self {
            Noise::Iid(m) => m.plan(len, None),
            Noise::Ar1(m) => m.plan(len, None),
            Noise::Ar1White(m) => m.plan(len, None),
        }
    }
}

impl NoiseLikelihood for Noise {
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
            tab.whiten(&e, &mut w2);
            for (a, b) in w.iter().zip(&w2) {
                assert!((a - b).abs() < 1e-12);
            }
            let ll = tab.log_norm(e.len()) - 0.5 * ss;
            assert!((ll - m.log_likelihood(&e)).abs() < 1e-9 * n);
        }
    }

    #[test]
    fn invalid_parameters_are_errors() {
        let bad = |phi, sigma_ar, sigma_white| {
            NoiseParams::Ar1White {
                phi,
                sigma_ar,
                sigma_white,
            }
            .model()
        };
        assert!(matches!(
            bad(1.0, 1.0, 0.1),
            Err(McmcError::InvalidNoise { field: "phi", .. })
        ));
        assert!(matches!(
            bad(0.5, 0.0, 0.0),
            Err(McmcError::InvalidNoise {
                field: "sigma_white",
                ..
            })
        ));
        assert!(matches!(
            bad(0.5, -1.0, 0.1),
            Err(McmcError::InvalidNoise {
                field: "sigma_ar",
                ..
            })
        ));
        assert!(NoiseParams::fit(NoiseKind::Iid, &[0.0; 100], 5).is_err());
    }
}
