//! The annealing algorithm step: state, initial temperature, one temperature stage.

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};

use numerics::UnitBox;

use crate::{AnnealSettings, Error, Objective};

/// Why an optimisation stopped.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
#[non_exhaustive]
pub enum AnnealStopReason {
    /// The best cost stayed within tolerance for `stall_stages` stages after
    /// the last allowed re-annealing.
    Converged,
    /// The evaluation budget was used up.
    MaxEvaluations,
    /// The observer asked to stop.
    Interrupted,
}

/// One temperature stage, as recorded in the history.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[non_exhaustive]
pub struct StageRecord {
    /// Stage number (0 is the initial-temperature search).
    pub stage: u64,
    /// Evaluations used when the stage ended.
    pub evaluations: u64,
    /// Best cost when the stage ended.
    pub best_cost: f64,
    /// Cost of the current point when the stage ended.
    pub current_cost: f64,
    /// Temperature the stage ran at.
    pub temperature: f64,
    /// Raw fraction of the stage's moves that were accepted (stage 0: of the
    /// last event of the initial-temperature search; 0 when no move was made).
    pub acceptance: f64,
    /// Geometric mean of the per-coordinate steps at the end of the stage (unit coordinates).
    pub mean_step: f64,
    /// Re-annealings performed so far.
    pub reanneals: u32,
}

/// Outcome of one proposed move.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Move {
    Accepted,
    Rejected(f64),
    Failed,
}

/// The simulated-annealing algorithm state (the "solver" half of the
/// solver/driver split; [`crate::run`] is the driver).
///
/// Call [`Annealer::init`] once, then [`Annealer::next_iter`] until
/// [`Annealer::stop_reason`] is `Some`. Every call takes the evaluation limit
/// so that a driver owns the budget; the annealer never evaluates past it.
#[derive(Debug, Clone)]
pub struct Annealer {
    settings: AnnealSettings,
    ubox: UnitBox,
    rng: ChaCha8Rng,
    u: Vec<f64>,
    f: f64,
    u_best: Vec<f64>,
    f_best: f64,
    step: Vec<f64>,
    accepted: Vec<u32>,
    temperature: f64,
    initial_temperature: f64,
    stage: u64,
    reanneals: u32,
    evaluations: u64,
    failed: u64,
    stage_bests: Vec<f64>,
    history: Vec<StageRecord>,
    stop: Option<AnnealStopReason>,
    initialised: bool,
}

impl Annealer {
    /// Validate `settings` and the objective's bounds and allocate the state.
    ///
    /// # Errors
    /// Invalid settings or bounds.
    pub fn new<O: Objective + ?Sized>(
        objective: &O,
        settings: AnnealSettings,
    ) -> Result<Self, Error> {
        let settings = settings.validate()?;
        let ubox = UnitBox::new(objective)?;
        let n = ubox.dim();
        Ok(Self {
            settings,
            ubox,
            rng: ChaCha8Rng::seed_from_u64(settings.seed),
            u: vec![0.5; n],
            f: f64::INFINITY,
            u_best: vec![0.5; n],
            f_best: f64::INFINITY,
            step: vec![settings.initial_step; n],
            accepted: vec![0; n],
            temperature: 0.0,
            initial_temperature: 0.0,
            stage: 0,
            reanneals: 0,
            evaluations: 0,
            failed: 0,
            stage_bests: Vec::new(),
            history: Vec::new(),
            stop: None,
            initialised: false,
        })
    }

    /// Evaluate the start point (`x0`, or uniform random points until one
    /// succeeds) and find the initial temperature (see the crate doc). Uses at
    /// most `max_evaluations` evaluations in total.
    ///
    /// # Errors
    /// A start point of the wrong length, outside the bounds or failing, no
    /// feasible random start, or a zero budget.
    pub fn init<O: Objective + ?Sized>(
        &mut self,
        objective: &mut O,
        x0: Option<&[f64]>,
        max_evaluations: u64,
    ) -> Result<(), Error> {
        if max_evaluations == 0 {
            return Err(Error::BudgetTooSmall {
                budget: 0,
                needed: 1,
            });
        }
        let n = self.ubox.dim();
        match x0 {
            Some(x) => {
                self.ubox.to_unit(x, &mut self.u)?;
                self.evaluations += 1;
                match self.ubox.eval(objective, &self.u) {
                    Some(v) => self.f = v,
                    None => {
                        self.failed += 1;
                        return Err(Error::Numerics(
                            numerics::NumericsError::StartEvaluationFailed,
                        ));
                    }
                }
            }
            None => {
                let mut found = false;
                let mut attempts = 0;
                while attempts < self.settings.start_attempts && self.evaluations < max_evaluations
                {
                    attempts += 1;
                    for ui in self.u.iter_mut() {
                        *ui = self.rng.random::<f64>();
                    }
                    self.evaluations += 1;
                    if let Some(v) = self.ubox.eval(objective, &self.u) {
                        self.f = v;
                        found = true;
                        break;
                    }
                    self.failed += 1;
                }
                if !found {
                    return Err(Error::NoFeasibleStart { attempts });
                }
            }
        }
        self.u_best.copy_from_slice(&self.u);
        self.f_best = self.f;
        self.initialised = true;
        let acceptance = self.find_initial_temperature(objective, max_evaluations);
        self.initial_temperature = self.temperature;
        self.history.push(StageRecord {
            stage: 0,
            evaluations: self.evaluations,
            best_cost: self.f_best,
            current_cost: self.f,
            temperature: self.temperature,
            acceptance,
            mean_step: self.mean_step(),
            reanneals: 0,
        });
        debug_assert_eq!(self.u.len(), n);
        Ok(())
    }

    /// The initial-temperature search of the dissertation (§3.6.1/§4.1);
    /// returns the raw acceptance ratio of the last event.
    fn find_initial_temperature<O: Objective + ?Sized>(
        &mut self,
        objective: &mut O,
        limit: u64,
    ) -> f64 {
        let s = self.settings;
        let n = self.ubox.dim();
        let moves = s.t0_event_moves as usize;
        // Event 0: greedy moves, recording the uphill cost changes.
        let mut uphill = Vec::with_capacity(moves);
        for m in 0..moves {
            if self.evaluations >= limit {
                self.stop = Some(AnnealStopReason::MaxEvaluations);
                break;
            }
            if let Move::Rejected(d) = self.try_move(objective, m % n, 0.0) {
                if d > 0.0 {
                    uphill.push(d);
                }
            }
        }
        let scale = if uphill.is_empty() {
            1e-6 * self.f_best.abs().max(1.0)
        } else {
            uphill.sort_by(f64::total_cmp);
            uphill[uphill.len() / 2]
        };
        let mut t = (s.t0_start_fraction * scale).max(f64::MIN_POSITIVE);
        let neutral = s.acceptance.neutral();
        let mut previous: Option<u32> = None;
        let mut last_ratio = 0.0;
        for _ in 0..s.t0_max_events {
            if self.stop.is_some() {
                break;
            }
            let mut accepted = 0u32;
            for m in 0..moves {
                if self.evaluations >= limit {
                    self.stop = Some(AnnealStopReason::MaxEvaluations);
                    break;
                }
                if self.try_move(objective, m % n, t) == Move::Accepted {
                    accepted += 1;
                }
            }
            if self.stop.is_some() {
                break;
            }
            last_ratio = f64::from(accepted) / moves as f64;
            let ratio = last_ratio / neutral;
            let stable = previous.is_some_and(|p| {
                f64::from(accepted) - f64::from(p) < s.t0_stable_fraction * moves as f64
            });
            if ratio >= s.t0_min_acceptance && stable {
                break;
            }
            previous = Some(accepted);
            t *= s.t0_growth;
        }
        self.temperature = t;
        last_ratio
    }

    /// Propose a move of coordinate `h` (uniform in `±step[h]`, reflected
    /// into the box) and accept it with the acceptance rule at temperature `t`.
    fn try_move<O: Objective + ?Sized>(&mut self, objective: &mut O, h: usize, t: f64) -> Move {
        let old = self.u[h];
        let r: f64 = self.rng.random::<f64>() * 2.0 - 1.0;
        self.u[h] = reflect_into_unit(old + r * self.step[h]);
        self.evaluations += 1;
        let Some(fv) = self.ubox.eval(objective, &self.u) else {
            self.failed += 1;
            self.u[h] = old;
            return Move::Failed;
        };
        if fv < self.f_best {
            self.f_best = fv;
            self.u_best.copy_from_slice(&self.u);
        }
        let delta = fv - self.f;
        let p = self.settings.acceptance.probability(delta, t);
        if self.rng.random::<f64>() < p {
            self.f = fv;
            Move::Accepted
        } else {
            self.u[h] = old;
            Move::Rejected(delta)
        }
    }

    /// Run one temperature stage: `N_T` rounds of `N_s` sweeps over the
    /// coordinates, adapting the steps after each round; then test
    /// convergence, re-anneal or cool. Never evaluates past `max_evaluations`.
    /// Returns the stage's record, or `None` when the annealer is not
    /// initialised or has already stopped.
    pub fn next_iter<O: Objective + ?Sized>(
        &mut self,
        objective: &mut O,
        max_evaluations: u64,
    ) -> Option<StageRecord> {
        if !self.initialised || self.stop.is_some() {
            return None;
        }
        let s = self.settings;
        let n = self.ubox.dim();
        let t = self.temperature;
        let neutral = s.acceptance.neutral();
        let mut stage_accepted = 0u64;
        let mut stage_moves = 0u64;
        'rounds: for _ in 0..s.adaptations_per_stage {
            self.accepted.fill(0);
            for _ in 0..s.moves_per_adaptation {
                for h in 0..n {
                    if self.evaluations >= max_evaluations {
                        self.stop = Some(AnnealStopReason::MaxEvaluations);
                        break 'rounds;
                    }
                    stage_moves += 1;
                    if self.try_move(objective, h, t) == Move::Accepted {
                        self.accepted[h] += 1;
                        stage_accepted += 1;
                    }
                }
            }
            self.adapt_steps(neutral);
        }
        self.stage += 1;
        let record = StageRecord {
            stage: self.stage,
            evaluations: self.evaluations,
            best_cost: self.f_best,
            current_cost: self.f,
            temperature: t,
            acceptance: if stage_moves == 0 {
                0.0
            } else {
                stage_accepted as f64 / stage_moves as f64
            },
            mean_step: self.mean_step(),
            reanneals: self.reanneals,
        };
        self.history.push(record);
        if self.stop.is_some() {
            return Some(record);
        }
        // Convergence test (Corana's, on the best cost).
        self.stage_bests.push(self.f_best);
        let k = self.stage_bests.len();
        let tol = s.tolerance_abs + s.tolerance_rel * self.f_best.abs();
        let ne = s.stall_stages as usize;
        let stalled = k > ne
            && (1..=ne)
                .all(|j| (self.stage_bests[k - 1] - self.stage_bests[k - 1 - j]).abs() <= tol)
            && self.f - self.f_best <= tol;
        let cold = t * s.cooling < s.final_temperature * self.initial_temperature;
        let frozen = stalled || cold;
        if frozen {
            if self.reanneals < s.max_reanneals {
                self.reanneals += 1;
                self.temperature = s.reanneal_temperature * self.initial_temperature;
                self.step.fill(s.reanneal_step);
                self.stage_bests.clear();
                self.restart_from_best();
            } else {
                self.stop = Some(AnnealStopReason::Converged);
            }
        } else {
            self.temperature = (self.temperature * s.cooling).max(f64::MIN_POSITIVE);
            if s.restart_from_best {
                self.restart_from_best();
            }
        }
        Some(record)
    }

    fn restart_from_best(&mut self) {
        self.u.copy_from_slice(&self.u_best);
        self.f = self.f_best;
    }

    /// Corana's rule on the normalised acceptance ratio `ρ = a/(N_s·p₀)`:
    /// widen by `1 + c(ρ − hi)/(1 − hi)` above the band, narrow by
    /// `1 + c(lo − ρ)/lo` below it.
    fn adapt_steps(&mut self, neutral: f64) {
        let s = self.settings;
        let (lo, hi, c) = (
            s.target_acceptance_low,
            s.target_acceptance_high,
            s.step_gain,
        );
        for (v, &a) in self.step.iter_mut().zip(&self.accepted) {
            let rho = (f64::from(a) / (f64::from(s.moves_per_adaptation) * neutral)).min(1.0);
            if rho > hi {
                *v *= 1.0 + c * (rho - hi) / (1.0 - hi);
            } else if rho < lo {
                *v /= 1.0 + c * (lo - rho) / lo;
            }
            *v = v.clamp(s.min_step, 1.0);
        }
    }

    fn mean_step(&self) -> f64 {
        let n = self.step.len() as f64;
        (self.step.iter().map(|v| v.ln()).sum::<f64>() / n).exp()
    }

    /// Why the annealer stopped, if it has.
    #[must_use]
    pub fn stop_reason(&self) -> Option<AnnealStopReason> {
        self.stop
    }
    /// Mark the annealer stopped (used by drivers, e.g. when an observer interrupts).
    pub fn set_stopped(&mut self, reason: AnnealStopReason) {
        self.stop = Some(reason);
    }
    /// Best cost found so far.
    #[must_use]
    pub fn best_cost(&self) -> f64 {
        self.f_best
    }
    /// Best point found so far, in the objective's coordinates.
    #[must_use]
    pub fn best_x(&self) -> Vec<f64> {
        self.ubox.to_box(&self.u_best)
    }
    /// Best point found so far, in unit-box coordinates.
    #[must_use]
    pub fn best_unit(&self) -> &[f64] {
        &self.u_best
    }
    /// Cost of the current point of the chain.
    #[must_use]
    pub fn current_cost(&self) -> f64 {
        self.f
    }
    /// Temperature of the next stage.
    #[must_use]
    pub fn temperature(&self) -> f64 {
        self.temperature
    }
    /// Temperature found by the initial-temperature search.
    #[must_use]
    pub fn initial_temperature(&self) -> f64 {
        self.initial_temperature
    }
    /// Per-coordinate step half-widths, unit coordinates.
    #[must_use]
    pub fn steps(&self) -> &[f64] {
        &self.step
    }
    /// Evaluations used so far (failures included).
    #[must_use]
    pub fn evaluations(&self) -> u64 {
        self.evaluations
    }
    /// Evaluations that failed so far.
    #[must_use]
    pub fn failed_evaluations(&self) -> u64 {
        self.failed
    }
    /// Temperature stages completed.
    #[must_use]
    pub fn stage(&self) -> u64 {
        self.stage
    }
    /// Re-annealings performed.
    #[must_use]
    pub fn reanneals(&self) -> u32 {
        self.reanneals
    }
    /// One record per stage, the initial-temperature search first.
    #[must_use]
    pub fn history(&self) -> &[StageRecord] {
        &self.history
    }
    /// The validated settings.
    #[must_use]
    pub fn settings(&self) -> &AnnealSettings {
        &self.settings
    }

    pub(crate) fn take_history(&mut self) -> Vec<StageRecord> {
        std::mem::take(&mut self.history)
    }
    pub(crate) fn unit_box_mut(&mut self) -> &mut UnitBox {
        &mut self.ubox
    }
    pub(crate) fn set_best_unit(&mut self, u: &[f64], f: f64) {
        self.u_best.copy_from_slice(u);
        self.f_best = f;
    }
    pub(crate) fn add_evaluations(&mut self, evaluations: u64, failed: u64) {
        self.evaluations += evaluations;
        self.failed += failed;
    }
}

/// Fold any real `y` into `[0, 1]` by reflection at both walls (period 2).
///
/// This is how the annealer keeps moves inside the box: a proposal that
/// overshoots a bound by `d` lands `d` inside it, so the proposal density
/// stays symmetric and no probability mass piles up on the bounds.
///
/// ```
/// use identify_sa::reflect_into_unit;
/// assert_eq!(reflect_into_unit(0.25), 0.25);
/// assert!((reflect_into_unit(1.25) - 0.75).abs() < 1e-15);
/// assert!((reflect_into_unit(-0.25) - 0.25).abs() < 1e-15);
/// assert!((reflect_into_unit(2.5) - 0.5).abs() < 1e-15);
/// ```
pub fn reflect_into_unit(y: f64) -> f64 {
    if !y.is_finite() {
        return 0.5;
    }
    let m = y.rem_euclid(2.0);
    let r = if m > 1.0 { 2.0 - m } else { m };
    r.clamp(0.0, 1.0)
}
