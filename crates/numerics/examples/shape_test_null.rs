//! How often the shape tests of `numerics::cycle_shape` call pure noise reproducible: AR(1)
//! noise of correlation time τ (no shape at all) cut into segments of 125 samples (a 0.5 s
//! stance at 250 Hz) and 10 phases.
//!
//! * template test: one held-out segment against a smooth template (a push-off bump at 70 %
//!   of the segment and a dip at 20 %, the shape CEINMS's stances leave);
//! * sign-flip test: 10 segments (strides), each its own noise.
//!
//! `cargo run --release -p numerics --example shape_test_null -- [reps] [seed]` prints, per τ,
//! the share of p-values below 0.05, 0.01 and 0.001 (nominal: those numbers). The sign-flip
//! test is exact whatever τ; the template test treats the phases as independent, which smooth
//! noise is not.

use numerics::cycle_shape::{sign_flip_test, template_test, PhaseShape};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, StandardNormal};

const SAMPLES: usize = 125;
const FS_HZ: f64 = 250.0;
const BINS: usize = 10;

/// One stationary AR(1) segment of unit variance with `x_t = φ x_{t−1} + √(1−φ²) η_t`.
fn ar1(phi: f64, rng: &mut ChaCha8Rng) -> Vec<f64> {
    let innovation = (1.0 - phi * phi).sqrt();
    let mut x: f64 = StandardNormal.sample(rng);
    (0..SAMPLES)
        .map(|_| {
            let eta: f64 = StandardNormal.sample(rng);
            x = phi * x + innovation * eta;
            x
        })
        .collect()
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let reps: usize = args.get(1).and_then(|a| a.parse().ok()).unwrap_or(20_000);
    let seed: u64 = args.get(2).and_then(|a| a.parse().ok()).unwrap_or(7);
    let template = PhaseShape {
        means: (0..BINS)
            .map(|b| {
                let ph = (b as f64 + 0.5) / BINS as f64;
                30.0 * (-(ph - 0.7f64).powi(2) / 0.01).exp()
                    - 15.0 * (-(ph - 0.2f64).powi(2) / 0.01).exp()
            })
            .collect(),
    };
    println!("{reps} noise draws per τ, seed {seed}; share of p below 0.05 / 0.01 / 0.001");
    println!("τ (s)   template test               sign flips across 10 strides");
    for tau_s in [0.004, 0.02, 0.05, 0.1, 0.2, 0.4] {
        let phi = (-1.0 / (FS_HZ * tau_s)).exp();
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let mut template_p = Vec::with_capacity(reps);
        let mut flip_p = Vec::with_capacity(reps);
        for _ in 0..reps {
            let held = PhaseShape::of(&ar1(phi, &mut rng), None, BINS);
            template_p.push(template_test(&held, &template).expect("ten phases").p_value);
            let strides: Vec<PhaseShape> = (0..10)
                .map(|_| PhaseShape::of(&ar1(phi, &mut rng), None, BINS))
                .collect();
            flip_p.push(sign_flip_test(&strides, 0, 0).expect("ten strides").p_value);
        }
        let share = |p: &[f64], a: f64| p.iter().filter(|v| **v < a).count() as f64 / reps as f64;
        println!(
            "{tau_s:5.3}   {:.4} / {:.4} / {:.5}    {:.4} / {:.4} / {:.5}",
            share(&template_p, 0.05),
            share(&template_p, 0.01),
            share(&template_p, 1e-3),
            share(&flip_p, 0.05),
            share(&flip_p, 0.01),
            share(&flip_p, 1e-3),
        );
    }
}
