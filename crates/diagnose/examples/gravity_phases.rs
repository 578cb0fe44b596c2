//! The gravity moment against the catalogue over its whole phase range: each trial hides only
//! `gravity` (`m` N·m at phase `φ`) in a relaxed+2 trial with random true muscle parameters,
//! and the line says what the diagnosis names. A phase where something else is named (the
//! passive moment, an offset) is a confusion the rules tell as a false story.
//!
//! `cargo run --release -p diagnose --example gravity_phases -- MOMENT_NM SEEDS BASE`
//! (phases −150°, −120°, …, 180°, the effect's whole range; trial `i` of each phase has seed
//! `BASE + i`).

use diagnose::power::wilson_interval;
use diagnose::{no_observer, DiagnoseSettings};
use experiment::{random_params, synthesize, SynthConfig};
use muscle_model::{EffectKind, Effects, ModelParams};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let moment: f64 = args.first().map_or(Ok(6.0), |s| s.parse())?;
    let seeds: u64 = args.get(1).map_or(Ok(2), |s| s.parse())?;
    let base: u64 = args.get(2).map_or(Ok(8_200_000), |s| s.parse())?;
    let settings = DiagnoseSettings::default();
    let (mut exact_all, mut n_all) = (0, 0);
    println!("phase | trials | exactly gravity | named instead");
    for step in 0..12 {
        let phase = -150.0 + 30.0 * f64::from(step);
        let (mut exact, mut instead) = (0, Vec::new());
        for i in 0..seeds {
            let seed = base + i;
            let mut rng = ChaCha8Rng::seed_from_u64(seed);
            let params = random_params(&mut rng, &ModelParams::nominal());
            let mut effects = Effects::none();
            effects.set_values(EffectKind::Gravity, [moment, phase]);
            effects.validate()?;
            let cfg = SynthConfig::new("relaxed+2".parse()?, seed)
                .with_params(params)
                .with_effects(effects);
            let s = synthesize(&cfg)?;
            let d = diagnose::run(&s.trial, Some(&s.unloaded), &settings, &mut no_observer)?;
            if d.causes == ["gravity"] {
                exact += 1;
            } else {
                instead.push(format!("{:?} ({:?})", d.causes, d.verdict));
            }
        }
        println!(
            "{phase:.0}° | {seeds} | {exact} | {}",
            if instead.is_empty() {
                "—".to_string()
            } else {
                instead.join("; ")
            }
        );
        exact_all += exact;
        n_all += seeds as usize;
    }
    let (lo, hi) = wilson_interval(exact_all, n_all, 0.05);
    println!(
        "all | {n_all} | {exact_all} ({:.0}–{:.0} %) |",
        100.0 * lo,
        100.0 * hi
    );
    Ok(())
}
