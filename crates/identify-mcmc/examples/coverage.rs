//! Interval coverage over simulated trials with random true parameters.
//!
//! `cargo run --release -p identify-mcmc --example coverage -- [N=30] [ar1_white|ar1|iid] [exact] [from=K]`
//! synthesises N seed-protocol trials (seeds 1…N, truth drawn uniformly in the bounds by
//! `experiment::random_params`, nominal dynamometer error, unloaded run), identifies each with
//! [`McmcIdentifySettings::fast`] and the noise model estimated from the unloaded run, and prints
//! how often each 90 % interval holds the truth.

use std::ops::ControlFlow;

use experiment::{random_params, synthesize, SynthConfig};
use identify_mcmc::{identify, McmcIdentifySettings, NoiseKind, NoiseSpec};
use muscle_model::{Effects, ModelParams, ParamId, Problem};
use rand::SeedableRng;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().collect();
    let n: u64 = args.get(1).map(|s| s.parse()).transpose()?.unwrap_or(30);
    let kind = match args.get(2).map(String::as_str) {
        Some("iid") => NoiseKind::Iid,
        Some("ar1") => NoiseKind::Ar1,
        _ => NoiseKind::Ar1White,
    };
    // `exact`: correct the trial by the true systematic error instead of the unloaded run's
    // estimate (isolates the estimate's share of any miscalibration).
    let exact = args.iter().any(|a| a == "exact");
    // `from=K`: seeds K…K+N−1 instead of 1…N.
    let first: u64 = args
        .iter()
        .find_map(|a| a.strip_prefix("from="))
        .map(str::parse)
        .transpose()?
        .unwrap_or(1);
    let ids = ParamId::identified();
    let mut hits = [0usize; 9];
    let mut width = [0.0f64; 9];
    let mut conv = 0;
    let start = std::time::Instant::now();
    for seed in first..first + n {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
        let truth = random_params(&mut rng, &ModelParams::nominal());
        let cfg = SynthConfig::new("seed".parse()?, seed).with_params(truth);
        let syn = synthesize(&cfg)?;
        let problem = Problem::standard(syn.inputs.clone(), syn.trial.torque_nm.clone())?;
        let mut noise = NoiseSpec::from_unloaded(&syn.trial, &syn.unloaded, kind)?;
        if exact {
            let events = experiment::detect_events(&syn.trial.time_s, &syn.trial.ankle_angle_deg)?;
            noise.systematic = Some(experiment::systematic_error(
                &syn.trial.time_s,
                &events.all(),
                &cfg.dynamometer,
            ));
        }
        let res = identify(&problem, &noise, &McmcIdentifySettings::fast(seed), |_| {
            ControlFlow::Continue(())
        })?;
        conv += usize::from(res.converged);
        let mut line = format!("seed {seed:3}: ");
        for (k, (p, id)) in res.posterior.iter().zip(ids).enumerate() {
            let t = id.get(&truth, &Effects::none());
            let c = p.covers(t);
            hits[k] += usize::from(c);
            width[k] += (p.q95 - p.q05) / t;
            line.push(if c { '+' } else { '-' });
        }
        let (r, e) = res.worst_diagnostics();
        println!(
            "{line}  max R̂ {r:.3} min ESS {e:.0} converged {} wall {:.1} s",
            res.converged, res.wall_s
        );
    }
    let total: usize = hits.iter().sum();
    let m = 9.0 * n as f64;
    println!("| parameter | covered | rate | mean 90% width (% of truth) |");
    println!("|---|---|---|---|");
    for (k, id) in ids.iter().enumerate() {
        println!(
            "| {} | {}/{} | {:.2} | {:.2} |",
            id.name(),
            hits[k],
            n,
            hits[k] as f64 / n as f64,
            100.0 * width[k] / n as f64
        );
    }
    let rate = total as f64 / m;
    let margin = 2.576 * (0.09 / m).sqrt();
    println!(
        "all: {total}/{m} = {rate:.3} (99% binomial margin ±{margin:.3}); converged {conv}/{n}; {:.0} s",
        start.elapsed().as_secs_f64()
    );
    Ok(())
}
