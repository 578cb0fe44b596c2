//! Plain, copyable settings for the annealer and for Nelder–Mead, with validation.

use serde::{Deserialize, Serialize};

use numerics::NelderMeadSettings;

use crate::Error;

/// The acceptance rule for a move that changes the cost by `Δ` at temperature `T`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Acceptance {
    /// The dissertation's eq. 13, `p = 1 / (1 + exp(Δ/T))` (Barker's rule).
    /// A move with `Δ = 0` is accepted with probability ½.
    #[default]
    Logistic,
    /// Metropolis, `p = min(1, exp(−Δ/T))`.
    Metropolis,
}

impl Acceptance {
    /// The probability of accepting a move with cost change `delta` at temperature `t`.
    ///
    /// Computed without overflow for any `delta/t`; for `t ≤ 0` the rule's
    /// zero-temperature limit is returned (1 for `Δ < 0`, 0 for `Δ > 0`, and
    /// the rule's value at `Δ = 0`).
    ///
    /// ```
    /// use identify_sa::Acceptance;
    /// let p = Acceptance::Logistic.probability(1.0, 2.0);
    /// assert!((p - 1.0 / (1.0 + 0.5f64.exp())).abs() < 1e-15);
    /// assert_eq!(Acceptance::Metropolis.probability(-1.0, 2.0), 1.0);
    /// ```
    #[must_use]
    pub fn probability(self, delta: f64, t: f64) -> f64 {
        if delta.is_nan() {
            return 0.0;
        }
        let z = if t > 0.0 {
            delta / t
        } else if delta > 0.0 {
            f64::INFINITY
        } else if delta < 0.0 {
            f64::NEG_INFINITY
        } else {
            0.0
        };
        match self {
            Acceptance::Logistic => {
                if z > 0.0 {
                    let e = (-z).exp();
                    e / (1.0 + e)
                } else {
                    1.0 / (1.0 + z.exp())
                }
            }
            Acceptance::Metropolis => {
                if z <= 0.0 {
                    1.0
                } else {
                    (-z).exp()
                }
            }
        }
    }

    /// The acceptance probability of a move that does not change the cost
    /// (½ for [`Acceptance::Logistic`], 1 for [`Acceptance::Metropolis`]).
    /// Acceptance ratios are divided by this before being compared with the
    /// step-adaptation band, so the band means the same for both rules.
    #[must_use]
    pub fn neutral(self) -> f64 {
        match self {
            Acceptance::Logistic => 0.5,
            Acceptance::Metropolis => 1.0,
        }
    }
}

/// Settings of the simulated annealing driver [`crate::run`].
///
/// Plain data (`Copy`, `Default`, serde); build with struct-update syntax or
/// the `with_*` methods, and check with [`AnnealSettings::validate`] (the driver
/// validates again). Lengths (`*_step`) are in unit-box coordinates: every
/// parameter is rescaled to `[0, 1]` by its bounds. The defaults and their
/// reasons are listed in the crate documentation.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct AnnealSettings {
    /// Seed of the `ChaCha8Rng` stream. Default 42.
    pub seed: u64,
    /// Total objective evaluations, annealing and polish included. Default 100 000.
    pub max_evaluations: u64,
    /// Acceptance rule. Default [`Acceptance::Logistic`] (eq. 13).
    pub acceptance: Acceptance,
    /// Initial per-coordinate step half-width `v`, unit coordinates. Default 0.5.
    pub initial_step: f64,
    /// Smallest step `v`. Default 1e-10.
    pub min_step: f64,
    /// `N_s`: move cycles (one move per coordinate) between step adaptations. Default 10.
    pub moves_per_adaptation: u32,
    /// `N_T`: step adaptations per temperature stage. Default 5.
    pub adaptations_per_stage: u32,
    /// Corana's step-adaptation gain `c`. Default 2.
    pub step_gain: f64,
    /// Lower edge of the normalised acceptance band. Default 0.4.
    pub target_acceptance_low: f64,
    /// Upper edge of the normalised acceptance band. Default 0.6.
    pub target_acceptance_high: f64,
    /// Cooling factor `r` in `T ← r·T` after every stage. Default 0.85.
    pub cooling: f64,
    /// Moves per event of the initial-temperature search. Default 200.
    pub t0_event_moves: u32,
    /// Factor by which `T` is raised per event. Default 1.2 (+20 %).
    pub t0_growth: f64,
    /// First trial temperature, as a fraction of the median uphill `Δ` seen in
    /// the greedy first event. Default 0.1.
    pub t0_start_fraction: f64,
    /// The accepted count has stabilised when it grows by less than this
    /// fraction of the event's moves between events. Default 0.02.
    pub t0_stable_fraction: f64,
    /// Normalised acceptance ratio an event must reach before stabilisation
    /// counts. Default 0.55 (27.5 % raw with eq. 13; the dissertation saw ≈ 28.5 %).
    pub t0_min_acceptance: f64,
    /// Maximum events of the initial-temperature search. Default 60.
    pub t0_max_events: u32,
    /// Relative tolerance on the best cost across stages. Default 1e-7.
    pub tolerance_rel: f64,
    /// Absolute tolerance on the best cost across stages. Default 1e-10.
    pub tolerance_abs: f64,
    /// `N_ε`: stages over which the best must stay within tolerance. Default 4.
    pub stall_stages: u32,
    /// An annealing pass also ends when `T` falls below this fraction of the
    /// initial temperature. Default 1e-3.
    pub final_temperature: f64,
    /// Re-annealings allowed after convergence. Default 20.
    pub max_reanneals: u32,
    /// Temperature of a re-annealing, as a fraction of the initial one. Default 0.3.
    pub reanneal_temperature: f64,
    /// Step `v` every coordinate restarts with at a re-annealing. Default 0.1.
    pub reanneal_step: f64,
    /// Restart each stage from the best point found so far (Corana). Default true.
    pub restart_from_best: bool,
    /// Share of `max_evaluations` kept for the Nelder–Mead polish; 0 disables
    /// the polish. Default 0.1.
    pub polish_fraction: f64,
    /// Nelder–Mead settings of the polish (its budget is further capped by
    /// what is left of `max_evaluations`).
    pub polish: NelderMeadSettings,
    /// Random start points tried when the start is random and fails. Default 100.
    pub start_attempts: u32,
}

impl Default for AnnealSettings {
    fn default() -> Self {
        Self {
            seed: 42,
            max_evaluations: 100_000,
            acceptance: Acceptance::Logistic,
            initial_step: 0.5,
            min_step: 1e-10,
            moves_per_adaptation: 10,
            adaptations_per_stage: 5,
            step_gain: 2.0,
            target_acceptance_low: 0.4,
            target_acceptance_high: 0.6,
            cooling: 0.85,
            t0_event_moves: 200,
            t0_growth: 1.2,
            t0_start_fraction: 0.1,
            t0_stable_fraction: 0.02,
            t0_min_acceptance: 0.55,
            t0_max_events: 60,
            tolerance_rel: 1e-7,
            tolerance_abs: 1e-10,
            stall_stages: 4,
            final_temperature: 1e-3,
            max_reanneals: 20,
            reanneal_temperature: 0.3,
            reanneal_step: 0.1,
            restart_from_best: true,
            polish_fraction: 0.1,
            polish: NelderMeadSettings::default(),
            start_attempts: 100,
        }
    }
}

fn invalid(name: &'static str, value: f64, reason: &'static str) -> Error {
    Error::Numerics(numerics::NumericsError::InvalidSetting {
        name,
        value,
        reason,
    })
}

fn check_range(
    name: &'static str,
    v: f64,
    lo: f64,
    hi: f64,
    reason: &'static str,
) -> Result<(), Error> {
    // (lo, hi]
    if v > lo && v <= hi {
        Ok(())
    } else {
        Err(invalid(name, v, reason))
    }
}

fn check_nonneg(name: &'static str, v: f64) -> Result<(), Error> {
    if v >= 0.0 && v.is_finite() {
        Ok(())
    } else {
        Err(invalid(name, v, "must be finite and non-negative"))
    }
}

fn check_positive_count(name: &'static str, v: u32) -> Result<(), Error> {
    if v == 0 {
        Err(invalid(name, 0.0, "must be at least 1"))
    } else {
        Ok(())
    }
}

impl AnnealSettings {
    /// Validated settings with the given seed and budget, other fields at their defaults.
    ///
    /// # Errors
    /// [`Error::Numerics`] ([`numerics::NumericsError::InvalidSetting`]) when the budget is 0.
    pub fn new(seed: u64, max_evaluations: u64) -> Result<Self, Error> {
        Self {
            seed,
            max_evaluations,
            ..Self::default()
        }
        .validate()
    }

    /// Set the seed.
    #[must_use]
    pub fn with_seed(mut self, v: u64) -> Self {
        self.seed = v;
        self
    }
    /// Set the total evaluation budget.
    #[must_use]
    pub fn with_max_evaluations(mut self, v: u64) -> Self {
        self.max_evaluations = v;
        self
    }
    /// Set the acceptance rule.
    #[must_use]
    pub fn with_acceptance(mut self, v: Acceptance) -> Self {
        self.acceptance = v;
        self
    }
    /// Set the initial step (unit coordinates).
    #[must_use]
    pub fn with_initial_step(mut self, v: f64) -> Self {
        self.initial_step = v;
        self
    }
    /// Set `N_s` and `N_T`.
    #[must_use]
    pub fn with_stage_length(
        mut self,
        moves_per_adaptation: u32,
        adaptations_per_stage: u32,
    ) -> Self {
        self.moves_per_adaptation = moves_per_adaptation;
        self.adaptations_per_stage = adaptations_per_stage;
        self
    }
    /// Set the normalised acceptance band of step adaptation.
    #[must_use]
    pub fn with_target_acceptance(mut self, low: f64, high: f64) -> Self {
        self.target_acceptance_low = low;
        self.target_acceptance_high = high;
        self
    }
    /// Set the cooling factor `r`.
    #[must_use]
    pub fn with_cooling(mut self, v: f64) -> Self {
        self.cooling = v;
        self
    }
    /// Set the convergence tolerances (absolute, relative) and `N_ε`.
    #[must_use]
    pub fn with_tolerance(mut self, abs: f64, rel: f64, stall_stages: u32) -> Self {
        self.tolerance_abs = abs;
        self.tolerance_rel = rel;
        self.stall_stages = stall_stages;
        self
    }
    /// Set the re-annealing count, temperature fraction and restart step.
    #[must_use]
    pub fn with_reannealing(mut self, max_reanneals: u32, temperature: f64, step: f64) -> Self {
        self.max_reanneals = max_reanneals;
        self.reanneal_temperature = temperature;
        self.reanneal_step = step;
        self
    }
    /// Set the polish share of the budget (0 disables) and its settings.
    #[must_use]
    pub fn with_polish(mut self, fraction: f64, polish: NelderMeadSettings) -> Self {
        self.polish_fraction = fraction;
        self.polish = polish;
        self
    }

    /// Check every field; returns the settings unchanged when valid.
    ///
    /// # Errors
    /// [`Error::Numerics`] ([`numerics::NumericsError::InvalidSetting`]) naming the first invalid field.
    pub fn validate(self) -> Result<Self, Error> {
        if self.max_evaluations == 0 {
            return Err(invalid("max_evaluations", 0.0, "must be at least 1"));
        }
        check_range(
            "initial_step",
            self.initial_step,
            0.0,
            1.0,
            "must be in (0, 1]",
        )?;
        check_range(
            "min_step",
            self.min_step,
            0.0,
            self.initial_step,
            "must be in (0, initial_step]",
        )?;
        check_positive_count("moves_per_adaptation", self.moves_per_adaptation)?;
        check_positive_count("adaptations_per_stage", self.adaptations_per_stage)?;
        if !(self.step_gain > 0.0 && self.step_gain.is_finite()) {
            return Err(invalid(
                "step_gain",
                self.step_gain,
                "must be positive and finite",
            ));
        }
        check_range(
            "target_acceptance_low",
            self.target_acceptance_low,
            0.0,
            1.0,
            "must be in (0, 1]",
        )?;
        if !(self.target_acceptance_high >= self.target_acceptance_low
            && self.target_acceptance_high < 1.0)
        {
            return Err(invalid(
                "target_acceptance_high",
                self.target_acceptance_high,
                "must be in [target_acceptance_low, 1)",
            ));
        }
        if !(self.cooling > 0.0 && self.cooling < 1.0) {
            return Err(invalid("cooling", self.cooling, "must be in (0, 1)"));
        }
        check_positive_count("t0_event_moves", self.t0_event_moves)?;
        if !(self.t0_growth > 1.0 && self.t0_growth.is_finite()) {
            return Err(invalid(
                "t0_growth",
                self.t0_growth,
                "must be finite and > 1",
            ));
        }
        if !(self.t0_start_fraction > 0.0 && self.t0_start_fraction.is_finite()) {
            return Err(invalid(
                "t0_start_fraction",
                self.t0_start_fraction,
                "must be positive and finite",
            ));
        }
        check_nonneg("t0_stable_fraction", self.t0_stable_fraction)?;
        if !(self.t0_min_acceptance >= 0.0 && self.t0_min_acceptance < 1.0) {
            return Err(invalid(
                "t0_min_acceptance",
                self.t0_min_acceptance,
                "must be in [0, 1)",
            ));
        }
        check_positive_count("t0_max_events", self.t0_max_events)?;
        check_nonneg("tolerance_rel", self.tolerance_rel)?;
        check_nonneg("tolerance_abs", self.tolerance_abs)?;
        check_positive_count("stall_stages", self.stall_stages)?;
        check_range(
            "final_temperature",
            self.final_temperature,
            0.0,
            1.0,
            "must be in (0, 1]",
        )?;
        check_range(
            "reanneal_temperature",
            self.reanneal_temperature,
            0.0,
            1.0,
            "must be in (0, 1]",
        )?;
        check_range(
            "reanneal_step",
            self.reanneal_step,
            0.0,
            1.0,
            "must be in (0, 1]",
        )?;
        if !(self.polish_fraction >= 0.0 && self.polish_fraction < 1.0) {
            return Err(invalid(
                "polish_fraction",
                self.polish_fraction,
                "must be in [0, 1)",
            ));
        }
        self.polish.validate()?;
        check_positive_count("start_attempts", self.start_attempts)?;
        Ok(self)
    }
}
