//! The single-trial acceptance on fresh random truths, with the default settings.
//!
//! `cargo run --release -p identify-mcmc --example acceptance -- SEED…` synthesises a
//! seed-protocol trial per seed (truth uniform in the bounds, nominal dynamometer error, unloaded run), runs
//! [`identify`] with [`McmcIdentifySettings::default`] (sampler seed = trial seed) and prints: max
//! R̂ (≤ 1.01), min bulk ESS (≥ 400), truths inside their 90 % intervals (≥ 6/9), the soleus
//! LST error of the posterior mean (≤ 1.5 %), the soleus LST / gl α0 identifiability flags
//! (identifiable / not) and the wall time (≤ 120 s on 2 cores), then `PASS` or `FAIL`.

use std::ops::ControlFlow;

use experiment::{random_params, synthesize, SynthConfig};
use identify_mcmc::{identify, McmcIdentifySettings, McmcSettings, NoiseKind, NoiseSpec};
use muscle_model::{Effects, ModelParams, ParamId, Problem};
use rand::SeedableRng;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let seeds: Vec<u64> = std::env::args()
        .skip(1)
        .map(|s| s.parse())
        .collect::<Result<_, _>>()?;
    let ids = ParamId::identified();
    for seed in seeds {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
        let truth = random_params(&mut rng, &ModelParams::nominal());
        let syn = synthesize(&SynthConfig::new("seed".parse()?, seed).with_params(truth))?;
        let problem = Problem::standard(syn.inputs.clone(), syn.trial.torque_nm.clone())?;
        let noise = NoiseSpec::from_unloaded(&syn.trial, &syn.unloaded, NoiseKind::Ar1White)?;
        let d = McmcIdentifySettings::default();
        let settings = McmcIdentifySettings {
            mcmc: McmcSettings { seed, ..d.mcmc },
            ..d
        };
        let res = identify(&problem, &noise, &settings, |_| ControlFlow::Continue(()))?;
        let covered = res
            .posterior
            .iter()
            .zip(ids)
            .filter(|(p, id)| p.covers(id.get(&truth, &Effects::none())))
            .count();
        let sol = res.get("sol.lst_m").ok_or("no sol.lst_m")?;
        let err = 100.0 * (sol.mean / truth.muscles[0].lst_m - 1.0);
        let gl_alpha = res.get("gl.alpha_deg").ok_or("no gl.alpha_deg")?;
        let (r, e) = res.worst_diagnostics();
        let pass = r <= 1.01
            && e >= 400.0
            && covered >= 6
            && err.abs() <= 1.5
            && sol.identifiable
            && !gl_alpha.identifiable
            && res.wall_s <= 120.0;
        println!(
            "seed {seed}: max R̂ {r:.4}, min bulk ESS {e:.0}, covered {covered}/9, sol LST error {err:+.3} %, sol LST identifiable {}, gl α0 identifiable {}, wall {:.1} s, modes {}, jump acceptance {:.3} → {}",
            sol.identifiable,
            gl_alpha.identifiable,
            res.wall_s,
            res.modes.len(),
            res.jump_acceptance_rate,
            if pass { "PASS" } else { "FAIL" }
        );
    }
    Ok(())
}
