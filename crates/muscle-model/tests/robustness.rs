//! 1000 random parameter vectors from twice the identification bounds box (seeded) all simulate the
//! full seed-like trial (2048 Hz, 3.33 s) to finite torque.

mod common;

use common::random_identified;
use muscle_model::{
    simulate_into, synthetic, Effects, ModelParams, Muscle, SimSettings, Workspace,
};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use std::time::Instant;

#[test]
fn thousand_random_vectors_in_twice_the_bounds_box_simulate() {
    let tr = synthetic::seed_like_trial(2048.0).unwrap();
    let mut rng = ChaCha8Rng::seed_from_u64(20_160_301);
    let mut ws = Workspace::new();
    let mut torque = vec![0.0; tr.len()];
    let nominal = ModelParams::nominal();
    let start = Instant::now();
    let mut rhs = 0usize;
    let mut outside = 0usize;
    for k in 0..1000 {
        let p = random_identified(&mut rng, 2.0);
        // count draws outside the bounds box (so the test really exercises the wider box)
        if Muscle::ALL
            .iter()
            .any(|&m| (p.muscle(m).lst_m / nominal.muscle(m).lst_m - 1.0).abs() > 0.05)
        {
            outside += 1;
        }
        let stats = simulate_into(
            &mut ws,
            &tr,
            &p,
            &Effects::none(),
            &SimSettings::default(),
            &mut torque,
        )
        .unwrap_or_else(|e| panic!("draw {k} failed: {e}; params {p:?}"));
        rhs += stats.rhs_calls;
        assert!(torque.iter().all(|t| t.is_finite()), "draw {k}");
        // physically sensible torque: never beyond the Biodex range
        assert!(
            torque.iter().all(|t| t.abs() < 678.0),
            "draw {k}: torque out of range"
        );
    }
    let el = start.elapsed();
    println!(
        "1000 simulations of {} samples in {:.2?} ({:.2} ms each, {} RHS calls on average); {} draws with an LST outside ±5 %",
        tr.len(),
        el,
        el.as_secs_f64(),
        rhs / 1000,
        outside
    );
    assert!(outside > 500);
}
