//! The torque noise a protocol is designed for: AR(1) plus white noise given by its
//! correlation time, so that one description serves trials at any sampling rate.
//!
//! At sampling interval `Δt` the AR coefficient is `φ = exp(−Δt/τc)`; a correlation time is
//! recovered from a fitted coefficient as `τc = −Δt/ln φ`.

use experiment::{DynamometerCorrection, DynamometerSettings};
use muscle_model::Ar1White;
use serde::Serialize;

use crate::error::{DesignError, Result};

/// AR(1) + white torque noise in physical units.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct DesignNoise {
    /// Stationary sd of the AR(1) part (N·m).
    pub ar1_sd_nm: f64,
    /// Correlation time of the AR(1) part (s).
    pub ar1_corr_time_s: f64,
    /// Sd of the white part (N·m).
    pub white_sd_nm: f64,
}

impl DesignNoise {
    /// The random part of the synthetic dynamometer (σ_AR 1.2 N·m, 0.03 s, white 0.4 N·m).
    #[must_use]
    pub fn synthetic() -> Self {
        Self::from_settings(&DynamometerSettings::default())
    }

    /// The random part of a synthetic dynamometer.
    #[must_use]
    pub fn from_settings(s: &DynamometerSettings) -> Self {
        Self {
            ar1_sd_nm: s.ar1_sd_nm,
            ar1_corr_time_s: s.ar1_corr_time_s,
            white_sd_nm: s.white_sd_nm,
        }
    }

    /// The random part fitted to an unloaded run ([`DynamometerCorrection::from_unloaded`]).
    ///
    /// # Errors
    /// [`DesignError::Invalid`] when the fit has no correlation (φ ≤ 0) or is not finite.
    pub fn from_correction(c: &DynamometerCorrection) -> Result<Self> {
        let r = c.random;
        if !(r.phi > 0.0 && r.phi < 1.0 && c.dt_s > 0.0) {
            return Err(DesignError::Invalid {
                what: "noise",
                reason: format!(
                    "the unloaded run's AR coefficient {} gives no correlation time",
                    r.phi
                ),
            });
        }
        let n = Self {
            ar1_sd_nm: r.sigma_ar,
            ar1_corr_time_s: -c.dt_s / r.phi.ln(),
            white_sd_nm: r.sigma_white,
        };
        n.at(c.dt_s)?;
        Ok(n)
    }

    /// The noise sampled every `dt_s` seconds.
    ///
    /// # Errors
    /// [`DesignError::Invalid`] for non-finite or negative values.
    pub fn at(&self, dt_s: f64) -> Result<Ar1White> {
        let ok = self.ar1_corr_time_s > 0.0 && self.ar1_corr_time_s.is_finite() && dt_s > 0.0;
        let phi = if ok {
            (-dt_s / self.ar1_corr_time_s).exp()
        } else {
            f64::NAN
        };
        Ar1White::new(phi, self.ar1_sd_nm, self.white_sd_nm).map_err(|e| DesignError::Invalid {
            what: "noise",
            reason: e.to_string(),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn correlation_time_round_trips() {
        let n = DesignNoise::synthetic();
        assert_eq!(n.ar1_sd_nm, 1.2);
        let m = n.at(1.0 / 2048.0).unwrap();
        assert!((m.phi - (-1.0 / (2048.0 * 0.03f64)).exp()).abs() < 1e-15);
        assert!(DesignNoise {
            ar1_corr_time_s: -1.0,
            ..n
        }
        .at(0.001)
        .is_err());
    }
}
