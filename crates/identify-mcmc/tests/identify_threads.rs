//! `identify` and `identify_session` give bit-identical results with 1 and 2 threads, and a hit
//! cap is reported honestly.

use std::ops::ControlFlow;

use experiment::{synthesize, SynthConfig};
use identify_mcmc::{identify, ChainStopReason, McmcIdentifySettings, NoiseKind, NoiseSpec};
use muscle_model::Problem;

mod common;
use common::synthetic_session::SyntheticSession;

#[test]
fn thread_count_does_not_change_the_result_and_cap_is_reported() {
    let syn = synthesize(&SynthConfig::new("seed".parse().unwrap(), 5)).unwrap();
    let problem = Problem::standard(syn.inputs.clone(), syn.trial.torque_nm.clone()).unwrap();
    let noise = NoiseSpec::from_unloaded(&syn.trial, &syn.unloaded, NoiseKind::Ar1White).unwrap();
    let mut settings = McmcIdentifySettings::fast(3);
    settings.nelder_mead_evaluations = 200;
    settings.mcmc.warmup_min = 200;
    settings.mcmc.block = 100;
    settings.mcmc.max_total = 400;
    let run = |threads: usize| {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        pool.install(|| identify(&problem, &noise, &settings, |_| ControlFlow::Continue(())))
            .unwrap()
    };
    let one = run(1);
    let two = run(2);
    assert_eq!(one.run.draws, two.run.draws);
    assert_eq!(one.run.log_density, two.run.log_density);
    assert_eq!(one.posterior, two.posterior);
    // 400 iterations cannot reach bulk ESS 150 on 9 parameters: the cap is reported.
    assert_eq!(one.stop, ChainStopReason::CapReached);
    assert!(!one.converged);
    let lp = &one.run.log_density[0];
    assert!(lp.iter().all(|v| v.is_finite()));
}

/// A session of two trials (one corrected by its unloaded run, one whose noise is fitted to its
/// residual of the joint fit): the same draws with 1 and 2 threads, and each trial keeps its own
/// noise model.
#[test]
fn a_session_does_not_depend_on_the_thread_count() {
    let session = SyntheticSession::new(&["knee0@30", "knee90@30"], 4);
    let residual = NoiseSpec::from_residual(NoiseKind::Ar1White);
    let trials = [
        identify_mcmc::SessionTrialLikelihood {
            problem: &session.problems[0],
            noise: &session.noises[0],
        },
        identify_mcmc::SessionTrialLikelihood {
            problem: &session.problems[1],
            noise: &residual,
        },
    ];
    let mut settings = McmcIdentifySettings::fast(11);
    settings.nelder_mead_evaluations = 150;
    settings.mcmc.warmup_min = 200;
    settings.mcmc.block = 100;
    settings.mcmc.max_total = 300;
    let run = |threads: usize| {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        pool.install(|| {
            identify_mcmc::identify_session(&trials, &settings, |_| ControlFlow::Continue(()))
        })
        .unwrap()
    };
    let one = run(1);
    let two = run(2);
    assert_eq!(one.run.draws, two.run.draws);
    assert_eq!(one.run.log_density, two.run.log_density);
    assert_eq!(one.trials, two.trials);
    assert_eq!(one.posterior_correlation, two.posterior_correlation);
    assert!(one.trials[0].corrected && !one.trials[1].corrected);
    assert_ne!(one.trials[0].noise, one.trials[1].noise);
    assert_eq!(one.trials[0].noise, {
        let identify_mcmc::McmcNoiseSource::Fixed(n) = session.noises[0].source else {
            panic!("the unloaded run fixes the noise")
        };
        n
    });
}
