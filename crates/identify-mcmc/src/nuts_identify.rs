//! The Bayesian identification of a session's shared parameters with the gradient-based sampler
//! ([`identify_session_nuts`]): the same trials, corrections, noise models and report as the
//! random walk of module `session_identify`, sampled by NUTS on the full posterior of module
//! `full_posterior` with its exact gradient.
//!
//! The random walk samples `F0` on its exact conditional and the other parameters in
//! coordinates whitened by a Laplace factor found by a multi-start search; NUTS needs neither:
//! it samples every free parameter through the logistic transform of its bound, adapts a
//! metric in warm-up (Stan's windows), and moves along the gradient.
//!
//! The chains start around the least-squares optimum of the session (a bounded
//! Levenberg–Marquardt on the exact Jacobian from the base point): chain `c` at `u* + 0.5·z`,
//! `z ~ N(0, I)` from the seed's stream 0, in the unconstrained coordinates `u`. From Stan's
//! default, `u ~ U(−2, 2)`, far from the narrow posterior of a whole trial, the first warm-up
//! iterations built trees of hundreds of leapfrog steps.

use std::time::Instant;

use crate::full_posterior::{sampled_bounds, FullPosterior};
use crate::identify::{
    McmcIdentification, McmcIdentifySettings, NutsStats, SessionTrialLikelihood,
};
use crate::session_identify::{
    check_shared, corrected_problem, named_correlations, noise_models, pooled_rms, posteriors,
    trial_fits, trial_models,
};
use crate::summary::strongest_correlations;
use crate::{run_nuts, ChainStopReason, McmcError, NutsSettings, RunResult};
use muscle_model::{Problem, ProblemSet, ProblemSetWorkspace};
use numerics::{levenberg_marquardt, LevenbergMarquardtSettings, Residuals};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, StandardNormal};

/// Sample the posterior of the shared free parameters of a session's trials with NUTS
/// (module documentation). `settings` gives the convergence targets (`mcmc.rhat_target`,
/// `mcmc.ess_target`), the correlations to report and the noise fit's evaluations; `nuts`
/// the sampler's own settings (seed, chains, warm-up, draws).
///
/// `converged` says whether every parameter reached R̂ < target and bulk ESS ≥ target with
/// the draws asked for (the run does not extend itself).
///
/// # Errors
/// As [`crate::identify_session`]; and [`McmcError::NoExactGradient`] when the model has no
/// exact derivative for a free parameter (activation, delay, fatigue) or formulation.
pub fn identify_session_nuts(
    trials: &[SessionTrialLikelihood<'_>],
    settings: &McmcIdentifySettings,
    nuts: &NutsSettings,
) -> Result<McmcIdentification, McmcError> {
    let started = Instant::now();
    check_shared(trials)?;
    settings.mcmc.validate()?;
    nuts.validate()?;
    let corrected: Vec<Problem> = trials
        .iter()
        .map(corrected_problem)
        .collect::<Result<_, _>>()?;
    for p in &corrected {
        p.exact_jacobian_available()
            .map_err(|e| McmcError::NoExactGradient {
                reason: e.to_string(),
            })?;
    }
    let first = &corrected[0];
    let bounds = sampled_bounds(first);
    let (noise_params, mut evaluations, mut failed) = noise_models(trials, &corrected, settings)?;
    let models = trial_models(trials, &corrected, &noise_params)?;
    let target = FullPosterior::new(&models);
    let (starts, fit_evaluations) = starts_near_the_optimum(&corrected, nuts);
    evaluations += fit_evaluations;
    let out = run_nuts(&target, nuts, Some(&starts))?;
    evaluations += out.gradient_evaluations;
    failed += out.failed_evaluations;

    let targets_met = out.max_rhat() < settings.mcmc.rhat_target
        && out.min_ess_bulk() >= settings.mcmc.ess_target;
    // the random walk's report, filled from the NUTS run
    let chain_accept: Vec<f64> = out
        .stats
        .iter()
        .map(|c| c.iter().map(|d| d.accept_stat).sum::<f64>() / c.len().max(1) as f64)
        .collect();
    let run = RunResult {
        settings: settings.mcmc,
        dim: out.dim,
        draws: out.draws.clone(),
        log_density: out.log_density.clone(),
        warmup_iterations: nuts.warmup,
        sampling_iterations: nuts.draws,
        warmup_converged: true,
        stop: if targets_met {
            ChainStopReason::Converged
        } else {
            ChainStopReason::CapReached
        },
        converged: targets_met,
        acceptance_rate: chain_accept.clone(),
        warmup_acceptance_rate: out.adaptation_accept_stat.clone(),
        jump_acceptance_rate: vec![f64::NAN; nuts.chains],
        evaluations: out.gradient_evaluations,
        failed_evaluations: out.failed_evaluations,
        out_of_bounds: 0,
        zero_density: 0,
        max_abs_coordinate: f64::NAN,
        summary: out.summary.clone(),
        correlation: out.correlation.clone(),
        strongest_correlations: strongest_correlations(&out.correlation),
    };
    let names = first.names().to_vec();
    let posterior = posteriors(&run, &names);
    let correlations = named_correlations(&run, &names, settings.correlations);
    let mean: Vec<f64> = posterior.iter().map(|p| p.mean).collect();
    let fits = trial_fits(trials, &corrected, &noise_params, &mean);
    evaluations += 2 * trials.len() as u64;
    let (rms_nm, rms_corrected_nm) = pooled_rms(trials, &corrected, &mean, &fits);
    let optimum = out
        .log_density
        .iter()
        .enumerate()
        .flat_map(|(c, lp)| lp.iter().enumerate().map(move |(i, v)| (c, i, *v)))
        .fold((0, 0, f64::NEG_INFINITY), |best, cur| {
            if cur.2 > best.2 {
                cur
            } else {
                best
            }
        });
    let optimum: Vec<f64> = (0..out.dim)
        .map(|k| out.draws[k][optimum.0][optimum.1])
        .collect();
    let stats = NutsStats {
        settings: *nuts,
        step_size: out.step_size.clone(),
        inv_metric: out.inv_metric.clone(),
        gradient_evaluations: out.gradient_evaluations,
        mean_leapfrog: out.mean_leapfrog(),
        mean_accept_stat: out.mean_accept_stat(),
        divergences: out.divergences,
        warmup_divergences: out.warmup_divergences,
        max_depth_hits: out.max_depth_hits,
        draws: out.stats,
    };
    Ok(McmcIdentification {
        names,
        bounds,
        posterior,
        correlations,
        posterior_correlation: run.correlation.clone(),
        converged: targets_met,
        max_abs_z: f64::NAN,
        z_half_width: f64::NAN,
        stop: run.stop,
        warmup_iterations: nuts.warmup,
        sampling_iterations: nuts.draws,
        acceptance_rate: stats.mean_accept_stat,
        evaluations,
        failed_evaluations: failed,
        optimum,
        modes: Vec::new(),
        jump_acceptance_rate: f64::NAN,
        rms_nm,
        rms_corrected_nm,
        noise: noise_params[0],
        corrected: trials[0].noise.systematic.is_some(),
        trials: fits,
        wall_s: started.elapsed().as_secs_f64(),
        nuts: Some(stats),
        run,
    })
}

/// `measured − predicted` of every trial of a set, with the model's exact Jacobian.
struct SetResiduals<'a>(&'a ProblemSet);

impl Residuals for SetResiduals<'_> {
    type Workspace = ProblemSetWorkspace;
    fn workspace(&self) -> ProblemSetWorkspace {
        ProblemSetWorkspace::new(self.0)
    }
    fn residuals(&self, x: &[f64], ws: &mut ProblemSetWorkspace, out: &mut Vec<f64>) -> bool {
        out.resize(self.0.samples(), 0.0);
        self.0.residuals_with(x, ws, out).is_ok()
    }
    fn jacobian(&self, x: &[f64], ws: &mut ProblemSetWorkspace, jac: &mut [f64]) -> Option<bool> {
        let mut full = Vec::new();
        if self.0.jacobian_with(x, ws, &mut full).is_err() || full.len() != jac.len() {
            return Some(false);
        }
        for (j, f) in jac.iter_mut().zip(&full) {
            *j = -f;
        }
        Some(true)
    }
}

/// One start per chain around the least-squares optimum (module documentation), strictly
/// inside the bounds, and the evaluations of the fit.
fn starts_near_the_optimum(corrected: &[Problem], nuts: &NutsSettings) -> (Vec<Vec<f64>>, u64) {
    let first = &corrected[0];
    let bounds = sampled_bounds(first);
    let base: Vec<f64> = first
        .base_vector()
        .iter()
        .zip(&bounds)
        .map(|(v, (lo, hi))| v.clamp(*lo, *hi))
        .collect();
    let (optimum, evaluations) = match ProblemSet::new(corrected.to_vec()) {
        Ok(set) => {
            match levenberg_marquardt(
                &SetResiduals(&set),
                &base,
                &bounds,
                &LevenbergMarquardtSettings::default(),
                |_| {},
            ) {
                Ok(fit) => (fit.x, fit.evaluations as u64),
                Err(_) => (base, 1),
            }
        }
        Err(_) => (base, 0),
    };
    let transform = crate::LogisticBox::new(&bounds);
    let mut u = vec![0.0; bounds.len()];
    // an optimum at a bound maps to ±∞: pull it just inside
    let inside: Vec<f64> = optimum
        .iter()
        .zip(&bounds)
        .map(|(v, (lo, hi))| v.clamp(lo + 1e-3 * (hi - lo), hi - 1e-3 * (hi - lo)))
        .collect();
    transform.to_unconstrained(&inside, &mut u);
    let mut rng = ChaCha8Rng::seed_from_u64(nuts.seed);
    rng.set_stream(0);
    let starts = (0..nuts.chains)
        .map(|_| {
            let v: Vec<f64> = u
                .iter()
                .map(|ui| {
                    let z: f64 = StandardNormal.sample(&mut rng);
                    ui + 0.5 * z
                })
                .collect();
            let mut x = vec![0.0; v.len()];
            transform.to_box(&v, &mut x);
            x
        })
        .collect();
    (starts, evaluations)
}

#[cfg(test)]
mod curvature_study {
    //! Why a sampler with one fixed metric needs short steps on the bundled trial: the local
    //! curvature of the posterior, measured in the metric of the posterior's own covariance,
    //! in the coordinates NUTS samples and in the random walk's (F0 integrated out).

    use super::*;
    use crate::sampling_coordinates::Conditional;
    use crate::{
        identify_session, GradLogDensity, LogDensity, LogisticBox, NoiseKind, NoiseParams,
        NoiseSpec,
    };
    use muscle_model::SimSettings;
    use nalgebra::DMatrix;

    /// The bundled trial's problem and noise model.
    fn bundled() -> (Problem, NoiseSpec) {
        let root = concat!(env!("CARGO_MANIFEST_DIR"), "/../../fixtures/seed");
        let trial = experiment::read_trial(format!("{root}/trial.csv")).unwrap();
        let unloaded = experiment::read_unloaded(format!("{root}/unloaded.csv")).unwrap();
        let inputs = experiment::model_inputs(&trial, &Default::default()).unwrap();
        let problem = Problem::standard(inputs, trial.torque_nm.clone()).unwrap();
        let noise = NoiseSpec::from_unloaded(&trial, &unloaded, NoiseKind::Ar1White).unwrap();
        (problem, noise)
    }

    /// The random walk's kept draws (seed 42), pooled over the chains, as model vectors.
    fn random_walk_draws(trials: &[SessionTrialLikelihood<'_>]) -> Vec<Vec<f64>> {
        let settings = McmcIdentifySettings::default();
        let rw =
            identify_session(trials, &settings, |_| std::ops::ControlFlow::Continue(())).unwrap();
        assert!(rw.converged);
        let draws = &rw.run.draws;
        let d = draws.len();
        (0..draws[0].len())
            .flat_map(|c| (0..draws[0][c].len()).map(move |i| (c, i)))
            .map(|(c, i)| (0..d).map(|k| draws[k][c][i]).collect())
            .collect()
    }

    /// The trials' problems corrected by their dynamometer error (simulated with `sim`, or
    /// their own settings) and their noise models, as the samplers build them.
    fn corrected_with_noise(
        trials: &[SessionTrialLikelihood<'_>],
        sim: Option<SimSettings>,
    ) -> (Vec<Problem>, Vec<NoiseParams>) {
        let corrected: Vec<Problem> = trials
            .iter()
            .map(|t| {
                let p = corrected_problem(t).unwrap();
                match sim {
                    Some(s) => p.with_settings(s),
                    None => p,
                }
            })
            .collect();
        let (noise_params, _, _) =
            noise_models(trials, &corrected, &McmcIdentifySettings::default()).unwrap();
        (corrected, noise_params)
    }

    /// The lower Cholesky factor of the sample covariance of `points`.
    fn covariance_factor(points: &[Vec<f64>]) -> DMatrix<f64> {
        let d = points[0].len();
        let n = points.len() as f64;
        let mean: Vec<f64> = (0..d)
            .map(|k| points.iter().map(|u| u[k]).sum::<f64>() / n)
            .collect();
        let cov = DMatrix::from_fn(d, d, |a, b| {
            points
                .iter()
                .map(|u| (u[a] - mean[a]) * (u[b] - mean[b]))
                .sum::<f64>()
                / (n - 1.0)
        });
        cov.cholesky().unwrap().l()
    }

    /// Largest and smallest eigenvalue of `−∇² log p` (symmetrised) in the metric `L Lᵀ`.
    fn extreme_curvatures(hess: &DMatrix<f64>, l: &DMatrix<f64>) -> (f64, f64) {
        let sym = (hess + hess.transpose()) * 0.5;
        let eig = (l.transpose() * sym * l).symmetric_eigenvalues();
        (eig.max(), eig.min())
    }

    /// `(smallest, median, largest)` of `v`.
    fn spread(mut v: Vec<f64>) -> (f64, f64, f64) {
        v.sort_by(f64::total_cmp);
        (v[0], v[v.len() / 2], v[v.len() - 1])
    }

    #[test]
    #[ignore = "a study: about 15 s; run by .ci/statistical"]
    fn the_bundled_posterior_is_a_thin_curved_ridge() {
        let (problem, noise) = bundled();
        let trials = [SessionTrialLikelihood {
            problem: &problem,
            noise: &noise,
        }];
        let pooled_x = random_walk_draws(&trials);
        let (corrected, noise_params) = corrected_with_noise(&trials, None);
        let models = trial_models(&trials, &corrected, &noise_params).unwrap();
        let target = FullPosterior::new(&models);
        let bounds = sampled_bounds(&corrected[0]);
        let box_map = LogisticBox::new(&bounds);
        let d = bounds.len();
        // the kept draws on the unconstrained coordinates
        let pooled: Vec<Vec<f64>> = pooled_x
            .iter()
            .map(|x| {
                let mut u = vec![0.0; d];
                box_map.to_unconstrained(x, &mut u);
                u
            })
            .collect();
        let l = covariance_factor(&pooled);
        // ∇ log p(u), the density on u with the transform's Jacobian
        let grad_u = |u: &[f64]| {
            let mut x = vec![0.0; d];
            box_map.to_box(u, &mut x);
            let mut g = vec![0.0; d];
            target.log_density_grad(&x, &mut g).unwrap();
            box_map.chain_rule(u, &mut g);
            g
        };
        let (mut largest, mut smallest) = (Vec::new(), Vec::new());
        let every = pooled.len() / 40;
        for u in pooled.iter().step_by(every).take(40) {
            // −∇² log p by central differences of the exact gradient (h = 0.01 on u: below
            // 10⁻³ the integrator's jitter in the gradient dominates)
            let h = 1e-2;
            let mut hess = DMatrix::zeros(d, d);
            for k in 0..d {
                let mut a = u.clone();
                a[k] += h;
                let ga = grad_u(&a);
                a[k] -= 2.0 * h;
                let gb = grad_u(&a);
                for j in 0..d {
                    hess[(j, k)] = -(ga[j] - gb[j]) / (2.0 * h);
                }
            }
            let (big, small) = extreme_curvatures(&hess, &l);
            largest.push(big);
            smallest.push(small);
        }
        let (lo_max, med_max, hi_max) = spread(largest);
        let (_, med_min, _) = spread(smallest);
        println!(
            "curvature in the metric of the posterior covariance, 40 draws: largest eigenvalue \
             {lo_max:.1}–{hi_max:.1} (median {med_max:.1}), smallest: median {med_min:.2} \
             (a Gaussian posterior: every eigenvalue 1)"
        );
        // A Gaussian gives 1 everywhere. Curvatures far above 1 mean a ridge thinner than the
        // posterior's spread: leapfrog steps in that metric are stable only below about
        // 2/√λ, so a fixed-metric sampler must take many steps to cross the posterior.
        assert!(med_max > 10.0, "median largest curvature {med_max}");
    }

    /// The same measure in the random walk's coordinates: F0 integrated out (its exact
    /// Gaussian conditional), the other parameters on the logit scale whitened by the Laplace
    /// factor at the posterior mean. A sampler on the collapsed posterior of θ alone (NUTS in
    /// these coordinates, F0 drawn from its conditional after each draw) would see this
    /// curvature.
    #[test]
    #[ignore = "a study: about 40 s; run by .ci/statistical"]
    fn integrating_f0_out_leaves_a_ridge() {
        let (problem, noise) = bundled();
        let trials = [SessionTrialLikelihood {
            problem: &problem,
            noise: &noise,
        }];
        let pooled = random_walk_draws(&trials);
        // the log density itself is differenced twice: at rtol 10⁻¹⁰ its jitter is far below
        // what a step of 0.05 moves it by
        let tight = SimSettings {
            rtol: 1e-10,
            atol: 1e-12,
            ..SimSettings::default()
        };
        let (corrected, noise_params) = corrected_with_noise(&trials, Some(tight));
        let models = trial_models(&trials, &corrected, &noise_params).unwrap();
        let d = pooled[0].len();
        let n = pooled.len() as f64;
        let mean: Vec<f64> = (0..d)
            .map(|k| pooled.iter().map(|x| x[k]).sum::<f64>() / n)
            .collect();
        let (laplace, _) = Conditional::new(&models, &mean, 20.0);
        let target = Conditional::with_chol_logit(&models, &mean, laplace.chol_nl(), 20.0);
        let nl = target.nl().to_vec();
        let m = nl.len();
        let zs: Vec<Vec<f64>> = pooled.iter().map(|x| target.z_of(x)).collect();
        let l = covariance_factor(&zs);
        let spread_of_z: Vec<String> = nl
            .iter()
            .enumerate()
            .map(|(a, &i)| format!("{} {:.2}", problem.names()[i], l.row(a).norm()))
            .collect();
        // log π(z, u = 0): the F0 coordinates u enter only through the box's truncation
        let f = |z: &[f64]| {
            let mut v = vec![0.0; d];
            for (a, &i) in nl.iter().enumerate() {
                v[i] = z[a];
            }
            target.log_density(&v).unwrap()
        };
        let h = 0.05;
        let (mut largest, mut smallest) = (Vec::new(), Vec::new());
        let every = zs.len() / 30;
        for z in zs.iter().step_by(every).take(30) {
            let f0 = f(z);
            let at = |moves: &[(usize, f64)]| {
                let mut q = z.clone();
                for &(k, s) in moves {
                    q[k] += s * h;
                }
                f(&q)
            };
            let mut hess = DMatrix::zeros(m, m);
            for a in 0..m {
                hess[(a, a)] = -(at(&[(a, 1.0)]) - 2.0 * f0 + at(&[(a, -1.0)])) / (h * h);
                for b in a + 1..m {
                    let v = -(at(&[(a, 1.0), (b, 1.0)])
                        - at(&[(a, 1.0), (b, -1.0)])
                        - at(&[(a, -1.0), (b, 1.0)])
                        + at(&[(a, -1.0), (b, -1.0)]))
                        / (4.0 * h * h);
                    hess[(a, b)] = v;
                    hess[(b, a)] = v;
                }
            }
            let (big, small) = extreme_curvatures(&hess, &l);
            largest.push(big);
            smallest.push(small);
        }
        let (lo_max, med_max, hi_max) = spread(largest);
        let (lo_min, med_min, _) = spread(smallest);
        println!(
            "collapsed posterior of θ = (LST, α0) in the random walk's whitened coordinates, \
             30 draws: posterior sd of z {spread_of_z:?} (1 if the Laplace factor were the \
             posterior's); curvature in the metric of the draws' covariance: largest eigenvalue \
             {lo_max:.1}–{hi_max:.1} (median {med_max:.1}), smallest {lo_min:.2} (median \
             {med_min:.2})"
        );
        // Integrating F0 out removes the F0 part of the ridge but not the ridge: the
        // gastrocnemii's LST and α0 still trade against each other more tightly than the
        // posterior's spread, and in some draws the log density is convex in a direction.
        assert!(med_max > 3.0, "median largest curvature {med_max}");
        assert!(lo_min < 0.0, "smallest curvature {lo_min}");
    }
}
