//! `surae identify --method mcmc`: the sampler on one trial, and its figures (traces, R̂,
//! histograms, corner plot).

use super::*;

/// Trace plots, R̂ over iterations, marginal histograms and the corner plot.
pub(super) fn mcmc_figures(
    set: &mut FigureSet<'_>,
    prep: &Prepared,
    m: &identify_mcmc::McmcIdentification,
) -> AppResult {
    let truth = prep
        .truth
        .as_ref()
        .map(|t| super::extended::truth_values(prep.problem.free(), t));
    posterior_figures(set, truth, m)
}

/// The posterior's tables and figures, with the true values of the free parameters when known.
pub(super) fn posterior_figures(
    set: &mut FigureSet<'_>,
    truth: Option<Vec<f64>>,
    m: &identify_mcmc::McmcIdentification,
) -> AppResult {
    let labels: Vec<String> = m.names.iter().map(|n| report::param_label(n)).collect();
    let names: Vec<&str> = labels.iter().map(|s| s.as_str()).collect();
    let draws = &m.run.draws;
    let pooled: Vec<Vec<f64>> = draws
        .iter()
        .map(|per| per.iter().flatten().copied().collect())
        .collect();
    let mut rows = Vec::new();
    for p in &m.posterior {
        let mut row = vec![
            report::param_label(&p.name),
            report::format_sig(p.mean, 5),
            report::format_sig(p.sd, 3),
            format!(
                "[{}, {}]",
                report::format_sig(p.q05, 5),
                report::format_sig(p.q95, 5)
            ),
            format!("{:.4}", p.rhat),
            format!("{:.0}", p.ess_bulk),
            format!("{:.0}", p.ess_tail),
            format!("{:.2}", p.prior_sd_ratio),
            if p.identifiable { "yes" } else { "no" }.into(),
        ];
        if let Some(t) = &truth {
            let i = m.names.iter().position(|n| *n == p.name).unwrap_or(0);
            row.push(if p.covers(t[i]) { "inside" } else { "outside" }.into());
        }
        rows.push(row);
    }
    let mut headers = vec![
        "parameter",
        "mean",
        "sd",
        "90 % interval",
        "R̂",
        "bulk ESS",
        "tail ESS",
        "sd / prior sd",
        "identifiable",
    ];
    if truth.is_some() {
        headers.push("truth");
    }
    set.page()
        .table("Posterior", &headers, &rows)
        .map_err(|e| AppError::internal(e.to_string()))?;
    let corr: Vec<Vec<String>> = m
        .correlations
        .iter()
        .take(6)
        .map(|c| vec![c.a.clone(), c.b.clone(), format!("{:+.2}", c.r)])
        .collect();
    set.page()
        .table("Strongest posterior correlations", &["a", "b", "r"], &corr)
        .map_err(|e| AppError::internal(e.to_string()))?;
    set.add(
        "traces",
        "Trace plots of the kept draws, one colour per chain (dissertation Figs. 16–17)",
        report::figures::traces(&names, draws, 0),
    )?;
    // R̂ over the kept draws, on growing prefixes (dissertation Fig. 15)
    let n_draws = draws.first().and_then(|c| c.first()).map_or(0, |d| d.len());
    if n_draws >= 40 {
        let checkpoints: Vec<usize> = (1..=20).map(|k| (n_draws * k / 20).max(8)).collect();
        let rhat: Vec<Vec<f64>> = draws
            .iter()
            .map(|per| {
                checkpoints
                    .iter()
                    .map(|&k| {
                        let chains: Vec<&[f64]> = per.iter().map(|c| &c[..k]).collect();
                        identify_mcmc::diagnostics::rhat(&chains)
                    })
                    .collect()
            })
            .collect();
        let its: Vec<f64> = checkpoints.iter().map(|&k| k as f64).collect();
        set.add(
            "rhat",
            "Rank-normalised split R̂ over the kept draws (dissertation Fig. 15)",
            report::figures::rhat_history(&names, &its, &rhat),
        )?;
    }
    set.add(
        "histograms",
        "Marginal posteriors with the 90 % interval (truth marked when known)",
        report::figures::histograms(&names, &pooled, truth.as_deref()),
    )?;
    set.add(
        "corner",
        "Pairwise posterior draws and correlations",
        report::figures::corner(&names, &pooled, truth.as_deref()),
    )?;
    Ok(())
}

/// The sampler's settings for `--seed` and `--max-iterations`.
pub(super) fn mcmc_settings(
    seed: u64,
    max_iterations: Option<usize>,
) -> AppResult<identify_mcmc::McmcIdentifySettings> {
    let mut settings = identify_mcmc::McmcIdentifySettings::default();
    settings.mcmc.seed = seed;
    if let Some(n) = max_iterations {
        settings.mcmc.max_total = n;
        settings
            .mcmc
            .validate()
            .map_err(|e| AppError::bad(format!("--max-iterations {n}: {e}")))?;
    }
    Ok(settings)
}

/// NUTS's settings for `--seed` and `--max-iterations` (warm-up plus draws per chain, split
/// in half; default 1000 + 1000, Stan's), with a dense metric.
pub(super) fn nuts_settings(
    seed: u64,
    max_iterations: Option<usize>,
) -> AppResult<identify_mcmc::NutsSettings> {
    // a dense metric: the muscles' F0 and α0 are correlated in the posterior, which a
    // diagonal metric leaves for the trajectories to wind along
    let mut settings = identify_mcmc::NutsSettings {
        seed,
        dense_metric: true,
        ..identify_mcmc::NutsSettings::default()
    };
    if let Some(n) = max_iterations {
        settings.warmup = n / 2;
        settings.draws = n - n / 2;
        settings
            .validate()
            .map_err(|e| AppError::bad(format!("--max-iterations {n}: {e}")))?;
    }
    Ok(settings)
}

/// Runs `method`'s sampler on `trials` (the random walk with a progress display; NUTS runs
/// its fixed number of iterations).
pub(super) fn sample_with(
    method: Method,
    trials: &[identify_mcmc::SessionTrialLikelihood<'_>],
    seed: u64,
    max_iterations: Option<usize>,
    what: &str,
    rep: &Reporter,
) -> AppResult<identify_mcmc::McmcIdentification> {
    if method == Method::Nuts {
        let settings = identify_mcmc::McmcIdentifySettings::default();
        let nuts = nuts_settings(seed, max_iterations)?;
        rep.say(&format!(
            "NUTS: {} chains × ({} warm-up + {} draws) …",
            nuts.chains, nuts.warmup, nuts.draws
        ));
        return identify_mcmc::identify_session_nuts(trials, &settings, &nuts)
            .map_err(|e| AppError::bad(format!("{what}: identification failed: {e}")));
    }
    let settings = mcmc_settings(seed, max_iterations)?;
    sample(trials, &settings, what, rep)
}

/// Runs the sampler on `trials` with a progress display.
pub(super) fn sample(
    trials: &[identify_mcmc::SessionTrialLikelihood<'_>],
    settings: &identify_mcmc::McmcIdentifySettings,
    what: &str,
    rep: &Reporter,
) -> AppResult<identify_mcmc::McmcIdentification> {
    let cap = settings.mcmc.max_total as u64;
    let progress = rep.progress(cap, "MCMC");
    let m =
        identify_mcmc::identify_session(trials, settings, |p: &identify_mcmc::ChainProgress| {
            progress.chain(0, p.iterations as u64, f64::NAN);
            progress.message(format!(
                "{:?}: max R̂ {:.4}, min ESS {:.0}, acceptance {:.2}",
                p.phase, p.max_rhat, p.min_ess_bulk, p.acceptance_rate
            ));
            progress.flow()
        })
        .map_err(|e| AppError::bad(format!("{what}: identification failed: {e}")))?;
    progress.finish();
    if progress.stop_requested() {
        return Err(AppError::Interrupted);
    }
    Ok(m)
}

/// One entry of `trials` in `identify.json`: the trial's fit at the posterior mean where it is
/// judged (`rms_nm`, `r2`), against its torque as measured, and its noise model.
pub(super) fn trial_entry(
    name: &str,
    fit: &identify_mcmc::McmcTrialFit,
    (rms, r2): (f64, f64),
) -> McmcTrialReport {
    McmcTrialReport {
        name: name.to_string(),
        rms_nm: rms,
        r2,
        rms_raw_nm: fit.rms_nm,
        noise_model: fit.noise,
    }
}

/// The parameters' posterior means by name: an MCMC identification's estimate.
pub(super) fn posterior_means(m: &identify_mcmc::McmcIdentification) -> BTreeMap<String, f64> {
    m.posterior
        .iter()
        .map(|p| (p.name.clone(), p.mean))
        .collect()
}

/// What MCMC adds to `identify.json`.
pub(super) fn mcmc_report(
    m: &identify_mcmc::McmcIdentification,
    trials: Vec<McmcTrialReport>,
) -> McmcReport {
    let posterior = m
        .posterior
        .iter()
        .map(|p| {
            (
                p.name.clone(),
                PosteriorReport {
                    mean: p.mean,
                    sd: p.sd,
                    q05: p.q05,
                    q95: p.q95,
                    rhat: p.rhat,
                    ess_bulk: p.ess_bulk,
                    ess_tail: p.ess_tail,
                    identifiable: p.identifiable,
                    prior_sd_ratio: p.prior_sd_ratio,
                },
            )
        })
        .collect();
    McmcReport {
        posterior,
        converged: m.converged,
        stop: format!("{:?}", m.stop),
        chains: m.run.draws.first().map_or(0, |c| c.len()),
        warmup_iterations: m.warmup_iterations,
        sampling_iterations: m.sampling_iterations,
        acceptance_rate: m.acceptance_rate,
        modes: m.modes.len(),
        jump_acceptance_rate: m.jump_acceptance_rate,
        correlations: m
            .correlations
            .iter()
            .take(10)
            .map(|c| CorrelationReport {
                a: c.a.clone(),
                b: c.b.clone(),
                r: c.r,
            })
            .collect(),
        posterior_correlation: CorrelationMatrixReport {
            names: m.names.clone(),
            matrix: m.posterior_correlation.clone(),
        },
        noise_model: m.noise,
        trials,
        nuts: m.nuts.as_ref().map(|n| {
            let (_, min_ess) = m.worst_diagnostics();
            NutsReport {
                step_size: n.step_size.clone(),
                dense_metric: n.settings.dense_metric,
                mean_leapfrog: n.mean_leapfrog,
                mean_accept_stat: n.mean_accept_stat,
                divergences: n.divergences,
                warmup_divergences: n.warmup_divergences,
                max_depth_hits: n.max_depth_hits,
                gradient_evaluations: n.gradient_evaluations,
                gradients_per_effective_draw: n.gradient_evaluations as f64 / min_ess,
            }
        }),
    }
}

/// The summary printed after sampling: convergence, fit, the posterior table and which
/// parameters the data identify.
pub(super) fn summary_lines(
    what: &str,
    m: &identify_mcmc::McmcIdentification,
    trials: &[McmcTrialReport],
    corrected: bool,
) -> Vec<String> {
    let (max_rhat, min_ess) = m.worst_diagnostics();
    let mut lines = vec![format!(
        "identify ({}): {what} — {} evaluations in {:.1} s; {}",
        if m.nuts.is_some() { "nuts" } else { "mcmc" },
        m.evaluations,
        m.wall_s,
        if m.converged {
            format!("converged (max R̂ {max_rhat:.4}, min bulk ESS {min_ess:.0})")
        } else {
            format!(
                "NOT converged: stopped ({:?}) with max R̂ {max_rhat:.4}, min bulk ESS {min_ess:.0}",
                m.stop
            )
        }
    )];
    // the correction is named only when a dynamometer's unloaded run gave one
    lines.push(if corrected {
        format!(
            "  torque RMS at the posterior mean {:.2} N·m after removing the dynamometer's cycle-locked error ({:.2} N·m against the raw torque)",
            m.rms_corrected_nm, m.rms_nm
        )
    } else {
        format!("  torque RMS at the posterior mean {:.2} N·m", m.rms_nm)
    });
    if trials.len() > 1 {
        lines.push("  trial                     RMS (N·m)     R²   raw RMS (N·m)".into());
        for t in trials {
            lines.push(format!(
                "  {:<24} {:>9.2} {:>8.3}   {:>9.2}",
                t.name, t.rms_nm, t.r2, t.rms_raw_nm
            ));
        }
    }
    match &m.nuts {
        Some(n) => {
            let min_ess = m.posterior.iter().fold(f64::INFINITY, |a, p| a.min(p.ess_bulk));
            lines.push(format!(
                "  NUTS: mean step size {:.3}, {:.1} leapfrog steps per draw, accept_stat {:.2}, {} divergent of {} draws ({} in warm-up), {} at the largest tree depth",
                n.step_size.iter().sum::<f64>() / n.step_size.len().max(1) as f64,
                n.mean_leapfrog,
                n.mean_accept_stat,
                n.divergences,
                n.settings.draws * n.settings.chains,
                n.warmup_divergences,
                n.max_depth_hits
            ));
            lines.push(format!(
                "  {} gradient evaluations (simulation + exact Jacobian), {:.1} per effective draw of the slowest parameter",
                n.gradient_evaluations,
                n.gradient_evaluations as f64 / min_ess
            ));
        }
        None => lines.push(format!(
            "  {} posterior mode(s) from the multi-start search; random-walk acceptance {:.2}, mode-jump acceptance {:.2}",
            m.modes.len(),
            m.acceptance_rate,
            m.jump_acceptance_rate
        )),
    }
    let width = m.names.iter().map(|n| n.len()).max().unwrap_or(0).max(16);
    lines.push(format!(
        "  {:<width$} {:>10} {:>9}        90 % interval             R̂      ESS  identifiable",
        "parameter", "mean", "sd"
    ));
    for p in &m.posterior {
        lines.push(format!(
            "  {:<width$} {:>10.5} {:>9.5}  [{:>10.5}, {:>10.5}]  {:.4} {:>6.0}  {}",
            p.name,
            p.mean,
            p.sd,
            p.q05,
            p.q95,
            p.rhat,
            p.ess_bulk,
            if p.identifiable {
                "yes"
            } else {
                "no (sd ≥ half the prior's)"
            }
        ));
    }
    let flagged: Vec<&str> = m
        .posterior
        .iter()
        .filter(|p| p.identifiable)
        .map(|p| p.name.as_str())
        .collect();
    lines.push(format!(
        "  identifiable: {} of {} ({})",
        flagged.len(),
        m.posterior.len(),
        if flagged.is_empty() {
            "none".to_string()
        } else {
            flagged.join(", ")
        }
    ));
    if let Some(c) = m.correlations.first() {
        lines.push(format!(
            "  strongest correlation: {} ~ {} (r = {:+.2})",
            c.a, c.b, c.r
        ));
    }
    lines
}

pub(super) fn run_mcmc(
    prep: &Prepared,
    method: Method,
    seed: u64,
    max_iterations: Option<usize>,
    rep: &Reporter,
) -> AppResult<Outcome> {
    use identify_mcmc::{NoiseKind, NoiseSpec, SessionTrialLikelihood};
    // The sampler corrects the raw torque itself (NoiseSpec carries the
    // systematic part), so it gets the problem on the torque as measured.
    let problem = Problem::new(
        prep.problem.inputs().clone(),
        prep.prepared.raw_torque().to_vec(),
        *prep.problem.base_params(),
        *prep.problem.base_effects(),
        prep.problem.free().to_vec(),
    )
    .map_err(|e| AppError::internal(e.to_string()))?;
    let noise = NoiseSpec::from_prepared(&prep.prepared, NoiseKind::Ar1White)
        .map_err(|e| AppError::bad(format!("{}: {e}", prep.loaded.name)))?;
    let trial = SessionTrialLikelihood {
        problem: &problem,
        noise: &noise,
    };
    let m = sample_with(
        method,
        &[trial],
        seed,
        max_iterations,
        &prep.loaded.name,
        rep,
    )?;
    let mean = m.mean();
    // prediction on the corrected scale, like the SA figures
    let prediction = prep
        .problem
        .predict(&mean)
        .map_err(|e| AppError::internal(format!("simulation of the posterior mean failed: {e}")))?;
    let fit = experiment::moment_fit(prep.problem.measured(), &prediction);
    let trials = vec![trial_entry(&prep.loaded.name, &m.trials[0], fit)];
    let lines = summary_lines(&prep.loaded.name, &m, &trials, prep.dynamometer.is_some());
    let estimate = Estimate {
        method,
        params: posterior_means(&m),
        rms_nm: m.rms_corrected_nm,
        rms_raw_nm: m.rms_nm,
        evaluations: m.evaluations,
        wall_s: m.wall_s,
        sa: None,
        mcmc: Some(mcmc_report(&m, trials)),
    };
    Ok(Outcome {
        estimate,
        lines,
        prediction,
        mcmc: Some(m),
    })
}
