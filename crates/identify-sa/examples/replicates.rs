//! Identify `N` synthetic seed-protocol trials with random true parameters (uniform inside the
//! identification bounds, nominal dynamometer error, unloaded run supplied) and print the median and worst error
//! per parameter as a Markdown table.
//!
//! `cargo run --release -p identify-sa --example replicates -- 20`
//!
//! Replicate `k` uses truth `random_params(ChaCha8Rng::seed_from_u64(1000 + k))` and synthesis
//! seed `1000 + k`; the identification uses the default settings.

use experiment::{
    random_params, synthesize, CrosstalkSettings, InputOptions, PreparedTrial, Protocol,
    SynthConfig,
};
use identify_sa::{identify, NoObserver, SaIdentifySettings};
use muscle_model::{Effects, ModelParams};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

fn median(v: &mut [f64]) -> f64 {
    v.sort_by(f64::total_cmp);
    let n = v.len();
    if n % 2 == 1 {
        v[n / 2]
    } else {
        0.5 * (v[n / 2 - 1] + v[n / 2])
    }
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let n: u64 = std::env::args()
        .nth(1)
        .and_then(|s| s.parse().ok())
        .unwrap_or(20);
    let mut names: Vec<String> = Vec::new();
    let mut errs: Vec<Vec<f64>> = Vec::new();
    let (mut ratios, mut walls, mut evals) = (Vec::new(), Vec::new(), Vec::new());
    for k in 0..n {
        let seed = 1000 + k;
        let truth = random_params(
            &mut ChaCha8Rng::seed_from_u64(seed),
            &ModelParams::nominal(),
        );
        let syn = synthesize(&SynthConfig::new(Protocol::Seed, seed).with_params(truth))?;
        let prep = PreparedTrial::prepare(
            &syn.trial,
            Some(&syn.unloaded),
            &InputOptions::default(),
            &CrosstalkSettings::off(),
            "synthetic trial",
        )?;
        let problem = prep.standard_problem()?;
        let id = identify(&problem, &SaIdentifySettings::default(), &NoObserver)?;
        let floor = problem.rms(&problem.vector_from(&truth, &Effects::none()))?;
        let e = id.errors_pct(&truth);
        if names.is_empty() {
            names = problem.names().to_vec();
            errs = vec![Vec::new(); names.len()];
        }
        for (j, name) in names.iter().enumerate() {
            errs[j].push(e[name]);
        }
        eprintln!(
            "replicate {k}: rms/floor {:.4}, sol LST {:.2} %, {} evaluations, {:.1} s",
            id.rms_nm / floor,
            e["sol.lst_m"],
            id.evaluations,
            id.wall_s
        );
        ratios.push(id.rms_nm / floor);
        walls.push(id.wall_s);
        evals.push(id.evaluations as f64);
    }
    println!("| parameter | median error (%) | worst error (%) |");
    println!("|---|---|---|");
    for (j, name) in names.iter().enumerate() {
        let worst = errs[j].iter().copied().fold(0.0, f64::max);
        println!("| {name} | {:.2} | {:.2} |", median(&mut errs[j]), worst);
    }
    let worst_ratio = ratios.iter().copied().fold(0.0, f64::max);
    let worst_wall = walls.iter().copied().fold(0.0, f64::max);
    println!();
    println!(
        "{n} replicates: RMS / noise floor median {:.4}, worst {:.4}; wall median {:.1} s, worst {:.1} s; evaluations median {:.0}",
        median(&mut ratios),
        worst_ratio,
        median(&mut walls),
        worst_wall,
        median(&mut evals)
    );
    Ok(())
}
