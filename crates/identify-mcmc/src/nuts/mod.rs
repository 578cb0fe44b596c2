//! The No-U-Turn Sampler: settings, per-draw statistics, the result and the parallel driver.
//!
//! The equations are in the crate documentation ("Gradient-based sampler"); one transition is
//! in `trajectory`, the warm-up adaptation in `adaptation`.

use rand::Rng;
use rand_chacha::ChaCha8Rng;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use crate::sampler::{chain_rng, check_target};
use crate::summary::{correlation_matrix, summaries, Summary};
use crate::{GradLogDensity, LogisticBox, McmcError, MAX_INIT_TRIES};

mod adaptation;
mod metric;
mod trajectory;

use adaptation::{DualAveraging, Windows};
use metric::{Metric, Welford};
use trajectory::{hamiltonian, leapfrog, sample_momentum, transition, Model, Point, Scratch};

/// Settings of [`run_nuts`], Stan's defaults. Counts are iterations **per chain**.
///
/// ```
/// use identify_mcmc::NutsSettings;
/// let s = NutsSettings { seed: 7, draws: 500, ..NutsSettings::default() };
/// assert_eq!((s.chains, s.warmup, s.max_depth), (4, 1000, 10));
/// assert!(s.validate().is_ok());
/// ```
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct NutsSettings {
    /// Seed of every chain's `ChaCha8Rng` (chain `c` uses stream `c + 1`).
    pub seed: u64,
    /// Number of chains (≥ 1; 4).
    pub chains: usize,
    /// Warm-up (adaptation) iterations, discarded (1000).
    pub warmup: usize,
    /// Kept draws (≥ 1; 1000).
    pub draws: usize,
    /// Mean acceptance statistic `δ` the step size adapts to (0.8).
    pub target_accept: f64,
    /// Largest tree depth: at most `2^max_depth − 1` leapfrog steps per draw (1..=30; 10).
    pub max_depth: u32,
    /// Energy error `H − H₀` above which a trajectory diverges (1000).
    pub max_energy_error: f64,
    /// Step size the initialisation heuristic starts from (1).
    pub initial_step_size: f64,
    /// Warm-up iterations before the first metric window (75).
    pub init_buffer: usize,
    /// Warm-up iterations after the last metric window (50).
    pub term_buffer: usize,
    /// Length of the first metric window; each next one doubles (25).
    pub base_window: usize,
    /// Adapt a dense inverse metric (the posterior covariance, Stan's `dense_e`) instead of a
    /// diagonal one (`diag_e`, Stan's default; false).
    pub dense_metric: bool,
}

impl Default for NutsSettings {
    fn default() -> Self {
        Self {
            seed: 42,
            chains: 4,
            warmup: 1000,
            draws: 1000,
            target_accept: 0.8,
            max_depth: 10,
            max_energy_error: 1000.0,
            initial_step_size: 1.0,
            init_buffer: 75,
            term_buffer: 50,
            base_window: 25,
            dense_metric: false,
        }
    }
}

impl NutsSettings {
    /// Check every field; the first problem found is returned.
    ///
    /// # Errors
    /// [`McmcError::InvalidSetting`] naming the field and the allowed range.
    pub fn validate(&self) -> Result<(), McmcError> {
        let bad = |name: &'static str, value: String, reason: &'static str| {
            Err(McmcError::InvalidSetting {
                name,
                value,
                reason,
            })
        };
        if self.chains == 0 {
            return bad("chains", "0".into(), "at least one chain is needed");
        }
        if self.draws == 0 {
            return bad("draws", "0".into(), "at least one draw is needed");
        }
        if !(self.target_accept > 0.0 && self.target_accept < 1.0) {
            return bad(
                "target_accept",
                self.target_accept.to_string(),
                "must lie in (0, 1)",
            );
        }
        if !(1..=30).contains(&self.max_depth) {
            return bad(
                "max_depth",
                self.max_depth.to_string(),
                "must lie in 1..=30",
            );
        }
        if !(self.max_energy_error.is_finite() && self.max_energy_error > 0.0) {
            return bad(
                "max_energy_error",
                self.max_energy_error.to_string(),
                "must be finite and > 0",
            );
        }
        if !(self.initial_step_size.is_finite() && self.initial_step_size > 0.0) {
            return bad(
                "initial_step_size",
                self.initial_step_size.to_string(),
                "must be finite and > 0",
            );
        }
        if self.base_window == 0 {
            return bad("base_window", "0".into(), "must be at least 1");
        }
        Ok(())
    }
}

/// CmdStan's sampler statistics of one kept draw.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[non_exhaustive]
pub struct NutsDraw {
    /// `lp__`: `log p(u)` on the unconstrained coordinates, `log π(x(u)) + log J(u)`.
    pub lp: f64,
    /// `accept_stat__`: mean of `min(1, e^{H₀−H})` over the trajectory's points.
    pub accept_stat: f64,
    /// `stepsize__`.
    pub step_size: f64,
    /// `treedepth__`: doublings of the trajectory.
    pub tree_depth: u32,
    /// `n_leapfrog__`: leapfrog steps (gradient evaluations) of the transition.
    pub n_leapfrog: u32,
    /// `divergent__`: the energy error exceeded the limit or an evaluation failed.
    pub divergent: bool,
    /// `energy__`: the Hamiltonian at the selected point.
    pub energy: f64,
}

/// The outcome of [`run_nuts`].
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[non_exhaustive]
pub struct NutsRun {
    /// The settings used.
    pub settings: NutsSettings,
    /// Number of parameters.
    pub dim: usize,
    /// Kept draws in the box coordinates, `[parameter][chain][draw]`.
    pub draws: Vec<Vec<Vec<f64>>>,
    /// `log π(x)` of every kept draw (box coordinates, no Jacobian), `[chain][draw]`.
    pub log_density: Vec<Vec<f64>>,
    /// Sampler statistics of every kept draw, `[chain][draw]`.
    pub stats: Vec<Vec<NutsDraw>>,
    /// The adapted step size of every chain.
    pub step_size: Vec<f64>,
    /// Mean `accept_stat__` of every chain over its last stretch of step-size adaptation (the
    /// warm-up iterations since the last restart of the dual averaging: the terminal buffer
    /// for the default schedule), the quantity the dual averaging drives to `target_accept`;
    /// NaN without warm-up. The kept draws' mean ([`NutsRun::mean_accept_stat`]) is usually
    /// higher: they use `exp(x̄)`, smaller than the typical adapted step (as in Stan).
    pub adaptation_accept_stat: Vec<f64>,
    /// The adapted inverse metric (unconstrained coordinates) of every chain: its diagonal, or
    /// with [`NutsSettings::dense_metric`] every element row by row.
    pub inv_metric: Vec<Vec<f64>>,
    /// Gradient evaluations over all chains (start search, step-size heuristic, warm-up and
    /// sampling).
    pub gradient_evaluations: u64,
    /// Evaluations that failed (`None`, non-finite value or gradient).
    pub failed_evaluations: u64,
    /// Divergent transitions among the kept draws.
    pub divergences: u64,
    /// Divergent transitions during warm-up.
    pub warmup_divergences: u64,
    /// Kept draws whose trajectory stopped at `max_depth`.
    pub max_depth_hits: u64,
    /// Per-parameter summary of the kept draws (R̂, bulk and tail ESS; the bounds as prior).
    pub summary: Vec<Summary>,
    /// Pooled posterior correlation matrix.
    pub correlation: Vec<Vec<f64>>,
}

impl NutsRun {
    /// The chains of parameter `param` as slices, ready for [`crate::diagnostics`].
    ///
    /// # Panics
    /// If `param >= dim`.
    pub fn chains(&self, param: usize) -> Vec<&[f64]> {
        self.draws[param].iter().map(|c| c.as_slice()).collect()
    }

    fn mean_stat(&self, f: impl Fn(&NutsDraw) -> f64) -> f64 {
        let n: usize = self.stats.iter().map(Vec::len).sum();
        self.stats.iter().flatten().map(f).sum::<f64>() / n as f64
    }

    /// Mean `accept_stat__` over the kept draws.
    pub fn mean_accept_stat(&self) -> f64 {
        self.mean_stat(|s| s.accept_stat)
    }

    /// Mean `n_leapfrog__` over the kept draws.
    pub fn mean_leapfrog(&self) -> f64 {
        self.mean_stat(|s| f64::from(s.n_leapfrog))
    }

    /// Largest R̂ over the parameters.
    pub fn max_rhat(&self) -> f64 {
        self.summary.iter().fold(f64::NAN, |m, s| m.max(s.rhat))
    }

    /// Smallest bulk ESS over the parameters.
    pub fn min_ess_bulk(&self) -> f64 {
        self.summary.iter().fold(f64::NAN, |m, s| m.min(s.ess_bulk))
    }

    /// Smallest tail ESS over the parameters.
    pub fn min_ess_tail(&self) -> f64 {
        self.summary.iter().fold(f64::NAN, |m, s| m.min(s.ess_tail))
    }
}

/// What one chain hands back.
struct ChainOutput {
    draws: Vec<Vec<f64>>,
    log_density: Vec<f64>,
    stats: Vec<NutsDraw>,
    step_size: f64,
    adaptation_accept_stat: f64,
    inv_metric: Vec<f64>,
    evaluations: u64,
    failed: u64,
    warmup_divergences: u64,
}

/// Run `settings.chains` NUTS chains on `target` (crate documentation, "Gradient-based
/// sampler").
///
/// `init`: one start point per chain in the box coordinates (strictly inside the bounds), or
/// `None` for Stan's default, `u ~ U(−2, 2)` on every unconstrained coordinate, re-drawn while
/// the evaluation fails (up to [`MAX_INIT_TRIES`]). The chains run in parallel on rayon's
/// current pool; chain `c` uses `ChaCha8Rng::seed_from_u64(seed)` on stream `c + 1`, so the
/// result is bit-identical for any number of threads.
///
/// # Errors
/// Invalid settings or bounds, malformed or infeasible start points, or a step-size heuristic
/// that ran away ([`McmcError::StepSize`]).
///
/// ```
/// use identify_mcmc::{run_nuts, FnGradLogDensity, NutsSettings};
/// let target = FnGradLogDensity::new(vec![(-10.0, 10.0); 2], |x: &[f64], g: &mut [f64]| {
///     g.iter_mut().zip(x).for_each(|(g, x)| *g = -x);
///     Some(-0.5 * x.iter().map(|v| v * v).sum::<f64>())
/// });
/// let settings = NutsSettings { seed: 3, warmup: 300, draws: 300, ..NutsSettings::default() };
/// let run = run_nuts(&target, &settings, None).unwrap();
/// assert!(run.max_rhat() < 1.05 && run.divergences == 0);
/// ```
pub fn run_nuts<T: GradLogDensity + ?Sized>(
    target: &T,
    settings: &NutsSettings,
    init: Option<&[Vec<f64>]>,
) -> Result<NutsRun, McmcError> {
    settings.validate()?;
    check_target(target)?;
    if let Some(points) = init {
        if points.len() != settings.chains {
            return Err(McmcError::InitCount {
                expected: settings.chains,
                got: points.len(),
            });
        }
    }
    let bounds = target.bounds().to_vec();
    let transform = LogisticBox::new(&bounds);
    let outputs: Vec<Result<ChainOutput, McmcError>> = (0..settings.chains)
        .into_par_iter()
        .map(|c| {
            run_chain(
                target,
                &transform,
                settings,
                c,
                init.map(|p| p[c].as_slice()),
            )
        })
        .collect();
    let mut outputs = outputs.into_iter().collect::<Result<Vec<_>, _>>()?;
    let d = bounds.len();
    let draws: Vec<Vec<Vec<f64>>> = (0..d)
        .map(|i| {
            outputs
                .iter_mut()
                .map(|o| std::mem::take(&mut o.draws[i]))
                .collect()
        })
        .collect();
    let summary: Vec<Summary> = summaries(&draws, &bounds);
    let correlation = correlation_matrix(&draws);
    let stats: Vec<Vec<NutsDraw>> = outputs
        .iter_mut()
        .map(|o| std::mem::take(&mut o.stats))
        .collect();
    let count = |f: fn(&NutsDraw) -> bool| stats.iter().flatten().filter(|s| f(s)).count() as u64;
    let divergences = count(|s| s.divergent);
    let max_depth = settings.max_depth;
    let max_depth_hits = stats
        .iter()
        .flatten()
        .filter(|s| s.tree_depth >= max_depth)
        .count() as u64;
    Ok(NutsRun {
        settings: *settings,
        dim: d,
        draws,
        log_density: outputs
            .iter_mut()
            .map(|o| std::mem::take(&mut o.log_density))
            .collect(),
        stats,
        step_size: outputs.iter().map(|o| o.step_size).collect(),
        adaptation_accept_stat: outputs.iter().map(|o| o.adaptation_accept_stat).collect(),
        inv_metric: outputs
            .iter_mut()
            .map(|o| std::mem::take(&mut o.inv_metric))
            .collect(),
        gradient_evaluations: outputs.iter().map(|o| o.evaluations).sum(),
        failed_evaluations: outputs.iter().map(|o| o.failed).sum(),
        divergences,
        warmup_divergences: outputs.iter().map(|o| o.warmup_divergences).sum(),
        max_depth_hits,
        summary,
        correlation,
    })
}

/// The start of chain `chain`: the given point (checked) or Stan's uniform draws on
/// `(−2, 2)ᵈ` in the unconstrained coordinates.
fn start_point<T: GradLogDensity + ?Sized>(
    model: &mut Model<'_, T>,
    transform: &LogisticBox,
    bounds: &[(f64, f64)],
    chain: usize,
    init: Option<&[f64]>,
    rng: &mut ChaCha8Rng,
) -> Result<Point, McmcError> {
    let d = bounds.len();
    let mut z = Point {
        q: vec![0.0; d],
        p: vec![0.0; d],
        grad: vec![0.0; d],
        logp: f64::NEG_INFINITY,
    };
    if let Some(x0) = init {
        if x0.len() != d {
            return Err(McmcError::InitDimension {
                chain,
                expected: d,
                got: x0.len(),
            });
        }
        for (index, (&value, &(lo, hi))) in x0.iter().zip(bounds).enumerate() {
            if !(value > lo && value < hi) {
                return Err(McmcError::InitOutOfBounds {
                    chain,
                    index,
                    value,
                });
            }
        }
        transform.to_unconstrained(x0, &mut z.q);
        z.logp = model.eval(&z.q, &mut z.grad);
        return if z.logp.is_finite() {
            Ok(z)
        } else {
            Err(McmcError::InitNotFinite { chain })
        };
    }
    for _ in 0..MAX_INIT_TRIES {
        for q in &mut z.q {
            *q = rng.random_range(-2.0..2.0);
        }
        z.logp = model.eval(&z.q, &mut z.grad);
        if z.logp.is_finite() {
            return Ok(z);
        }
    }
    Err(McmcError::NoValidStart {
        chain,
        tries: MAX_INIT_TRIES,
    })
}

/// Stan's step-size heuristic: from `eps`, double (or halve) the step while one leapfrog step
/// from `z` with a fresh momentum keeps `H₀ − H` above (below) `log 0.8`; `z` is unchanged.
fn initial_step_size<T: GradLogDensity + ?Sized>(
    z: &Point,
    mut eps: f64,
    inv_metric: &Metric,
    model: &mut Model<'_, T>,
    rng: &mut ChaCha8Rng,
    chain: usize,
) -> Result<f64, McmcError> {
    let log_08 = 0.8f64.ln();
    let mut trial = z.clone();
    let mut step = |eps: f64, trial: &mut Point, rng: &mut ChaCha8Rng| {
        trial.clone_from(z);
        sample_momentum(trial, inv_metric, rng);
        let h0 = hamiltonian(trial, inv_metric);
        leapfrog(trial, eps, inv_metric, model);
        h0 - hamiltonian(trial, inv_metric)
    };
    let up = step(eps, &mut trial, rng) > log_08;
    loop {
        let delta = step(eps, &mut trial, rng);
        // `delta` is never NaN (`H` maps NaN to +∞): `−∞` after a failed step.
        let keep_going = if up { delta > log_08 } else { delta < log_08 };
        if !keep_going {
            return Ok(eps);
        }
        eps = if up { 2.0 * eps } else { 0.5 * eps };
        if !(eps <= 1e7 && eps > 0.0) {
            return Err(McmcError::StepSize {
                chain,
                step_size: eps,
            });
        }
    }
}

/// One chain: start, warm-up (dual averaging and metric windows) and the kept draws.
fn run_chain<T: GradLogDensity + ?Sized>(
    target: &T,
    transform: &LogisticBox,
    settings: &NutsSettings,
    chain: usize,
    init: Option<&[f64]>,
) -> Result<ChainOutput, McmcError> {
    let bounds = target.bounds();
    let d = bounds.len();
    let mut rng = chain_rng(settings.seed, chain);
    let mut model = Model::new(target, transform);
    let mut z = start_point(&mut model, transform, bounds, chain, init, &mut rng)?;
    let mut inv_metric = Metric::unit(d, settings.dense_metric);
    let mut scratch = Scratch::new(d, settings.max_depth);
    let mut eps = settings.initial_step_size;
    let mut dual = DualAveraging::new(settings.target_accept, eps);
    eps = initial_step_size(&z, eps, &inv_metric, &mut model, &mut rng, chain)?;
    let mut windows = Windows::new(
        settings.warmup,
        settings.init_buffer,
        settings.term_buffer,
        settings.base_window,
    );
    let mut welford = Welford::new(d, settings.dense_metric);
    let mut warmup_divergences = 0u64;
    // Sum and count of accept_stat since the dual averaging's last restart.
    let mut since_restart = (0.0, 0usize);
    for _ in 0..settings.warmup {
        let t = transition(
            &mut z,
            eps,
            &inv_metric,
            settings,
            &mut model,
            &mut rng,
            &mut scratch,
        );
        warmup_divergences += u64::from(t.divergent);
        eps = dual.learn(t.accept_stat);
        since_restart = (since_restart.0 + t.accept_stat, since_restart.1 + 1);
        if windows.in_window() {
            welford.add(&z.q);
        }
        if windows.advance() {
            inv_metric.update(&mut welford);
            eps = initial_step_size(&z, eps, &inv_metric, &mut model, &mut rng, chain)?;
            dual.restart(eps);
            since_restart = (0.0, 0);
        }
    }
    if settings.warmup > 0 {
        eps = dual.final_step_size();
    }
    let mut draws = vec![Vec::with_capacity(settings.draws); d];
    let mut log_density = Vec::with_capacity(settings.draws);
    let mut stats = Vec::with_capacity(settings.draws);
    let mut x = vec![0.0; d];
    for _ in 0..settings.draws {
        let t = transition(
            &mut z,
            eps,
            &inv_metric,
            settings,
            &mut model,
            &mut rng,
            &mut scratch,
        );
        model.to_box(&z.q, &mut x);
        for (col, &v) in draws.iter_mut().zip(&x) {
            col.push(v);
        }
        // log π(x) = log p(u) − log J(u); no extra evaluation.
        log_density.push(z.logp - transform.log_jacobian(&z.q));
        stats.push(NutsDraw {
            lp: z.logp,
            accept_stat: t.accept_stat,
            step_size: eps,
            tree_depth: t.tree_depth,
            n_leapfrog: t.n_leapfrog,
            divergent: t.divergent,
            energy: t.energy,
        });
    }
    Ok(ChainOutput {
        draws,
        log_density,
        stats,
        step_size: eps,
        adaptation_accept_stat: since_restart.0 / since_restart.1 as f64,
        inv_metric: inv_metric.elements(),
        evaluations: model.evaluations,
        failed: model.failed,
        warmup_divergences,
    })
}
