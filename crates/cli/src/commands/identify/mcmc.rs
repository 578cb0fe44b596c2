//! `surae identify --method mcmc`: the sampler on one trial, and its figures (traces, R̂,
//! histograms, corner plot).

use super::*;

/// Trace plots, R̂ over iterations, marginal histograms and the corner plot.
pub(super) fn mcmc_figures(
    set: &mut FigureSet<'_>,
    prep: &Prepared,
    m: &identify_mcmc::McmcIdentification,
) -> CmdResult {
    let labels: Vec<String> = m.names.iter().map(|n| report::param_label(n)).collect();
    let names: Vec<&str> = labels.iter().map(|s| s.as_str()).collect();
    let draws = &m.run.draws;
    let pooled: Vec<Vec<f64>> = draws
        .iter()
        .map(|per| per.iter().flatten().copied().collect())
        .collect();
    let none = muscle_model::Effects::none();
    let truth: Option<Vec<f64>> = prep.truth.as_ref().map(|t| {
        prep.problem
            .free()
            .iter()
            .map(|id| id.get(t, &none))
            .collect()
    });
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
        .map_err(|e| Failure::internal(e.to_string()))?;
    let corr: Vec<Vec<String>> = m
        .correlations
        .iter()
        .take(6)
        .map(|c| vec![c.a.clone(), c.b.clone(), format!("{:+.2}", c.r)])
        .collect();
    set.page()
        .table("Strongest posterior correlations", &["a", "b", "r"], &corr)
        .map_err(|e| Failure::internal(e.to_string()))?;
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

pub(super) fn run_mcmc(
    prep: &Prepared,
    seed: u64,
    max_iterations: Option<usize>,
    show: bool,
) -> CmdResult<Outcome> {
    use identify_mcmc::{McmcIdentifySettings, NoiseKind, NoiseSpec};
    // The sampler corrects the raw torque itself (NoiseSpec carries the
    // systematic part), so it gets the problem on the torque as measured.
    let problem = Problem::new(
        prep.problem.inputs().clone(),
        prep.measured_raw.clone(),
        *prep.problem.base_params(),
        *prep.problem.base_effects(),
        ParamId::identified().to_vec(),
    )
    .map_err(|e| Failure::internal(e.to_string()))?;
    let noise = match &prep.correction {
        Some(c) => NoiseSpec::from_correction(&prep.loaded.trial, c, NoiseKind::Ar1White)
            .map_err(|e| Failure::bad(format!("{}: {e}", prep.loaded.name)))?,
        None => NoiseSpec::from_residual(NoiseKind::Ar1White),
    };
    let mut settings = McmcIdentifySettings::default();
    settings.mcmc.seed = seed;
    if let Some(n) = max_iterations {
        settings.mcmc.max_total = n;
        settings
            .mcmc
            .validate()
            .map_err(|e| Failure::bad(format!("--max-iterations {n}: {e}")))?;
    }
    let cap = settings.mcmc.max_total as u64;
    let progress = ProgressDisplay::new(show, cap, "MCMC");
    let m = identify_mcmc::identify(
        &problem,
        &noise,
        &settings,
        |p: &identify_mcmc::ChainProgress| {
            progress.chain(0, p.iterations as u64, f64::NAN);
            progress.message(format!(
                "{:?}: max R̂ {:.4}, min ESS {:.0}, acceptance {:.2}",
                p.phase, p.max_rhat, p.min_ess_bulk, p.acceptance_rate
            ));
            progress.flow()
        },
    )
    .map_err(|e| Failure::bad(format!("{}: identification failed: {e}", prep.loaded.name)))?;
    progress.finish();
    if progress.stop_requested() {
        return Err(Failure::Interrupted);
    }
    let mean = m.mean();
    // prediction on the corrected scale, like the SA figures
    let prediction = prep
        .problem
        .predict(&mean)
        .map_err(|e| Failure::internal(format!("simulation of the posterior mean failed: {e}")))?;
    let params: Map<String, Value> = m
        .posterior
        .iter()
        .map(|p| (p.name.clone(), json!(p.mean)))
        .collect();
    let posterior: Map<String, Value> = m
        .posterior
        .iter()
        .map(|p| {
            (
                p.name.clone(),
                json!({
                    "mean": p.mean, "sd": p.sd, "q05": p.q05, "q95": p.q95,
                    "rhat": p.rhat, "ess_bulk": p.ess_bulk, "ess_tail": p.ess_tail,
                    "identifiable": p.identifiable, "prior_sd_ratio": p.prior_sd_ratio,
                }),
            )
        })
        .collect();
    let (max_rhat, min_ess) = m.worst_diagnostics();
    let doc = json!({
        "method": Method::Mcmc.name(),
        "params": params,
        "rms_nm": m.rms_corrected_nm,
        "rms_raw_nm": m.rms_nm,
        "evaluations": m.evaluations,
        "wall_s": m.wall_s,
        "posterior": posterior,
        "converged": m.converged,
        "stop": format!("{:?}", m.stop),
        "chains": m.run.draws.first().map_or(0, |c| c.len()),
        "warmup_iterations": m.warmup_iterations,
        "sampling_iterations": m.sampling_iterations,
        "acceptance_rate": m.acceptance_rate,
        "modes": m.modes.len(),
        "jump_acceptance_rate": m.jump_acceptance_rate,
        "correlations": m.correlations.iter().take(10).map(|c| json!({"a": c.a, "b": c.b, "r": c.r})).collect::<Vec<_>>(),
        "noise_model": m.noise,
    });
    let mut lines = vec![format!(
        "identify (mcmc): {} — {} evaluations in {:.1} s; {}",
        prep.loaded.name,
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
    lines.push(format!(
        "  torque RMS at the posterior mean {:.2} N·m after removing the dynamometer's cycle-locked error ({:.2} N·m against the raw torque)",
        m.rms_corrected_nm, m.rms_nm
    ));
    lines.push(format!(
        "  {} posterior mode(s) from the multi-start search; random-walk acceptance {:.2}, mode-jump acceptance {:.2}",
        m.modes.len(),
        m.acceptance_rate,
        m.jump_acceptance_rate
    ));
    lines.push(
        "  parameter          mean        sd        90 % interval             R̂      ESS  identifiable"
            .into(),
    );
    for p in &m.posterior {
        lines.push(format!(
            "  {:<16} {:>10.5} {:>9.5}  [{:>10.5}, {:>10.5}]  {:.4} {:>6.0}  {}",
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
    if let Some(c) = m.correlations.first() {
        lines.push(format!(
            "  strongest correlation: {} ~ {} (r = {:+.2})",
            c.a, c.b, c.r
        ));
    }
    Ok(Outcome {
        doc,
        lines,
        prediction,
        mcmc: Some(m),
    })
}
