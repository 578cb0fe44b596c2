//! How honest the diagnosis's per-trial detection limits are (`candidates[].detection_limit`).
//!
//! `cargo run --release -p diagnose --example limit_calibration -- N BASE_SEED [effect,effect,…]`
//!
//! For `i < N`, the no-effect trial of seed `BASE_SEED + i` (with `emg_ta`, so that every
//! effect is eligible) is diagnosed. Each listed effect's reported limit `L` is then hidden in
//! the same subject and noise (`scenarios::hidden_trial_sized`, same seed: the same muscle
//! parameters and dynamometer noise), and [`diagnose::power::noncentrality`] with the true
//! default dynamometer noise (docs/dynamometer.md) gives the probability that the ΔBIC rule at best names an effect of size `L`.
//! The limit asks for 0.95; the table prints, per effect, the mean, smallest and largest of
//! that probability over the N subjects.
use diagnose::power::{noncentrality, rule_power, true_noise};
use diagnose::scenarios::{hidden_trial, hidden_trial_sized};
use diagnose::{no_observer, run, DiagnoseSettings};
use experiment::DynamometerSettings;
use muscle_model::EffectKind;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let n: u64 = args
        .first()
        .ok_or("usage: N BASE_SEED [effects]")?
        .parse()?;
    let base: u64 = args.get(1).ok_or("usage: N BASE_SEED [effects]")?.parse()?;
    let kinds: Vec<EffectKind> = match args.get(2) {
        Some(list) => list
            .split(',')
            .map(|s| EffectKind::from_name(s).ok_or(format!("unknown effect {s}")))
            .collect::<Result<_, _>>()?,
        None => EffectKind::ALL.to_vec(),
    };
    let settings = DiagnoseSettings::default();
    let noise = true_noise(&DynamometerSettings::default(), 2048.0)?;
    let mut powers: Vec<Vec<f64>> = vec![Vec::new(); kinds.len()];
    for i in 0..n {
        let seed = base + i;
        let t = hidden_trial(&[], true, seed)?;
        let d = run(
            &t.synthetic.trial,
            Some(&t.synthetic.unloaded),
            &settings,
            &mut no_observer,
        )?;
        for (j, kind) in kinds.iter().enumerate() {
            let Some(limit) = d
                .candidates
                .iter()
                .find(|c| c.effect == kind.name())
                .and_then(|c| c.detection_limit)
            else {
                continue;
            };
            let h = hidden_trial_sized(*kind, limit, seed)?;
            let info = noncentrality(
                &h.synthetic.trial,
                &h.synthetic.model_torque,
                &[],
                &noise,
                &settings,
            )?;
            let p = rule_power(
                info.lambda,
                kind.params().len(),
                info.n_obs,
                settings.max_delta_bic,
            );
            println!(
                "{seed} {}: limit {limit:.4}, λ {:.1}, rule power {p:.3}",
                kind.name(),
                info.lambda
            );
            powers[j].push(p);
        }
    }
    println!("effect | trials | mean rule power at the limit | smallest | largest");
    for (kind, p) in kinds.iter().zip(&powers) {
        if p.is_empty() {
            continue;
        }
        let mean = p.iter().sum::<f64>() / p.len() as f64;
        let lo = p.iter().copied().fold(f64::INFINITY, f64::min);
        let hi = p.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        println!(
            "{} | {} | {mean:.3} | {lo:.3} | {hi:.3}",
            kind.name(),
            p.len()
        );
    }
    Ok(())
}
