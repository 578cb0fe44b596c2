//! MCMC identification of `fixtures/seed` with a noise model from its unloaded run.
//!
//! `cargo run --release -p identify-mcmc --example seed -- [ar1_white|ar1|iid] [SEED] [chains.csv]`
//! (any order; `SEED` is the sampler seed, 42 by default) prints, per parameter, the truth, the posterior summary, the error of the posterior mean
//! and the identifiability flag, then the diagnostics and the wall time.

use std::ops::ControlFlow;
use std::path::Path;

use identify_mcmc::{identify, McmcIdentifySettings, NoiseKind, NoiseSpec};
use muscle_model::{Effects, ModelParams, ParamId, Problem};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut kind = NoiseKind::Ar1White;
    let mut settings = McmcIdentifySettings::default();
    let mut csv = None;
    for a in std::env::args().skip(1) {
        match a.as_str() {
            "iid" => kind = NoiseKind::Iid,
            "ar1" => kind = NoiseKind::Ar1,
            "ar1_white" => kind = NoiseKind::Ar1White,
            _ => match a.parse::<u64>() {
                Ok(seed) => settings.mcmc.seed = seed,
                Err(_) => csv = Some(a),
            },
        }
    }
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../fixtures/seed");
    let trial = experiment::read_trial(dir.join("trial.csv"))?;
    let unloaded = experiment::read_unloaded(dir.join("unloaded.csv"))?;
    let truth_json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("truth.json"))?)?;
    let truth = ModelParams::from_json_str(&truth_json["params"].to_string())?;
    let inputs = experiment::model_inputs(&trial, &experiment::InputOptions::default())?;
    let problem = Problem::standard(inputs, trial.torque_nm.clone())?;
    let noise = NoiseSpec::from_unloaded(&trial, &unloaded, kind)?;
    println!(
        "noise model: {:?}; seed {}",
        noise.source, settings.mcmc.seed
    );
    let res = identify(&problem, &noise, &settings, |p| {
        eprintln!(
            "{:?} it {} max R̂ {:.4} min ESS {:.0} acc {:.3}",
            p.phase, p.iterations, p.max_rhat, p.min_ess_bulk, p.acceptance_rate
        );
        ControlFlow::Continue(())
    })?;
    let tv: Vec<f64> = ParamId::identified()
        .iter()
        .map(|id| id.get(&truth, &Effects::none()))
        .collect();
    println!("| parameter | truth | mean | error % | sd | q05 | q95 | in 90% | R̂ | ESS bulk | ESS tail | sd/prior sd | identifiable |");
    println!("|---|---|---|---|---|---|---|---|---|---|---|---|---|");
    let mut covered = 0;
    for (p, t) in res.posterior.iter().zip(&tv) {
        covered += usize::from(p.covers(*t));
        println!(
            "| {} | {:.5} | {:.5} | {:+.2} | {:.4} | {:.5} | {:.5} | {} | {:.4} | {:.0} | {:.0} | {:.3} | {} |",
            p.name, t, p.mean, 100.0 * (p.mean - t) / t, p.sd, p.q05, p.q95,
            if p.covers(*t) { "yes" } else { "no" }, p.rhat, p.ess_bulk, p.ess_tail,
            p.prior_sd_ratio, p.identifiable
        );
    }
    let (rhat, ess) = res.worst_diagnostics();
    println!(
        "covered {covered}/9; converged {} ({:?}); max R̂ {rhat:.4}; min bulk ESS {ess:.0}; warm-up {} + sampling {} per chain; evaluations {}; acceptance {:.3}; RMS {:.3} N·m (corrected {:.3}); max|z| {:.2}; wall {:.1} s",
        res.converged, res.stop, res.warmup_iterations, res.sampling_iterations, res.evaluations,
        res.acceptance_rate, res.rms_nm, res.rms_corrected_nm, res.max_abs_z, res.wall_s
    );
    for c in &res.correlations {
        println!("corr {} ~ {}: {:+.3}", c.a, c.b, c.r);
    }
    if let Some(path) = csv {
        res.write_chains_csv(std::io::BufWriter::new(std::fs::File::create(path)?))?;
    }
    Ok(())
}
