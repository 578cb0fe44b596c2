//! How well one unloaded run pins down the noise model: the default unloaded run (3 cycles,
//! about 8 s) of `N` seeds, each fitted like a diagnosis fits it ([`experiment::DynamometerCorrection::from_unloaded`]),
//! and the scatter of the estimated low-frequency level `σ_a²(1+φ)/(1−φ) + σ_w²` (the noise
//! power per sample at frequency 0, which sets the evidence of every slow term) against the
//! true one.
//!
//! `cargo run --release -p diagnose --example noise_scatter -- [N] [BASE_SEED]`
use diagnose::power::{low_frequency_level, true_noise};
use diagnose::{NoiseModelSource, TrialNoiseModel};
use experiment::{unloaded_run, DynamometerCorrection, DynamometerSettings};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().collect();
    let n: u64 = args.get(1).map_or(Ok(50), |s| s.parse())?;
    let base: u64 = args.get(2).map_or(Ok(1), |s| s.parse())?;
    let s = DynamometerSettings::default();
    let mut ratios = Vec::new();
    let mut truth = f64::NAN;
    for seed in base..base + n {
        let u = unloaded_run(&s, seed)?;
        let fs = u.sample_rate_hz();
        truth = low_frequency_level(&true_noise(&s, fs)?);
        let c = DynamometerCorrection::from_unloaded(&u)?;
        let m = TrialNoiseModel::from_correction(&c, NoiseModelSource::Unloaded, u.len());
        ratios.push(low_frequency_level(&m.random_part()) / truth);
    }
    let k = ratios.len() as f64;
    let mean = ratios.iter().sum::<f64>() / k;
    let sd = (ratios.iter().map(|r| (r - mean).powi(2)).sum::<f64>() / (k - 1.0)).sqrt();
    ratios.sort_by(f64::total_cmp);
    println!(
        "true level {truth:.1} N·m² per sample; estimate / truth over {n} unloaded runs: mean {mean:.3}, sd {sd:.3}, min {:.2}, max {:.2}",
        ratios[0],
        ratios[ratios.len() - 1]
    );
    Ok(())
}
