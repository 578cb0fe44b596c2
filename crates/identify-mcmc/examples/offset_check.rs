//! How well the unloaded run's correction removes the dynamometer's constant offset.
//!
//! `cargo run --release -p identify-mcmc --example offset_check -- [N=12]` synthesises N
//! seed-protocol trials (seeds 1…N, random truths), estimates the systematic error from each
//! unloaded run ([`experiment::DynamometerCorrection`]) and prints the error of the estimated
//! offset and the mean of what is left of the trial's error after the correction
//! (`measured − model(truth) − systematic`), then their mean ± sd over the trials. These are the
//! numbers behind `identify_mcmc::UNLOADED_OFFSET_SD_NM`.

use experiment::{random_params, synthesize, SynthConfig};
use muscle_model::ModelParams;
use rand::SeedableRng;

fn mean_sd(v: &[f64]) -> (f64, f64) {
    let n = v.len() as f64;
    let m = v.iter().sum::<f64>() / n;
    let var = v.iter().map(|x| (x - m) * (x - m)).sum::<f64>() / (n - 1.0).max(1.0);
    (m, var.sqrt())
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let n: u64 = std::env::args()
        .nth(1)
        .map(|s| s.parse())
        .transpose()?
        .unwrap_or(12);
    let mut offset_err = Vec::new();
    let mut left = Vec::new();
    let mut white_var = Vec::new();
    for seed in 1..=n {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
        let truth = random_params(&mut rng, &ModelParams::nominal());
        let cfg = SynthConfig::new("seed".parse()?, seed).with_params(truth);
        let true_offset = cfg.dynamometer.offset_nm;
        let syn = synthesize(&cfg)?;
        let est = experiment::DynamometerCorrection::from_unloaded(&syn.unloaded)?;
        let sys = est.correct(&syn.trial)?.systematic_nm;
        let rem: Vec<f64> = syn
            .trial
            .torque_nm
            .iter()
            .zip(&syn.model_torque)
            .zip(&sys)
            .map(|((m, t), s)| m - t - s)
            .collect();
        let mean = rem.iter().sum::<f64>() / rem.len() as f64;
        // The remainder whitened by the noise model fitted on the unloaded run: i.i.d. N(0, 1)
        // if the noise model is right (variance 1, no autocorrelation left).
        let spec = identify_mcmc::NoiseSpec::from_correction(
            &syn.trial,
            &est,
            identify_mcmc::NoiseKind::Ar1White,
        )?;
        let identify_mcmc::McmcNoiseSource::Fixed(params) = spec.source else {
            unreachable!("from_correction fixes the noise model")
        };
        let centred: Vec<f64> = rem.iter().map(|v| v - mean).collect();
        let mut w = Vec::new();
        params.model()?.whiten(&centred, &mut w);
        let var = w.iter().map(|v| v * v).sum::<f64>() / w.len() as f64;
        let lag1 = w.windows(2).map(|p| p[0] * p[1]).sum::<f64>() / w.len() as f64 / var;
        let lag10 = w.windows(11).map(|p| p[0] * p[10]).sum::<f64>() / w.len() as f64 / var;
        white_var.push(var);
        println!(
            "          whitened remainder: variance {var:.3}, lag-1 {lag1:+.3}, lag-10 {lag10:+.3}"
        );
        println!(
            "seed {seed:3}: offset estimate {:+.3} N·m (true {true_offset:+.3}, error {:+.3}); mean left after correction {mean:+.3} N·m",
            est.offset_nm,
            est.offset_nm - true_offset
        );
        offset_err.push(est.offset_nm - true_offset);
        left.push(mean);
    }
    let (a, b) = mean_sd(&offset_err);
    let (c, d) = mean_sd(&left);
    let (e, f) = mean_sd(&white_var);
    println!("offset error {a:+.3} ± {b:.3} N·m; mean left {c:+.3} ± {d:.3} N·m; whitened variance {e:.3} ± {f:.3} over {n} trials");
    Ok(())
}
