//! Measures the numbers quoted in `docs/model.md`: accuracy of the default integration
//! settings against a tight run, invariant drift, and time per simulation.
//!
//! `cargo run --release -p muscle-model --example accuracy_and_speed`

use muscle_model::musculotendon::{IX_FT, IX_LMT};
use muscle_model::{
    simulate, simulate_into, synthetic, Effects, Formulation, ModelParams, Muscle, MuscleUnit,
    ParamId, SimSettings, Workspace,
};
use numerics::rms_diff;
use std::time::Instant;

fn main() {
    let tr = synthetic::seed_like_trial(2048.0).expect("trial");
    let e = Effects::none();
    println!(
        "seed-like trial: {} samples at 2048 Hz ({:.3} s)",
        tr.len(),
        tr.times()[tr.len() - 1]
    );
    // parameter sets: nominal and the 2^9 corners would be too many; use nominal and ±bounds
    let mut sets = vec![("nominal".to_string(), ModelParams::nominal())];
    for (sign, label) in [(-1.0, "all lower bounds"), (1.0, "all upper bounds")] {
        let mut p = ModelParams::nominal();
        let mut ee = Effects::none();
        for id in ParamId::identified() {
            let (lo, hi) = id.default_bounds(&ModelParams::nominal(), &ee);
            id.set(&mut p, &mut ee, if sign < 0.0 { lo } else { hi });
        }
        sets.push((label.to_string(), p));
    }
    let candidates = [
        (
            "fast, rtol 1e-5, atol 1e-7",
            SimSettings {
                rtol: 1e-5,
                atol: 1e-7,
                ..SimSettings::default()
            },
        ),
        ("fast, default (rtol 1e-6)", SimSettings::default()),
        (
            "fast, rtol 1e-8, atol 1e-10",
            SimSettings {
                rtol: 1e-8,
                atol: 1e-10,
                ..SimSettings::default()
            },
        ),
        (
            "four-state, default tolerances",
            SimSettings {
                formulation: Formulation::FourState,
                ..SimSettings::default()
            },
        ),
        (
            "four-state, rtol 1e-8, atol 1e-10",
            SimSettings {
                formulation: Formulation::FourState,
                rtol: 1e-8,
                atol: 1e-10,
                ..SimSettings::default()
            },
        ),
    ];
    for (label, p) in &sets {
        let tight = simulate(&tr, p, &e, &SimSettings::tight()).expect("tight");
        println!(
            "{label}: tight run {} RHS calls",
            tight.total_stats().rhs_calls
        );
        for (name, s) in &candidates {
            let out = simulate(&tr, p, &e, &s.with_states()).expect("sim");
            let (mut inv, mut lmt) = (0.0_f64, 0.0_f64);
            for m in Muscle::ALL {
                let u = MuscleUnit::new(p, m, &e);
                for (i, y) in out.states_of(m).expect("states").iter().enumerate() {
                    inv = inv.max((u.detail(y).tendon_force_from_lengths - y[IX_FT]).abs());
                    lmt = lmt.max((y[IX_LMT] - u.lmt(tr.angle()[i])).abs());
                }
            }
            let mx = out
                .torque
                .iter()
                .zip(&tight.torque)
                .map(|(a, b)| (a - b).abs())
                .fold(0.0, f64::max);
            println!(
                "  {name:36} RMS vs tight {:.2e} N·m, max {:.2e} N·m, max|F̃T−fT(ε)| {:.1e}, max|LMT−LMT(q)| {:.1e} m, {} RHS calls",
                rms_diff(&out.torque, &tight.torque),
                mx,
                inv,
                lmt,
                out.total_stats().rhs_calls
            );
        }
    }
    // timing of the hot path
    let mut ws = Workspace::new();
    let mut torque = vec![0.0; tr.len()];
    let p = ModelParams::nominal();
    let s = SimSettings::default();
    for _ in 0..20 {
        simulate_into(&mut ws, &tr, &p, &e, &s, &mut torque).expect("warm-up");
    }
    let reps = 500;
    let t0 = Instant::now();
    for _ in 0..reps {
        simulate_into(&mut ws, &tr, &p, &e, &s, &mut torque).expect("sim");
    }
    let per = t0.elapsed().as_secs_f64() / reps as f64;
    println!(
        "simulate_into, default settings: {:.3} ms per simulation of the seed-like trial",
        per * 1e3
    );
}
