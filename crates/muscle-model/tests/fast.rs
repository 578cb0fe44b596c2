//! The fast formulation (default) against the tight reference, and the per-muscle cache of
//! `simulate_into` (bit-identical reuse).

use muscle_model::{
    simulate, simulate_into, synthetic, Effects, ModelParams, SimSettings, Workspace,
};
use numerics::rms_diff;

#[test]
fn fast_default_is_within_a_hundredth_of_a_newton_metre_of_tight() {
    let tr = synthetic::seed_like_trial(2048.0).unwrap();
    let p = ModelParams::nominal();
    let cases = [
        Effects::none(),
        Effects::from_json_str(r#"{"fatigue": {"rate_per_s": 0.03}}"#).unwrap(),
        Effects::from_json_str(r#"{"electromechanical_delay": {"delay_ms": 40}}"#).unwrap(),
        Effects::from_json_str(r#"{"eccentric_enhancement": {"flen": 1.7}}"#).unwrap(),
    ];
    for e in cases {
        let tight = simulate(&tr, &p, &e, &SimSettings::tight()).unwrap();
        let fast = simulate(&tr, &p, &e, &SimSettings::default()).unwrap();
        let err = rms_diff(&fast.torque, &tight.torque);
        println!("{e:?}: {err:.2e} N·m RMS, {:?}", fast.total_stats());
        assert!(err < 0.01, "{err} N·m RMS");
        // the recorded-state run computes the same torque
        let with = simulate(&tr, &p, &e, &SimSettings::default().with_states()).unwrap();
        assert_eq!(with.torque, fast.torque);
    }
}

#[test]
fn cached_muscles_give_bit_identical_torque() {
    let tr = synthetic::seed_like_trial(1024.0).unwrap();
    let e = Effects::none();
    let s = SimSettings::default();
    let base = ModelParams::nominal();
    let mut moved = base;
    moved.muscles[1].lst_m *= 1.01;
    let mut f0 = moved;
    f0.muscles[2].fom_n *= 1.1;
    let mut ws = Workspace::new();
    let mut out = vec![0.0; tr.len()];
    let mut fresh = vec![0.0; tr.len()];
    for (k, p) in [base, moved, f0, base, moved].iter().enumerate() {
        simulate_into(&mut ws, &tr, p, &e, &s, &mut out).unwrap();
        simulate_into(&mut Workspace::new(), &tr, p, &e, &s, &mut fresh).unwrap();
        assert_eq!(out, fresh, "call {k}");
        assert_eq!(out, simulate(&tr, p, &e, &s).unwrap().torque, "call {k}");
    }
    // base: 3 integrated; moved: gm; f0 (gl's F0 only): none; base and moved again: reused
    assert_eq!(ws.cache_counts(), (11, 4));
}
