//! The Metropolis–Hastings driver: parallel chains, adaptive warm-up, monitoring.
//!
//! One chain's step and proposal are in `chain` (its adaptation in `adaptation`); the checks
//! between blocks are in `monitor`.

use std::ops::ControlFlow;

use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use crate::mixture::MixtureProposal;
use crate::summary::{
    correlation_matrix, strongest_correlations, summaries, CorrelationPair, Summary,
};
use crate::{LogDensity, McmcError, McmcSettings};

mod adaptation;
mod chain;
mod monitor;

pub(crate) use chain::chain_rng;
use chain::{Chain, Context};
pub use chain::{ChainPhase, MAX_INIT_TRIES};
use monitor::{check_interval, mean_rate, monitor, refit_mixture};

/// What the observer of [`run_with_observer`] sees after every block.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[non_exhaustive]
pub struct ChainProgress {
    /// Current phase.
    pub phase: ChainPhase,
    /// Iterations per chain so far (warm-up + sampling).
    pub iterations: usize,
    /// Iterations per chain in the current phase.
    pub phase_iterations: usize,
    /// Largest R̂ over the parameters (warm-up: over its second half; NaN
    /// before `warmup_min`).
    pub max_rhat: f64,
    /// Smallest bulk ESS over the parameters (NaN during warm-up).
    pub min_ess_bulk: f64,
    /// Mean acceptance rate over the chains in the current phase.
    pub acceptance_rate: f64,
}

/// Why sampling stopped.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[non_exhaustive]
pub enum ChainStopReason {
    /// Every parameter reached R̂ < `rhat_target` and bulk ESS ≥ `ess_target`.
    Converged,
    /// `max_total` iterations were spent before the targets were met.
    CapReached,
    /// The observer asked to stop.
    Stopped,
}

/// The outcome of [`run`].
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[non_exhaustive]
pub struct RunResult {
    /// The settings used.
    pub settings: McmcSettings,
    /// Number of parameters.
    pub dim: usize,
    /// Kept sampling draws in the target's reported coordinates
    /// ([`LogDensity::evaluate`]; the sampler's own coordinates by default), indexed
    /// `[parameter][chain][draw]`.
    pub draws: Vec<Vec<Vec<f64>>>,
    /// Stored log density of every kept draw (the second value of
    /// [`LogDensity::evaluate`]; `log π` by default), `[chain][draw]`.
    pub log_density: Vec<Vec<f64>>,
    /// Warm-up iterations per chain (chosen by monitoring).
    pub warmup_iterations: usize,
    /// Sampling iterations per chain (kept draws = ⌊this / `thin`⌋).
    pub sampling_iterations: usize,
    /// Whether warm-up ended by its R̂ criterion (false: by its cap or a stop).
    pub warmup_converged: bool,
    /// Why sampling stopped.
    pub stop: ChainStopReason,
    /// `stop == Converged`: all R̂ < target and all bulk ESS ≥ target.
    pub converged: bool,
    /// Acceptance rate of every chain during sampling.
    pub acceptance_rate: Vec<f64>,
    /// Acceptance rate of every chain during warm-up.
    pub warmup_acceptance_rate: Vec<f64>,
    /// Acceptance rate of the mixture (mode-jumping) steps of every chain during sampling
    /// (NaN without a mixture proposal).
    #[serde(default)]
    pub jump_acceptance_rate: Vec<f64>,
    /// Calls of `log_density` over all chains (start-point search included).
    pub evaluations: u64,
    /// Calls that failed (`None`, NaN or +∞): rejected proposals.
    pub failed_evaluations: u64,
    /// Proposals outside the bounds (rejected without evaluation).
    pub out_of_bounds: u64,
    /// Proposals where the target returned a zero density (`−∞`; e.g. outside the prior box
    /// of a target sampled in transformed coordinates).
    #[serde(default)]
    pub zero_density: u64,
    /// Largest `|coordinate|` of any state the chains visited during sampling, in the
    /// sampler's own coordinates.
    pub max_abs_coordinate: f64,
    /// Per-parameter posterior summary of the kept draws.
    pub summary: Vec<Summary>,
    /// Pooled posterior correlation matrix.
    pub correlation: Vec<Vec<f64>>,
    /// Every parameter pair, strongest |correlation| first.
    pub strongest_correlations: Vec<CorrelationPair>,
}

impl RunResult {
    /// The chains of parameter `param` as slices, ready for [`crate::diagnostics`].
    ///
    /// # Panics
    /// If `param >= dim`.
    pub fn chains(&self, param: usize) -> Vec<&[f64]> {
        self.draws[param].iter().map(|c| c.as_slice()).collect()
    }
}

/// Run the sampler with no observer. See [`run_with_observer`].
pub fn run<T: LogDensity + ?Sized>(
    target: &T,
    settings: &McmcSettings,
    init: Option<&[Vec<f64>]>,
) -> Result<RunResult, McmcError> {
    run_with_observer(target, settings, init, |_| ControlFlow::Continue(()))
}

/// Validate the target's dimension and bounds.
pub(crate) fn check_target<T: LogDensity + ?Sized>(target: &T) -> Result<(), McmcError> {
    let d = target.dim();
    if d == 0 {
        return Err(McmcError::EmptyTarget);
    }
    let b = target.bounds();
    if b.len() != d {
        return Err(McmcError::BoundsLength {
            expected: d,
            got: b.len(),
        });
    }
    for (index, &(lower, upper)) in b.iter().enumerate() {
        if !(lower.is_finite() && upper.is_finite() && lower < upper) {
            return Err(McmcError::InvalidBounds {
                index,
                lower,
                upper,
            });
        }
    }
    Ok(())
}

/// Run `settings.n_chains` Metropolis–Hastings chains on `target`.
///
/// `init`: one start point per chain, or `None` for points drawn uniformly
/// from the bounds by each chain's own RNG (re-drawn while the log density
/// fails, up to [`MAX_INIT_TRIES`]). The chains run in parallel on rayon's
/// current pool; chain `c` uses `ChaCha8Rng::seed_from_u64(seed)` with stream
/// `c + 1`, so the result is bit-identical for any thread count. `observer`
/// is called after every block and may stop the run
/// ([`ChainStopReason::Stopped`]); the draws so far are then returned.
///
/// # Errors
/// Invalid settings or bounds, malformed or infeasible start points
/// ([`McmcError`]).
pub fn run_with_observer<T, F>(
    target: &T,
    settings: &McmcSettings,
    init: Option<&[Vec<f64>]>,
    observer: F,
) -> Result<RunResult, McmcError>
where
    T: LogDensity + ?Sized,
    F: FnMut(&ChainProgress) -> ControlFlow<()>,
{
    run_with_proposal(target, settings, init, None, observer)
}

/// [`run_with_observer`] with an optional mode-jumping [`MixtureProposal`]: at every step of
/// warm-up and sampling, with the mixture's probability, the chain proposes an independence
/// draw from the mixture for the mixture's coordinates instead of a random-walk step (and the
/// random walk's scale adapts to its own steps only). The mixture is fixed, so the kept draws
/// still come from one Metropolis–Hastings kernel.
///
/// # Errors
/// As [`run_with_observer`], and a mixture coordinate outside the target's dimension.
pub fn run_with_proposal<T, F>(
    target: &T,
    settings: &McmcSettings,
    init: Option<&[Vec<f64>]>,
    mixture: Option<&MixtureProposal>,
    mut observer: F,
) -> Result<RunResult, McmcError>
where
    T: LogDensity + ?Sized,
    F: FnMut(&ChainProgress) -> ControlFlow<()>,
{
    check_run(target, settings, init, mixture)?;
    let bounds = target.bounds().to_vec();
    let report_bounds = target.report_bounds().to_vec();
    let mut ctx = Context {
        lower: bounds.iter().map(|b| b.0).collect(),
        upper: bounds.iter().map(|b| b.1).collect(),
        widths: bounds.iter().map(|b| b.1 - b.0).collect(),
        settings,
        mixture: mixture.cloned(),
    };
    let built: Vec<Result<Chain, McmcError>> = (0..settings.n_chains)
        .into_par_iter()
        .map(|c| Chain::new(target, &ctx, c, init.map(|p| p[c].as_slice())))
        .collect();
    let mut chains = built.into_iter().collect::<Result<Vec<_>, _>>()?;
    let warmup = warm_up(target, &mut ctx, &mut chains, &mut observer);
    for c in &mut chains {
        c.phase_iter = 0;
        c.warm = Vec::new();
        c.warm_x = Vec::new();
    }
    let (samp, stop) = if warmup.stopped {
        (0, ChainStopReason::Stopped)
    } else {
        sample(target, &ctx, &mut chains, warmup.iterations, &mut observer)
    };
    Ok(collect_result(
        chains,
        settings,
        &report_bounds,
        &warmup,
        samp,
        stop,
    ))
}

/// Validate the settings, the target, the mixture's coordinates and the start points.
fn check_run<T: LogDensity + ?Sized>(
    target: &T,
    settings: &McmcSettings,
    init: Option<&[Vec<f64>]>,
    mixture: Option<&MixtureProposal>,
) -> Result<(), McmcError> {
    settings.validate()?;
    check_target(target)?;
    let d = target.dim();
    if let Some(mix) = mixture {
        let mut seen = vec![false; d];
        for &i in mix.coords() {
            if i >= d || std::mem::replace(&mut seen[i], true) {
                return Err(McmcError::InvalidSetting {
                    name: "mixture.coords",
                    value: i.to_string(),
                    reason: "coordinates must be distinct and below the target's dimension",
                });
            }
        }
    }
    let report_bounds = target.report_bounds();
    if report_bounds.len() != d {
        return Err(McmcError::BoundsLength {
            expected: d,
            got: report_bounds.len(),
        });
    }
    if let Some(points) = init {
        if points.len() != settings.n_chains {
            return Err(McmcError::InitCount {
                expected: settings.n_chains,
                got: points.len(),
            });
        }
    }
    Ok(())
}

/// How the warm-up ended.
struct Warmup {
    /// Iterations per chain.
    iterations: usize,
    /// R̂ fell below `warmup_rhat_target`.
    converged: bool,
    /// The observer asked to stop.
    stopped: bool,
}

/// The warm-up: blocks of adaptation until R̂ over the second half of the warm-up draws falls
/// below `warmup_rhat_target` (checked from `warmup_min` on) or the cap, the mixture refitted
/// after every block.
fn warm_up<T, F>(
    target: &T,
    ctx: &mut Context<'_>,
    chains: &mut [Chain],
    observer: &mut F,
) -> Warmup
where
    T: LogDensity + ?Sized,
    F: FnMut(&ChainProgress) -> ControlFlow<()>,
{
    let settings = ctx.settings;
    let d = target.dim();
    let block = settings.block;
    let warmup_cap = settings
        .warmup_min
        .max(settings.max_total / 2)
        .min(settings.max_total - block);
    let mut warm = 0usize;
    let mut warmup_converged = false;
    let mut stopped = false;
    while warm < warmup_cap {
        let n = check_interval(block, warm).min(warmup_cap - warm);
        chains
            .par_iter_mut()
            .for_each(|c| c.run_block(target, ctx, n, ChainPhase::Warmup));
        warm += n;
        let max_rhat = if warm >= settings.warmup_min {
            monitor(chains, d, true).0
        } else {
            f64::NAN
        };
        let progress = ChainProgress {
            phase: ChainPhase::Warmup,
            iterations: warm,
            phase_iterations: warm,
            max_rhat,
            min_ess_bulk: f64::NAN,
            acceptance_rate: mean_rate(chains, ChainPhase::Warmup),
        };
        if observer(&progress).is_break() {
            stopped = true;
            break;
        }
        if max_rhat < settings.warmup_rhat_target {
            warmup_converged = true;
            break;
        }
        refit_mixture(ctx, chains, settings.seed, warm as u64);
    }
    Warmup {
        iterations: warm,
        converged: warmup_converged,
        stopped,
    }
}

/// Sampling with the frozen proposal, after `warm` iterations of warm-up, until every R̂ <
/// `rhat_target` and bulk ESS ≥ `ess_target`, the cap or the observer's stop; the iterations
/// per chain and why it stopped.
fn sample<T, F>(
    target: &T,
    ctx: &Context<'_>,
    chains: &mut [Chain],
    warm: usize,
    observer: &mut F,
) -> (usize, ChainStopReason)
where
    T: LogDensity + ?Sized,
    F: FnMut(&ChainProgress) -> ControlFlow<()>,
{
    let settings = ctx.settings;
    let d = target.dim();
    let block = settings.block;
    let mut samp = 0usize;
    let stop;
    loop {
        let n = check_interval(block, samp).min(settings.max_total - warm - samp);
        if n == 0 {
            stop = ChainStopReason::CapReached;
            break;
        }
        chains
            .par_iter_mut()
            .for_each(|c| c.run_block(target, ctx, n, ChainPhase::Sampling));
        samp += n;
        let (max_rhat, min_ess) = monitor(chains, d, false);
        let progress = ChainProgress {
            phase: ChainPhase::Sampling,
            iterations: warm + samp,
            phase_iterations: samp,
            max_rhat,
            min_ess_bulk: min_ess,
            acceptance_rate: mean_rate(chains, ChainPhase::Sampling),
        };
        let flow = observer(&progress);
        if max_rhat < settings.rhat_target && min_ess >= settings.ess_target {
            stop = ChainStopReason::Converged;
            break;
        }
        if flow.is_break() {
            stop = ChainStopReason::Stopped;
            break;
        }
    }
    (samp, stop)
}

/// The chains' kept draws, log densities, counters and their summaries as a [`RunResult`].
fn collect_result(
    mut chains: Vec<Chain>,
    settings: &McmcSettings,
    report_bounds: &[(f64, f64)],
    warmup: &Warmup,
    samp: usize,
    stop: ChainStopReason,
) -> RunResult {
    let d = report_bounds.len();
    let draws: Vec<Vec<Vec<f64>>> = (0..d)
        .map(|i| {
            chains
                .iter_mut()
                .map(|c| std::mem::take(&mut c.samp[i]))
                .collect()
        })
        .collect();
    let summary: Vec<Summary> = summaries(&draws, report_bounds);
    let correlation = correlation_matrix(&draws);
    let strongest = strongest_correlations(&correlation);
    RunResult {
        settings: *settings,
        dim: d,
        log_density: chains
            .iter_mut()
            .map(|c| std::mem::take(&mut c.samp_lp))
            .collect(),
        draws,
        warmup_iterations: warmup.iterations,
        sampling_iterations: samp,
        warmup_converged: warmup.converged,
        converged: stop == ChainStopReason::Converged,
        stop,
        acceptance_rate: chains.iter().map(|c| c.samp_counts.rate()).collect(),
        warmup_acceptance_rate: chains.iter().map(|c| c.warm_counts.rate()).collect(),
        jump_acceptance_rate: chains.iter().map(|c| c.jump_counts.rate()).collect(),
        evaluations: chains.iter().map(|c| c.evaluations).sum(),
        failed_evaluations: chains.iter().map(|c| c.failed).sum(),
        out_of_bounds: chains.iter().map(|c| c.out_of_bounds).sum(),
        zero_density: chains.iter().map(|c| c.zero_density).sum(),
        max_abs_coordinate: chains.iter().fold(0.0, |m, c| m.max(c.max_abs)),
        summary,
        correlation,
        strongest_correlations: strongest,
    }
}
