//! The model's effects (`docs/model.md` section 5): exactly zero at the null value, expected sign and size, composable.

#![allow(clippy::needless_range_loop)] // index-parallel arrays read clearer in tests

mod common;

use common::{idx, max_diff};
use muscle_model::{
    simulate, synthetic, EffectKind, Effects, ModelError, ModelParams, SimOutput, SimSettings,
    TrialInputs,
};

const FS: f64 = 2048.0;

fn run(tr: &TrialInputs, e: &Effects) -> SimOutput {
    simulate(tr, &ModelParams::nominal(), e, &SimSettings::default()).unwrap()
}

fn with(kind: EffectKind, values: &[(&str, f64)]) -> Effects {
    let mut e = Effects::none();
    e.set_values(kind, kind.null_values());
    for (name, v) in values {
        e.set_param(kind, name, *v).unwrap();
    }
    e
}

#[test]
fn every_effect_is_exactly_zero_at_its_null_value() {
    let tr = synthetic::seed_like_trial(FS).unwrap();
    let base = run(&tr, &Effects::none());
    for kind in EffectKind::ALL {
        let out = run(&tr, &Effects::none().with_null(kind));
        assert_eq!(out.torque, base.torque, "{kind} at null changes the torque");
    }
    // all at null together
    let mut all = Effects::none();
    for kind in EffectKind::ALL {
        all = all.with_null(kind);
    }
    assert_eq!(run(&tr, &all).torque, base.torque);
}

#[test]
fn joint_level_effects_add_their_formula() {
    let tr = synthetic::seed_like_trial(FS).unwrap();
    let base = run(&tr, &Effects::none());
    let q = tr.angle();
    let check = |e: Effects, f: &dyn Fn(usize) -> f64, label: &str| {
        let out = run(&tr, &e);
        for i in 0..tr.len() {
            let d = out.torque[i] - base.torque[i];
            assert!(
                (d - f(i)).abs() < 1e-9,
                "{label} sample {i}: {d} vs {}",
                f(i)
            );
        }
    };
    check(
        with(EffectKind::TorqueOffset, &[("offset_nm", -1.5)]),
        &|_| -1.5,
        "offset",
    );
    check(
        with(
            EffectKind::PassiveJointTorque,
            &[("scale_nm", 0.8), ("stiffness_per_rad", 10.0)],
        ),
        &|i| 0.8 * ((10.0 * q[i]).exp() - 1.0),
        "passive",
    );
    check(
        with(
            EffectKind::Gravity,
            &[("moment_nm", 5.0), ("phase_deg", 30.0)],
        ),
        &|i| 5.0 * (q[i] - 30f64.to_radians()).sin(),
        "gravity",
    );
    // passive joint torque resists dorsiflexion: plantarflexion (> 0) at +15°
    let out = run(
        &tr,
        &with(
            EffectKind::PassiveJointTorque,
            &[("scale_nm", 1.0), ("stiffness_per_rad", 10.0)],
        ),
    );
    let d0 = out.torque[0] - base.torque[0];
    assert!((d0 - ((10.0 * 15f64.to_radians()).exp() - 1.0)).abs() < 1e-9 && d0 > 12.0);
}

#[test]
fn viscous_damping_and_inertia_follow_the_motion() {
    let tr = synthetic::seed_like_trial(FS).unwrap();
    let st = synthetic::seed_times();
    let base = run(&tr, &Effects::none());
    // damping: −30 °/s during the concentric cruise → τ += b·q̇ = −2·0.5236
    let out = run(
        &tr,
        &with(EffectKind::ViscousDamping, &[("b_nm_s_per_rad", 2.0)]),
    );
    let i = idx(FS, 0.5 * (st.concentric_start + st.reversal));
    let d = out.torque[i] - base.torque[i];
    assert!((d + 2.0 * 30f64.to_radians()).abs() < 1e-6, "damping {d}");
    // and +30 °/s in the eccentric cruise
    let i = idx(FS, 0.5 * (st.reversal + st.eccentric_end));
    let d = out.torque[i] - base.torque[i];
    assert!((d - 2.0 * 30f64.to_radians()).abs() < 1e-6, "damping {d}");
    // inertia: in the middle of the first acceleration ramp q̈ = −600 °/s² → τ −= I·q̈ > 0
    let out = run(&tr, &with(EffectKind::Inertia, &[("i_kg_m2", 0.1)]));
    let i = idx(FS, st.concentric_start + 0.025);
    let d = out.torque[i] - base.torque[i];
    assert!((d - 0.1 * 600f64.to_radians()).abs() < 0.01, "inertia {d}");
    // zero during the cruise
    let i = idx(FS, 0.5 * (st.concentric_start + st.reversal));
    assert!((out.torque[i] - base.torque[i]).abs() < 1e-6);
}

/// Time at which `v` first crosses `level` (linear interpolation between samples).
fn crossing(v: &[f64], level: f64, fs: f64) -> f64 {
    let k = v.iter().position(|&x| x >= level).unwrap();
    let frac = (level - v[k - 1]) / (v[k] - v[k - 1]);
    (k as f64 - 1.0 + frac) / fs
}

#[test]
fn electromechanical_delay_shifts_the_torque_onset() {
    let tr = synthetic::isometric_trial(FS, 1.0, 0.0, 1.0, 0.2).unwrap();
    let base = run(&tr, &Effects::none());
    let out = run(
        &tr,
        &with(EffectKind::ElectromechanicalDelay, &[("delay_ms", 40.0)]),
    );
    let rest = base.torque[0];
    let peak = base.torque[tr.len() - 1];
    for frac in [0.1, 0.5, 0.9] {
        let level = rest + frac * (peak - rest);
        let shift = crossing(&out.torque, level, FS) - crossing(&base.torque, level, FS);
        println!(
            "onset shift at {:.0} %: {:.3} ms",
            frac * 100.0,
            shift * 1e3
        );
        assert!((shift - 0.040).abs() < 0.5e-3, "shift {shift}");
    }
    // identical before the (undelayed) onset, and the same plateau
    assert!((out.torque[idx(FS, 0.19)] - base.torque[idx(FS, 0.19)]).abs() < 1e-6);
    assert!((out.torque[tr.len() - 1] - peak).abs() < 1e-3);
}

#[test]
fn fatigue_decays_the_active_torque() {
    let tr = synthetic::isometric_trial(FS, 3.0, 0.0, 1.0, 0.05).unwrap();
    let base = run(&tr, &Effects::none());
    let out = run(&tr, &with(EffectKind::Fatigue, &[("rate_per_s", 0.2)]));
    let rest = base.torque[0];
    // ∫â ≈ t − 0.05 s at full activation; active force × exp(−0.2·∫â)
    for t in [1.0, 2.0, 3.0] {
        let i = idx(FS, t);
        let ratio = (out.torque[i] - rest) / (base.torque[i] - rest);
        let expected = (-0.2f64 * (t - 0.05)).exp();
        println!("t {t}: active torque ratio {ratio:.4}, exp(−k∫â) ≈ {expected:.4}");
        assert!(ratio < 1.0);
        assert!(
            (ratio - expected).abs() < 0.03,
            "t {t}: {ratio} vs {expected}"
        );
    }
    // monotone decay after the rise
    let i1 = idx(FS, 0.5);
    assert!(out.torque[i1..].windows(2).all(|w| w[1] <= w[0] + 1e-9));
}

#[test]
fn antagonist_coactivation_subtracts_the_ta_activation() {
    let tr = synthetic::seed_like_trial(FS).unwrap();
    let base = run(&tr, &Effects::none());
    let out = run(
        &tr,
        &with(EffectKind::AntagonistCoactivation, &[("gain_nm", 20.0)]),
    );
    let a_ta = out.activation_ta.as_ref().unwrap();
    let mut max_a = 0.0_f64;
    for i in 0..tr.len() {
        let d = out.torque[i] - base.torque[i];
        assert!((d + 20.0 * a_ta[i]).abs() < 1e-9);
        assert!(
            a_ta[i] >= 0.05 - 1e-6 && a_ta[i] <= 0.15 + 1e-6,
            "a_TA {}",
            a_ta[i]
        );
        max_a = max_a.max(a_ta[i]);
    }
    // a_TA follows the TA envelope (0.05 → 0.15) through eq. 3
    assert!(max_a > 0.149, "{max_a}");
    // without emg_ta the effect is an error, not a silent zero
    let no_ta = synthetic::isometric_trial(512.0, 0.5, 0.0, 1.0, 0.1).unwrap();
    let err = simulate(
        &no_ta,
        &ModelParams::nominal(),
        &with(EffectKind::AntagonistCoactivation, &[("gain_nm", 20.0)]),
        &SimSettings::default(),
    )
    .unwrap_err();
    assert!(matches!(err, ModelError::InvalidInput { .. }));
}

#[test]
fn eccentric_enhancement_raises_eccentric_torque_only() {
    let tr = synthetic::seed_like_trial(FS).unwrap();
    let st = synthetic::seed_times();
    let base = run(&tr, &Effects::none());
    let out = run(
        &tr,
        &with(EffectKind::EccentricEnhancement, &[("flen", 1.8)]),
    );
    let ecc = idx(FS, 0.5 * (st.reversal + st.eccentric_end));
    let conc = idx(FS, 0.5 * (st.concentric_start + st.reversal));
    let gain = out.torque[ecc] / base.torque[ecc];
    let dc = (out.torque[conc] - base.torque[conc]).abs();
    println!("eccentric gain {gain:.4}, concentric change {dc:.2e} N·m");
    assert!(gain > 1.02 && gain < 1.3, "{gain}");
    assert!(dc < 0.05, "concentric change {dc}");
    // the same as changing curves.flen
    let mut p = ModelParams::nominal();
    p.curves.flen = 1.8;
    let viaparams = simulate(&tr, &p, &Effects::none(), &SimSettings::default()).unwrap();
    assert_eq!(viaparams.torque, out.torque);
}

#[test]
fn effects_compose() {
    let tr = synthetic::seed_like_trial(FS).unwrap();
    let base = run(&tr, &Effects::none());
    let kinds: [(EffectKind, &[(&str, f64)]); 5] = [
        (EffectKind::TorqueOffset, &[("offset_nm", 2.0)]),
        (
            EffectKind::Gravity,
            &[("moment_nm", -4.0), ("phase_deg", 10.0)],
        ),
        (EffectKind::ViscousDamping, &[("b_nm_s_per_rad", 1.0)]),
        (EffectKind::AntagonistCoactivation, &[("gain_nm", 10.0)]),
        (
            EffectKind::PassiveJointTorque,
            &[("scale_nm", 0.5), ("stiffness_per_rad", 6.0)],
        ),
    ];
    let mut all = Effects::none();
    let mut sum = base.torque.clone();
    for (k, v) in kinds {
        let single = run(&tr, &with(k, v));
        for i in 0..sum.len() {
            sum[i] += single.torque[i] - base.torque[i];
        }
        for (name, x) in v {
            all.set_param(k, name, *x).unwrap();
        }
    }
    assert_eq!(all.enabled().len(), 5);
    let together = run(&tr, &all);
    // joint-level effects are additive
    let diff = max_diff(&together.torque, &sum);
    assert!(diff < 1e-9, "{diff}");
    // the delay moves the muscle torque (and a_TA); joint-level terms add on top of it
    let mut d = Effects::none();
    d.set_param(EffectKind::ElectromechanicalDelay, "delay_ms", 30.0)
        .unwrap();
    let delayed = run(&tr, &d);
    d.set_param(EffectKind::TorqueOffset, "offset_nm", 2.0)
        .unwrap();
    let delayed_offset = run(&tr, &d);
    for i in 0..sum.len() {
        assert!((delayed_offset.torque[i] - delayed.torque[i] - 2.0).abs() < 1e-9);
    }
    assert!(max_diff(&delayed.torque, &base.torque) > 5.0);
    // and fatigue + delay + eccentric enhancement run together
    let mut e = all;
    e.set_param(EffectKind::Fatigue, "rate_per_s", 0.1).unwrap();
    e.set_param(EffectKind::EccentricEnhancement, "flen", 1.6)
        .unwrap();
    let out = run(&tr, &e);
    assert!(out.torque.iter().all(|t| t.is_finite()));
    assert!(max_diff(&out.torque, &together.torque) > 1.0);
}
