//! What the driver does between blocks: the convergence monitor, the interval to the next
//! check, the acceptance rates and the refit of the jump mixture.

use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rayon::prelude::*;

use crate::diagnostics;

use super::chain::{Chain, ChainPhase, Context};

/// Largest R̂ and smallest bulk ESS over the parameters: during warm-up over
/// the second half of the warm-up draws (R̂ only), during sampling over all
/// sampling draws. NaN propagates (a NaN R̂ is never "below target").
pub(super) fn monitor(chains: &[Chain], d: usize, warmup: bool) -> (f64, f64) {
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
pub(super) fn check_interval(block: usize, done: usize) -> usize {
    block * (done / (10 * block)).max(1)
}

pub(super) fn mean_rate(chains: &[Chain], phase: ChainPhase) -> f64 {
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
pub(super) fn refit_mixture(ctx: &mut Context<'_>, chains: &[Chain], seed: u64, iterations: u64) {
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
