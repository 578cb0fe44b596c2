//! Curve values at known points and continuity where the model's curves
//! (`docs/model.md` section 2) make pieces join smoothly.

use muscle_model::activation::{Activation, ManalBuchanan};
use muscle_model::curves::{
    active_force_length, force_velocity, passive_force_length, tendon_force, tendon_stiffness,
    Curves,
};
use muscle_model::geometry::{lmt, moment_arm, Pennation};
use muscle_model::{ActivationParams, CurveParams, ModelParams, Muscle};

const E0T: f64 = 0.04;

#[test]
fn active_force_length_known_values() {
    assert_eq!(active_force_length(1.0, 0.45), 1.0);
    // exp(-0.25/0.45)
    assert!((active_force_length(1.5, 0.45) - 0.573_753_420_737_432_7).abs() < 1e-15);
    assert!((active_force_length(0.5, 0.45) - 0.573_753_420_737_432_7).abs() < 1e-15);
    // exp(-0.09/0.45) = exp(-0.2)
    assert!((active_force_length(0.7, 0.45) - (-0.2f64).exp()).abs() < 1e-15);
}

#[test]
fn passive_force_length_known_values() {
    assert_eq!(passive_force_length(1.0, 5.0, 0.6), 0.0);
    assert_eq!(passive_force_length(0.8, 5.0, 0.6), 0.0);
    // unit force at strain e0M
    assert!((passive_force_length(1.6, 5.0, 0.6) - 1.0).abs() < 1e-14);
    // (e^{5·0.3/0.6} − 1)/(e^5 − 1) = (e^{2.5} − 1)/(e^5 − 1)
    let want = (2.5f64.exp() - 1.0) / (5.0f64.exp() - 1.0);
    assert!((passive_force_length(1.3, 5.0, 0.6) - want).abs() < 1e-15);
    // continuous at l = 1
    assert!(passive_force_length(1.0 + 1e-9, 5.0, 0.6) < 1e-9);
}

#[test]
fn tendon_force_known_values_and_smooth_join() {
    let eps_toe = 0.609 * E0T;
    assert_eq!(tendon_force(0.0, E0T), 0.0);
    assert_eq!(tendon_force(-0.01, E0T), 0.0);
    assert!((tendon_force(eps_toe, E0T) - 0.33).abs() < 1e-15);
    // linear part: klin(ε0 − εtoe) + Ftoe = 1.712·0.391 + 0.33
    assert!((tendon_force(E0T, E0T) - (1.712 * 0.391 + 0.33)).abs() < 1e-13);
    // toe: 0.33 (e^{3·0.5} − 1)/(e^3 − 1) at half the toe strain
    let want = 0.33 * (1.5f64.exp() - 1.0) / (3.0f64.exp() - 1.0);
    assert!((tendon_force(0.5 * eps_toe, E0T) - want).abs() < 1e-15);
    // value continuity at εtoe
    let d = 1e-10;
    assert!((tendon_force(eps_toe + d, E0T) - tendon_force(eps_toe - d, E0T)).abs() < 1e-8);
    // slope continuity at εtoe: the Thelen constants join to 0.07 % (42.77 vs 42.80)
    let left = tendon_stiffness(eps_toe, E0T);
    let right = tendon_stiffness(eps_toe + 1e-12, E0T);
    assert!((right - 1.712 / E0T).abs() < 1e-12);
    let rel = (left - right).abs() / right;
    assert!(rel < 1e-3, "toe/linear slope mismatch {rel}");
    // stiffness is the derivative of the force (central differences)
    for &e in &[0.3 * eps_toe, 0.9 * eps_toe, 1.5 * eps_toe, 0.05] {
        let h = 1e-7;
        let fd = (tendon_force(e + h, E0T) - tendon_force(e - h, E0T)) / (2.0 * h);
        assert!(
            (fd - tendon_stiffness(e, E0T)).abs() < 1e-5 * fd.abs().max(1.0),
            "ε = {e}"
        );
    }
}

#[test]
fn force_velocity_known_values_and_slopes() {
    let (af, flen) = (0.25, 1.4);
    assert_eq!(force_velocity(0.0, af, flen), 1.0);
    assert_eq!(force_velocity(-1.0, af, flen), 0.0);
    assert_eq!(force_velocity(-1.5, af, flen), 0.0);
    // (1 − 0.5)/(1 + 0.5/0.25) = 1/6
    assert!((force_velocity(-0.5, af, flen) - 1.0 / 6.0).abs() < 1e-15);
    let c = 0.4 * 0.25 / 2.5;
    assert!((force_velocity(c, af, flen) - 1.2).abs() < 1e-15);
    assert!((force_velocity(1e6, af, flen) - flen).abs() < 1e-6);
    // continuity at 0 and slopes: concentric 1 + 1/Af = 5, eccentric twice that
    let h = 1e-7;
    let right = (force_velocity(h, af, flen) - 1.0) / h;
    let left = (1.0 - force_velocity(-h, af, flen)) / h;
    assert!((left - 5.0).abs() < 1e-5, "concentric slope {left}");
    assert!((right - 10.0).abs() < 1e-4, "eccentric slope {right}");
    assert!((right / left - 2.0).abs() < 1e-5);
    assert!((force_velocity(1e-12, af, flen) - force_velocity(-1e-12, af, flen)).abs() < 1e-10);
    // the twice-slope property holds for any Af, Flen
    for &(af, flen) in &[(0.1, 1.2), (0.5, 1.8), (0.25, 2.0)] {
        let r = (force_velocity(h, af, flen) - 1.0) / h;
        let l = (1.0 - force_velocity(-h, af, flen)) / h;
        assert!((r / l - 2.0).abs() < 1e-4, "Af {af} Flen {flen}: {}", r / l);
    }
}

#[test]
fn precomputed_curves_equal_free_functions() {
    let p = CurveParams::default();
    let c = Curves::new(&p, p.flen);
    for k in 0..200 {
        let x = -0.5 + 2.5 * k as f64 / 200.0;
        assert!((c.fl(x) - active_force_length(x, p.gamma)).abs() < 1e-15);
        assert!((c.fpe(x) - passive_force_length(x, p.kpe, p.e0m)).abs() < 1e-12);
        let e = x * 0.1;
        assert!((c.ft(e) - tendon_force(e, p.e0t)).abs() < 1e-12);
        assert!((c.dft(e) - tendon_stiffness(e, p.e0t)).abs() < 1e-9);
        assert!((c.fv(x - 1.0) - force_velocity(x - 1.0, p.af, p.flen)).abs() < 1e-14);
    }
}

#[test]
fn manal_buchanan_formulas_and_continuity() {
    let mb = ManalBuchanan::new(0.08);
    let s = 0.08 / 2f64.sqrt();
    assert!((mb.u0 - (0.3085 - s)).abs() < 1e-15);
    assert!((mb.a0 - (0.3085 + s)).abs() < 1e-15);
    assert!((mb.m - (1.0 - mb.a0) / (1.0 - mb.u0)).abs() < 1e-15);
    assert_eq!(mb.apply(0.0), 0.0);
    assert!((mb.apply(1.0) - 1.0).abs() < 1e-15);
    assert!((mb.apply(mb.u0) - mb.a0).abs() < 1e-15);
    // value and slope continuous at u0
    let h = 1e-9;
    assert!((mb.apply(mb.u0 - h) - mb.apply(mb.u0 + h)).abs() < 1e-8);
    let log_slope = mb.alpha * mb.beta / (mb.beta * mb.u0 + 1.0);
    assert!((log_slope - mb.m).abs() < 1e-12, "{log_slope} vs {}", mb.m);
    // the log piece is α ln(βa + 1)
    let a = 0.1;
    assert!((mb.apply(a) - mb.alpha * (mb.beta * a + 1.0).ln()).abs() < 1e-15);
    // 50 % excitation gives more than 50 % activation (m·0.5 + 1 − m)
    assert!((mb.apply(0.5) - (0.5 * mb.m + 1.0 - mb.m)).abs() < 1e-15);
    assert!(mb.apply(0.5) > 0.57 && mb.apply(0.5) < 0.58);
    // monotone, concave below u0
    let mut prev = -1.0;
    for k in 0..=1000 {
        let v = mb.apply(k as f64 / 1000.0);
        assert!(v > prev);
        prev = v;
    }
    // A = 0 is the identity; the largest shape A = 0.12 is still continuous
    let id = ManalBuchanan::new(0.0);
    for &a in &[0.0, 0.1, 0.3, 0.77, 1.0] {
        assert_eq!(id.apply(a), a);
    }
    let mb12 = ManalBuchanan::new(0.12);
    assert!((mb12.apply(mb12.u0 - 1e-12) - mb12.a0).abs() < 1e-10);
    assert!((mb12.slope(mb12.u0 - 1e-12) - mb12.m).abs() < 1e-9);
    // small shapes tend to the identity
    let tiny = ManalBuchanan::new(1e-6);
    assert!((tiny.apply(0.2) - 0.2).abs() < 1e-5);
}

#[test]
fn activation_dynamics_constants() {
    let act = Activation::new(&ActivationParams::default());
    assert!((act.k2 - 20.0).abs() < 1e-12);
    assert!((act.k1 - (1.0 / 0.015 - 20.0)).abs() < 1e-12);
    // rising: (1 − 0)(k1 + k2) = 1/τact; falling: (0 − 1)(k2) = −1/τdeact
    assert!((act.rate(1.0, 0.0) - 1.0 / 0.015).abs() < 1e-9);
    assert!((act.rate(0.0, 1.0) + 1.0 / 0.05).abs() < 1e-9);
    // u is clamped to [0, 1]
    assert_eq!(act.rate(1.7, 0.2), act.rate(1.0, 0.2));
}

#[test]
fn moment_arm_is_the_derivative_of_the_length() {
    let p = ModelParams::nominal();
    for m in Muscle::ALL {
        let c = p.muscle(m).lmt_poly_m;
        for k in 0..=45 {
            let q = (-25.0 + k as f64).to_radians();
            let h = 1e-6;
            let fd = (lmt(&c, q + h) - lmt(&c, q - h)) / (2.0 * h);
            assert!((fd - moment_arm(&c, q)).abs() < 1e-9, "{m} q {q}");
            // plantarflexion moment arm positive, 3.5–5 cm, over −25°..+20°
            assert!(moment_arm(&c, q) > 0.035 && moment_arm(&c, q) < 0.05);
        }
        assert_eq!(lmt(&c, 0.0), c[0]);
    }
}

#[test]
fn pennation_constant_thickness_and_cap() {
    let pn = Pennation::new(0.05, 25.0);
    // at the optimal length α = α0
    assert!((pn.alpha(0.05).to_degrees() - 25.0).abs() < 1e-10);
    // constant thickness LM·sin α = h
    for &lm in &[0.03, 0.04, 0.06, 0.08] {
        assert!((lm * pn.alpha(lm).sin() - pn.h).abs() < 1e-15);
    }
    // capped at 84°
    assert!((pn.alpha(0.001).to_degrees() - 84.0).abs() < 1e-10);
    assert!((pn.alpha(pn.lm_cap * 0.5).to_degrees() - 84.0).abs() < 1e-10);
    // α0 = 0 gives no pennation
    assert_eq!(Pennation::new(0.05, 0.0).cos_alpha(0.04), 1.0);
}
