//! The Metropolis–Hastings driver: parallel chains, adaptive warm-up, monitoring.

use std::ops::ControlFlow;

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::StandardNormal;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use numerics::cholesky::cholesky_in_place;

use crate::mixture::MixtureProposal;
use crate::summary::{correlation_matrix, strongest_correlations, CorrelationPair, Summary};
use crate::{diagnostics, LogDensity, McmcError, McmcSettings, Proposal};

/// Uniform draws from the bounds tried per chain to find a finite start.
pub const MAX_INIT_TRIES: usize = 1_000;

/// Which phase a [`ChainProgress`] report comes from.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum ChainPhase {
    /// Warm-up (adaptation on for [`Proposal::Adaptive`]); draws discarded.
    Warmup,
    /// Sampling with the frozen proposal; draws kept.
    Sampling,
}

/// What the observer of [`run_with_observer`] sees after every block.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
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
    /// The chains of parameter `param` as slices, ready for [`diagnostics`].
    ///
    /// # Panics
    /// If `param >= dim`.
    pub fn chains(&self, param: usize) -> Vec<&[f64]> {
        self.draws[param].iter().map(|c| c.as_slice()).collect()
    }
}

/// Proposal state and warm-up accumulators of one chain.
struct Adaptation {
    /// Lower Cholesky factor of the proposal covariance, row-major d×d.
    chol: Vec<f64>,
    log_lambda: f64,
    rm_count: f64,
    window_len: usize,
    window_max: usize,
    win_n: usize,
    win_accepted: usize,
    win_mean: Vec<f64>,
    win_m2: Vec<f64>,
    cov: Vec<f64>,
}

impl Adaptation {
    fn new(widths: &[f64]) -> Self {
        let d = widths.len();
        let mut chol = vec![0.0; d * d];
        for (i, w) in widths.iter().enumerate() {
            chol[i * d + i] = 0.1 * w;
        }
        let base = (10 * d).max(100);
        Self {
            chol,
            log_lambda: default_log_lambda(d),
            rm_count: 0.0,
            window_len: base,
            window_max: base << 7,
            win_n: 0,
            win_accepted: 0,
            win_mean: vec![0.0; d],
            win_m2: vec![0.0; d * d],
            cov: vec![0.0; d * d],
        }
    }

    /// One Robbins–Monro scale update and one Welford covariance update.
    fn update(&mut self, x: &[f64], alpha: f64, accepted: bool, target: f64, widths: &[f64]) {
        self.rm_count += 1.0;
        let gamma = self.rm_count.powf(-0.6);
        self.log_lambda = (self.log_lambda + gamma * (alpha - target)).clamp(-60.0, 20.0);
        let d = x.len();
        self.win_n += 1;
        if accepted {
            self.win_accepted += 1;
        }
        let n = self.win_n as f64;
        for (i, &xi) in x.iter().enumerate() {
            let delta = xi - self.win_mean[i];
            self.win_mean[i] += delta / n;
            // M2 += δ_old ⊗ (x − mean_new), lower triangle only.
            let row = &mut self.win_m2[i * d..=i * d + i];
            for ((m2, &xj), &mj) in row.iter_mut().zip(x).zip(&self.win_mean) {
                *m2 += delta * (xj - mj);
            }
        }
        if self.win_n >= self.window_len {
            self.end_window(widths);
        }
    }

    /// Close a window: shrink its covariance, refactor, restart the scale.
    fn end_window(&mut self, widths: &[f64]) {
        let d = widths.len();
        let n = self.win_n as f64;
        if self.win_accepted > 2 * d && self.win_n > 1 {
            let shrink = n / (n + 5.0);
            for (i, w) in widths.iter().enumerate() {
                for j in 0..=i {
                    let mut c = shrink * self.win_m2[i * d + j] / (n - 1.0);
                    if i == j {
                        c += ((1.0 - shrink) * 1e-6 + 1e-12) * w * w;
                    }
                    self.cov[i * d + j] = c;
                }
            }
            if cholesky_in_place(&mut self.cov, d).is_ok() {
                self.chol.copy_from_slice(&self.cov);
                self.log_lambda = default_log_lambda(d);
            }
        }
        self.rm_count = 0.0;
        self.win_n = 0;
        self.win_accepted = 0;
        self.win_mean.iter_mut().for_each(|v| *v = 0.0);
        self.win_m2.iter_mut().for_each(|v| *v = 0.0);
        self.window_len = (2 * self.window_len).min(self.window_max);
    }
}

fn default_log_lambda(d: usize) -> f64 {
    (2.38f64 * 2.38 / d as f64).ln()
}

/// Read-only context shared by all chains.
struct Context<'a> {
    lower: Vec<f64>,
    upper: Vec<f64>,
    widths: Vec<f64>,
    settings: &'a McmcSettings,
    mixture: Option<MixtureProposal>,
}

#[derive(Default, Clone, Copy)]
struct Counters {
    proposed: u64,
    accepted: u64,
}

impl Counters {
    fn rate(&self) -> f64 {
        if self.proposed == 0 {
            f64::NAN
        } else {
            self.accepted as f64 / self.proposed as f64
        }
    }
}

/// One chain: RNG stream, state, proposal, stored draws and counters.
struct Chain {
    rng: ChaCha8Rng,
    x: Vec<f64>,
    lp: f64,
    y: Vec<f64>,
    z: Vec<f64>,
    /// Reported coordinates and stored log density of the current state / the proposal.
    rx: Vec<f64>,
    ry: Vec<f64>,
    stored: f64,
    /// Largest `|x_i|` (sampler coordinates) over the sampling phase's states.
    max_abs: f64,
    adapt: Adaptation,
    /// Warm-up draws, `[parameter][draw]`.
    warm: Vec<Vec<f64>>,
    /// Warm-up states in sampler coordinates, the mixture's coordinates only (kept when the
    /// mixture refits), `[draw][coordinate]`.
    warm_x: Vec<Vec<f64>>,
    /// Sampling draws, `[parameter][draw]`.
    samp: Vec<Vec<f64>>,
    samp_lp: Vec<f64>,
    phase_iter: usize,
    warm_counts: Counters,
    samp_counts: Counters,
    /// Mixture (mode-jumping) steps of the sampling phase.
    jump_counts: Counters,
    evaluations: u64,
    failed: u64,
    out_of_bounds: u64,
    zero_density: u64,
}

impl Chain {
    fn new<T: LogDensity + ?Sized>(
        target: &T,
        ctx: &Context<'_>,
        chain: usize,
        init: Option<&[f64]>,
    ) -> Result<Self, McmcError> {
        let d = ctx.widths.len();
        let mut rng = ChaCha8Rng::seed_from_u64(ctx.settings.seed);
        rng.set_stream(chain as u64 + 1);
        let mut evaluations = 0u64;
        let mut failed = 0u64;
        let mut rx = vec![0.0; d];
        let (x, (lp, stored)) = match init {
            Some(x0) => {
                if x0.len() != d {
                    return Err(McmcError::InitDimension {
                        chain,
                        expected: d,
                        got: x0.len(),
                    });
                }
                for (i, &v) in x0.iter().enumerate() {
                    if !(v >= ctx.lower[i] && v <= ctx.upper[i]) {
                        return Err(McmcError::InitOutOfBounds {
                            chain,
                            index: i,
                            value: v,
                        });
                    }
                }
                evaluations += 1;
                match target.evaluate(x0, &mut rx) {
                    Some(v) if v.0.is_finite() => (x0.to_vec(), v),
                    _ => return Err(McmcError::InitNotFinite { chain }),
                }
            }
            None => {
                let mut x = vec![0.0; d];
                let mut found = None;
                for _ in 0..MAX_INIT_TRIES {
                    for ((xi, lo), w) in x.iter_mut().zip(&ctx.lower).zip(&ctx.widths) {
                        *xi = lo + w * rng.random::<f64>();
                    }
                    evaluations += 1;
                    match target.evaluate(&x, &mut rx) {
                        Some(v) if v.0.is_finite() => {
                            found = Some(v);
                            break;
                        }
                        _ => failed += 1,
                    }
                }
                match found {
                    Some(v) => (x, v),
                    None => {
                        return Err(McmcError::NoValidStart {
                            chain,
                            tries: MAX_INIT_TRIES,
                        })
                    }
                }
            }
        };
        Ok(Self {
            rng,
            x,
            lp,
            y: vec![0.0; d],
            z: vec![0.0; d],
            rx,
            ry: vec![0.0; d],
            stored,
            max_abs: 0.0,
            adapt: Adaptation::new(&ctx.widths),
            warm: vec![Vec::new(); d],
            warm_x: Vec::new(),
            samp: vec![Vec::new(); d],
            samp_lp: Vec::new(),
            phase_iter: 0,
            warm_counts: Counters::default(),
            samp_counts: Counters::default(),
            jump_counts: Counters::default(),
            evaluations,
            failed,
            out_of_bounds: 0,
            zero_density: 0,
        })
    }

    /// One Metropolis–Hastings step; returns `(acceptance probability, accepted, mixture step)`.
    fn step<T: LogDensity + ?Sized>(&mut self, target: &T, ctx: &Context<'_>) -> (f64, bool, bool) {
        // ln q(x) − ln q(y) of an independence step (0 for the symmetric random walk).
        let mut log_q_ratio = 0.0;
        let jump = match &ctx.mixture {
            Some(mix) if mix.probability() > 0.0 => self.rng.random::<f64>() < mix.probability(),
            _ => false,
        };
        if let (true, Some(mix)) = (jump, &ctx.mixture) {
            self.y.copy_from_slice(&self.x);
            mix.sample(&mut self.rng, &mut self.y);
            log_q_ratio = mix.log_density(&self.x) - mix.log_density(&self.y);
        } else {
            self.random_walk(ctx);
        }
        let (alpha, accepted) = self.accept(target, ctx, log_q_ratio);
        (alpha, accepted, jump)
    }

    /// Write the random-walk proposal into `y`.
    fn random_walk(&mut self, ctx: &Context<'_>) {
        let d = self.x.len();
        match ctx.settings.proposal {
            Proposal::Dissertation { scale } => {
                for i in 0..d {
                    let u: f64 = self.rng.random::<f64>() * 2.0 - 1.0;
                    self.y[i] = self.x[i] + scale * ctx.widths[i] * u;
                }
            }
            Proposal::Adaptive => {
                for zi in self.z.iter_mut() {
                    *zi = self.rng.sample(StandardNormal);
                }
                let s = (0.5 * self.adapt.log_lambda).exp();
                for i in 0..d {
                    let row = &self.adapt.chol[i * d..i * d + i + 1];
                    let lz: f64 = row.iter().zip(&self.z).map(|(l, z)| l * z).sum();
                    self.y[i] = self.x[i] + s * lz;
                }
            }
        }
    }

    /// Accept or reject the proposal in `y` given `ln q(x) − ln q(y)`.
    fn accept<T: LogDensity + ?Sized>(
        &mut self,
        target: &T,
        ctx: &Context<'_>,
        log_q_ratio: f64,
    ) -> (f64, bool) {
        let inside = self
            .y
            .iter()
            .enumerate()
            .all(|(i, &v)| v >= ctx.lower[i] && v <= ctx.upper[i]);
        if !inside {
            self.out_of_bounds += 1;
            return (0.0, false);
        }
        self.evaluations += 1;
        match target.evaluate(&self.y, &mut self.ry) {
            Some((v, stored)) if v.is_finite() => {
                let log_ratio = v - self.lp + log_q_ratio;
                let alpha = if log_ratio.is_nan() {
                    0.0
                } else if log_ratio >= 0.0 {
                    1.0
                } else {
                    log_ratio.exp()
                };
                let u: f64 = self.rng.random();
                if u < alpha {
                    std::mem::swap(&mut self.x, &mut self.y);
                    std::mem::swap(&mut self.rx, &mut self.ry);
                    self.lp = v;
                    self.stored = stored;
                    (alpha, true)
                } else {
                    (alpha, false)
                }
            }
            Some((v, _)) if v == f64::NEG_INFINITY => {
                self.zero_density += 1;
                (0.0, false)
            }
            _ => {
                self.failed += 1;
                (0.0, false)
            }
        }
    }

    /// Run `iters` iterations of the given phase.
    fn run_block<T: LogDensity + ?Sized>(
        &mut self,
        target: &T,
        ctx: &Context<'_>,
        iters: usize,
        phase: ChainPhase,
    ) {
        let thin = ctx.settings.thin;
        let adaptive = matches!(ctx.settings.proposal, Proposal::Adaptive);
        let store_len = iters / thin + 1;
        match phase {
            ChainPhase::Warmup => self.warm.iter_mut().for_each(|v| v.reserve(store_len)),
            ChainPhase::Sampling => {
                self.samp.iter_mut().for_each(|v| v.reserve(store_len));
                self.samp_lp.reserve(store_len);
            }
        }
        for _ in 0..iters {
            let (alpha, accepted, jump) = self.step(target, ctx);
            let counts = match phase {
                ChainPhase::Warmup => &mut self.warm_counts,
                ChainPhase::Sampling => &mut self.samp_counts,
            };
            counts.proposed += 1;
            counts.accepted += u64::from(accepted);
            if jump && phase == ChainPhase::Sampling {
                self.jump_counts.proposed += 1;
                self.jump_counts.accepted += u64::from(accepted);
            }
            // The random walk's scale adapts to its own acceptance only.
            if adaptive && phase == ChainPhase::Warmup && !jump {
                self.adapt.update(
                    &self.x,
                    alpha,
                    accepted,
                    ctx.settings.target_acceptance,
                    &ctx.widths,
                );
            }
            if phase == ChainPhase::Sampling {
                for v in &self.x {
                    self.max_abs = self.max_abs.max(v.abs());
                }
            }
            self.phase_iter += 1;
            if self.phase_iter % thin == 0 {
                let store = match phase {
                    ChainPhase::Warmup => &mut self.warm,
                    ChainPhase::Sampling => &mut self.samp,
                };
                for (s, &v) in store.iter_mut().zip(&self.rx) {
                    s.push(v);
                }
                if phase == ChainPhase::Warmup {
                    if let Some(mix) = ctx.mixture.as_ref().filter(|m| m.refit_components() > 0) {
                        self.warm_x
                            .push(mix.coords().iter().map(|&i| self.x[i]).collect());
                    }
                }
                if phase == ChainPhase::Sampling {
                    self.samp_lp.push(self.stored);
                }
            }
        }
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
fn check_target<T: LogDensity + ?Sized>(target: &T) -> Result<(), McmcError> {
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

/// Largest R̂ and smallest bulk ESS over the parameters: during warm-up over
/// the second half of the warm-up draws (R̂ only), during sampling over all
/// sampling draws. NaN propagates (a NaN R̂ is never "below target").
fn monitor(chains: &[Chain], d: usize, warmup: bool) -> (f64, f64) {
    let per_param: Vec<(f64, f64)> = (0..d)
        .into_par_iter()
        .map(|i| {
            let slices: Vec<&[f64]> = chains
                .iter()
                .map(|c| {
                    if warmup {
                        let v = &c.warm[i];
                        &v[v.len() / 2..]
                    } else {
                        c.samp[i].as_slice()
                    }
                })
                .collect();
            let r = diagnostics::rhat(&slices);
            let e = if warmup {
                f64::NAN
            } else {
                diagnostics::ess_bulk(&slices)
            };
            (r, e)
        })
        .collect();
    let mut max_rhat = f64::NEG_INFINITY;
    let mut min_ess = f64::INFINITY;
    for (r, e) in per_param {
        max_rhat = if r.is_nan() || max_rhat.is_nan() {
            f64::NAN
        } else {
            max_rhat.max(r)
        };
        min_ess = if e.is_nan() || min_ess.is_nan() {
            f64::NAN
        } else {
            min_ess.min(e)
        };
    }
    (max_rhat, min_ess)
}

/// Iterations until the next convergence check: `block`, growing to about
/// 10 % of the iterations already done in the phase (a multiple of `block`),
/// so the cost of monitoring stays proportional to the cost of sampling.
fn check_interval(block: usize, done: usize) -> usize {
    block * (done / (10 * block)).max(1)
}

fn mean_rate(chains: &[Chain], phase: ChainPhase) -> f64 {
    let (acc, prop) = chains.iter().fold((0u64, 0u64), |(a, p), c| {
        let k = match phase {
            ChainPhase::Warmup => c.warm_counts,
            ChainPhase::Sampling => c.samp_counts,
        };
        (a + k.accepted, p + k.proposed)
    });
    if prop == 0 {
        f64::NAN
    } else {
        acc as f64 / prop as f64
    }
}

/// Replace a refitting mixture by its refit to the pooled second halves of the chains'
/// warm-up states (at most 1 500 per chain, evenly thinned). Deterministic: the k-means
/// seeding draws from the seed's stream `2²² + iterations`.
fn refit_mixture(ctx: &mut Context<'_>, chains: &[Chain], seed: u64, iterations: u64) {
    let Some(mix) = ctx.mixture.as_ref().filter(|m| m.refit_components() > 0) else {
        return;
    };
    let mut pooled = Vec::new();
    for c in chains {
        let half = &c.warm_x[c.warm_x.len() / 2..];
        let step = half.len().div_ceil(1_500).max(1);
        pooled.extend(half.iter().step_by(step).cloned());
    }
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    rng.set_stream((1 << 22) + iterations);
    if let Some(new) = mix.refitted(&pooled, &mut rng) {
        ctx.mixture = Some(new);
    }
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
    let bounds = target.bounds().to_vec();
    let report_bounds = target.report_bounds().to_vec();
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

    // Warm-up.
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
            .for_each(|c| c.run_block(target, &ctx, n, ChainPhase::Warmup));
        warm += n;
        let max_rhat = if warm >= settings.warmup_min {
            monitor(&chains, d, true).0
        } else {
            f64::NAN
        };
        let progress = ChainProgress {
            phase: ChainPhase::Warmup,
            iterations: warm,
            phase_iterations: warm,
            max_rhat,
            min_ess_bulk: f64::NAN,
            acceptance_rate: mean_rate(&chains, ChainPhase::Warmup),
        };
        if observer(&progress).is_break() {
            stopped = true;
            break;
        }
        if max_rhat < settings.warmup_rhat_target {
            warmup_converged = true;
            break;
        }
        refit_mixture(&mut ctx, &chains, settings.seed, warm as u64);
    }
    for c in &mut chains {
        c.phase_iter = 0;
        c.warm = Vec::new();
        c.warm_x = Vec::new();
    }

    // Sampling with the frozen proposal.
    let mut samp = 0usize;
    let mut stop = ChainStopReason::Stopped;
    if !stopped {
        loop {
            let n = check_interval(block, samp).min(settings.max_total - warm - samp);
            if n == 0 {
                stop = ChainStopReason::CapReached;
                break;
            }
            chains
                .par_iter_mut()
                .for_each(|c| c.run_block(target, &ctx, n, ChainPhase::Sampling));
            samp += n;
            let (max_rhat, min_ess) = monitor(&chains, d, false);
            let progress = ChainProgress {
                phase: ChainPhase::Sampling,
                iterations: warm + samp,
                phase_iterations: samp,
                max_rhat,
                min_ess_bulk: min_ess,
                acceptance_rate: mean_rate(&chains, ChainPhase::Sampling),
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
    }

    let draws: Vec<Vec<Vec<f64>>> = (0..d)
        .map(|i| {
            chains
                .iter_mut()
                .map(|c| std::mem::take(&mut c.samp[i]))
                .collect()
        })
        .collect();
    let summary: Vec<Summary> = (0..d)
        .into_par_iter()
        .map(|i| {
            let slices: Vec<&[f64]> = draws[i].iter().map(|c| c.as_slice()).collect();
            Summary::from_chains(&slices, report_bounds[i])
        })
        .collect();
    let correlation = correlation_matrix(&draws);
    let strongest = strongest_correlations(&correlation);
    Ok(RunResult {
        settings: *settings,
        dim: d,
        log_density: chains
            .iter_mut()
            .map(|c| std::mem::take(&mut c.samp_lp))
            .collect(),
        draws,
        warmup_iterations: warm,
        sampling_iterations: samp,
        warmup_converged,
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
    })
}
