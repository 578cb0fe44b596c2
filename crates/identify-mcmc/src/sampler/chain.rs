//! One chain of the sampler: its RNG stream, state, proposal (random walk or mode jump),
//! stored draws and counters.

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::StandardNormal;
use serde::{Deserialize, Serialize};

use crate::mixture::MixtureProposal;
use crate::{LogDensity, McmcError, McmcSettings, Proposal};

use super::adaptation::Adaptation;

/// Uniform draws from the bounds tried per chain to find a finite start.
pub const MAX_INIT_TRIES: usize = 1_000;

/// Which phase a [`ChainProgress`](super::ChainProgress) report comes from.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[non_exhaustive]
pub enum ChainPhase {
    /// Warm-up (adaptation on for [`Proposal::Adaptive`]); draws discarded.
    Warmup,
    /// Sampling with the frozen proposal; draws kept.
    Sampling,
}

/// The RNG of chain `chain` (from 0): `ChaCha8Rng::seed_from_u64(seed)` on stream
/// `chain + 1` (stream 0 is left for start designs), shared by every sampler of the crate so
/// that a run is bit-identical for any number of threads.
pub(crate) fn chain_rng(seed: u64, chain: usize) -> ChaCha8Rng {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    rng.set_stream(chain as u64 + 1);
    rng
}

/// Read-only context shared by all chains.
pub(super) struct Context<'a> {
    pub(super) lower: Vec<f64>,
    pub(super) upper: Vec<f64>,
    pub(super) widths: Vec<f64>,
    pub(super) settings: &'a McmcSettings,
    pub(super) mixture: Option<MixtureProposal>,
}

#[derive(Default, Clone, Copy)]
pub(super) struct Counters {
    pub(super) proposed: u64,
    pub(super) accepted: u64,
}

impl Counters {
    pub(super) fn rate(&self) -> f64 {
        if self.proposed == 0 {
            f64::NAN
        } else {
            self.accepted as f64 / self.proposed as f64
        }
    }
}

/// One chain: RNG stream, state, proposal, stored draws and counters.
pub(super) struct Chain {
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
    pub(super) max_abs: f64,
    adapt: Adaptation,
    /// Warm-up draws, `[parameter][draw]`.
    pub(super) warm: Vec<Vec<f64>>,
    /// Warm-up states in sampler coordinates, the mixture's coordinates only (kept when the
    /// mixture refits), `[draw][coordinate]`.
    pub(super) warm_x: Vec<Vec<f64>>,
    /// Sampling draws, `[parameter][draw]`.
    pub(super) samp: Vec<Vec<f64>>,
    pub(super) samp_lp: Vec<f64>,
    pub(super) phase_iter: usize,
    pub(super) warm_counts: Counters,
    pub(super) samp_counts: Counters,
    /// Mixture (mode-jumping) steps of the sampling phase.
    pub(super) jump_counts: Counters,
    pub(super) evaluations: u64,
    pub(super) failed: u64,
    pub(super) out_of_bounds: u64,
    pub(super) zero_density: u64,
}

impl Chain {
    pub(super) fn new<T: LogDensity + ?Sized>(
        target: &T,
        ctx: &Context<'_>,
        chain: usize,
        init: Option<&[f64]>,
    ) -> Result<Self, McmcError> {
        let d = ctx.widths.len();
        let mut rng = chain_rng(ctx.settings.seed, chain);
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
    pub(super) fn run_block<T: LogDensity + ?Sized>(
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
