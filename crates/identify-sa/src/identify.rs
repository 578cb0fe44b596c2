//! Identification of the muscle parameters (SPEC §8): parallel annealing chains on the
//! sum of squared torque errors, each polished by a bounded Levenberg–Marquardt.

use std::collections::BTreeMap;
use std::ops::ControlFlow;
use std::time::Instant;

use muscle_model::{ModelParams, ParamId, Problem, ProblemWorkspace};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use crate::{
    run, Error, NelderMeadSettings, Objective, Progress, Settings, StageRecord, StopReason,
};

/// A [`Problem`] seen as an [`Objective`]: the cost is the (weighted) sum of squared torque
/// errors of the dissertation's eq. 12, [`Problem::sse_with`], evaluated with a reusable
/// [`ProblemWorkspace`]; a failed simulation is `None` (a rejected move).
#[derive(Debug)]
pub struct ProblemObjective<'a> {
    problem: &'a Problem,
    ws: ProblemWorkspace,
}

impl<'a> ProblemObjective<'a> {
    /// Wrap a problem (allocates one workspace).
    #[must_use]
    pub fn new(problem: &'a Problem) -> Self {
        Self {
            problem,
            ws: ProblemWorkspace::new(),
        }
    }
}

impl Objective for ProblemObjective<'_> {
    fn dim(&self) -> usize {
        self.problem.dim()
    }
    fn bounds(&self) -> &[(f64, f64)] {
        self.problem.bounds()
    }
    fn cost(&mut self, x: &[f64]) -> Option<f64> {
        self.problem.sse_with(x, &mut self.ws).ok()
    }
}

/// Settings of the bounded Levenberg–Marquardt polish (see [`identify`]).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct LmSettings {
    /// Maximum Jacobian evaluations (iterations). Default 40; 0 disables the polish.
    pub max_iterations: u32,
    /// Central-difference step, unit-box coordinates (share of each range). Default 1e-3
    /// (large enough that the adaptive integrator's error, ~0.01 N·m, does not dominate).
    pub fd_step: f64,
    /// Initial damping `λ` (relative to the diagonal of `JᵀJ`). Default 1e-3.
    pub lambda0: f64,
    /// Stop when an accepted step lowers the cost by less than this fraction. Default 1e-10.
    pub ftol_rel: f64,
}

impl Default for LmSettings {
    fn default() -> Self {
        Self {
            max_iterations: 40,
            fd_step: 1e-3,
            lambda0: 1e-3,
            ftol_rel: 1e-10,
        }
    }
}

/// Settings of [`identify`]. Plain data; `Default` are the values documented in the crate doc
/// (chosen so that a seed-protocol fit takes well under 30 s on two cores).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct IdentifySettings {
    /// Master seed: chain `k` anneals with seed [`chain_seed`]`(seed, k)`. Default 42.
    pub seed: u64,
    /// Independent annealing chains, run in parallel (rayon); chain 0 starts from the base
    /// (nominal) values clamped into the bounds, the others from uniform random points of their
    /// own stream. The result does not depend on the number of threads. Default 4.
    pub chains: u32,
    /// Annealer settings of every chain (its `seed` is replaced per chain). Defaults:
    /// [`IdentifySettings::default_annealer`].
    pub annealer: Settings,
    /// The Levenberg–Marquardt polish applied to every chain's best point.
    pub polish: LmSettings,
}

impl Default for IdentifySettings {
    fn default() -> Self {
        Self {
            seed: 42,
            chains: 4,
            annealer: Self::default_annealer(),
            polish: LmSettings::default(),
        }
    }
}

impl IdentifySettings {
    /// The annealer settings used per chain by default: 6 000 evaluations, cooling 0.8,
    /// stages of `N_s = 5` × `N_T = 4` sweeps (180 evaluations for 9 parameters), 6
    /// re-annealings at 0.1 T₀ with steps 0.05, and a 5 % Nelder–Mead polish before the
    /// Levenberg–Marquardt one. Everything else is [`Settings::default`].
    #[must_use]
    pub fn default_annealer() -> Settings {
        Settings {
            max_evaluations: 6_000,
            cooling: 0.8,
            moves_per_adaptation: 5,
            adaptations_per_stage: 4,
            max_reanneals: 6,
            reanneal_temperature: 0.1,
            reanneal_step: 0.05,
            polish_fraction: 0.05,
            polish: NelderMeadSettings::default(),
            ..Settings::default()
        }
    }

    /// Set the master seed.
    #[must_use]
    pub fn with_seed(mut self, seed: u64) -> Self {
        self.seed = seed;
        self
    }

    /// Set the number of chains.
    #[must_use]
    pub fn with_chains(mut self, chains: u32) -> Self {
        self.chains = chains;
        self
    }

    /// Set the per-chain evaluation budget of the annealer.
    #[must_use]
    pub fn with_chain_evaluations(mut self, evaluations: u64) -> Self {
        self.annealer.max_evaluations = evaluations;
        self
    }

    /// Check every field.
    ///
    /// # Errors
    /// [`Error::InvalidSetting`] naming the first invalid field.
    pub fn validate(self) -> Result<Self, Error> {
        if self.chains == 0 {
            return Err(Error::InvalidSetting {
                name: "chains",
                value: 0.0,
                reason: "must be at least 1",
            });
        }
        self.annealer.validate()?;
        let p = &self.polish;
        if !(p.fd_step > 0.0 && p.fd_step <= 0.1) {
            return Err(Error::InvalidSetting {
                name: "polish.fd_step",
                value: p.fd_step,
                reason: "must be in (0, 0.1]",
            });
        }
        if !(p.lambda0 > 0.0 && p.lambda0.is_finite()) {
            return Err(Error::InvalidSetting {
                name: "polish.lambda0",
                value: p.lambda0,
                reason: "must be positive and finite",
            });
        }
        if !(p.ftol_rel >= 0.0 && p.ftol_rel.is_finite()) {
            return Err(Error::InvalidSetting {
                name: "polish.ftol_rel",
                value: p.ftol_rel,
                reason: "must be finite and non-negative",
            });
        }
        Ok(self)
    }
}

/// The seed of chain `k`: `seed` for chain 0, a SplitMix64 mix of `(seed, k)` otherwise.
#[must_use]
pub fn chain_seed(seed: u64, k: u32) -> u64 {
    if k == 0 {
        return seed;
    }
    let mut z = seed.wrapping_add(u64::from(k).wrapping_mul(0x9E37_79B9_7F4A_7C15));
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// What [`identify`] reports to its observer.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case", tag = "event")]
pub enum IdentifyEvent {
    /// Progress of one annealing chain (after its initial-temperature search, every stage and
    /// its Nelder–Mead polish).
    Chain {
        /// Chain index.
        chain: u32,
        /// The annealer's snapshot.
        progress: Progress,
    },
    /// One accepted or rejected Levenberg–Marquardt iteration of a chain's polish.
    Polish {
        /// Chain index.
        chain: u32,
        /// Iteration number (from 1).
        iteration: u32,
        /// Best cost so far.
        cost: f64,
        /// Evaluations of the polish so far.
        evaluations: u64,
    },
}

/// Receives [`IdentifyEvent`]s, possibly from several threads at once (chains run in
/// parallel); returning `ControlFlow::Break(())` from a `Chain` event interrupts that chain
/// (its best point so far is still polished and returned).
///
/// Implemented for [`crate::NoObserver`] and every `Fn(&IdentifyEvent) -> ControlFlow<()> + Sync`.
pub trait IdentifyObserver: Sync {
    /// See the trait doc.
    fn observe(&self, event: &IdentifyEvent) -> ControlFlow<()>;
}

impl IdentifyObserver for crate::NoObserver {
    fn observe(&self, _: &IdentifyEvent) -> ControlFlow<()> {
        ControlFlow::Continue(())
    }
}

impl<F: Fn(&IdentifyEvent) -> ControlFlow<()> + Sync> IdentifyObserver for F {
    fn observe(&self, event: &IdentifyEvent) -> ControlFlow<()> {
        self(event)
    }
}

/// Summary of one annealing chain.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ChainSummary {
    /// Seed of the chain.
    pub seed: u64,
    /// Best cost of the annealing (before any polish).
    pub annealing_cost: f64,
    /// Cost after the annealer's Nelder–Mead polish.
    pub nelder_mead_cost: f64,
    /// Cost after the Levenberg–Marquardt polish.
    pub cost: f64,
    /// The chain's final point.
    pub x: Vec<f64>,
    /// Evaluations of the annealer (Nelder–Mead included).
    pub annealing_evaluations: u64,
    /// Evaluations of the Levenberg–Marquardt polish.
    pub polish_evaluations: u64,
    /// Levenberg–Marquardt iterations.
    pub polish_iterations: u32,
    /// Failed simulations (rejected moves).
    pub failed_evaluations: u64,
    /// Initial temperature found.
    pub initial_temperature: f64,
    /// Temperature stages run.
    pub stages: u64,
    /// Re-annealings performed.
    pub reanneals: u32,
    /// Why the annealing stopped.
    pub stop: StopReason,
    /// Stage history of the chain.
    pub history: Vec<StageRecord>,
}

/// The result of [`identify`].
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Identification {
    /// The free parameters, in the problem's order.
    pub free: Vec<ParamId>,
    /// The best parameter vector (problem order).
    pub x: Vec<f64>,
    /// The best parameters by name (`sol.lst_m`, …).
    pub params: BTreeMap<String, f64>,
    /// Sum of squared torque errors at `x` against the problem's measured torque (N²·m²).
    pub sse: f64,
    /// RMS torque error `sqrt(SSE/Σw)` at `x` against the problem's measured torque (N·m).
    pub rms_nm: f64,
    /// Objective evaluations (simulations) over every chain and polish.
    pub evaluations: u64,
    /// Wall-clock time of the whole identification (s).
    pub wall_s: f64,
    /// Index of the chain that gave `x`.
    pub best_chain: u32,
    /// One summary per chain.
    pub chains: Vec<ChainSummary>,
}

impl Identification {
    /// Percentage errors `100·|x − truth|/|truth|` of every identified parameter against the
    /// values in `truth` (see [`errors_pct`]).
    #[must_use]
    pub fn errors_pct(&self, truth: &ModelParams) -> BTreeMap<String, f64> {
        errors_pct(&self.params, &truth_values(&self.free, truth))
    }

    /// The stage history of the best chain.
    #[must_use]
    pub fn history(&self) -> &[StageRecord] {
        self.chains
            .get(self.best_chain as usize)
            .map_or(&[], |c| c.history.as_slice())
    }
}

/// The values of `free` in `truth` (effects at their null values), by name.
#[must_use]
pub fn truth_values(free: &[ParamId], truth: &ModelParams) -> BTreeMap<String, f64> {
    let effects = muscle_model::Effects::none();
    free.iter()
        .map(|p| (p.name(), p.get(truth, &effects)))
        .collect()
}

/// `name → 100·|x − truth|/|truth|` for every name present in both maps (a zero truth gives
/// the absolute error × 100).
#[must_use]
pub fn errors_pct(
    params: &BTreeMap<String, f64>,
    truth: &BTreeMap<String, f64>,
) -> BTreeMap<String, f64> {
    params
        .iter()
        .filter_map(|(k, &v)| {
            truth.get(k).map(|&t| {
                let d = (v - t).abs();
                let e = if t == 0.0 {
                    100.0 * d
                } else {
                    100.0 * d / t.abs()
                };
                (k.clone(), e)
            })
        })
        .collect()
}

/// Identify the free parameters of `problem` by minimising the sum of squared torque errors
/// (dissertation eq. 12).
///
/// `settings.chains` annealing chains run in parallel ([`run`] with
/// `settings.annealer`, chain `k` seeded with [`chain_seed`]); chain 0 starts from the base
/// values (clamped into the bounds), the others from random points. Every chain's best point
/// is then polished by a bounded Levenberg–Marquardt on the residual vector (central-difference
/// Jacobian; coordinates at a bound whose gradient points outward are held fixed; steps are
/// clipped to the box). The best polished chain wins (ties: lowest index). The result is a
/// deterministic function of `(problem, settings)`, whatever the number of threads.
///
/// # Errors
/// Invalid settings or bounds; a failing start point of chain 0, or no feasible random start
/// of another chain.
pub fn identify<B: IdentifyObserver + ?Sized>(
    problem: &Problem,
    settings: &IdentifySettings,
    observer: &B,
) -> Result<Identification, Error> {
    let settings = settings.validate()?;
    let start = Instant::now();
    let base: Vec<f64> = problem
        .base_vector()
        .iter()
        .zip(problem.bounds())
        .map(|(&v, &(lo, hi))| v.clamp(lo, hi))
        .collect();
    let chains: Vec<Result<ChainSummary, Error>> = (0..settings.chains)
        .into_par_iter()
        .map(|k| run_chain(problem, &settings, k, &base, observer))
        .collect();
    let chains = chains.into_iter().collect::<Result<Vec<_>, _>>()?;
    let mut best = 0usize;
    for (k, c) in chains.iter().enumerate() {
        if c.cost < chains[best].cost {
            best = k;
        }
    }
    let x = chains[best].x.clone();
    let sse = chains[best].cost;
    let weight_sum = problem
        .weights()
        .map_or(problem.inputs().len() as f64, |w| w.iter().sum());
    let evaluations = chains
        .iter()
        .map(|c| c.annealing_evaluations + c.polish_evaluations)
        .sum();
    Ok(Identification {
        free: problem.free().to_vec(),
        params: problem
            .names()
            .iter()
            .cloned()
            .zip(x.iter().copied())
            .collect(),
        x,
        sse,
        rms_nm: (sse / weight_sum).sqrt(),
        evaluations,
        wall_s: start.elapsed().as_secs_f64(),
        best_chain: best as u32,
        chains,
    })
}

fn run_chain<B: IdentifyObserver + ?Sized>(
    problem: &Problem,
    settings: &IdentifySettings,
    k: u32,
    base: &[f64],
    observer: &B,
) -> Result<ChainSummary, Error> {
    let seed = chain_seed(settings.seed, k);
    let s = settings.annealer.with_seed(seed);
    let mut objective = ProblemObjective::new(problem);
    let x0 = if k == 0 { Some(base) } else { None };
    let out = run(&mut objective, x0, &s, &mut |p: &Progress| {
        observer.observe(&IdentifyEvent::Chain {
            chain: k,
            progress: *p,
        })
    })?;
    let lm = levenberg_marquardt(
        problem,
        &out.x,
        out.cost,
        &settings.polish,
        |it, cost, ev| {
            let _ = observer.observe(&IdentifyEvent::Polish {
                chain: k,
                iteration: it,
                cost,
                evaluations: ev,
            });
        },
    );
    Ok(ChainSummary {
        seed,
        annealing_cost: out.annealing_cost,
        nelder_mead_cost: out.cost,
        cost: lm.cost,
        x: lm.x,
        annealing_evaluations: out.evaluations,
        polish_evaluations: lm.evaluations,
        polish_iterations: lm.iterations,
        failed_evaluations: out.failed_evaluations + lm.failed,
        initial_temperature: out.initial_temperature,
        stages: out.stages,
        reanneals: out.reanneals,
        stop: out.stop,
        history: out.history,
    })
}

/// Result of the Levenberg–Marquardt polish.
struct LmResult {
    x: Vec<f64>,
    cost: f64,
    evaluations: u64,
    failed: u64,
    iterations: u32,
}

/// Bounded Levenberg–Marquardt on the residual `measured − predicted`, in unit-box coordinates.
///
/// Per iteration: central-difference Jacobian `J` of the prediction (one-sided at a bound),
/// gradient `g = Jᵀr`; coordinates at a bound with `g` pointing out of the box are held; solve
/// `(JᵀJ + λ·diag(JᵀJ)) δ = g` on the others, clip `u + δ` to the box, accept if the cost
/// drops (λ ÷ 3) or raise λ × 4 and retry (up to 10 times per Jacobian).
fn levenberg_marquardt(
    problem: &Problem,
    x0: &[f64],
    f0: f64,
    s: &LmSettings,
    mut report: impl FnMut(u32, f64, u64),
) -> LmResult {
    let n = problem.dim();
    let m = problem.inputs().len();
    let bounds = problem.bounds();
    let lo: Vec<f64> = bounds.iter().map(|b| b.0).collect();
    let w: Vec<f64> = bounds.iter().map(|b| b.1 - b.0).collect();
    let to_x = |u: &[f64]| -> Vec<f64> {
        u.iter()
            .zip(lo.iter().zip(&w))
            .map(|(&ui, (&l, &wi))| (l + ui.clamp(0.0, 1.0) * wi).clamp(l, l + wi))
            .collect()
    };
    let sqrt_w: Option<Vec<f64>> = problem
        .weights()
        .map(|ws| ws.iter().map(|v| v.sqrt()).collect());
    let mut u: Vec<f64> = x0
        .iter()
        .zip(lo.iter().zip(&w))
        .map(|(&x, (&l, &wi))| ((x - l) / wi).clamp(0.0, 1.0))
        .collect();
    let mut cost = f0;
    let mut out = LmResult {
        x: x0.to_vec(),
        cost: f0,
        evaluations: 0,
        failed: 0,
        iterations: 0,
    };
    if s.max_iterations == 0 || !f0.is_finite() {
        return out;
    }
    let mut ws = ProblemWorkspace::new();
    let mut r = vec![0.0; m];
    // Weighted residual at the current point.
    let residual = |x: &[f64], ws: &mut ProblemWorkspace, r: &mut [f64]| -> bool {
        if problem.residuals_with(x, ws, r).is_err() {
            return false;
        }
        if let Some(sw) = &sqrt_w {
            for (ri, wi) in r.iter_mut().zip(sw) {
                *ri *= wi;
            }
        }
        r.iter().all(|v| v.is_finite())
    };
    out.evaluations += 1;
    if !residual(&out.x, &mut ws, &mut r) {
        out.failed += 1;
        return out;
    }
    cost = cost.min(r.iter().map(|v| v * v).sum());
    let mut lambda = s.lambda0;
    let h = s.fd_step;
    let mut jac = vec![0.0; n * m];
    let mut trial_r = vec![0.0; m];
    for it in 1..=s.max_iterations {
        out.iterations = it;
        // Columns of J = −∂r/∂u (derivative of the prediction), in parallel, deterministic.
        let cols: Vec<Option<(Vec<f64>, u64)>> = (0..n)
            .into_par_iter()
            .map_init(
                || (ProblemWorkspace::new(), vec![0.0; m], vec![0.0; m]),
                |(ws, rp, rm), j| {
                    let (up, um) = ((u[j] + h).min(1.0), (u[j] - h).max(0.0));
                    let mut uu = u.clone();
                    uu[j] = up;
                    let ok_p = residual(&to_x(&uu), ws, rp);
                    uu[j] = um;
                    let ok_m = residual(&to_x(&uu), ws, rm);
                    if !(ok_p && ok_m) || up <= um {
                        return None;
                    }
                    let d = up - um;
                    Some((
                        rm.iter().zip(rp.iter()).map(|(a, b)| (a - b) / d).collect(),
                        2,
                    ))
                },
            )
            .collect();
        let mut failed = false;
        for (j, c) in cols.into_iter().enumerate() {
            out.evaluations += 2;
            match c {
                Some((col, _)) => jac[j * m..(j + 1) * m].copy_from_slice(&col),
                None => failed = true,
            }
        }
        if failed {
            out.failed += 1;
            break;
        }
        // Normal equations.
        let mut jtj = vec![0.0; n * n];
        let mut g = vec![0.0; n];
        for a in 0..n {
            let ca = &jac[a * m..(a + 1) * m];
            g[a] = ca.iter().zip(&r).map(|(x, y)| x * y).sum();
            for b in 0..=a {
                let cb = &jac[b * m..(b + 1) * m];
                let v: f64 = ca.iter().zip(cb).map(|(x, y)| x * y).sum();
                jtj[a * n + b] = v;
                jtj[b * n + a] = v;
            }
        }
        let free: Vec<usize> = (0..n)
            .filter(|&j| !((u[j] <= 0.0 && g[j] < 0.0) || (u[j] >= 1.0 && g[j] > 0.0)))
            .collect();
        if free.is_empty() {
            break;
        }
        let mut improved = false;
        let mut converged = false;
        for _ in 0..10 {
            let k = free.len();
            let mut a = vec![0.0; k * k];
            let mut b = vec![0.0; k];
            for (p, &i) in free.iter().enumerate() {
                b[p] = g[i];
                for (q, &j) in free.iter().enumerate() {
                    a[p * k + q] = jtj[i * n + j];
                }
                a[p * k + p] += lambda * jtj[i * n + i].max(1e-300);
            }
            let Some(delta) = solve_spd(&mut a, &mut b, k) else {
                lambda *= 4.0;
                continue;
            };
            let mut un = u.clone();
            for (p, &i) in free.iter().enumerate() {
                un[i] = (u[i] + delta[p]).clamp(0.0, 1.0);
            }
            let xn = to_x(&un);
            out.evaluations += 1;
            if residual(&xn, &mut ws, &mut trial_r) {
                let c: f64 = trial_r.iter().map(|v| v * v).sum();
                if c < cost {
                    let gain = (cost - c) / cost;
                    u = un;
                    cost = c;
                    std::mem::swap(&mut r, &mut trial_r);
                    out.x = xn;
                    out.cost = c;
                    lambda = (lambda / 3.0).max(1e-12);
                    improved = true;
                    converged = gain < s.ftol_rel;
                    break;
                }
            } else {
                out.failed += 1;
            }
            lambda *= 4.0;
        }
        report(it, cost, out.evaluations);
        if !improved || converged {
            break;
        }
    }
    out
}

/// Solve `A x = b` for a symmetric positive-definite `A` (row-major `k × k`) by Cholesky;
/// `None` when `A` is not numerically positive definite.
fn solve_spd(a: &mut [f64], b: &mut [f64], k: usize) -> Option<Vec<f64>> {
    for j in 0..k {
        let mut d = a[j * k + j];
        for p in 0..j {
            d -= a[j * k + p] * a[j * k + p];
        }
        if !(d > 0.0 && d.is_finite()) {
            return None;
        }
        let l = d.sqrt();
        a[j * k + j] = l;
        for i in j + 1..k {
            let mut v = a[i * k + j];
            for p in 0..j {
                v -= a[i * k + p] * a[j * k + p];
            }
            a[i * k + j] = v / l;
        }
    }
    for i in 0..k {
        let mut v = b[i];
        for p in 0..i {
            v -= a[i * k + p] * b[p];
        }
        b[i] = v / a[i * k + i];
    }
    for i in (0..k).rev() {
        let mut v = b[i];
        for p in i + 1..k {
            v -= a[p * k + i] * b[p];
        }
        b[i] = v / a[i * k + i];
    }
    Some(b.to_vec())
}

/// A trial turned into the SPEC §8 problem, with what was subtracted from its torque.
#[derive(Debug, Clone)]
pub struct PreparedTrial {
    /// The standard problem (nominal base, 9 free parameters) on the corrected torque.
    pub problem: Problem,
    /// The trial's measured torque as read (N·m).
    pub raw_torque: Vec<f64>,
    /// What was subtracted from `raw_torque` (offset + transients at the trial's own events),
    /// when an unloaded run was given.
    pub subtracted: Option<Vec<f64>>,
    /// The dynamometer correction estimated from the unloaded run, when given.
    pub correction: Option<experiment::DynamometerCorrection>,
    /// The trial's motion events (detected from its angle), when an unloaded run was given.
    pub events: Option<experiment::Events>,
}

impl PreparedTrial {
    /// RMS of `raw_torque − model(x)` (N·m): the fit judged against the torque as measured,
    /// without the dynamometer correction.
    ///
    /// # Errors
    /// A failed simulation or a vector of the wrong length.
    pub fn raw_rms_nm(&self, x: &[f64]) -> Result<f64, Error> {
        let pred = self.problem.predict(x)?;
        let n = pred.len().max(1) as f64;
        let ss: f64 = pred
            .iter()
            .zip(&self.raw_torque)
            .map(|(p, m)| (m - p) * (m - p))
            .sum();
        Ok((ss / n).sqrt())
    }

    /// RMS of the subtracted systematic part (N·m); 0 without an unloaded run.
    #[must_use]
    pub fn subtracted_rms_nm(&self) -> f64 {
        self.subtracted.as_ref().map_or(0.0, |s| {
            (s.iter().map(|v| v * v).sum::<f64>() / s.len().max(1) as f64).sqrt()
        })
    }
}

/// Build the SPEC §8 problem from a trial ([`experiment::model_inputs()`] with `opts`) and,
/// optionally, its unloaded run.
///
/// With an unloaded run, the dynamometer's cycle-locked error is removed from the measured
/// torque before fitting: [`experiment::DynamometerCorrection::from_unloaded`] estimates the
/// offset and the damped-sinusoid transient after a motion event from the unloaded run, and
/// [`experiment::DynamometerCorrection::correct`] subtracts them at the trial's own starts,
/// reversals and stops ([`experiment::detect_events`] on its angle). Without one, the raw
/// torque is fitted (a left-in offset then biases the forces).
///
/// # Errors
/// Invalid trial or unloaded run (e.g. no motion in it), or a problem the model rejects.
pub fn prepare_trial(
    trial: &experiment::Trial,
    unloaded: Option<&experiment::Unloaded>,
    opts: &experiment::InputOptions,
) -> Result<PreparedTrial, Error> {
    let inputs = experiment::model_inputs(trial, opts)?;
    let raw = trial.torque_nm.clone();
    let (measured, subtracted, correction, events) = match unloaded {
        Some(u) => {
            let c = experiment::DynamometerCorrection::from_unloaded(u)?;
            let corrected = c.correct(trial)?;
            (
                corrected.torque_nm,
                Some(corrected.systematic_nm),
                Some(c),
                Some(corrected.events),
            )
        }
        None => (raw.clone(), None, None, None),
    };
    let problem = Problem::standard(inputs, measured)?;
    Ok(PreparedTrial {
        problem,
        raw_torque: raw,
        subtracted,
        correction,
        events,
    })
}
