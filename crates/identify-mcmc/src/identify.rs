//! What the Bayesian identification of the muscle model (docs/results.md) takes and gives: where
//! the noise model comes from ([`NoiseSpec`]), the settings, the mode mixture of the jump
//! proposal, and the report ([`McmcIdentification`]). The procedure, for a session and for one
//! trial ([`crate::identify()`]), is in module `session_identify`.

use std::io::Write;

use muscle_model::Problem;
use numerics::cholesky::solve_lower_in_place;
use serde::{Deserialize, Serialize};

use crate::mixture::{ComponentSpec, MixtureProposal};
use crate::modes::Mode;
use crate::noise::{NoiseKind, NoiseParams};
use crate::sampling_coordinates::Conditional;
use crate::{ChainStopReason, McmcError, McmcSettings, RunResult};

/// Where the likelihood's noise model comes from.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum McmcNoiseSource {
    /// Given (e.g. fitted to the unloaded run's random remainder).
    Fixed(NoiseParams),
    /// Fitted by moments ([`NoiseParams::fit`]) to the residual of the preliminary
    /// Nelder–Mead fit (fallback when no unloaded run is available; the residual then also
    /// holds any systematic error not removed, which inflates σ and widens the intervals).
    FromResidual(NoiseKind),
}

/// The noise side of the likelihood: systematic correction and random model.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct NoiseSpec {
    /// Systematic dynamometer error at every trial sample (N·m), subtracted from the measured
    /// torque before anything else; `None` leaves the torque as measured.
    pub systematic: Option<Vec<f64>>,
    /// The random part.
    pub source: McmcNoiseSource,
    /// Prior sd of a constant torque offset left after the correction, integrated out of the
    /// likelihood (N·m; 0: none). The unloaded run's offset is an estimate: over 12 synthetic
    /// seed-protocol trials its error was −0.10 ± 0.09 N·m and the trial's remainder kept a mean
    /// of +0.16 ± 0.14 N·m (`cargo run --release -p identify-mcmc --example offset_check`);
    /// left in, such an offset biases LST and α0 by about their posterior sd.
    #[serde(default)]
    pub offset_sd_nm: f64,
    /// Lags `1..=max_lag` used by moment fits of [`NoiseKind::Ar1White`] (at 2048 Hz, 20 lags
    /// ≈ 10 ms, a third of the nominal 30 ms correlation time of docs/formats.md, "Synthetic trials").
    pub max_lag: usize,
}

/// [`NoiseSpec::offset_sd_nm`] after the unloaded run's correction (N·m): a few times the
/// offset errors measured on synthetic trials.
pub const UNLOADED_OFFSET_SD_NM: f64 = 0.5;

/// [`NoiseSpec::offset_sd_nm`] without an unloaded run (N·m): the dynamometer's offset is then
/// not removed at all (the nominal synthetic offset is −1.5 N·m).
pub const NO_UNLOADED_OFFSET_SD_NM: f64 = 5.0;

/// Default lags of the [`NoiseKind::Ar1White`] moment fit.
pub const DEFAULT_MAX_LAG: usize = 20;

impl NoiseSpec {
    /// A fixed noise model with an optional systematic correction.
    pub fn fixed(noise: NoiseParams, systematic: Option<Vec<f64>>) -> Self {
        Self {
            systematic,
            source: McmcNoiseSource::Fixed(noise),
            offset_sd_nm: 0.0,
            max_lag: DEFAULT_MAX_LAG,
        }
    }

    /// The fallback without an unloaded run: no correction, `kind` fitted to the residual of the
    /// preliminary fit.
    pub fn from_residual(kind: NoiseKind) -> Self {
        Self {
            systematic: None,
            source: McmcNoiseSource::FromResidual(kind),
            offset_sd_nm: NO_UNLOADED_OFFSET_SD_NM,
            max_lag: DEFAULT_MAX_LAG,
        }
    }

    /// The pipeline with an unloaded run: [`experiment::DynamometerCorrection`] of the
    /// unloaded run, then [`NoiseSpec::from_correction`].
    ///
    /// # Errors
    /// The unloaded run or the trial's angle cannot be analysed, or invalid noise values.
    pub fn from_unloaded(
        trial: &experiment::Trial,
        unloaded: &experiment::Unloaded,
        kind: NoiseKind,
    ) -> Result<Self, McmcError> {
        let correction = experiment::DynamometerCorrection::from_unloaded(unloaded)?;
        Self::from_correction(trial, &correction, kind)
    }

    /// A dynamometer correction (offset, damped-sinusoid transient and AR(1)+white random
    /// part, `docs/dynamometer.md`) applied to a trial: the trial is corrected by the
    /// systematic part at its own detected events, and the random part of `kind` is taken
    /// from the correction's `(φ, σ_ar, σ_w)`: `Iid {σ}` with the marginal
    /// `σ = √(σ_ar² + σ_w²)`, `Ar1 {φ = ρ₁, σ_innov = σ√(1−ρ₁²)}` with its lag-one
    /// correlation `ρ₁ = φ·σ_ar²/σ²`, or `Ar1White {φ, σ_ar, σ_w}` itself.
    ///
    /// # Errors
    /// The trial's angle cannot be analysed, or invalid noise values.
    pub fn from_correction(
        trial: &experiment::Trial,
        correction: &experiment::DynamometerCorrection,
        kind: NoiseKind,
    ) -> Result<Self, McmcError> {
        let systematic = correction.correct(trial)?.systematic_nm;
        Self::with_systematic(correction, systematic, kind)
    }

    /// The noise side of a prepared trial: [`NoiseSpec::from_correction`] with the systematic
    /// part the preparation already placed at the trial's events, or
    /// [`NoiseSpec::from_residual`] without an unloaded run.
    ///
    /// # Errors
    /// Invalid noise values.
    pub fn from_prepared(
        prepared: &experiment::PreparedTrial,
        kind: NoiseKind,
    ) -> Result<Self, McmcError> {
        match (prepared.correction(), prepared.systematic()) {
            (Some(c), Some(s)) => Self::with_systematic(c, s.to_vec(), kind),
            _ => Ok(Self::from_residual(kind)),
        }
    }

    /// [`NoiseSpec::from_correction`] with the trial's systematic part given.
    fn with_systematic(
        correction: &experiment::DynamometerCorrection,
        systematic: Vec<f64>,
        kind: NoiseKind,
    ) -> Result<Self, McmcError> {
        let r = correction.random;
        let sigma = r.marginal_sd();
        let lag1 = r.autocorrelation(1);
        let noise = match kind {
            NoiseKind::Iid => NoiseParams::Iid { sigma },
            NoiseKind::Ar1 => NoiseParams::Ar1 {
                phi: lag1,
                sigma_innov: sigma * (1.0 - lag1 * lag1).max(0.0).sqrt(),
            },
            NoiseKind::Ar1White => NoiseParams::Ar1White {
                phi: r.phi,
                sigma_ar: r.sigma_ar,
                sigma_white: r.sigma_white,
            },
        };
        noise.model()?;
        Ok(Self {
            offset_sd_nm: UNLOADED_OFFSET_SD_NM,
            ..Self::fixed(noise, Some(systematic))
        })
    }

    /// Fit `kind` to an unloaded run's torque `unloaded_torque` after removing its systematic
    /// part `unloaded_systematic` (same length), and correct the trial by `trial_systematic`.
    ///
    /// # Errors
    /// Lengths differ, or the remainder cannot be fitted ([`McmcError::NoiseFit`]).
    pub fn from_remainder(
        kind: NoiseKind,
        unloaded_torque: &[f64],
        unloaded_systematic: &[f64],
        trial_systematic: Option<Vec<f64>>,
    ) -> Result<Self, McmcError> {
        if unloaded_torque.len() != unloaded_systematic.len() {
            return Err(McmcError::Length {
                what: "unloaded systematic part",
                expected: unloaded_torque.len(),
                got: unloaded_systematic.len(),
            });
        }
        let rem: Vec<f64> = unloaded_torque
            .iter()
            .zip(unloaded_systematic)
            .map(|(t, s)| t - s)
            .collect();
        let mean = rem.iter().sum::<f64>() / rem.len().max(1) as f64;
        let rem: Vec<f64> = rem.iter().map(|v| v - mean).collect();
        let noise = NoiseParams::fit(kind, &rem, DEFAULT_MAX_LAG)?;
        let offset_sd_nm = if trial_systematic.is_some() {
            UNLOADED_OFFSET_SD_NM
        } else {
            NO_UNLOADED_OFFSET_SD_NM
        };
        Ok(Self {
            offset_sd_nm,
            ..Self::fixed(noise, trial_systematic)
        })
    }
}

/// One trial of a session: its problem on the torque as measured, and its noise side.
#[derive(Clone, Copy, Debug)]
pub struct SessionTrialLikelihood<'a> {
    /// The trial's problem. Every trial of a session has the same free parameters and bounds.
    pub problem: &'a Problem,
    /// Its systematic correction, random noise model and offset nuisance.
    pub noise: &'a NoiseSpec,
}

/// Settings of [`crate::identify()`].
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct McmcIdentifySettings {
    /// The sampler (seed, chains, warm-up, caps, targets).
    pub mcmc: McmcSettings,
    /// Nelder–Mead budget of each start of the mode search (and of the preliminary fit when
    /// the noise model comes from the residual).
    pub nelder_mead_evaluations: u64,
    /// Starts of the mode search (module `modes`: the middle of the bounds and Latin-hypercube
    /// points); 0 skips the search and centres everything on the base values.
    #[serde(default = "default_mode_starts")]
    pub mode_starts: usize,
    /// A second optimum is kept as a mode when its marginal log density is within this much
    /// of the best one (mass ratio `e^−gap`).
    #[serde(default = "default_mode_gap")]
    pub mode_gap: f64,
    /// Probability of a mode-jumping step (an independence draw of the nonlinear parameters
    /// from a Student-t mixture on the modes, [`crate::MixtureProposal`]) instead of a
    /// random-walk step; 0 turns it off.
    #[serde(default = "default_jump_probability")]
    pub jump_probability: f64,
    /// Degrees of freedom of the mixture components.
    #[serde(default = "default_jump_nu")]
    pub jump_nu: f64,
    /// Scale of each component relative to its mode's Laplace standard deviations (and to
    /// its cluster's standard deviations after a refit).
    #[serde(default = "default_jump_inflation")]
    pub jump_inflation: f64,
    /// During warm-up the jump mixture is refitted to the pooled warm-up states with up to
    /// this many k-means clusters ([`crate::MixtureProposal::with_refit`]); 0 keeps the modes.
    #[serde(default = "default_jump_refit")]
    pub jump_refit_components: usize,
    /// Start dispersion: the F0 coordinates of a chain start are `u ~ N(0, spread²·I)` (1 = their
    /// conditional's own spread) and LST/α0 a draw from the chain's mode component; 0 starts
    /// every chain at the best mode. Redrawn (up to 50 times) while the density is not finite, then
    /// the best mode itself.
    pub start_spread: f64,
    /// Number of strongest posterior correlations reported.
    pub correlations: usize,
    /// The sampler runs in its own coordinates `(z, u)` but stores, monitors and summarises the
    /// model's parameters. It stops at the stricter targets `ESS ≥ margin·ess_target`,
    /// `R̂ < 1 + (rhat_target − 1)/margin` (≥ 1; 1 by default: the monitored numbers are the
    /// reported ones), and `converged` is decided with the targets of `mcmc`.
    pub monitor_margin: f64,
    /// Half-width `K` of the sampling box in whitened coordinates `z` (see [`crate::identify()`]). The
    /// coordinates have no walls, so this box is the only truncation left: with the Laplace
    /// factor fitted at the best mode, a weakly identified parameter (gl LST on fixtures/seed)
    /// reaches |z| ≈ 18, hence 50.
    pub z_half_width: f64,
}

fn default_mode_starts() -> usize {
    12
}
fn default_mode_gap() -> f64 {
    12.0
}
fn default_jump_probability() -> f64 {
    0.2
}
fn default_jump_nu() -> f64 {
    4.0
}
fn default_jump_inflation() -> f64 {
    1.3
}
fn default_jump_refit() -> usize {
    4
}

impl Default for McmcIdentifySettings {
    /// 4 chains, warm-up ≥ 1 000 and checks every 500 iterations, cap 100 000 iterations per
    /// chain; mode search of 12 Nelder–Mead starts × 600 evaluations; jumps with probability
    /// 0.2 (ν = 4, inflation 1.3, refit with up to 4 clusters); starts drawn from the mode
    /// mixture with `u ~ N(0, 1.5²I)`; 5 correlations; `K = 50`; monitor margin 1.
    fn default() -> Self {
        Self {
            mcmc: McmcSettings {
                warmup_min: 1_000,
                block: 500,
                max_total: 100_000,
                ..McmcSettings::default()
            },
            nelder_mead_evaluations: 600,
            mode_starts: default_mode_starts(),
            mode_gap: default_mode_gap(),
            jump_probability: default_jump_probability(),
            jump_nu: default_jump_nu(),
            jump_inflation: default_jump_inflation(),
            jump_refit_components: default_jump_refit(),
            start_spread: 1.5,
            correlations: 5,
            z_half_width: 50.0,
            monitor_margin: 1.0,
        }
    }
}

impl McmcIdentifySettings {
    /// Cheaper settings for replicate studies (coverage): warm-up ≥ 1 000, checks every 250,
    /// cap 40 000 iterations per chain, bulk ESS target 150 (R̂ target stays 1.01); the mode
    /// search as by default. (A cap of 8 000 stops most runs inside warm-up, R̂ up to 1.65, and
    /// the intervals then cover the truth only 78 % of the time.)
    pub fn fast(seed: u64) -> Self {
        let d = Self::default();
        Self {
            mcmc: McmcSettings {
                seed,
                warmup_min: 1_000,
                block: 250,
                max_total: 40_000,
                ess_target: 150.0,
                ..d.mcmc
            },
            ..d
        }
    }
}

/// Posterior summary of one named parameter (a `posterior` entry of `identify.json`, docs/formats.md).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[non_exhaustive]
pub struct ParamPosterior {
    /// Name as in the parameters JSON (docs/formats.md), e.g. `sol.lst_m`.
    pub name: String,
    /// Posterior mean.
    pub mean: f64,
    /// Posterior sd.
    pub sd: f64,
    /// 5 % quantile.
    pub q05: f64,
    /// 95 % quantile.
    pub q95: f64,
    /// Rank-normalised split R̂.
    pub rhat: f64,
    /// Bulk ESS.
    pub ess_bulk: f64,
    /// Tail ESS.
    pub ess_tail: f64,
    /// `sd < prior_sd/2`.
    pub identifiable: bool,
    /// Sd of the uniform prior, `width/√12`.
    pub prior_sd: f64,
    /// `sd / prior_sd`.
    pub prior_sd_ratio: f64,
}

impl ParamPosterior {
    /// Whether `v` lies in the central 90 % interval `[q05, q95]`.
    pub fn covers(&self, v: f64) -> bool {
        v >= self.q05 && v <= self.q95
    }
}

/// A posterior correlation between two named parameters.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[non_exhaustive]
pub struct NamedCorrelation {
    /// First parameter.
    pub a: String,
    /// Second parameter.
    pub b: String,
    /// Pearson correlation of the pooled draws.
    pub r: f64,
}

/// One mode of the marginal posterior of the nonlinear parameters.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[non_exhaustive]
pub struct ModeInfo {
    /// Model parameters at the mode (F0 at its conditional optimum), in vector order.
    pub x: Vec<f64>,
    /// `ln p(θ_best) − ln p(θ_mode)` of the marginal posterior (0 for the best mode).
    pub log_density_gap: f64,
    /// Weight of the mode's component in the jump proposal.
    pub weight: f64,
}

/// The jump proposal of `modes` in `target`'s whitened coordinates: component `m` has mean
/// `z_m = L⁻¹(θ_m − θ_best)` and covariance `s²·(L⁻¹L_m)(L⁻¹L_m)ᵀ` (`s` the inflation),
/// weight `0.7·w_m/Σw + 0.3/M` with the Laplace mass `w_m = p(θ_m)·det L_m`.
pub(crate) fn mode_mixture(
    target: &Conditional<'_>,
    modes: &[Mode],
    settings: &McmcIdentifySettings,
) -> Result<(MixtureProposal, Vec<ModeInfo>), McmcError> {
    let nl = target.nl().to_vec();
    let m = nl.len();
    let lb = target.chol_nl();
    let best_ld = modes[0].log_density;
    let log_det = |l: &[f64]| (0..m).map(|i| l[i * m + i].ln()).sum::<f64>();
    let ld0 = log_det(&modes[0].chol_nl);
    let mut raw: Vec<f64> = modes
        .iter()
        .map(|md| {
            let gap = md.log_density - best_ld;
            let w = (gap + log_det(&md.chol_nl) - ld0).exp();
            if w.is_finite() && w > 0.0 {
                w
            } else {
                1.0
            }
        })
        .collect();
    let total: f64 = raw.iter().sum();
    let n = modes.len() as f64;
    for w in raw.iter_mut() {
        *w = 0.7 * *w / total + 0.3 / n;
    }
    let s2 = settings.jump_inflation * settings.jump_inflation;
    let mut specs = Vec::with_capacity(modes.len());
    for (md, &w) in modes.iter().zip(&raw) {
        // A = L_best⁻¹ L_m (both on the sampling scale), column by column.
        let lm = target.phi_factor(&md.x, &md.chol_nl);
        let mut a = vec![0.0; m * m];
        let mut column = vec![0.0; m];
        for col in 0..m {
            for (r, v) in column.iter_mut().enumerate() {
                *v = lm[r * m + col];
            }
            solve_lower_in_place(lb, &mut column);
            for (r, v) in column.iter().enumerate() {
                a[r * m + col] = *v;
            }
        }
        let mut cov = vec![0.0; m * m];
        for i in 0..m {
            for j in 0..m {
                cov[i * m + j] = s2 * (0..m).map(|k| a[i * m + k] * a[j * m + k]).sum::<f64>();
            }
        }
        specs.push(ComponentSpec {
            weight: w,
            mean: target.z_of(&md.x),
            cov,
        });
    }
    let mixture = MixtureProposal::new(
        nl,
        &specs,
        settings.jump_nu,
        settings.jump_probability.clamp(0.0, 1.0),
    )?;
    let info = modes
        .iter()
        .zip(&raw)
        .map(|(md, &w)| ModeInfo {
            x: md.x.clone(),
            log_density_gap: if best_ld.is_finite() {
                best_ld - md.log_density
            } else {
                0.0
            },
            weight: w,
        })
        .collect();
    Ok((mixture, info))
}

/// One trial's fit at the posterior mean.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[non_exhaustive]
pub struct McmcTrialFit {
    /// RMS torque error against the torque as measured (N·m).
    pub rms_nm: f64,
    /// RMS against the corrected torque (measured − systematic).
    pub rms_corrected_nm: f64,
    /// The trial's noise model.
    pub noise: NoiseParams,
    /// Whether a systematic correction was applied to this trial.
    pub corrected: bool,
}

/// What the gradient-based sampler reports beside the posterior: CmdStan's per-draw
/// statistics and the adapted step sizes and metrics.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[non_exhaustive]
pub struct NutsStats {
    /// The sampler's settings.
    pub settings: crate::NutsSettings,
    /// Sampler statistics of every kept draw, `[chain][draw]`.
    pub draws: Vec<Vec<crate::NutsDraw>>,
    /// The adapted step size of every chain.
    pub step_size: Vec<f64>,
    /// The adapted inverse metric (diagonal, unconstrained coordinates) of every chain.
    pub inv_metric: Vec<Vec<f64>>,
    /// Gradient evaluations (each one simulation and its exact Jacobian) over all chains.
    pub gradient_evaluations: u64,
    /// Mean leapfrog steps per kept draw.
    pub mean_leapfrog: f64,
    /// Mean `accept_stat__` of the kept draws.
    pub mean_accept_stat: f64,
    /// Divergent transitions among the kept draws, and during warm-up.
    pub divergences: u64,
    /// Divergent transitions during warm-up.
    pub warmup_divergences: u64,
    /// Kept draws whose trajectory stopped at the largest tree depth.
    pub max_depth_hits: u64,
}

/// What [`crate::identify()`] found.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[non_exhaustive]
pub struct McmcIdentification {
    /// Parameter names in vector order.
    pub names: Vec<String>,
    /// Bounds (the uniform prior).
    pub bounds: Vec<(f64, f64)>,
    /// Posterior per parameter.
    pub posterior: Vec<ParamPosterior>,
    /// Strongest posterior correlations (by |r|).
    pub correlations: Vec<NamedCorrelation>,
    /// Pearson correlation matrix of the kept draws (`names` × `names`).
    #[serde(default)]
    pub posterior_correlation: Vec<Vec<f64>>,
    /// The sampler converged and every parameter's R̂ < target and bulk ESS ≥ target (false:
    /// the cap was hit or the run stopped).
    pub converged: bool,
    /// Largest `|z|` over the states visited while sampling; near `z_half_width` the box
    /// truncates the posterior (then raise `McmcIdentifySettings::z_half_width`).
    pub max_abs_z: f64,
    /// The `K` used.
    pub z_half_width: f64,
    /// Why sampling stopped.
    pub stop: ChainStopReason,
    /// Warm-up iterations per chain.
    pub warmup_iterations: usize,
    /// Sampling iterations per chain.
    pub sampling_iterations: usize,
    /// Mean acceptance rate over chains during sampling.
    pub acceptance_rate: f64,
    /// Model evaluations: preliminary fit (without an unloaded run), mode search with its
    /// Laplace factors, chain starts and chains.
    pub evaluations: u64,
    /// Failed simulations among them (rejected proposals).
    pub failed_evaluations: u64,
    /// The best mode found by the multi-start search (the centre of the sampling coordinates).
    pub optimum: Vec<f64>,
    /// Every mode the search kept, best first.
    #[serde(default)]
    pub modes: Vec<ModeInfo>,
    /// Mean acceptance rate of the mode-jumping steps during sampling (NaN when off).
    #[serde(default)]
    pub jump_acceptance_rate: f64,
    /// RMS torque error at the posterior mean against the torque as measured (N·m), over every
    /// sample of the session.
    pub rms_nm: f64,
    /// RMS at the posterior mean against the corrected torque (measured − systematic).
    pub rms_corrected_nm: f64,
    /// The noise model used (of the first trial; every trial's in `trials`).
    pub noise: NoiseParams,
    /// Whether a systematic correction was applied (to the first trial).
    pub corrected: bool,
    /// Each trial's fit at the posterior mean and noise model, in the session's order.
    #[serde(default)]
    pub trials: Vec<McmcTrialFit>,
    /// Wall time of the whole identification (s).
    pub wall_s: f64,
    /// The gradient-based sampler's statistics (with [`crate::identify_session_nuts`]; `None`
    /// for the random walk).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub nuts: Option<NutsStats>,
    /// The sampler result in the model's parameters: draws `[parameter][chain][draw]`,
    /// log-likelihood `ℓ(x)` per draw, summaries and correlations in `x` (the sampler itself
    /// ran in `z`; the chains stored `x` at every step).
    pub run: RunResult,
}

impl McmcIdentification {
    /// The NUTS chains for [`crate::write_cmdstan_nuts_chain`] (`None` for the random walk).
    pub fn nuts_chains(&self) -> Option<crate::cmdstan::NutsChains<'_>> {
        self.nuts.as_ref().map(|n| crate::cmdstan::NutsChains {
            settings: &n.settings,
            stats: &n.draws,
            step_size: &n.step_size,
            inv_metric: &n.inv_metric,
            draws: &self.run.draws,
        })
    }

    /// Posterior means in vector order.
    pub fn mean(&self) -> Vec<f64> {
        self.posterior.iter().map(|p| p.mean).collect()
    }

    /// The posterior of parameter `name`.
    pub fn get(&self, name: &str) -> Option<&ParamPosterior> {
        self.posterior.iter().find(|p| p.name == name)
    }

    /// Largest R̂ and smallest bulk ESS over the parameters.
    pub fn worst_diagnostics(&self) -> (f64, f64) {
        self.posterior
            .iter()
            .fold((f64::NEG_INFINITY, f64::INFINITY), |(r, e), p| {
                (r.max(p.rhat), e.min(p.ess_bulk))
            })
    }

    /// Write the kept draws as CSV (`log_density` is the log-likelihood `ℓ(x)` of the draw): header `chain,iteration,<names…>,log_density`, one row per
    /// chain and kept draw (`iteration` counts kept draws of the sampling phase from 0); numbers
    /// in Rust's shortest round-trip form.
    ///
    /// # Errors
    /// I/O errors of `w`.
    pub fn write_chains_csv<W: Write>(&self, mut w: W) -> std::io::Result<()> {
        write!(w, "chain,iteration")?;
        for n in &self.names {
            write!(w, ",{n}")?;
        }
        writeln!(w, ",log_density")?;
        let draws = &self.run.draws;
        for (c, lp) in self.run.log_density.iter().enumerate() {
            for (k, l) in lp.iter().enumerate() {
                write!(w, "{c},{k}")?;
                for p in draws {
                    write!(w, ",{}", p[c][k])?;
                }
                writeln!(w, ",{l}")?;
            }
        }
        Ok(())
    }
}
