//! Accuracy against [`SimSettings::tight`] on the seed and relaxed2 fixtures (with and without
//! effects) and single-core timing of the evaluations an annealer makes (development probe).
//!
//! `cargo run --release -p muscle-model --example move_probe`; `RTOL`, `ATOL`, `HMAX` override
//! the default settings, `REPS` the repetitions.

use muscle_model::{
    simulate, simulate_into, Effects, ModelParams, Problem, ProblemWorkspace, SimSettings,
    Workspace,
};
use numerics::rms_diff;
use std::time::Instant;

fn env(k: &str, d: f64) -> f64 {
    std::env::var(k)
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(d)
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let root = concat!(env!("CARGO_MANIFEST_DIR"), "/../../fixtures");
    let d = SimSettings::default();
    let s = SimSettings {
        rtol: env("RTOL", d.rtol),
        atol: env("ATOL", d.atol),
        h_max: env("HMAX", d.h_max),
        ..d
    };
    let reps = env("REPS", 2000.0) as usize;
    let effects = [
        ("none", Effects::none()),
        (
            "fatigue",
            Effects::from_json_str(r#"{"fatigue": {"rate_per_s": 0.03}}"#)?,
        ),
        (
            "delay",
            Effects::from_json_str(r#"{"electromechanical_delay": {"delay_ms": 40}}"#)?,
        ),
        (
            "ecc",
            Effects::from_json_str(r#"{"eccentric_enhancement": {"flen": 1.7}}"#)?,
        ),
    ];
    let p = ModelParams::nominal();
    let mut worst: f64 = 0.0;
    if std::env::var("NO_ACC").is_err() {
        for fx in ["seed", "relaxed2"] {
            let trial = experiment::read_trial(format!("{root}/{fx}/trial.csv"))?;
            let inputs = experiment::model_inputs(&trial, &Default::default())?;
            for (name, e) in &effects {
                let tight = simulate(&inputs, &p, e, &SimSettings::tight())?;
                let fast = simulate(&inputs, &p, e, &s)?;
                let err = rms_diff(&fast.torque, &tight.torque);
                worst = worst.max(err);
                println!(
                    "{fx:9} {name:8} RMS vs tight {err:.3e} N·m, rhs {}",
                    fast.total_stats().rhs_calls
                );
            }
        }
        println!("worst {worst:.3e} N·m");
    }

    let trial = experiment::read_trial(format!("{root}/seed/trial.csv"))?;
    let inputs = experiment::model_inputs(&trial, &Default::default())?;
    let e = Effects::none();
    // forward simulation, all three muscles integrated
    let sets: Vec<ModelParams> = (0..3)
        .map(|k| {
            let mut q = p;
            for m in &mut q.muscles {
                m.lst_m *= 1.0 + 1e-4 * k as f64;
            }
            q
        })
        .collect();
    let mut ws = Workspace::new();
    let mut torque = vec![0.0; inputs.len()];
    let mut t = Vec::new();
    for k in 0..reps / 4 + 10 {
        let t0 = Instant::now();
        simulate_into(&mut ws, &inputs, &sets[k % 3], &e, &s, &mut torque)?;
        if k >= 10 {
            t.push(t0.elapsed().as_secs_f64());
        }
    }
    println!("forward (3 muscles): median {:.1} µs", median(t) * 1e6);

    let problem = Problem::standard(inputs.clone(), trial.torque_nm.clone())?.with_settings(s);
    let x0 = problem.base_vector();
    let mut state = 0x2545_f491_4f6c_dd1d_u64;
    let mut next = move || {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        state
    };
    for (label, coords) in [
        ("LST/alpha move", vec![0usize, 2, 3, 5, 6, 8]),
        ("F0 move", vec![1, 4, 7]),
        ("any move, 50% reverted", (0..9).collect()),
    ] {
        let mut pws = ProblemWorkspace::new();
        let mut x = x0.clone();
        let mut t = Vec::new();
        let t_all = Instant::now();
        for k in 0..reps + 20 {
            let c = coords[(next() % coords.len() as u64) as usize];
            let u = (next() >> 11) as f64 / (1u64 << 53) as f64;
            let old = x[c];
            x[c] = x0[c] * (1.0 + 0.02 * (u - 0.5));
            let t0 = Instant::now();
            std::hint::black_box(problem.sse_with(&x, &mut pws)?);
            if k >= 20 {
                t.push(t0.elapsed().as_secs_f64());
            }
            if next() % 2 == 0 {
                x[c] = old;
            }
        }
        let wall = t_all.elapsed().as_secs_f64() / (reps + 20) as f64;
        let mut ts = t.clone();
        ts.sort_by(f64::total_cmp);
        let q = |f: f64| ts[((ts.len() - 1) as f64 * f) as usize] * 1e6;
        println!(
            "sse_with, {label}: p10 {:.1} p25 {:.1} p75 {:.1} p90 {:.1} µs",
            q(0.1),
            q(0.25),
            q(0.75),
            q(0.9)
        );
        println!(
            "sse_with, {label}: median {:.1} µs, mean {:.1} µs, wall/eval {:.1} µs",
            median(t.clone()) * 1e6,
            t.iter().sum::<f64>() / t.len() as f64 * 1e6,
            wall * 1e6
        );
    }
    Ok(())
}
