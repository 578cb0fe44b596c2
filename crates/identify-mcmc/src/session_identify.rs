//! Bayesian identification of the muscle model (docs/results.md) over a session, several
//! trials of one subject that share the muscle parameters: noise model, start points, chains,
//! report.
//!
//! [`identify`] samples the posterior of a [`Problem`]'s free parameters:
//!
//! 1. the measured torque is corrected by the dynamometer's systematic error
//!    ([`NoiseSpec::systematic`], e.g. the cycle-locked part estimated from the unloaded run);
//! 2. the noise model is the one given, or (no unloaded run) fitted to the residual of a
//!    Nelder–Mead fit of the sum of squares (`numerics::nelder_mead`; for a session, each
//!    trial's noise to its own residual of one joint fit);
//! 3. a multi-start search (module `modes`) finds the modes of the posterior of LST and α0 with
//!    F0 integrated out; the best one centres the wall-free sampling coordinates (module
//!    `sampling_coordinates`) and all of them make the jump mixture ([`crate::MixtureProposal`]);
//! 4. `n_chains` chains start from draws of that mixture (`u ~ N(0, spread²)` for F0, from the
//!    seed's stream 0) and run the adaptive Metropolis–Hastings sampler of this crate with mode
//!    jumps (uniform prior on the bounds; a failed simulation is a rejected proposal) until
//!    every R̂ < 1.01 and bulk ESS ≥ 400 on the model's parameters (which the chains store at
//!    every step), or the cap;
//! 5. the report names each parameter (`sol.lst_m`, …) with its summary, identifiability,
//!    the posterior correlation matrix and the strongest correlations.
//!
//! Each trial keeps its own dynamometer correction ([`NoiseSpec::systematic`]), its own random
//! noise model and its own constant-offset nuisance; the noises of different trials are
//! independent, so the log-likelihood is the sum of the trials' log-likelihoods
//!
//! `ℓ(x) = Σ_t ℓ_t(x)`, `ℓ_t(x) = N_t − ½·|W_t(y_t − s_t − τ_t(x))|²` (offset integrated out),
//!
//! with `s_t` the trial's systematic error and `W_t` its whitening filter. The sampling
//! coordinates of a session are those of one trial with summed Gram quantities (module
//! `trial_term`), the mode search runs on the summed marginal, and the Laplace factor stacks the
//! trials' whitened Jacobians. A trial whose noise comes from the residual
//! ([`McmcNoiseSource::FromResidual`]) is fitted to its own residual of one joint Nelder–Mead
//! fit of the summed squared errors. A session of one trial is exactly [`identify`].

use std::ops::ControlFlow;
use std::time::Instant;

use muscle_model::Problem;
use numerics::{nelder_mead, FnObjective, NelderMeadSettings};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, StandardNormal};

use crate::identify::{
    mode_mixture, McmcIdentification, McmcIdentifySettings, McmcNoiseSource, McmcTrialFit,
    NamedCorrelation, NoiseSpec, ParamPosterior, SessionTrialLikelihood,
};
use crate::mixture::MixtureProposal;
use crate::modes::{find_modes, Mode};
use crate::noise::NoiseParams;
use crate::sampling_coordinates::Conditional;
use crate::trial_term::TrialModel;
use crate::{run_with_proposal, ChainProgress, LogDensity, McmcError, McmcSettings, RunResult};

/// Sample the posterior of `problem`'s free parameters (see the module documentation).
///
/// `observer` sees the sampler's [`ChainProgress`] after every block and may stop the run.
///
/// # Errors
/// Invalid settings, a systematic correction of the wrong length, a Nelder–Mead start where the
/// model fails, a noise fit that fails, or a start point without finite density.
pub fn identify<F>(
    problem: &Problem,
    noise: &NoiseSpec,
    settings: &McmcIdentifySettings,
    observer: F,
) -> Result<McmcIdentification, McmcError>
where
    F: FnMut(&ChainProgress) -> ControlFlow<()>,
{
    identify_session(
        &[SessionTrialLikelihood { problem, noise }],
        settings,
        observer,
    )
}

/// `problem` with its measured torque replaced by `measured` (everything else kept).
fn with_measured(problem: &Problem, measured: Vec<f64>) -> Result<Problem, McmcError> {
    let mut p = Problem::new(
        problem.inputs().clone(),
        measured,
        *problem.base_params(),
        *problem.base_effects(),
        problem.free().to_vec(),
    )?
    .with_bounds(problem.bounds().to_vec())?
    .with_settings(*problem.settings());
    if let Some(w) = problem.weights() {
        p = p.with_weights(w.to_vec())?;
    }
    Ok(p)
}

/// The trial's problem on its corrected torque (measured − systematic).
pub(crate) fn corrected_problem(t: &SessionTrialLikelihood<'_>) -> Result<Problem, McmcError> {
    let problem = t.problem;
    match &t.noise.systematic {
        None => Ok(problem.clone()),
        Some(s) => {
            if s.len() != problem.measured().len() {
                return Err(McmcError::Length {
                    what: "systematic correction",
                    expected: problem.measured().len(),
                    got: s.len(),
                });
            }
            let m: Vec<f64> = problem
                .measured()
                .iter()
                .zip(s)
                .map(|(m, s)| m - s)
                .collect();
            with_measured(problem, m)
        }
    }
}

/// Every trial has the first trial's free parameters and bounds.
pub(crate) fn check_shared(trials: &[SessionTrialLikelihood<'_>]) -> Result<(), McmcError> {
    let first = trials.first().ok_or(McmcError::EmptySession)?.problem;
    for (i, t) in trials.iter().enumerate().skip(1) {
        if t.problem.free() != first.free() {
            return Err(McmcError::SessionMismatch {
                trial: i,
                what: "free parameters",
            });
        }
        if t.problem.bounds() != first.bounds() {
            return Err(McmcError::SessionMismatch {
                trial: i,
                what: "bounds",
            });
        }
    }
    Ok(())
}

/// The noise model of every trial: given, or fitted to that trial's residual of one joint
/// Nelder–Mead fit of the summed squared errors (run only when some trial needs it). Returns the
/// models and the evaluations and failures of the fit.
pub(crate) fn noise_models(
    trials: &[SessionTrialLikelihood<'_>],
    corrected: &[Problem],
    settings: &McmcIdentifySettings,
) -> Result<(Vec<NoiseParams>, u64, u64), McmcError> {
    let mut evaluations = 0u64;
    let mut failed = 0u64;
    let needs_fit = trials
        .iter()
        .any(|t| matches!(t.noise.source, McmcNoiseSource::FromResidual(_)));
    let mut fit_x = None;
    if needs_fit {
        let bounds = corrected[0].bounds().to_vec();
        let x0: Vec<f64> = corrected[0]
            .base_vector()
            .iter()
            .zip(&bounds)
            .map(|(v, (lo, hi))| v.clamp(*lo, *hi))
            .collect();
        let mut objective = FnObjective::new(bounds, |x: &[f64]| {
            let mut total = 0.0;
            for p in corrected {
                total += p.sse(x).ok()?;
            }
            Some(total)
        });
        let nm = NelderMeadSettings {
            max_evaluations: settings.nelder_mead_evaluations.max(1) * 5,
            ..NelderMeadSettings::default()
        };
        let out = nelder_mead(&mut objective, &x0, &nm).map_err(|e| McmcError::Start {
            reason: e.to_string(),
        })?;
        evaluations += out.evaluations + 1;
        failed += out.failed_evaluations;
        fit_x = Some(out.x);
    }
    let mut models = Vec::with_capacity(trials.len());
    for (t, p) in trials.iter().zip(corrected) {
        models.push(match (t.noise.source, &fit_x) {
            (McmcNoiseSource::Fixed(n), _) => n,
            (McmcNoiseSource::FromResidual(kind), Some(x)) => {
                let pred = p.predict(x)?;
                // Only the samples the likelihood sees (a trial with weights is measured only
                // where its weight is positive).
                let r: Vec<f64> = p
                    .measured()
                    .iter()
                    .zip(&pred)
                    .enumerate()
                    .filter(|(i, _)| p.weights().is_none_or(|w| w[*i] > 0.0))
                    .map(|(_, (m, p))| m - p)
                    .collect();
                let mean = r.iter().sum::<f64>() / r.len().max(1) as f64;
                let r: Vec<f64> = r.iter().map(|v| v - mean).collect();
                NoiseParams::fit(kind, &r, t.noise.max_lag)?
            }
            (McmcNoiseSource::FromResidual(_), None) => unreachable!("fit run when needed"),
        });
    }
    Ok((models, evaluations, failed))
}

/// Sample the posterior of the shared free parameters of a session's trials (module
/// documentation): each trial corrected by its own systematic error, with its own noise model
/// and offset nuisance.
///
/// `observer` sees the sampler's [`ChainProgress`] after every block and may stop the run.
///
/// # Errors
/// An empty session, trials whose free parameters or bounds differ, invalid settings, a
/// systematic correction of the wrong length, a Nelder–Mead start where the model fails, a
/// noise fit that fails, or a start point without finite density.
pub fn identify_session<F>(
    trials: &[SessionTrialLikelihood<'_>],
    settings: &McmcIdentifySettings,
    observer: F,
) -> Result<McmcIdentification, McmcError>
where
    F: FnMut(&ChainProgress) -> ControlFlow<()>,
{
    let started = Instant::now();
    check_shared(trials)?;
    settings.mcmc.validate()?;
    if !(settings.start_spread.is_finite() && settings.start_spread >= 0.0) {
        return Err(McmcError::InvalidSetting {
            name: "start_spread",
            value: settings.start_spread.to_string(),
            reason: "must be finite and ≥ 0",
        });
    }
    let corrected: Vec<Problem> = trials
        .iter()
        .map(corrected_problem)
        .collect::<Result<_, _>>()?;
    let first = &corrected[0];
    let d = first.dim();
    let bounds = first.bounds().to_vec();

    let (noise_params, mut evaluations, mut failed) = noise_models(trials, &corrected, settings)?;
    let models = trial_models(trials, &corrected, &noise_params)?;

    let k = settings.z_half_width;
    let modes = marginal_modes(
        &models,
        first,
        &bounds,
        settings,
        &mut evaluations,
        &mut failed,
    );
    let best = &modes[0];
    let optimum = best.x.clone();

    // Sampling coordinates: F0 on its exact conditional, the rest whitened by the best mode's
    // Laplace factor; the mixture of all modes proposes the jumps.
    let target = Conditional::with_chol_logit(&models, &best.x, &best.chol_nl, k);
    let (mixture, mode_info) = mode_mixture(&target, &modes, settings)?;

    let inits = dispersed_starts(
        &target,
        &mixture,
        &best.x,
        d,
        settings,
        &mut evaluations,
        &mut failed,
    );

    let margin = settings.monitor_margin;
    if !(margin.is_finite() && margin >= 1.0) {
        return Err(McmcError::InvalidSetting {
            name: "monitor_margin",
            value: margin.to_string(),
            reason: "must be finite and ≥ 1",
        });
    }
    let inner = McmcSettings {
        ess_target: settings.mcmc.ess_target * margin,
        rhat_target: 1.0 + (settings.mcmc.rhat_target - 1.0) / margin,
        ..settings.mcmc
    };
    let mixture = mixture.with_refit(settings.jump_refit_components, settings.jump_inflation);
    let jumps = (settings.jump_probability > 0.0).then_some(&mixture);
    let mut run = run_with_proposal(&target, &inner, Some(&inits), jumps, observer)?;
    run.settings = settings.mcmc;
    evaluations += run.evaluations;
    failed += run.failed_evaluations;

    // The chains stored the model's parameters and ℓ(x) of every kept draw (the target's
    // reported coordinates), and the sampler monitored and summarised those.
    let max_abs_z = run.max_abs_coordinate;
    let targets_met = run
        .summary
        .iter()
        .all(|s| s.rhat < settings.mcmc.rhat_target && s.ess_bulk >= settings.mcmc.ess_target);

    let names = first.names().to_vec();
    let posterior = posteriors(&run, &names);
    let correlations = named_correlations(&run, &names, settings.correlations);
    let mean: Vec<f64> = posterior.iter().map(|p| p.mean).collect();
    let trial_fits = trial_fits(trials, &corrected, &noise_params, &mean);
    evaluations += 2 * trials.len() as u64;
    let (rms_nm, rms_corrected_nm) = pooled_rms(trials, &corrected, &mean, &trial_fits);
    if trials.len() > 1 {
        evaluations += 2 * trials.len() as u64;
    }
    let acc = finite(&run.acceptance_rate);
    let acceptance_rate = acc.iter().sum::<f64>() / acc.len().max(1) as f64;
    debug_assert_eq!(d, posterior.len());
    let jump = finite(&run.jump_acceptance_rate);
    Ok(McmcIdentification {
        names,
        bounds,
        posterior,
        correlations,
        posterior_correlation: run.correlation.clone(),
        converged: run.converged && targets_met,
        max_abs_z,
        z_half_width: k,
        stop: run.stop,
        warmup_iterations: run.warmup_iterations,
        sampling_iterations: run.sampling_iterations,
        acceptance_rate,
        evaluations,
        failed_evaluations: failed,
        optimum,
        modes: mode_info,
        jump_acceptance_rate: if jump.is_empty() {
            f64::NAN
        } else {
            jump.iter().sum::<f64>() / jump.len() as f64
        },
        rms_nm,
        rms_corrected_nm,
        noise: noise_params[0],
        corrected: trials[0].noise.systematic.is_some(),
        trials: trial_fits,
        wall_s: started.elapsed().as_secs_f64(),
        nuts: None,
        run,
    })
}

/// The modes of the marginal posterior of the nonlinear parameters, best first: the
/// multi-start search, or (no starts) the base point clamped to the bounds alone.
fn marginal_modes(
    models: &[TrialModel<'_>],
    first: &Problem,
    bounds: &[(f64, f64)],
    settings: &McmcIdentifySettings,
    evaluations: &mut u64,
    failed: &mut u64,
) -> Vec<Mode> {
    let k = settings.z_half_width;
    if settings.mode_starts > 0 {
        let search = find_modes(
            models,
            settings.mode_starts,
            settings.nelder_mead_evaluations.max(1),
            settings.mcmc.seed,
            settings.mode_gap,
        );
        *evaluations += search.evaluations;
        *failed += search.failed;
        search.modes
    } else {
        let x0: Vec<f64> = first
            .base_vector()
            .iter()
            .zip(bounds)
            .map(|(v, (lo, hi))| v.clamp(*lo, *hi))
            .collect();
        let (t, sims) = Conditional::new(models, &x0, k);
        *evaluations += sims;
        vec![Mode {
            x: x0,
            log_density: f64::NAN,
            chol_nl: t.chol_nl().to_vec(),
        }]
    }
}

/// One start point per chain in the sampling coordinates: chain `c` from mixture component `c`
/// (mod the number of modes), `u ~ N(0, spread²)`, drawn from the seed's stream 0 (the chains
/// use streams 1..) until the density is finite (50 tries, else the best mode itself).
fn dispersed_starts(
    target: &Conditional<'_>,
    mixture: &MixtureProposal,
    best: &[f64],
    d: usize,
    settings: &McmcIdentifySettings,
    evaluations: &mut u64,
    failed: &mut u64,
) -> Vec<Vec<f64>> {
    let k = settings.z_half_width;
    let mut rng = ChaCha8Rng::seed_from_u64(settings.mcmc.seed);
    rng.set_stream(0);
    let nl = target.nl().to_vec();
    let mut inits = Vec::with_capacity(settings.mcmc.n_chains);
    // Fallback start: the best mode itself (u = 0).
    let mut at_best = vec![0.0; d];
    for (&i, z) in nl.iter().zip(target.z_of(best)) {
        at_best[i] = z.clamp(-k, k);
    }
    for c in 0..settings.mcmc.n_chains {
        let mut chosen = at_best.clone();
        for _ in 0..50 {
            let mut cand: Vec<f64> = (0..d)
                .map(|_| {
                    let z: f64 = StandardNormal.sample(&mut rng);
                    settings.start_spread * z
                })
                .collect();
            if settings.start_spread > 0.0 {
                mixture.sample_component(c, &mut rng, &mut cand);
            } else {
                for &i in &nl {
                    cand[i] = 0.0;
                }
            }
            for v in cand.iter_mut() {
                *v = v.clamp(-k, k);
            }
            *evaluations += 1;
            if target.log_density(&cand).is_some_and(f64::is_finite) {
                chosen = cand;
                break;
            }
            *failed += 1;
        }
        inits.push(chosen);
    }
    inits
}

/// Every trial's likelihood model: its corrected problem, its noise model and its offset's
/// prior sd.
pub(crate) fn trial_models<'a>(
    trials: &[SessionTrialLikelihood<'_>],
    corrected: &'a [Problem],
    noise_params: &[NoiseParams],
) -> Result<Vec<TrialModel<'a>>, McmcError> {
    corrected
        .iter()
        .zip(trials)
        .zip(noise_params)
        .map(|((problem, t), n)| {
            Ok(TrialModel {
                problem,
                noise: n.model()?,
                offset_sd: t.noise.offset_sd_nm,
            })
        })
        .collect()
}

/// Each parameter's posterior summary under its name.
pub(crate) fn posteriors(run: &RunResult, names: &[String]) -> Vec<ParamPosterior> {
    run.summary
        .iter()
        .zip(names)
        .map(|(s, n)| ParamPosterior {
            name: n.clone(),
            mean: s.mean,
            sd: s.sd,
            q05: s.q05,
            q95: s.q95,
            rhat: s.rhat,
            ess_bulk: s.ess_bulk,
            ess_tail: s.ess_tail,
            identifiable: s.identifiable,
            prior_sd: s.prior_sd,
            prior_sd_ratio: s.prior_sd_ratio,
        })
        .collect()
}

/// The `count` strongest posterior correlations, by parameter name.
pub(crate) fn named_correlations(
    run: &RunResult,
    names: &[String],
    count: usize,
) -> Vec<NamedCorrelation> {
    run.strongest_correlations
        .iter()
        .take(count)
        .map(|c| NamedCorrelation {
            a: names[c.i].clone(),
            b: names[c.j].clone(),
            r: c.r,
        })
        .collect()
}

/// Each trial's fit at the posterior mean `mean`, against its torque as measured and as
/// corrected.
pub(crate) fn trial_fits(
    trials: &[SessionTrialLikelihood<'_>],
    corrected: &[Problem],
    noise_params: &[NoiseParams],
    mean: &[f64],
) -> Vec<McmcTrialFit> {
    trials
        .iter()
        .zip(corrected)
        .zip(noise_params)
        .map(|((t, c), n)| McmcTrialFit {
            rms_nm: t.problem.rms(mean).unwrap_or(f64::NAN),
            rms_corrected_nm: c.rms(mean).unwrap_or(f64::NAN),
            noise: *n,
            corrected: t.noise.systematic.is_some(),
        })
        .collect()
}

/// The finite values of `rates` (a chain without such steps reports NaN).
fn finite(rates: &[f64]) -> Vec<f64> {
    rates.iter().copied().filter(|v| v.is_finite()).collect()
}

/// The RMS over every sample of the session (measured, corrected): the trial's own for a
/// session of one, else `√(Σ SSE_t / Σ n_t)` over the samples each trial weighs.
pub(crate) fn pooled_rms(
    trials: &[SessionTrialLikelihood<'_>],
    corrected: &[Problem],
    mean: &[f64],
    fits: &[McmcTrialFit],
) -> (f64, f64) {
    if fits.len() == 1 {
        return (fits[0].rms_nm, fits[0].rms_corrected_nm);
    }
    let weight = |p: &Problem| {
        p.weights()
            .map_or(p.measured().len() as f64, |w| w.iter().sum::<f64>())
    };
    let total: f64 = corrected.iter().map(weight).sum();
    let sse = |p: &Problem| p.sse(mean).unwrap_or(f64::NAN);
    let raw: f64 = trials.iter().map(|t| sse(t.problem)).sum();
    let cor: f64 = corrected.iter().map(sse).sum();
    ((raw / total).sqrt(), (cor / total).sqrt())
}
