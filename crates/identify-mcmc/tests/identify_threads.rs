//! `identify` gives bit-identical results with 1 and 2 threads, and reports a hit cap honestly.

use std::ops::ControlFlow;

use experiment::{synthesize, SynthConfig};
use identify_mcmc::{identify, ChainStopReason, McmcIdentifySettings, NoiseKind, NoiseSpec};
use muscle_model::Problem;

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
