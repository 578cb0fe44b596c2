//! An effect's parameter sampled jointly with the 9 muscle parameters: the antagonist gain on a
//! relaxed+2 trial with a TA channel.
//!
//! `cargo run --release -p identify-mcmc --example ta_posterior -- [SEED=1] [GAIN=9.3]` synthesises
//! the trial (random truth from `SEED`, antagonist gain `GAIN` N·m), adds
//! `antagonist_coactivation.gain_nm` (bounds 0…100) to the free parameters and prints every
//! posterior with the strongest correlations. The gain trades against sol α0 (r ≈ −0.8): with
//! seed 20240609 and gain 9.32 the posterior is 8.4 ± 1.1 N·m (90 % interval 6.6–10.2), a useful
//! check on the Laplace uncertainty `surae diagnose` reports for the same effect.
use std::ops::ControlFlow;

use experiment::{random_params, synthesize, SynthConfig};
use identify_mcmc::{identify, McmcIdentifySettings, NoiseKind, NoiseSpec};
use muscle_model::{EffectKind, Effects, ModelParams, ParamId, Problem};
use rand::SeedableRng;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().collect();
    let seed: u64 = args.get(1).map_or(Ok(1), |s| s.parse())?;
    let gain: f64 = args.get(2).map_or(Ok(9.3), |s| s.parse())?;
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
    let truth = random_params(&mut rng, &ModelParams::nominal());
    let effects = Effects::from_json_str(&format!(
        "{{\"antagonist_coactivation\": {{\"gain_nm\": {gain}}}}}"
    ))?;
    let mut cfg = SynthConfig::new("relaxed+2".parse()?, seed)
        .with_params(truth)
        .with_effects(effects);
    cfg.emg.include_ta = true;
    let syn = synthesize(&cfg)?;
    let mut free: Vec<ParamId> = ParamId::identified().to_vec();
    free.extend(ParamId::of_effect(EffectKind::AntagonistCoactivation));
    let base_effects = Effects::none().with_null(EffectKind::AntagonistCoactivation);
    let problem = Problem::new(
        syn.inputs.clone(),
        syn.trial.torque_nm.clone(),
        ModelParams::nominal(),
        base_effects,
        free,
    )?;
    println!("bounds {:?}", problem.bounds());
    let noise = NoiseSpec::from_unloaded(&syn.trial, &syn.unloaded, NoiseKind::Ar1White)?;
    let res = identify(&problem, &noise, &McmcIdentifySettings::fast(seed), |_| {
        ControlFlow::Continue(())
    })?;
    for p in &res.posterior {
        println!(
            "{:28} mean {:10.4} sd {:9.4} [{:10.4}, {:10.4}] R̂ {:.3}",
            p.name, p.mean, p.sd, p.q05, p.q95, p.rhat
        );
    }
    for c in &res.correlations {
        println!("corr {} {} {:.2}", c.a, c.b, c.r);
    }
    println!("truth gain {gain}; converged {}", res.converged);
    Ok(())
}
