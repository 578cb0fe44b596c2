//! Metropolis–Hastings identification with several chains, rank-normalised
//! split R̂ and bulk/tail ESS (method and measured results: docs/results.md).
//!
//! The crate is generic: anything implementing [`LogDensity`] (dimension,
//! bounds, `log π(x)` or `None` for a failed evaluation) can be sampled. The
//! prior is uniform on the bounds box. A target that also gives its gradient
//! ([`GradLogDensity`]) can be sampled by the No-U-Turn Sampler instead
//! ([`run_nuts`], section "Gradient-based sampler").
//!
//! # Sampler
//!
//! Each chain is a random-walk Metropolis–Hastings chain: from `x` propose
//! `y`, accept with probability `α = min(1, π(y)/π(x))`, where `π(y) = 0`
//! outside the bounds and a failed evaluation counts as a rejection. Two
//! symmetric proposals ([`Proposal`]):
//!
//! * **adaptive** (default): `y = x + √λ·L·z`, `z ~ N(0, I)`, `L·Lᵀ = C`.
//!   During warm-up `C` is re-estimated at the end of doubling windows
//!   (first `max(100, 10d)` iterations) as
//!   `C = n/(n+5)·S + (5/(n+5)·10⁻⁶ + 10⁻¹²)·diag(w²)`, `S` the window's sample
//!   covariance and `w` the bound widths (Haario et al. 2001; windows as in
//!   Stan), and `log λ` follows the Robbins–Monro recursion
//!   `log λ ← log λ + k^{−0.6}(α − 0.234)` restarted at `λ = 2.38²/d` after
//!   each window (Andrieu & Thoms 2008). Both are frozen when warm-up ends, so
//!   the kept draws come from one fixed Metropolis–Hastings kernel.
//! * **dissertation** (eq. 19): `y_i = x_i + s·w_i·U(−1, 1)` for every
//!   coordinate, never adapted.
//!
//! Chains run in parallel (rayon); chain `c` draws from
//! `ChaCha8Rng::seed_from_u64(seed)` on stream `c + 1`, so results are
//! bit-identical for any number of threads.
//!
//! Warm-up length is chosen by monitoring: after at least `warmup_min`
//! iterations, warm-up ends once every parameter's R̂ over the second half of
//! the warm-up draws is below `warmup_rhat_target` (1.05). Sampling then
//! continues in blocks until every parameter has `R̂ < 1.01` and bulk
//! `ESS ≥ 400` over the kept draws, or until `max_total` iterations per chain
//! (100 000 by default), in which case [`RunResult::stop`] is
//! [`ChainStopReason::CapReached`] and `converged` is false.
//!
//! # Gradient-based sampler ([`run_nuts`])
//!
//! A target that also gives its gradient ([`GradLogDensity`]; closures via
//! [`FnGradLogDensity`]) can be sampled by the No-U-Turn Sampler as in Stan (multinomial NUTS,
//! Betancourt 2017; Hoffman & Gelman 2014), configured by [`NutsSettings`] and returning a
//! [`NutsRun`] (draws in the box coordinates, [`NutsDraw`] statistics per draw, the summaries
//! above).
//!
//! * **Transform** ([`LogisticBox`]): every coordinate runs on `u ∈ ℝ` with
//!   `x = lo + (hi − lo)·σ(u)`, `σ(u) = 1/(1 + e^{−u})`; the density on `u` is
//!   `log p(u) = log π(x(u)) + Σᵢ [log(hiᵢ − loᵢ) + log σ(uᵢ) + log(1 − σ(uᵢ))]`, with gradient
//!   `∂ log p/∂uᵢ = ∂ log π/∂xᵢ·(hiᵢ − loᵢ)σ(uᵢ)(1 − σ(uᵢ)) + 1 − 2σ(uᵢ)`.
//! * **Hamiltonian**: `H(u, p) = −log p(u) + ½ pᵀM⁻¹p` with a diagonal metric `M`, momenta
//!   `p ~ N(0, M)` drawn afresh at every transition.
//! * **Leapfrog** with step `ε`: `p ← p + (ε/2)∇log p(u)`, `u ← u + ε M⁻¹p`,
//!   `p ← p + (ε/2)∇log p(u)`.
//! * **Trajectory**: doubled forward or backward in time at random (up to `max_depth`
//!   doublings, `2^max_depth − 1` steps). Every point carries the weight `e^{−H}`; within a new
//!   subtree a point is drawn in proportion to the weights, and the subtree's draw replaces
//!   the current one with probability `min(1, W_new/W_old)` (biased progressive sampling). A
//!   step with `H − H₀ > max_energy_error` (1000) or a failed evaluation is a divergence: the
//!   subtree is discarded and the trajectory stops.
//! * **U-turn** (generalised criterion): with `ρ` the sum of the momenta of a (sub)trajectory
//!   and `p♯ = M⁻¹p` at its two ends, it continues while `p♯₋·ρ > 0` and `p♯₊·ρ > 0`; as in
//!   Stan's `base_nuts`, the check is also applied to each half extended by the nearest point
//!   of the other half, at every merge.
//! * **Step size**: starting from `initial_step_size`, a heuristic doubles (halves) `ε` while one
//!   leapfrog step keeps `H₀ − H` above (below) `log 0.8`. During warm-up, dual averaging
//!   (Nesterov; `δ = target_accept`, `γ = 0.05`, `t₀ = 10`, `κ = 0.75`, `μ = log(10ε)`)
//!   updates, with the transition's acceptance statistic `a_t` (the mean of
//!   `min(1, e^{H₀−H})` over the trajectory),
//!   `s̄_t = (1 − 1/(t + t₀))·s̄_{t−1} + (δ − a_t)/(t + t₀)`, `log ε_t = μ − √t·s̄_t/γ`,
//!   `x̄_t = t^{−κ}·log ε_t + (1 − t^{−κ})·x̄_{t−1}`; sampling uses `ε = e^{x̄}`.
//! * **Metric**: Stan's windows (initial buffer 75, slow windows from 25 doubling, terminal
//!   buffer 50); at the end of each window `M⁻¹ = n/(n+5)·var + 10⁻³·5/(n+5)`, `var` the
//!   window's sample variance of `u`, after which the step-size heuristic runs again and the
//!   dual averaging restarts.
//!
//! Chains are independent and run in parallel on rayon with the same RNG streams as the random
//! walk, so results are bit-identical for any number of threads. [`write_cmdstan_nuts_chain`]
//! writes a chain with CmdStan's NUTS columns.
//!
//! # Diagnostics ([`diagnostics`])
//!
//! For `M` chains of `N` draws, chain means `θ̄_m`, chain variances `s_m²`:
//!
//! * `B = N/(M−1)·Σ(θ̄_m − θ̄)²`, `W = (1/M)·Σ s_m²`,
//!   `R̂ = √(((N−1)/N·W + B/N)/W)` (Gelman–Rubin; [`diagnostics::rhat_classic`]
//!   on whole chains, [`diagnostics::rhat_basic`] on split chains);
//! * rank normalisation `z = Φ⁻¹((r − 3/8)/(S + 1/4))` of the pooled ranks `r`
//!   of `S` draws; [`diagnostics::rhat`] is the larger of R̂ of the
//!   rank-normalised split chains and of the rank-normalised split chains of
//!   `|θ − median θ|` (Vehtari et al. 2021);
//! * `ESS = MN/τ̂`, `τ̂ = −1 + 2·Σ_{t<T} ρ̂_t + ρ̂_T`, with
//!   `ρ̂_t = 1 − (W − (1/M)Σ_m γ̂_{t,m})/var⁺`, `var⁺ = (N−1)/N·W + B/N`,
//!   `γ̂_{t,m}` the biased autocovariance, truncated by Geyer's initial
//!   positive sequence and made monotone, and `τ̂ ≥ 1/log₁₀(MN)`;
//!   [`diagnostics::ess_bulk`] is the ESS of the rank-normalised split chains,
//!   [`diagnostics::ess_tail`] the smaller ESS of the split indicators
//!   `I(θ ≤ q₀.₀₅)` and `I(θ ≤ q₀.₉₅)`.
//!
//! They match R's `posterior` package to ~1e-12 on Stan's reference chains.
//!
//! # Identifiability ([`Summary`])
//!
//! Each parameter's posterior sd is compared with the uniform prior's
//! `width/√12`; `identifiable` means `sd < prior_sd/2`. The pooled correlation
//! matrix and the pairs sorted by `|r|` show which parameters trade off.
//!
//! # Chains for other tools ([`cmdstan`])
//!
//! [`write_cmdstan_chain`] writes one chain's kept draws in CmdStan's CSV layout (`lp__`, the
//! parameters with `_` for `.`, `log_lik.1`), which `arviz.from_cmdstan` reads;
//! [`write_cmdstan_nuts_chain`] writes a [`NutsRun`]'s chain with CmdStan's NUTS columns
//! (`lp__,accept_stat__,stepsize__,treedepth__,n_leapfrog__,divergent__,energy__`, then the
//! parameters).
//!
//! # Identification of the muscle model ([`identify()`])
//!
//! The posterior of a [`muscle_model::Problem`] under a uniform prior on its bounds and the
//! likelihood of the torque residual under a noise model ([`noise`]): the dynamometer's
//! AR(1) + white error `e_t = x_t + w_t`, `x_t = φx_{t−1} + η_t`, whose exact Gaussian
//! likelihood `ℓ = −½Σ(ln 2πF_t + v_t²/F_t)` comes from the scalar Kalman filter
//! (innovations `v_t`, variances `F_t`). The measured torque is first corrected by the
//! cycle-locked systematic error estimated from the unloaded run ([`NoiseSpec::from_unloaded`]).
//! Before sampling, a multi-start Nelder–Mead search (module `modes`) finds the modes of the
//! posterior of the nonlinear parameters (F0 integrated out exactly). The chains then run in
//! coordinates without walls (module `sampling_coordinates`): LST and α0 on the logit scale of their
//! bounds, whitened by the best mode's Laplace fit, and F0 on its exact truncated Gaussian
//! conditional through the GHK map, which removes the curved F0–length ridge. Each step is,
//! with probability `jump_probability`, an independence proposal from a Student-t mixture on
//! the modes (refitted by k-means to the pooled warm-up states; [`MixtureProposal`]) and
//! otherwise the adaptive random walk; the chains start from draws of that mixture. Every step also yields the model's parameters
//! ([`LogDensity::evaluate`]), so the chains store, monitor (R̂, ESS) and report those directly.
//!
//! # Sessions ([`identify_session`])
//!
//! Several trials of one subject share the muscle parameters; each keeps its own systematic
//! correction, noise model and offset nuisance, and the log-likelihood is the sum of the
//! trials' (their noises are independent). [`identify()`] is a session of one trial.
//!
//! # Example
//!
//! A correlated 2-D Gaussian (ρ = 0.9) in a box far wider than the posterior:
//!
//! ```
//! use identify_mcmc::{run, FnLogDensity, McmcSettings};
//!
//! let rho: f64 = 0.9;
//! let target = FnLogDensity::new(vec![(-10.0, 10.0), (-10.0, 10.0)], move |x: &[f64]| {
//!     let q = (x[0] * x[0] - 2.0 * rho * x[0] * x[1] + x[1] * x[1]) / (1.0 - rho * rho);
//!     Some(-0.5 * q)
//! });
//! let settings = McmcSettings { seed: 7, warmup_min: 1000, block: 500, max_total: 20_000, ..McmcSettings::default() };
//! let result = run(&target, &settings, None).unwrap();
//! assert!(result.converged);
//! for s in &result.summary {
//!     assert!(s.mean.abs() < 0.3 && (s.sd - 1.0).abs() < 0.2 && s.rhat < 1.01);
//!     assert!(s.identifiable); // sd ≈ 1 against the prior's 20/√12 ≈ 5.8
//! }
//! assert!((result.correlation[0][1] - rho).abs() < 0.05);
//! ```

pub mod cmdstan;
pub mod diagnostics;
mod full_posterior;
pub mod identify;
pub mod mixture;
mod modes;
pub mod noise;
mod nuts;
mod nuts_identify;
mod sampler;
mod sampling_coordinates;
mod session_identify;
mod settings;
mod summary;
mod target;
mod transform;
mod trial_term;

pub use cmdstan::{write_cmdstan_chain, write_cmdstan_nuts_chain, NutsChains};
pub use mixture::{ComponentSpec, MixtureProposal};
pub use sampler::{
    run, run_with_observer, run_with_proposal, ChainPhase, ChainProgress, ChainStopReason,
    RunResult, MAX_INIT_TRIES,
};
pub use settings::{McmcSettings, Proposal};
pub use summary::{correlation_matrix, strongest_correlations, CorrelationPair, Summary};
pub use target::{FnGradLogDensity, FnLogDensity, GradLogDensity, LogDensity};

pub use nuts::{run_nuts, NutsDraw, NutsRun, NutsSettings};
pub use transform::LogisticBox;

pub use identify::{
    McmcIdentification, McmcIdentifySettings, McmcNoiseSource, ModeInfo, NamedCorrelation,
    NoiseSpec, NutsStats, ParamPosterior, DEFAULT_MAX_LAG, NO_UNLOADED_OFFSET_SD_NM,
    UNLOADED_OFFSET_SD_NM,
};
pub use identify::{McmcTrialFit, SessionTrialLikelihood};
pub use noise::{Ar1White, Noise, NoiseKind, NoiseParams};
pub use nuts_identify::identify_session_nuts;
pub use session_identify::{identify, identify_session};

/// Everything that can go wrong before sampling starts.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum McmcError {
    /// A [`McmcSettings`] field is out of range.
    #[error("invalid setting `{name}` = {value}: {reason}")]
    InvalidSetting {
        /// Field name.
        name: &'static str,
        /// Offending value, formatted.
        value: String,
        /// What is required.
        reason: &'static str,
    },
    /// The target has no parameters.
    #[error("the target has no parameters")]
    EmptyTarget,
    /// `bounds().len() != dim()`.
    #[error("the target has {expected} parameters but {got} bounds")]
    BoundsLength {
        /// `dim()`.
        expected: usize,
        /// `bounds().len()`.
        got: usize,
    },
    /// A bound is not finite or `lower >= upper`.
    #[error("bounds of parameter {index} are invalid: ({lower}, {upper})")]
    InvalidBounds {
        /// Parameter index.
        index: usize,
        /// Lower bound.
        lower: f64,
        /// Upper bound.
        upper: f64,
    },
    /// The number of start points differs from `n_chains`.
    #[error("{got} start points given for {expected} chains")]
    InitCount {
        /// `n_chains`.
        expected: usize,
        /// Points given.
        got: usize,
    },
    /// A start point has the wrong length.
    #[error("start point of chain {chain} has {got} coordinates, expected {expected}")]
    InitDimension {
        /// Chain index.
        chain: usize,
        /// `dim()`.
        expected: usize,
        /// Its length.
        got: usize,
    },
    /// A start point lies outside the bounds.
    #[error("start point of chain {chain}: parameter {index} = {value} is outside its bounds")]
    InitOutOfBounds {
        /// Chain index.
        chain: usize,
        /// Parameter index.
        index: usize,
        /// Its value.
        value: f64,
    },
    /// The log density fails (or is not finite) at a given start point.
    #[error("start point of chain {chain}: the log density failed or is not finite")]
    InitNotFinite {
        /// Chain index.
        chain: usize,
    },
    /// No uniformly drawn point in the bounds had a finite log density.
    #[error("chain {chain}: no finite log density in {tries} uniform draws from the bounds")]
    NoValidStart {
        /// Chain index.
        chain: usize,
        /// Draws tried.
        tries: usize,
    },
    /// A noise-model parameter is out of range.
    #[error("invalid noise parameter `{field}` = {value}")]
    InvalidNoise {
        /// Field name.
        field: &'static str,
        /// Its value.
        value: f64,
    },
    /// A noise model could not be fitted to a record.
    #[error("cannot fit the noise model to {samples} samples: {reason}")]
    NoiseFit {
        /// Record length.
        samples: usize,
        /// Why.
        reason: &'static str,
    },
    /// A vector has the wrong length.
    #[error("{what} has {got} samples, expected {expected}")]
    Length {
        /// What.
        what: &'static str,
        /// Expected length.
        expected: usize,
        /// Its length.
        got: usize,
    },
    /// The preliminary fit could not start.
    #[error("the preliminary Nelder–Mead fit failed: {reason}")]
    Start {
        /// Why.
        reason: String,
    },
    /// The model rejected the problem.
    #[error(transparent)]
    Model(#[from] muscle_model::ModelError),
    /// Trial / unloaded input problems.
    #[error(transparent)]
    Experiment(#[from] experiment::ExperimentError),
    /// A session without trials.
    #[error("the session has no trials")]
    EmptySession,
    /// A trial of a session differs from the first in what the trials must share.
    #[error("trial {trial} of the session has other {what} than trial 0")]
    SessionMismatch {
        /// Index of the trial in the session.
        trial: usize,
        /// `free parameters` or `bounds`.
        what: &'static str,
    },
    /// The step-size heuristic of [`run_nuts`] doubled past `10⁷` or halved to zero (the
    /// density is flat or its gradient fails around the chain's state).
    #[error("chain {chain}: the step-size heuristic ran away (step size {step_size})")]
    StepSize {
        /// Chain index.
        chain: usize,
        /// The step size when it stopped.
        step_size: f64,
    },
    /// A kept draw could not be mapped back to the model's parameters (its simulation failed
    /// on re-evaluation; cannot happen for a deterministic model).
    #[error("a kept draw could not be re-evaluated")]
    Remap,
    /// The gradient-based sampler needs the model's exact gradient, which it does not have for
    /// a free parameter or the formulation.
    #[error("NUTS needs the model's exact gradient: {reason}")]
    NoExactGradient {
        /// The model's reason.
        reason: String,
    },
}
