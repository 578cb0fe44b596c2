//! Bounded simulated annealing (SA), generic over an objective, with the
//! dissertation's acceptance rule and initial-temperature search, Corana-style
//! step adaptation, re-annealing from the best point and a Nelder–Mead polish.
//!
//! The muscle identification ([`identify()`], module [`mod@identify`]; results and method in docs/results.md) wraps a
//! `muscle_model::Problem` as an [`Objective`] ([`ProblemObjective`]: cost = the SSE of the
//! dissertation's eq. 12, a failed simulation = a rejected move); the annealer itself does
//! not depend on the model.
//!
//! # Identification ([`identify()`])
//!
//! * The problem comes from `experiment::PreparedTrial`: its `standard_problem` is the
//!   standard problem on the torque with the dynamometer's cycle-locked error subtracted
//!   (offset + damped-sinusoid transient after each motion event, placed at the trial's own
//!   events detected from its angle) when an unloaded run was given.
//! * [`identify()`] runs `chains` = 4 independent annealing chains in parallel (rayon; chain
//!   0 from the nominal values, the others from random points; chain `k` seeded with
//!   [`chain_seed`]), each with [`SaIdentifySettings::default_annealer`] (6 000 evaluations,
//!   cooling 0.8, stages of 5 × 4 sweeps, 6 re-annealings at 0.1 T₀, a 5 % Nelder–Mead
//!   polish), then polishes every chain's best with a bounded Levenberg–Marquardt on the
//!   residual vector ([`SaIdentifySettings::default_polish`]: ≤ 40 iterations, central
//!   differences of 10⁻³ of each range; `numerics::lm`) and keeps the best. The result does not depend on the thread count.
//! * `rms_nm` is the RMS of (torque fitted − model), the torque fitted being the corrected
//!   one when an unloaded run was given (`experiment::PreparedTrial::raw_torque` is the torque
//!   as measured).
//!
//! Budget: one simulation of the seed trial (6 828 samples) takes about 0.7 ms on one core
//! of the 2-core machine; the default ≈ 26 000 evaluations take ≈ 9 s of wall time on two
//! idle cores. In tuning runs (4 random truths) 2 chains of 3 000 already reached the same
//! minimum after the polish, but single chains from random starts were seen to end in a far
//! basin (RMS 1.2 × floor): four chains and the 2.5× budget margin buy robustness.
//!
//! # The problem
//!
//! Minimise `f(x)` over the box `lᵢ ≤ xᵢ ≤ uᵢ`, where `f` may fail
//! ([`Objective::cost`] returns `None`). All moves are made in unit-box
//! coordinates `zᵢ = (xᵢ − lᵢ)/(uᵢ − lᵢ) ∈ [0, 1]`, so one step size means
//! the same share of every parameter's range.
//!
//! # The algorithm ([`Annealer`], driven by [`run`])
//!
//! **Moves** (Corana et al. 1987): coordinates are visited in turn; coordinate
//! `h` moves by `r·v_h`, `r ~ U(−1, 1)`, and the result is folded back into
//! `[0, 1]` by reflection at the walls ([`reflect_into_unit`]), so every
//! evaluated point lies inside the bounds and the proposal stays symmetric.
//!
//! **Acceptance** (the dissertation's eq. 13, Barker's rule): a move that
//! changes the cost by `Δ` is accepted with probability
//!
//! ```text
//! p = 1 / (1 + exp(Δ/T))
//! ```
//!
//! ([`Acceptance::Logistic`]; [`Acceptance::Metropolis`], `p = min(1, e^(−Δ/T))`,
//! is available). A failed evaluation is a rejected move. The best point ever
//! evaluated is kept, accepted or not.
//!
//! **Initial temperature** (dissertation §3.6.1/§4.1): a first event of
//! `t0_event_moves` = 200 greedy moves measures the uphill `Δ`; the search
//! starts at `T = t0_start_fraction · median(Δ⁺)` and runs events of 200
//! moves, raising `T` by 20 % (`t0_growth`) per event, until the number of
//! accepted moves has stabilised: it grew by less than `t0_stable_fraction`
//! = 2 % of the moves since the previous event *and* the acceptance ratio,
//! divided by `p(Δ = 0)` (½ for eq. 13), is at least `t0_min_acceptance` =
//! 0.55 (27.5 % raw, the dissertation reports ≈ 28.5 %). Because only `Δ/T`
//! enters, `T₀` scales with the cost: it needs no user-supplied scale.
//!
//! **Step adaptation** (Corana): a stage is `N_T` = 5 rounds of `N_s` = 10
//! sweeps over the coordinates. After each round, with `a_h` the accepted
//! moves of coordinate `h` and `ρ = a_h / (N_s · p(Δ=0))` the normalised
//! acceptance ratio,
//!
//! ```text
//! v_h ← v_h · (1 + c (ρ − 0.6)/0.4)   if ρ > 0.6
//! v_h ← v_h / (1 + c (0.4 − ρ)/0.4)   if ρ < 0.4,     c = 2,
//! ```
//!
//! clamped to `[min_step, 1]`. Normalising by `p(Δ=0)` keeps Corana's
//! 0.4–0.6 band meaningful under eq. 13, whose raw acceptance never exceeds
//! about ½ on a flat landscape (the band is 20–30 % raw acceptance).
//!
//! **Cooling and restarts**: after each stage `T ← r·T` (`r` = 0.85) and the
//! chain restarts from the best point (`restart_from_best`, as in Corana).
//!
//! **Re-annealing**: an annealing pass ends when the best cost has changed by
//! at most `tolerance_abs + tolerance_rel·|f_best|` over the last
//! `stall_stages` = 4 stages with the chain at the best point, or when
//! `T < final_temperature · T₀` (10⁻³). Then, up to `max_reanneals` = 20
//! times, the chain restarts from the best point at
//! `T = reanneal_temperature · T₀` (0.3 T₀) with every step reset to
//! `reanneal_step` = 0.1. After the last pass the run stops with
//! [`AnnealStopReason::Converged`]; in practice the budget usually ends it first
//! ([`AnnealStopReason::MaxEvaluations`]).
//!
//! **Polish**: the share `polish_fraction` = 10 % of `max_evaluations` is kept
//! for [`nelder_mead()`] from the best point (initial simplex edge 0.05 of each
//! range, adaptive coefficients, vertices clamped into the box, restarts).
//!
//! Everything random comes from one `ChaCha8Rng` seeded with
//! [`AnnealSettings::seed`]; there is no threading, so a run is a deterministic
//! function of `(objective, start, settings)`.
//!
//! # Defaults
//!
//! | setting | default | why |
//! |---|---|---|
//! | `max_evaluations` | 100 000 | total, polish included |
//! | `acceptance` | eq. 13 | the dissertation's rule |
//! | `initial_step`, `min_step` | 0.5, 1e-10 | half the box: global moves while hot |
//! | `moves_per_adaptation` `N_s`, `adaptations_per_stage` `N_T` | 10, 5 | a stage is `50·n` evaluations (Corana's 20 × max(100, 5n) is far too long for a 10⁵ budget) |
//! | `step_gain` `c`, band | 2, 0.4–0.6 normalised | Corana |
//! | `cooling` `r` | 0.85 | Corana; on Rastrigin 5-D (100 seeds) 0.8 gave 97 % vs 94 %, within seed noise, so Corana's value is kept |
//! | `t0_event_moves`, `t0_growth` | 200, 1.2 | the dissertation |
//! | `t0_start_fraction`, `t0_stable_fraction`, `t0_min_acceptance`, `t0_max_events` | 0.1, 0.02, 0.55, 60 | see above |
//! | `tolerance_rel`, `tolerance_abs`, `stall_stages` | 1e-7, 1e-10, 4 | Corana's test on the best |
//! | `final_temperature` | 1e-3 · T₀ | below it SA crawls; the polish is far cheaper |
//! | `max_reanneals`, `reanneal_temperature`, `reanneal_step` | 20, 0.3 · T₀, 0.1 | short passes, many restarts: Rastrigin 5-D 94 % vs 81 % with 10⁻⁶ T₀ |
//! | `polish_fraction` | 0.1 | Nelder–Mead settles the basin in ~10³ evaluations |
//! | polish: `initial_step`, `ftol_abs`, `ftol_rel`, `xtol`, `max_restarts` | 0.05, 1e-12, 1e-10, 1e-9, 6 | see [`NelderMeadSettings`] |
//! | `start_attempts` | 100 | random starts tried when the start fails |
//!
//! For the muscle problem (9 parameters, cost ≈ 10⁵ N²·m² at the optimum,
//! 0.1–1 ms per evaluation) a stage is 450 evaluations; the first pass
//! (T₀ → 10⁻³ T₀) is about 43 stages ≈ 19 000 evaluations after the
//! initial-temperature search (a few thousand), each re-annealing (0.3 T₀ →
//! 10⁻³ T₀) about 35 stages ≈ 16 000 evaluations.
//!
//! # Measured success rates
//!
//! Default settings, uniform random start, seeds 1000–1019 (the tests in
//! `tests/standard_functions.rs`), and over seeds 0–99
//! (`cargo run --release -p identify-sa --example success_rates 100`).
//! Success is `f < 10⁻⁴` (f* = 0), or for Rastrigin every `|xᵢ| < 0.5`
//! (the global basin).
//!
//! | function, box | n | budget | seeds 1000–1019 | seeds 0–99 | test asserts |
//! |---|---|---|---|---|---|
//! | Rosenbrock, [−5, 10]ⁿ | 2 | 5 000 | 20/20 | 100 % | ≥ 19/20 |
//! | Rosenbrock | 5 | 20 000 | 20/20 | 97 % | ≥ 17/20 |
//! | Rosenbrock | 10 | 50 000 | 20/20 | 97 % | ≥ 17/20 |
//! | Rastrigin, [−5.12, 5.12]ⁿ | 2 | 10 000 | 20/20 | 100 % | ≥ 19/20 |
//! | Rastrigin | 5 | 100 000 | 20/20 | 94 % | ≥ 16/20 |
//! | Ackley, [−32.768, 32.768]ⁿ | 2 | 10 000 | 20/20 | 100 % | ≥ 19/20 |
//! | Ackley | 10 | 50 000 | 20/20 | 100 % | ≥ 19/20 |
//!
//! The Rosenbrock failures end in its local minimum near `(−1, 1, …, 1)`
//! (f ≈ 3.93–3.99). With Metropolis acceptance instead of eq. 13
//! (everything else default) Rastrigin 5-D drops to 63 %.
//!
//! # Example
//!
//! ```
//! use std::ops::ControlFlow;
//! use identify_sa::{run, FnObjective, AnnealProgress, AnnealSettings};
//!
//! // A correlated quadratic valley on a box, minimum at (1, 2).
//! let mut valley = FnObjective::new(vec![(-5.0, 5.0), (0.0, 4.0)], |x: &[f64]| {
//!     Some((x[0] - 1.0).powi(2) + 50.0 * (x[1] - 2.0 * x[0]).powi(2))
//! });
//! let settings = AnnealSettings::default().with_seed(7).with_max_evaluations(10_000);
//! let mut stages = 0;
//! let out = run(&mut valley, None, &settings, &mut |p: &AnnealProgress| {
//!     stages += 1; // e.g. drive a progress bar with p.evaluations / p.max_evaluations
//!     ControlFlow::Continue(())
//! })
//! .unwrap();
//! assert!(out.cost < 1e-10);
//! assert!((out.x[0] - 1.0).abs() < 1e-4 && (out.x[1] - 2.0).abs() < 1e-4);
//! assert!(out.evaluations <= 10_000);
//! assert!(stages > 1);
//! ```

mod annealer;
mod error;
mod executor;
pub mod identify;
mod search;
mod settings;
#[cfg(feature = "test-support")]
pub mod test_functions;

pub use annealer::{reflect_into_unit, AnnealStopReason, Annealer, StageRecord};
pub use error::Error;
pub use executor::{run, AnnealPhase, AnnealProgress, NoObserver, Observer, Outcome};
pub use identify::{
    best_two_agree, chain_seed, errors_pct, identify, identify_set, identify_set_with_search,
    truth_values, ChainSummary, Identification, IdentifyEvent, IdentifyObserver, ProblemObjective,
    ProblemSetObjective, SaIdentifySettings,
};
/// Nelder–Mead and the objective trait live in `numerics`; they are part of this crate's API.
pub use numerics::{nelder_mead, FnObjective, NelderMeadOutcome, NelderMeadSettings, Objective};
pub use search::{search_set, SearchSettings};
pub use settings::{Acceptance, AnnealSettings};
