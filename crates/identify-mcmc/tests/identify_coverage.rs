//! Calibration of the 90 % intervals over simulated trials with random true parameters.
//!
//! 10 seed-protocol trials (seeds 101…110, truth uniform in the bounds, SPEC noise, noise
//! model from each trial's unloaded run), [`IdentifySettings::fast`]: 90 intervals. The rate
//! must lie within the 99 % binomial margin of 0.90 for 90 intervals, `2.576·√(0.09/90) =
//! ±0.081` (intervals of one trial are not independent, so this margin is if anything
//! narrow). The 30-trial run is the `coverage` example (docs/results.md).

use std::ops::ControlFlow;

use experiment::{random_params, synthesize, SynthConfig};
use identify_mcmc::{identify, IdentifySettings, NoiseKind, NoiseSpec};
use muscle_model::{Effects, ModelParams, ParamId, Problem};
use rand::SeedableRng;

#[test]
fn ninety_percent_intervals_cover_the_truth_ninety_percent_of_the_time() {
    let n = 10u64;
    let mut hits = 0usize;
    for seed in 101..101 + n {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
        let truth = random_params(&mut rng, &ModelParams::nominal());
        let cfg = SynthConfig::new("seed".parse().unwrap(), seed).with_params(truth);
        let syn = synthesize(&cfg).unwrap();
        let problem = Problem::standard(syn.inputs.clone(), syn.trial.torque_nm.clone()).unwrap();
        let noise =
            NoiseSpec::from_unloaded(&syn.trial, &syn.unloaded, NoiseKind::Ar1White).unwrap();
        let res = identify(&problem, &noise, &IdentifySettings::fast(seed), |_| {
            ControlFlow::Continue(())
        })
        .unwrap();
        for (p, id) in res.posterior.iter().zip(ParamId::identified()) {
            hits += usize::from(p.covers(id.get(&truth, &Effects::none())));
        }
    }
    let m = 9.0 * n as f64;
    let rate = hits as f64 / m;
    let margin = 2.576 * (0.09 / m).sqrt();
    assert!(
        (rate - 0.90).abs() <= margin,
        "coverage {hits}/{m} = {rate:.3}, margin ±{margin:.3}"
    );
}
