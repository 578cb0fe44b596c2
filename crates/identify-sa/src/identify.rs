//! Identification of the muscle parameters (LST, F0, α0 of each muscle): parallel annealing chains on the
//! sum of squared torque errors, each polished by a bounded Levenberg–Marquardt.

use std::collections::BTreeMap;
use std::ops::ControlFlow;
use std::time::Instant;

use muscle_model::{
    ModelParams, ParamId, Problem, ProblemSet, ProblemSetWorkspace, ProblemWorkspace,
};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use numerics::{levenberg_marquardt, FiniteDifferences, LevenbergMarquardtSettings, Residuals};

use crate::{
    run, AnnealProgress, AnnealSettings, AnnealStopReason, Error, NelderMeadSettings, Objective,
    StageRecord,
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

/// A [`ProblemSet`] seen as an [`Objective`]: the sum of its trials' weighted squared torque
/// errors, [`ProblemSet::sse_with`]; a failed simulation is `None` (a rejected move).
#[derive(Debug)]
pub struct ProblemSetObjective<'a> {
    set: &'a ProblemSet,
    ws: ProblemSetWorkspace,
}

impl<'a> ProblemSetObjective<'a> {
    /// Wrap a set (allocates one workspace per trial).
    #[must_use]
    pub fn new(set: &'a ProblemSet) -> Self {
        Self {
            set,
            ws: ProblemSetWorkspace::new(set),
        }
    }
}

impl Objective for ProblemSetObjective<'_> {
    fn dim(&self) -> usize {
        self.set.dim()
    }
    fn bounds(&self) -> &[(f64, f64)] {
        self.set.bounds()
    }
    fn cost(&mut self, x: &[f64]) -> Option<f64> {
        self.set.sse_with(x, &mut self.ws).ok()
    }
}

/// Settings of [`identify`]. Plain data; `Default` are the values documented in the crate doc
/// (chosen so that a seed-protocol fit takes well under 30 s on two cores).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct SaIdentifySettings {
    /// Master seed: chain `k` anneals with seed [`chain_seed`]`(seed, k)`. Default 42.
    pub seed: u64,
    /// Independent annealing chains, run in parallel (rayon); chain 0 starts from the base
    /// (nominal) values clamped into the bounds, the others from uniform random points of their
    /// own stream. The result does not depend on the number of threads. Default 4.
    pub chains: u32,
    /// Annealer settings of every chain (its `seed` is replaced per chain). Defaults:
    /// [`SaIdentifySettings::default_annealer`].
    pub annealer: AnnealSettings,
    /// The Levenberg–Marquardt polish applied to every chain's best point. Defaults:
    /// [`SaIdentifySettings::default_polish`]; `max_iterations` 0 disables it.
    pub polish: LevenbergMarquardtSettings,
    /// Chains added (seeded as chains `chains…chains + extra_chains − 1`) when the best two of
    /// the first `chains` disagree: their RMS errors differ by more than `agreement_rel` of the
    /// better. Default 0 (never). A cost with several minima then gets more starts only where
    /// the first ones did not settle it.
    pub extra_chains: u32,
    /// Relative difference of the best two chains' RMS errors below which they agree. Default
    /// 0.01.
    pub agreement_rel: f64,
}

impl Default for SaIdentifySettings {
    fn default() -> Self {
        Self {
            seed: 42,
            chains: 4,
            annealer: Self::default_annealer(),
            polish: Self::default_polish(),
            extra_chains: 0,
            agreement_rel: 0.01,
        }
    }
}

impl SaIdentifySettings {
    /// The annealer settings used per chain by default: 6 000 evaluations, cooling 0.8,
    /// stages of `N_s = 5` × `N_T = 4` sweeps (180 evaluations for 9 parameters), 6
    /// re-annealings at 0.1 T₀ with steps 0.05, and a 5 % Nelder–Mead polish before the
    /// Levenberg–Marquardt one. Everything else is [`AnnealSettings::default`].
    #[must_use]
    pub fn default_annealer() -> AnnealSettings {
        AnnealSettings {
            max_evaluations: 6_000,
            cooling: 0.8,
            moves_per_adaptation: 5,
            adaptations_per_stage: 4,
            max_reanneals: 6,
            reanneal_temperature: 0.1,
            reanneal_step: 0.05,
            polish_fraction: 0.05,
            polish: NelderMeadSettings::default(),
            ..AnnealSettings::default()
        }
    }

    /// The polish used by default: up to 40 Jacobians of central differences with a step of
    /// 10⁻³ of each range (large enough that the adaptive integrator's error, ~0.01 N·m, does
    /// not dominate), initial damping 10⁻³ (floor 10⁻¹², no ceiling), at most 10 rejected
    /// steps per Jacobian, and a stop when a step gains less than 10⁻¹⁰ of the cost.
    #[must_use]
    pub fn default_polish() -> LevenbergMarquardtSettings {
        LevenbergMarquardtSettings {
            max_iterations: 40,
            differences: FiniteDifferences::Central,
            fd_step: 1e-3,
            lambda0: 1e-3,
            lambda_min: 1e-12,
            lambda_max: f64::INFINITY,
            max_rejections: 10,
            ftol_rel: 1e-10,
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

    /// Add `extra` chains when the best two of the first ones disagree by more than
    /// `agreement_rel` of the RMS.
    #[must_use]
    pub fn with_extra_chains(mut self, extra: u32, agreement_rel: f64) -> Self {
        self.extra_chains = extra;
        self.agreement_rel = agreement_rel;
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
    /// [`Error::Numerics`] ([`numerics::NumericsError::InvalidSetting`]) naming the first invalid field.
    pub fn validate(self) -> Result<Self, Error> {
        if self.chains == 0 {
            return Err(Error::Numerics(numerics::NumericsError::InvalidSetting {
                name: "chains",
                value: 0.0,
                reason: "must be at least 1",
            }));
        }
        if !(self.agreement_rel.is_finite() && self.agreement_rel >= 0.0) {
            return Err(Error::Numerics(numerics::NumericsError::InvalidSetting {
                name: "agreement_rel",
                value: self.agreement_rel,
                reason: "must be finite and non-negative",
            }));
        }
        self.annealer.validate()?;
        self.polish.validate()?;
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
        progress: AnnealProgress,
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
#[non_exhaustive]
pub struct ChainSummary {
    /// Seed of the chain.
    pub seed: u64,
    /// Best cost of the annealing (before any polish).
    pub annealing_cost: f64,
    /// Cost after the annealer's Nelder–Mead polish.
    pub nelder_mead_cost: f64,
    /// Cost after the Levenberg–Marquardt polish (with a search set, [`identify_set_with_search`]:
    /// the cost of the chain's point on the whole set, after the final polish for the best chain).
    pub cost: f64,
    /// With a search set, the chain's cost on it after its polish there; `None` otherwise.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub search_cost: Option<f64>,
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
    pub stop: AnnealStopReason,
    /// Stage history of the chain.
    pub history: Vec<StageRecord>,
}

/// The result of [`identify`].
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[non_exhaustive]
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
    /// Each trial's RMS torque error at `x` (N·m), in the set's order (one value for a single
    /// trial).
    #[serde(default)]
    pub trial_rms_nm: Vec<f64>,
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
    settings: &SaIdentifySettings,
    observer: &B,
) -> Result<Identification, Error> {
    identify_set(&ProblemSet::single(problem.clone()), settings, observer)
}

/// [`identify`] over several trials of one subject: the cost is the sum of the trials' costs
/// ([`ProblemSet::sse_with`]) and the polish works on their residuals one after the other. A
/// set of one trial gives exactly what [`identify`] gives.
///
/// # Errors
/// As [`identify`].
pub fn identify_set<B: IdentifyObserver + ?Sized>(
    set: &ProblemSet,
    settings: &SaIdentifySettings,
    observer: &B,
) -> Result<Identification, Error> {
    identify_searched(set, None, settings, observer)
}

/// [`identify_set`] with the chains' search on `search`, a set that is cheaper to simulate
/// than `set` and says the same about the parameters (windows of strides spread over a long
/// recording): every chain anneals and is polished on `search`, each chain's point is then
/// scored on `set` (its [`ChainSummary::cost`]; the search's cost is kept in
/// [`ChainSummary::search_cost`]), and the best is polished again on `set` with the same
/// Levenberg–Marquardt. The result's costs, RMS and point are `set`'s.
///
/// Why: the annealing's thousands of evaluations cost what the integrated length costs, while
/// the basin it finds is fixed by a few representative strides; the final polish on every
/// sample removes what the choice of strides moved.
///
/// # Errors
/// As [`identify`]; [`Error::Search`] when `search` has other free parameters or bounds than
/// `set`, or no chain's point can be simulated on `set`.
pub fn identify_set_with_search<B: IdentifyObserver + ?Sized>(
    set: &ProblemSet,
    search: &ProblemSet,
    settings: &SaIdentifySettings,
    observer: &B,
) -> Result<Identification, Error> {
    if search.names() != set.names() || search.bounds() != set.bounds() {
        return Err(Error::Search(
            "it must have the whole set's free parameters and bounds",
        ));
    }
    identify_searched(set, Some(search), settings, observer)
}

fn identify_searched<B: IdentifyObserver + ?Sized>(
    set: &ProblemSet,
    search: Option<&ProblemSet>,
    settings: &SaIdentifySettings,
    observer: &B,
) -> Result<Identification, Error> {
    let settings = settings.validate()?;
    let start = Instant::now();
    let base: Vec<f64> = set
        .base_vector()
        .iter()
        .zip(set.bounds())
        .map(|(&v, &(lo, hi))| v.clamp(lo, hi))
        .collect();
    let mut evaluations = 0;
    let mut chains = run_chains(
        set,
        search,
        &settings,
        0..settings.chains,
        &base,
        observer,
        &mut evaluations,
    )?;
    if settings.extra_chains > 0 && !best_two_agree(&chains, settings.agreement_rel) {
        let more = settings.chains..settings.chains + settings.extra_chains;
        chains.extend(run_chains(
            set,
            search,
            &settings,
            more,
            &base,
            observer,
            &mut evaluations,
        )?);
    }
    let mut best = 0usize;
    for (k, c) in chains.iter().enumerate() {
        if c.cost < chains[best].cost {
            best = k;
        }
    }
    if search.is_some() {
        let c = &mut chains[best];
        let k = best as u32;
        let lm = levenberg_marquardt_polish(
            set,
            &c.x,
            c.cost,
            &settings.polish,
            polish_events(observer, k),
        );
        evaluations += lm.evaluations;
        c.x = lm.x;
        c.cost = lm.cost;
        c.polish_evaluations += lm.evaluations;
        c.polish_iterations += lm.iterations;
        c.failed_evaluations += lm.failed;
    }
    let x = chains[best].x.clone();
    let sse = chains[best].cost;
    if !sse.is_finite() {
        return Err(Error::Search(
            "no chain's point can be simulated on the whole set",
        ));
    }
    let trial_rms_nm = set.rms_per_trial(&x)?;
    Ok(Identification {
        free: set.free().to_vec(),
        params: set.names().iter().cloned().zip(x.iter().copied()).collect(),
        x,
        sse,
        rms_nm: (sse / set.weight_sum()).sqrt(),
        trial_rms_nm,
        evaluations,
        wall_s: start.elapsed().as_secs_f64(),
        best_chain: best as u32,
        chains,
    })
}

/// Chains `ks` annealed and polished on `search` (else on `set`), each scored on `set` when
/// searched elsewhere; adds their evaluations to `evaluations`.
fn run_chains<B: IdentifyObserver + ?Sized>(
    set: &ProblemSet,
    search: Option<&ProblemSet>,
    settings: &SaIdentifySettings,
    ks: std::ops::Range<u32>,
    base: &[f64],
    observer: &B,
    evaluations: &mut u64,
) -> Result<Vec<ChainSummary>, Error> {
    let on = search.unwrap_or(set);
    let chains: Vec<Result<ChainSummary, Error>> = ks
        .into_par_iter()
        .map(|k| run_chain(on, settings, k, base, observer))
        .collect();
    let mut chains = chains.into_iter().collect::<Result<Vec<_>, _>>()?;
    *evaluations += chains
        .iter()
        .map(|c| c.annealing_evaluations + c.polish_evaluations)
        .sum::<u64>();
    if search.is_some() {
        let whole: Vec<f64> = chains
            .par_iter()
            .map(|c| {
                let mut ws = ProblemSetWorkspace::new(set);
                set.sse_with(&c.x, &mut ws).unwrap_or(f64::INFINITY)
            })
            .collect();
        *evaluations += whole.len() as u64;
        for (c, w) in chains.iter_mut().zip(whole) {
            c.search_cost = Some(c.cost);
            c.cost = w;
        }
    }
    Ok(chains)
}

/// Whether the two chains of lowest cost have RMS errors within `rel` of the better (a single
/// chain agrees with itself).
#[must_use]
pub fn best_two_agree(chains: &[ChainSummary], rel: f64) -> bool {
    let mut costs: Vec<f64> = chains.iter().map(|c| c.cost).collect();
    costs.sort_by(f64::total_cmp);
    match costs.as_slice() {
        [a, b, ..] => b.sqrt() - a.sqrt() <= rel * a.sqrt(),
        _ => true,
    }
}

/// What chain `k`'s polish reports to `observer`: one [`IdentifyEvent::Polish`] per iteration.
fn polish_events<B: IdentifyObserver + ?Sized>(
    observer: &B,
    k: u32,
) -> impl FnMut(u32, f64, u64) + '_ {
    move |it, cost, ev| {
        let _ = observer.observe(&IdentifyEvent::Polish {
            chain: k,
            iteration: it,
            cost,
            evaluations: ev,
        });
    }
}

fn run_chain<B: IdentifyObserver + ?Sized>(
    set: &ProblemSet,
    settings: &SaIdentifySettings,
    k: u32,
    base: &[f64],
    observer: &B,
) -> Result<ChainSummary, Error> {
    let seed = chain_seed(settings.seed, k);
    let s = settings.annealer.with_seed(seed);
    let mut objective = ProblemSetObjective::new(set);
    let x0 = if k == 0 { Some(base) } else { None };
    let out = run(&mut objective, x0, &s, &mut |p: &AnnealProgress| {
        observer.observe(&IdentifyEvent::Chain {
            chain: k,
            progress: *p,
        })
    })?;
    let lm = levenberg_marquardt_polish(
        set,
        &out.x,
        out.cost,
        &settings.polish,
        polish_events(observer, k),
    );
    Ok(ChainSummary {
        seed,
        annealing_cost: out.annealing_cost,
        nelder_mead_cost: out.cost,
        cost: lm.cost,
        search_cost: None,
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

/// The weighted residual `√wᵢ·(measuredᵢ − predictedᵢ)` of every trial of a set, whose sum of
/// squares is the cost the annealer minimised; one set of simulation workspaces per thread.
struct WeightedResiduals<'a> {
    set: &'a ProblemSet,
    sqrt_w: Option<Vec<f64>>,
}

impl Residuals for WeightedResiduals<'_> {
    type Workspace = ProblemSetWorkspace;
    fn workspace(&self) -> ProblemSetWorkspace {
        ProblemSetWorkspace::new(self.set)
    }
    fn residuals(&self, x: &[f64], ws: &mut ProblemSetWorkspace, out: &mut Vec<f64>) -> bool {
        out.resize(self.set.samples(), 0.0);
        if self.set.residuals_with(x, ws, out).is_err() {
            return false;
        }
        if let Some(sw) = &self.sqrt_w {
            for (ri, wi) in out.iter_mut().zip(sw) {
                *ri *= wi;
            }
        }
        true
    }
}

/// The bounded Levenberg–Marquardt of `numerics::lm` on the weighted residual, from the
/// annealer's best point `x0` (cost `f0`). The point and cost are `x0` and `f0` unless a step
/// was accepted, so a polish that gains nothing returns the annealer's result unchanged.
fn levenberg_marquardt_polish(
    set: &ProblemSet,
    x0: &[f64],
    f0: f64,
    s: &LevenbergMarquardtSettings,
    mut report: impl FnMut(u32, f64, u64),
) -> LmResult {
    let unchanged = LmResult {
        x: x0.to_vec(),
        cost: f0,
        evaluations: 0,
        failed: 0,
        iterations: 0,
    };
    if s.max_iterations == 0 || !f0.is_finite() {
        return unchanged;
    }
    let residuals = WeightedResiduals {
        set,
        sqrt_w: set
            .weights()
            .map(|ws| ws.iter().map(|v| v.sqrt()).collect()),
    };
    let fit = levenberg_marquardt(&residuals, x0, set.bounds(), s, |p| {
        report(p.iteration as u32, p.cost, p.evaluations as u64);
    });
    match fit {
        Ok(o) => {
            let counts = LmResult {
                evaluations: o.evaluations as u64,
                failed: o.failed_evaluations as u64,
                iterations: o.iterations as u32,
                ..unchanged
            };
            if o.accepted > 0 {
                LmResult {
                    x: o.x,
                    cost: o.cost,
                    ..counts
                }
            } else {
                counts
            }
        }
        // the start point cannot be simulated: one failed evaluation
        Err(_) => LmResult {
            evaluations: 1,
            failed: 1,
            ..unchanged
        },
    }
}
