//! Sampler settings (plain `Copy + Default + Serialize` data) and their validation.

use serde::{Deserialize, Serialize};

use crate::McmcError;

/// The random-walk proposal.
#[derive(Clone, Copy, Debug, PartialEq, Default, Serialize, Deserialize)]
pub enum Proposal {
    /// Gaussian random walk `y = x + √λ·L·z`, `z ~ N(0, I)`, `L·Lᵀ = C`, with
    /// the covariance `C` learned in doubling windows during warm-up
    /// (Haario et al. 2001, as windowed by Stan) and the global scale `λ`
    /// adapted by Robbins–Monro toward the target acceptance rate
    /// (Andrieu & Thoms 2008, algorithm 4). Frozen after warm-up.
    #[default]
    Adaptive,
    /// The dissertation's eq. 19: every coordinate moves at once by
    /// `x_i' = x_i + scale·w_i·U(−1, 1)`, `w_i` the width of its bounds. Never
    /// adapted.
    Dissertation {
        /// Step as a fraction of the bounds width (`> 0`).
        scale: f64,
    },
}

/// Settings of [`run`](crate::run). Counts are iterations **per chain**.
///
/// Convergence is checked every `block` iterations, an interval that grows to
/// about 10 % of the phase's iterations once those exceed `20·block` (always a
/// multiple of `block`). Warm-up runs in such blocks (adapting the proposal when it
/// is [`Proposal::Adaptive`]). Once at least `warmup_min` iterations are done,
/// warm-up ends after the first block at which every parameter's R̂ over the
/// second half of the warm-up draws is below `warmup_rhat_target`, and at the
/// latest at `max(warmup_min, max_total/2)` iterations (capped to
/// `max_total − block`). Then the proposal is frozen and sampling runs in
/// such blocks until every parameter has R̂ <
/// `rhat_target` and bulk ESS ≥ `ess_target` over all sampling draws
/// (converged), or the total reaches `max_total` (cap reached: reported, not
/// claimed as convergence).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct McmcSettings {
    /// Seed of every chain's `ChaCha8Rng` (chain `c` uses stream `c + 1`).
    pub seed: u64,
    /// Number of chains (≥ 1; 4 by default).
    pub n_chains: usize,
    /// The proposal.
    pub proposal: Proposal,
    /// Minimum warm-up iterations.
    pub warmup_min: usize,
    /// Iterations between two convergence checks, at least (≥ 4).
    pub block: usize,
    /// Cap on warm-up + sampling iterations.
    pub max_total: usize,
    /// R̂ every parameter must stay below at the end (1.01).
    pub rhat_target: f64,
    /// Bulk ESS every parameter must reach at the end (400).
    pub ess_target: f64,
    /// R̂ over the second half of warm-up that ends warm-up (1.05).
    pub warmup_rhat_target: f64,
    /// Keep every `thin`-th state (≥ 1); diagnostics use the kept draws.
    pub thin: usize,
    /// Acceptance rate the adaptive scale aims at (0.234, Roberts et al. 1997).
    pub target_acceptance: f64,
}

impl Default for McmcSettings {
    fn default() -> Self {
        Self {
            seed: 42,
            n_chains: 4,
            proposal: Proposal::Adaptive,
            warmup_min: 2_000,
            block: 1_000,
            max_total: 100_000,
            rhat_target: 1.01,
            ess_target: 400.0,
            warmup_rhat_target: 1.05,
            thin: 1,
            target_acceptance: 0.234,
        }
    }
}

impl McmcSettings {
    /// Check every field; the first problem found is returned.
    pub fn validate(&self) -> Result<(), McmcError> {
        let bad = |name: &'static str, value: String, reason: &'static str| {
            Err(McmcError::InvalidSetting {
                name,
                value,
                reason,
            })
        };
        if self.n_chains == 0 {
            return bad("n_chains", "0".into(), "at least one chain is needed");
        }
        if self.block < 4 {
            return bad("block", self.block.to_string(), "must be at least 4");
        }
        if self.thin == 0 {
            return bad("thin", "0".into(), "must be at least 1");
        }
        if self.max_total < self.warmup_min.saturating_add(self.block) {
            return bad(
                "max_total",
                self.max_total.to_string(),
                "must be at least warmup_min + block",
            );
        }
        if !(self.rhat_target.is_finite() && self.rhat_target > 1.0) {
            return bad(
                "rhat_target",
                self.rhat_target.to_string(),
                "must be finite and > 1",
            );
        }
        if !(self.warmup_rhat_target.is_finite() && self.warmup_rhat_target > 1.0) {
            return bad(
                "warmup_rhat_target",
                self.warmup_rhat_target.to_string(),
                "must be finite and > 1",
            );
        }
        if !(self.ess_target.is_finite() && self.ess_target > 0.0) {
            return bad(
                "ess_target",
                self.ess_target.to_string(),
                "must be finite and > 0",
            );
        }
        if !(self.target_acceptance > 0.0 && self.target_acceptance < 1.0) {
            return bad(
                "target_acceptance",
                self.target_acceptance.to_string(),
                "must lie in (0, 1)",
            );
        }
        if let Proposal::Dissertation { scale } = self.proposal {
            if !(scale.is_finite() && scale > 0.0) {
                return bad(
                    "proposal.scale",
                    scale.to_string(),
                    "must be finite and > 0",
                );
            }
        }
        Ok(())
    }
}
