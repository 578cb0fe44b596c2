//! Tolerances and limits of the adaptive integrator ([`AdaptiveSettings`]).

use crate::error::OdeError;

/// Tolerances and limits of the adaptive integrator.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AdaptiveSettings {
    /// Relative tolerance (default 1e-6).
    pub rtol: f64,
    /// Absolute tolerance (default 1e-9).
    pub atol: f64,
    /// First step size; `None` picks one from the problem (Hairer's `hinit`).
    pub h_init: Option<f64>,
    /// Largest step size (default unlimited).
    pub h_max: f64,
    /// Smallest step size before [`OdeError::StepSizeUnderflow`] (default 1e-14).
    pub h_min: f64,
    /// Largest number of attempted steps (default 1 000 000).
    pub max_steps: usize,
    /// Weight `β` of the previous step's error in the PI step-size controller
    /// ([`crate::DoPri5`]'s `h_new = h·safety·err^(−α)·err_prev^β`, `α = 0.2 − 0.75β`), in
    /// `[0, 0.1]` (default [`DEFAULT_PI_BETA`]). Larger values make the step size follow the
    /// error more slowly, which damps its oscillation where the steps run near the method's
    /// stability limit (Hairer & Wanner II, section IV.2; `DOPRI5`'s `WORK(5)`).
    pub pi_beta: f64,
}

/// The default [`AdaptiveSettings::pi_beta`], Hairer's `DOPRI5` default.
pub const DEFAULT_PI_BETA: f64 = 0.04;

/// A damped [`AdaptiveSettings::pi_beta`] for steps that run near the stability limit.
pub const STABILISED_PI_BETA: f64 = 0.08;

impl Default for AdaptiveSettings {
    fn default() -> Self {
        Self {
            rtol: 1e-6,
            atol: 1e-9,
            h_init: None,
            h_max: f64::INFINITY,
            h_min: 1e-14,
            max_steps: 1_000_000,
            pi_beta: DEFAULT_PI_BETA,
        }
    }
}

impl AdaptiveSettings {
    /// Sets the relative tolerance.
    #[must_use]
    pub fn with_rtol(mut self, rtol: f64) -> Self {
        self.rtol = rtol;
        self
    }
    /// Sets the absolute tolerance.
    #[must_use]
    pub fn with_atol(mut self, atol: f64) -> Self {
        self.atol = atol;
        self
    }
    /// Sets the first step size.
    #[must_use]
    pub fn with_h_init(mut self, h: f64) -> Self {
        self.h_init = Some(h);
        self
    }
    /// Sets the largest step size.
    #[must_use]
    pub fn with_h_max(mut self, h: f64) -> Self {
        self.h_max = h;
        self
    }
    /// Sets the step budget.
    #[must_use]
    pub fn with_max_steps(mut self, n: usize) -> Self {
        self.max_steps = n;
        self
    }
    /// Sets the step controller's weight `β` of the previous error.
    #[must_use]
    pub fn with_pi_beta(mut self, beta: f64) -> Self {
        self.pi_beta = beta;
        self
    }

    /// Checks the tolerances, step sizes and step budget.
    pub(crate) fn validate(&self) -> Result<(), OdeError> {
        let ok_tol = |v: f64| v.is_finite() && v >= 0.0;
        if !ok_tol(self.rtol) || !ok_tol(self.atol) || (self.rtol == 0.0 && self.atol == 0.0) {
            return Err(OdeError::InvalidInput {
                what: "tolerances must be finite, non-negative and not both zero",
            });
        }
        if let Some(h) = self.h_init {
            if !(h.is_finite() && h > 0.0) {
                return Err(OdeError::InvalidInput {
                    what: "h_init must be positive and finite",
                });
            }
        }
        if self.h_max.is_nan()
            || self.h_max <= 0.0
            || self.h_min.is_nan()
            || self.h_min < 0.0
            || self.h_min > self.h_max
        {
            return Err(OdeError::InvalidInput {
                what: "need 0 <= h_min <= h_max and h_max > 0",
            });
        }
        if !(0.0..=0.1).contains(&self.pi_beta) {
            return Err(OdeError::InvalidInput {
                what: "pi_beta must be in [0, 0.1]",
            });
        }
        if self.max_steps == 0 {
            return Err(OdeError::InvalidInput {
                what: "max_steps must be positive",
            });
        }
        Ok(())
    }
}
