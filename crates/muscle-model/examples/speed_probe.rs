//! Timing and accuracy of the forward simulation on the seed fixture (development probe).
//!
//! `cargo run --release -p muscle-model --example speed_probe [-- fixtures/seed/trial.csv]`

use muscle_model::{simulate, simulate_into, Effects, ModelParams, SimSettings, Workspace};
use numerics::rms_diff;
use std::time::Instant;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let path = std::env::args().nth(1).unwrap_or_else(|| {
        concat!(env!("CARGO_MANIFEST_DIR"), "/../../fixtures/seed/trial.csv").into()
    });
    let trial = experiment::read_trial(&path)?;
    let inputs = experiment::model_inputs(&trial, &Default::default())?;
    let p = ModelParams::nominal();
    let e = Effects::none();
    let tight = simulate(&inputs, &p, &e, &SimSettings::tight())?;
    let env = |k: &str, d: f64| {
        std::env::var(k)
            .ok()
            .and_then(|v| v.parse().ok())
            .unwrap_or(d)
    };
    let d = SimSettings::default();
    let s = SimSettings {
        rtol: env("RTOL", d.rtol),
        atol: env("ATOL", d.atol),
        h_max: env("HMAX", d.h_max),
        ..d
    };
    let fast = simulate(&inputs, &p, &e, &s)?;
    println!(
        "{} samples; default: RMS vs tight {:.3e} N·m, stats {:?}",
        inputs.len(),
        rms_diff(&fast.torque, &tight.torque),
        fast.total_stats()
    );
    for (label, all) in [
        ("all three muscles changed", true),
        ("one muscle changed", false),
    ] {
        let mut ws = Workspace::new();
        let mut torque = vec![0.0; inputs.len()];
        let reps = 300;
        let mut times = Vec::with_capacity(reps);
        let mut pp = p;
        for k in 0..reps + 20 {
            // perturb so no cache can return the previous result
            let f = 1.0 + 1e-6 * (k % 7) as f64;
            pp.muscles[0].lst_m = p.muscles[0].lst_m * f;
            if all {
                pp.muscles[1].lst_m = p.muscles[1].lst_m * f;
                pp.muscles[2].lst_m = p.muscles[2].lst_m * f;
            }
            let t0 = Instant::now();
            simulate_into(&mut ws, &inputs, &pp, &e, &s, &mut torque)?;
            if k >= 20 {
                times.push(t0.elapsed().as_secs_f64());
            }
        }
        times.sort_by(|a, b| a.total_cmp(b));
        println!(
            "simulate_into, {label}: median {:.1} µs",
            times[reps / 2] * 1e6
        );
    }
    Ok(())
}
