//! Event timing of [`experiment::detect_events`] on quantised, jittered encoders.
//!
//! `cargo run --release -p experiment --example event_timing -- [SEEDS=20]`
//!
//! For encoder resolutions of 0.001°, 0.01° and 0.05° and the protocols `seed`, `relaxed+2`,
//! `cycles+3` and `cycles+5`, each angle sample gets a uniform jitter of ± half a step and is
//! rounded to the step (seeds `0 … SEEDS−1`, `ChaCha8`). Prints the largest and the RMS error
//! of the detected event times against the protocol's, and the number of traces on which the
//! detector found a different number of events.

use experiment::{detect_events, Protocol};
use rand::SeedableRng;
use rand_distr::{Distribution, Uniform};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let seeds: u64 = std::env::args().nth(1).map_or(Ok(20), |s| s.parse())?;
    let jitter = Uniform::new(-0.5, 0.5)?;
    for step in [0.001f64, 0.01, 0.05] {
        for p in ["seed", "relaxed+2", "cycles+3", "cycles+5"] {
            let tr = p.parse::<Protocol>()?.trace()?;
            let truth = tr.events.all();
            let (mut worst, mut ss, mut count, mut miscounts) = (0.0f64, 0.0, 0usize, 0);
            for seed in 0..seeds {
                let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
                let angle: Vec<f64> = tr
                    .angle_deg
                    .iter()
                    .map(|a| ((a + step * jitter.sample(&mut rng)) / step).round() * step)
                    .collect();
                let found = detect_events(&tr.time_s, &angle).map(|e| e.all());
                match found {
                    Ok(found) if found.len() == truth.len() => {
                        for (a, b) in found.iter().zip(&truth) {
                            worst = worst.max((a - b).abs());
                            ss += (a - b).powi(2);
                            count += 1;
                        }
                    }
                    _ => miscounts += 1,
                }
            }
            let rms = (ss / count.max(1) as f64).sqrt();
            println!(
                "step {step}° {p}: largest error {:.3} ms, RMS {:.3} ms, miscounted on {miscounts} of {seeds}",
                worst * 1e3,
                rms * 1e3
            );
        }
    }
    Ok(())
}
