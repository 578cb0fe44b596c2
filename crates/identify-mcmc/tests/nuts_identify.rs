//! The identification with NUTS (`identify_session_nuts`): the same report as the random walk,
//! its sampler statistics and CmdStan chains, independent of the thread count, and its refusal
//! of parameters without an exact gradient.

use experiment::{synthesize, SynthConfig};
use identify_mcmc::{
    identify_session_nuts, write_cmdstan_nuts_chain, McmcError, McmcIdentifySettings, NoiseKind,
    NoiseSpec, NutsSettings, SessionTrialLikelihood,
};
use muscle_model::{ParamId, Problem};

fn short_problem(seed: u64) -> (Problem, NoiseSpec) {
    let syn = synthesize(&SynthConfig::new("seed".parse().unwrap(), seed)).unwrap();
    let fs = 2048;
    let problem = Problem::standard(syn.inputs.clone(), syn.trial.torque_nm.clone())
        .unwrap()
        .window(2 * fs..3 * fs, fs / 4)
        .unwrap();
    let noise = NoiseSpec::from_unloaded(&syn.trial, &syn.unloaded, NoiseKind::Ar1White).unwrap();
    // the correction is the whole trial's; the window's torque is already on its scale
    let noise = NoiseSpec {
        systematic: None,
        ..noise
    };
    (problem, noise)
}

#[test]
fn nuts_reports_like_the_random_walk_and_does_not_depend_on_the_thread_count() {
    let (problem, noise) = short_problem(8);
    let trial = [SessionTrialLikelihood {
        problem: &problem,
        noise: &noise,
    }];
    let settings = McmcIdentifySettings::default();
    let nuts = NutsSettings {
        seed: 4,
        chains: 2,
        warmup: 60,
        draws: 40,
        dense_metric: true,
        ..NutsSettings::default()
    };
    let run = |threads: usize| {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        pool.install(|| identify_session_nuts(&trial, &settings, &nuts))
            .unwrap()
    };
    let (one, two) = (run(1), run(2));
    assert_eq!(one.run.draws, two.run.draws);
    assert_eq!(one.posterior, two.posterior);
    let stats = one.nuts.as_ref().expect("NUTS statistics");
    assert_eq!(stats.draws.len(), 2);
    assert_eq!(stats.draws[0].len(), 40);
    assert!(stats.gradient_evaluations >= 2 * 100);
    // the gradients, the start's least-squares fit and the two simulations of the report
    assert!(one.evaluations > stats.gradient_evaluations + 2);
    assert_eq!(one.names.len(), 9);
    for (p, (lo, hi)) in one.posterior.iter().zip(&one.bounds) {
        assert!(p.mean > *lo && p.mean < *hi && p.sd > 0.0, "{p:?}");
    }
    // the best kept draw is the reported optimum, inside the bounds
    assert!(one
        .optimum
        .iter()
        .zip(&one.bounds)
        .all(|(x, (lo, hi))| x > lo && x < hi));
    assert!(one.rms_nm.is_finite() && one.rms_nm > 0.0);
    // CmdStan's NUTS layout, with the dense metric's rows
    let chains = one.nuts_chains().unwrap();
    let names: Vec<&str> = one.names.iter().map(String::as_str).collect();
    let mut csv = Vec::new();
    write_cmdstan_nuts_chain(chains, &names, 1, &["test"], &mut csv).unwrap();
    let text = String::from_utf8(csv).unwrap();
    assert!(text.contains("metric = dense_e"), "{text}");
    assert!(text.contains("# Elements of inverse mass matrix:"));
    let header = text.lines().find(|l| l.starts_with("lp__")).unwrap();
    assert!(header.starts_with(
        "lp__,accept_stat__,stepsize__,treedepth__,n_leapfrog__,divergent__,energy__,sol_lst_m"
    ));
    let rows = text
        .lines()
        .filter(|l| !l.starts_with('#') && !l.starts_with("lp__"))
        .count();
    assert_eq!(rows, 40);
}

#[test]
fn parameters_without_an_exact_gradient_are_refused_by_name() {
    let (problem, noise) = short_problem(9);
    let mut free = ParamId::identified().to_vec();
    free.push(ParamId::parse("activation.tau_deact_s").unwrap());
    let problem = Problem::new(
        problem.inputs().clone(),
        problem.measured().to_vec(),
        *problem.base_params(),
        *problem.base_effects(),
        free,
    )
    .unwrap();
    let trial = [SessionTrialLikelihood {
        problem: &problem,
        noise: &noise,
    }];
    let err = identify_session_nuts(
        &trial,
        &McmcIdentifySettings::default(),
        &NutsSettings::default(),
    )
    .unwrap_err();
    assert!(matches!(err, McmcError::NoExactGradient { .. }));
    assert!(err.to_string().contains("activation.tau_deact_s"), "{err}");
}
