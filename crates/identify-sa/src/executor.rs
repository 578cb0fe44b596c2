//! The driver loop: budget, stopping, observers and the final polish.

use std::ops::ControlFlow;

use serde::{Deserialize, Serialize};

use numerics::nelder_mead_unit;

use crate::{AnnealSettings, AnnealStopReason, Annealer, Error, Objective, StageRecord};

/// What the driver is doing when it calls the observer.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
#[non_exhaustive]
pub enum AnnealPhase {
    /// The start point is evaluated and the initial temperature found.
    InitialTemperature,
    /// A temperature stage has ended.
    Annealing,
    /// The Nelder–Mead polish has ended.
    Polish,
}

/// A snapshot passed to the observer.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[non_exhaustive]
pub struct AnnealProgress {
    /// Phase that just ended.
    pub phase: AnnealPhase,
    /// Evaluations used so far.
    pub evaluations: u64,
    /// The total budget.
    pub max_evaluations: u64,
    /// Best cost so far.
    pub best_cost: f64,
    /// Temperature of the next stage.
    pub temperature: f64,
    /// Stages completed.
    pub stage: u64,
    /// Re-annealings so far.
    pub reanneals: u32,
}

/// Receives progress after the initial-temperature search, after every stage
/// and after the polish; returning `ControlFlow::Break(())` stops the run
/// (the best point so far is returned with [`AnnealStopReason::Interrupted`]).
///
/// Implemented for `NoObserver` and for every `FnMut(&AnnealProgress) -> ControlFlow<()>`.
pub trait Observer {
    /// Called by the driver; see the trait doc.
    fn observe(&mut self, progress: &AnnealProgress) -> ControlFlow<()>;
}

/// An observer that does nothing.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct NoObserver;

impl Observer for NoObserver {
    fn observe(&mut self, _: &AnnealProgress) -> ControlFlow<()> {
        ControlFlow::Continue(())
    }
}

impl<F: FnMut(&AnnealProgress) -> ControlFlow<()>> Observer for F {
    fn observe(&mut self, progress: &AnnealProgress) -> ControlFlow<()> {
        self(progress)
    }
}

/// The result of [`run`].
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[non_exhaustive]
pub struct Outcome {
    /// Best point, in the objective's coordinates.
    pub x: Vec<f64>,
    /// Cost at `x`.
    pub cost: f64,
    /// Best cost before the polish.
    pub annealing_cost: f64,
    /// Evaluations used in total (start, initial temperature, stages, polish).
    pub evaluations: u64,
    /// Evaluations spent in the polish.
    pub polish_evaluations: u64,
    /// Evaluations that failed (`None` or non-finite).
    pub failed_evaluations: u64,
    /// Temperature found by the initial-temperature search.
    pub initial_temperature: f64,
    /// Temperature at the end.
    pub final_temperature: f64,
    /// Temperature stages run.
    pub stages: u64,
    /// Re-annealings performed.
    pub reanneals: u32,
    /// One record per stage (stage 0 = initial-temperature search).
    pub history: Vec<StageRecord>,
    /// Why the annealing stopped.
    pub stop: AnnealStopReason,
}

/// Minimise `objective` over its box by simulated annealing followed by a
/// Nelder–Mead polish (the driver; see the crate doc for the algorithm).
///
/// `x0` is the start point (inside the bounds); `None` draws it uniformly in
/// the box from the seeded stream. The run is a deterministic function of
/// `(objective, x0, settings)`.
///
/// # Errors
/// Invalid settings or bounds, a bad or failing start point, no feasible
/// random start.
pub fn run<O: Objective + ?Sized, B: Observer + ?Sized>(
    objective: &mut O,
    x0: Option<&[f64]>,
    settings: &AnnealSettings,
    observer: &mut B,
) -> Result<Outcome, Error> {
    let settings = settings.validate()?;
    let total = settings.max_evaluations;
    let reserve = if settings.polish_fraction > 0.0 {
        ((total as f64 * settings.polish_fraction).ceil() as u64).min(total - 1)
    } else {
        0
    };
    let anneal_limit = total - reserve;
    let mut annealer = Annealer::new(objective, settings)?;
    annealer.init(objective, x0, anneal_limit)?;
    let progress = |a: &Annealer, phase| AnnealProgress {
        phase,
        evaluations: a.evaluations(),
        max_evaluations: total,
        best_cost: a.best_cost(),
        temperature: a.temperature(),
        stage: a.stage(),
        reanneals: a.reanneals(),
    };
    if observer
        .observe(&progress(&annealer, AnnealPhase::InitialTemperature))
        .is_break()
    {
        annealer.set_stopped(AnnealStopReason::Interrupted);
    }
    while annealer.stop_reason().is_none() {
        if annealer.next_iter(objective, anneal_limit).is_none() {
            break;
        }
        if observer
            .observe(&progress(&annealer, AnnealPhase::Annealing))
            .is_break()
        {
            annealer.set_stopped(AnnealStopReason::Interrupted);
        }
    }
    let stop = annealer
        .stop_reason()
        .unwrap_or(AnnealStopReason::MaxEvaluations);
    let annealing_cost = annealer.best_cost();
    let mut polish_evaluations = 0;
    let budget = settings
        .polish
        .max_evaluations
        .min(total.saturating_sub(annealer.evaluations()));
    if settings.polish_fraction > 0.0 && stop != AnnealStopReason::Interrupted && budget > 0 {
        let n = annealer.best_unit().len();
        let u0 = annealer.best_unit().to_vec();
        let steps = vec![settings.polish.initial_step; n];
        let r = nelder_mead_unit(
            objective,
            annealer.unit_box_mut(),
            &u0,
            annealing_cost,
            &steps,
            &settings.polish,
            budget,
        );
        polish_evaluations = r.evaluations;
        annealer.add_evaluations(r.evaluations, r.failed);
        if r.f < annealing_cost {
            annealer.set_best_unit(&r.u, r.f);
        }
        // The observer's answer no longer matters: the run is over.
        let _ = observer.observe(&progress(&annealer, AnnealPhase::Polish));
    }
    Ok(Outcome {
        x: annealer.best_x(),
        cost: annealer.best_cost(),
        annealing_cost,
        evaluations: annealer.evaluations(),
        polish_evaluations,
        failed_evaluations: annealer.failed_evaluations(),
        initial_temperature: annealer.initial_temperature(),
        final_temperature: annealer.temperature(),
        stages: annealer.stage(),
        reanneals: annealer.reanneals(),
        history: annealer.take_history(),
        stop,
    })
}
