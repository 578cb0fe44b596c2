//! Multi-start search for the posterior's modes in the nonlinear parameters.
//!
//! The F0 of every muscle enters the torque linearly, so the posterior of the other parameters
//! `θ` (LST and α0 per muscle) with F0 integrated out is, up to a constant,
//! `p(θ) ∝ exp(N − ½RSS(θ))/det R(θ)` (module `sampling_coordinates` at `u = 0`). Its maxima are found by
//! Nelder–Mead from the middle of the bounds and from `n − 1` Latin-hypercube points in the box
//! (run in parallel; each start is independent, so the result does not depend on the thread
//! count). The optima are sorted by `ln p`; each is kept as a new mode when its `ln p` is within
//! `max_gap` of the best and it lies more than 4 Laplace standard deviations
//! (`|L_k⁻¹(θ − θ_k)| > 4`) from every mode kept before it. Each mode carries its Laplace factor.
//!
//! Random truths inside the identification bounds give posteriors with a second mode surprisingly often
//! (the gastrocnemii trade LST against α0 and against each other); a random walk started at one
//! optimum never finds the other, and its 90 % intervals then miss the truth.

use numerics::cholesky::solve_lower_in_place;
use numerics::latin_hypercube::{latin_hypercube, StrataShuffle};
use numerics::{nelder_mead, FnObjective, NelderMeadSettings};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rayon::prelude::*;

use crate::sampling_coordinates::Conditional;
use crate::trial_term::TrialModel;
use crate::LogDensity;

/// RNG stream of the start design (the chains use streams `1..`; the chain starts stream 0).
const STREAM: u64 = 1 << 20;

/// Squared whitened distance under which two optima are the same mode.
const SAME_MODE_D2: f64 = 16.0;

/// One mode of the marginal posterior of `θ`.
#[derive(Clone, Debug)]
pub(crate) struct Mode {
    /// Model parameter vector at the mode (F0 at its conditional optimum).
    pub x: Vec<f64>,
    /// `ln p(θ)` up to the constant shared by all modes.
    pub log_density: f64,
    /// Lower Cholesky factor of θ's Laplace covariance at the mode.
    pub chol_nl: Vec<f64>,
}

/// One Nelder–Mead start: optimum (whitened θ, `ln p`) if it ran, evaluations, failures.
type StartOutcome = (Option<(Vec<f64>, f64)>, u64, u64);

/// What [`find_modes`] returns.
pub(crate) struct ModeSearch {
    /// Modes, best first (never empty).
    pub modes: Vec<Mode>,
    /// Model evaluations.
    pub evaluations: u64,
    /// Failed evaluations among them.
    pub failed: u64,
}

/// `|L⁻¹ d|²` for the lower-triangular `L` (row-major m×m).
fn whitened_norm2(chol: &[f64], d: &[f64]) -> f64 {
    let mut w = d.to_vec();
    solve_lower_in_place(chol, &mut w);
    w.iter().map(|v| v * v).sum()
}

/// Search the modes of a session's posterior (see the module documentation; `trials` not
/// empty, sharing free parameters and bounds) with `starts` Nelder–Mead runs of `evaluations`
/// each.
pub(crate) fn find_modes(
    trials: &[TrialModel<'_>],
    starts: usize,
    evaluations: u64,
    seed: u64,
    max_gap: f64,
) -> ModeSearch {
    let scout = Conditional::box_scaled(trials);
    let problem = trials[0].problem;
    let d = problem.dim();
    let nl = scout.nl().to_vec();
    let m = nl.len();
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    rng.set_stream(STREAM);
    let mut points = vec![vec![0.0; m]];
    // Latin-hypercube points of the cube scaled to [−0.9, 0.9]^m
    points.extend(
        latin_hypercube(
            &mut rng,
            starts.saturating_sub(1),
            m,
            StrataShuffle::Descending,
        )
        .into_iter()
        .map(|p| p.into_iter().map(|u| 0.9 * (2.0 * u - 1.0)).collect()),
    );
    let eval = |zt: &[f64], x: &mut [f64]| -> Option<f64> {
        let mut v = vec![0.0; d];
        for (a, &i) in nl.iter().enumerate() {
            v[i] = zt[a];
        }
        scout
            .evaluate(&v, x)
            .map(|p| p.0)
            .filter(|lt| lt.is_finite())
    };
    let nm = NelderMeadSettings {
        max_evaluations: evaluations,
        initial_step: 0.15,
        ftol_abs: 1e-3,
        ftol_rel: 0.0,
        xtol: 1e-5,
        max_restarts: 2,
    };
    let runs: Vec<StartOutcome> = points
        .par_iter()
        .map(|z0| {
            let mut x = vec![0.0; d];
            let mut obj = FnObjective::new(vec![(-1.0, 1.0); m], |zt: &[f64]| {
                eval(zt, &mut x).map(|lt| -lt)
            });
            match nelder_mead(&mut obj, z0, &nm) {
                Ok(out) => (
                    Some((out.x, -out.cost)),
                    out.evaluations,
                    out.failed_evaluations,
                ),
                Err(_) => (None, 1, 1),
            }
        })
        .collect();
    let mut evals: u64 = runs.iter().map(|r| r.1).sum();
    let mut failed: u64 = runs.iter().map(|r| r.2).sum();
    let mut optima: Vec<(Vec<f64>, f64)> = runs
        .into_iter()
        .filter_map(|r| r.0)
        .filter(|(_, lt)| lt.is_finite())
        .collect();
    optima.sort_by(|a, b| b.1.total_cmp(&a.1));
    let mut modes: Vec<Mode> = Vec::new();
    let best = optima.first().map_or(f64::NAN, |o| o.1);
    for (zt, lt) in optima {
        if modes.len() >= 8 || lt < best - max_gap {
            break;
        }
        let mut x = vec![0.0; d];
        evals += 1;
        if eval(&zt, &mut x).is_none() {
            failed += 1;
            continue;
        }
        let duplicate = modes.iter().any(|k| {
            let diff: Vec<f64> = nl.iter().map(|&i| x[i] - k.x[i]).collect();
            whitened_norm2(&k.chol_nl, &diff) < SAME_MODE_D2
        });
        if duplicate {
            continue;
        }
        let (chol_nl, sims) = scout.laplace_at(&x);
        evals += sims;
        modes.push(Mode {
            x,
            log_density: lt,
            chol_nl,
        });
    }
    if modes.is_empty() {
        // Every start failed: fall back to the middle of the box with the prior's scale.
        let mid: Vec<f64> = problem
            .bounds()
            .iter()
            .map(|(lo, hi)| 0.5 * (lo + hi))
            .collect();
        let (chol_nl, sims) = scout.laplace_at(&mid);
        evals += sims;
        modes.push(Mode {
            x: mid,
            log_density: f64::NAN,
            chol_nl,
        });
    }
    ModeSearch {
        modes,
        evaluations: evals,
        failed,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn whitened_norm_solves_the_triangular_system() {
        // L = [[2, 0], [1, 1]]: L⁻¹(4, 3) = (2, 1), |.|² = 5.
        assert!((whitened_norm2(&[2.0, 0.0, 1.0, 1.0], &[4.0, 3.0]) - 5.0).abs() < 1e-15);
    }
}
