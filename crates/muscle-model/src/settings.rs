//! How a trial is integrated: tolerances, step limits and which of the equivalent forms of the
//! model's ODE is integrated ([`Formulation`]; the equations are in `docs/model.md`).
//!
//! The error control of [`ode::DoPri5`] accepts a step when its scaled RMS error
//! `sqrt(mean (eᵢ / (atol + rtol·max(|yᵢ|, |y₁ᵢ|)))²)` is at most 1, with steps no longer than
//! [`SimSettings::h_max`].

use crate::inputs::TrialInputs;
use ode::AdaptiveSettings;
use serde::{Deserialize, Serialize};

/// Integration settings of a simulation.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct SimSettings {
    /// Relative tolerance of the Dormand–Prince error control.
    pub rtol: f64,
    /// Absolute tolerance (state units: activation, normalised force, metres).
    pub atol: f64,
    /// Largest step (s).
    pub h_max: f64,
    /// Step limit per muscle.
    pub max_steps: usize,
    /// Keep the per-sample states in each [`crate::simulate::MuscleOutput::states`].
    pub record_states: bool,
    /// Which (mathematically equivalent) form of the ODE is integrated.
    pub formulation: Formulation,
}

/// How the model's system (`docs/model.md`) is integrated. Both have the same exact solution; they differ in
/// how integration error behaves.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Formulation {
    /// The four states `[a, F̃T, LM, LMT]` integrated as written in `docs/model.md`, driven by
    /// `vMT = r(q)·q̇`. Integration error makes `LMT` drift from `LMT(q)` and `F̃T` from
    /// `fT(ε)`, and a step that misses a fast feature of `q̇` (quantised or noisy angle data)
    /// leaves a lasting error.
    FourState,
    /// Only `a` and `LM` are integrated; `LMT = LMT(q(t))` and `F̃T = fT(ε(LMT, LM))` are
    /// evaluated from the invariants, so they hold exactly and `q̇` is not needed. Robust to
    /// quantised or noisy angles. [`SimSettings::tight`] uses it.
    Reduced,
    /// The reduced system with its inputs precomputed once per trial (default): activation
    /// `a`, `â`, the fatigue factor and `LMT(q)` at every sample, or at 400 points per second
    /// or more in a low-rate trial (activation integrated once with RK4, 4 substeps per
    /// interval; cubic Hermite between the points), so each
    /// muscle integrates only its fibre length `LM`. Same exact solution as
    /// [`Formulation::Reduced`]; the error control acts on `LM` alone. The per-trial part is
    /// kept with the [`crate::TrialInputs`] (shared by their clones and by every thread and
    /// [`crate::Workspace`]) and reused while the trial, the activation parameters, the delay and
    /// the fatigue rate stay the same.
    #[default]
    Fast,
}

impl Default for SimSettings {
    /// `rtol = 1e-6`, `atol = 1e-8`, `h_max = 30 ms`, [`Formulation::Fast`]: about 1e-3 N·m
    /// RMS from [`SimSettings::tight`] on the seed fixture (`docs/benchmarks.md`).
    fn default() -> Self {
        SimSettings {
            rtol: 1e-6,
            atol: 1e-8,
            h_max: 0.03,
            max_steps: 1_000_000,
            record_states: false,
            formulation: Formulation::Fast,
        }
    }
}

impl SimSettings {
    /// Tight settings for reference runs (`rtol = 1e-10`, `atol = 1e-12`,
    /// [`Formulation::Reduced`], `h_max = 10 ms`).
    pub fn tight() -> Self {
        SimSettings {
            rtol: 1e-10,
            atol: 1e-12,
            h_max: 0.01,
            max_steps: 1_000_000,
            record_states: false,
            formulation: Formulation::Reduced,
        }
    }

    /// The same settings with states recorded.
    #[must_use]
    pub fn with_states(mut self) -> Self {
        self.record_states = true;
        self
    }

    /// The integrator's settings for `inputs`: these tolerances and limits, and for a low-rate
    /// trial ([`TrialInputs::is_low_rate`]) the damped step-size controller
    /// ([`ode::STABILISED_PI_BETA`]).
    ///
    /// Why the damped controller there: with its inputs smooth cubics, what still rejects steps
    /// on a low-rate trial is the controller overshooting near the explicit method's stability
    /// limit (the fibre's `h·|∂L̇M/∂LM|` reaches 1–2.5 through a gait cycle), and a damped
    /// controller spends the same right-hand sides on accepted steps instead
    /// (`docs/model.md`, "Low-rate trials").
    pub(crate) fn adaptive(&self, inputs: &TrialInputs) -> AdaptiveSettings {
        let s = AdaptiveSettings {
            rtol: self.rtol,
            atol: self.atol,
            h_max: self.h_max,
            max_steps: self.max_steps,
            ..AdaptiveSettings::default()
        };
        if inputs.is_low_rate() {
            s.with_pi_beta(ode::STABILISED_PI_BETA)
        } else {
            s
        }
    }
}
