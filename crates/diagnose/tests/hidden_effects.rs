//! Tests that hide an effect in a synthetic relaxed+2 trial (random true parameters inside the
//! identification bounds, a random realistic magnitude, the noise of the synthetic trials,
//! unloaded run supplied; [`diagnose::scenarios`]), run the diagnosis without telling it
//! anything, and check the named causes, the recovered magnitude and the held-out gain.
//!
//! Each test is one trial on a fixed seed: it shows that every step of the diagnosis works
//! for each effect, not how often it does. The detection rate per effect over many seeds is
//! `detection_rates.rs` (statistical tier), with the measured rates in its doc comment.
//!
//! Seeds: base 20240601 plus the test's offset. `SURAE_DIAG_SEEDS=fresh` draws the base from
//! the clock, `SURAE_DIAG_SEEDS=<number>` uses that number; anything else fails. The seed is in
//! every failure message; reproduce one with `SURAE_DIAG_SEEDS=<seed − offset>` or
//! `cargo run --release -p diagnose --example diag_one`. On other seeds a test can fail
//! without a fault: the magnitude tolerances below are set from these seeds' errors, and a
//! small antagonist or gravity term is missed more often than the other effects (rates in
//! `detection_rates.rs`).
//! `-- --nocapture` prints each recovered magnitude and its error.

mod common;

use diagnose::scenarios::{align_to_fit, headline, hidden_trial, HiddenTrial};
use diagnose::{DiagnoseSettings, Diagnosis, Verdict};
use muscle_model::EffectKind;

/// The base seed of the fixed trials.
const BASE: u64 = 20_240_601;

fn diagnose_hidden(kinds: &[EffectKind], with_ta: bool, offset: u64) -> (HiddenTrial, Diagnosis) {
    let seed = common::base_seed(BASE) + offset;
    let t = hidden_trial(kinds, with_ta, seed)
        .unwrap_or_else(|e| panic!("seed {seed}: synthesis failed: {e}"));
    let d = common::diagnose_with_defaults(&t.synthetic.trial, &t.synthetic.unloaded, seed);
    check_report(&d, seed);
    (t, d)
}

/// The keys of `diagnosis.json` (docs/formats.md) and the 20-line summary.
fn check_report(d: &Diagnosis, seed: u64) {
    let v = d.to_json_value();
    // relaxed+2 has three cycles: each is held out in turn
    assert_eq!(v["cv_folds"], "3 cycles held out in turn", "seed {seed}");
    for k in [
        "verdict",
        "causes",
        "unexplained_structure",
        "baseline",
        "extended",
        "gain",
        "candidates",
    ] {
        assert!(
            v.get(k).is_some(),
            "seed {seed}: diagnosis.json lacks `{k}`"
        );
    }
    for k in ["params", "rms_nm", "heldout_rms_nm"] {
        assert!(
            v["baseline"].get(k).is_some() && v["extended"].get(k).is_some(),
            "seed {seed}: `{k}`"
        );
    }
    assert!(
        v["extended"].get("effects").is_some_and(|e| e.is_object()),
        "seed {seed}"
    );
    assert!(
        v["gain"]["heldout_rms_reduction_pct"].is_number() && v["gain"]["delta_bic"].is_number()
    );
    assert_eq!(
        v["baseline"]["params"].as_object().map(|m| m.len()),
        Some(9),
        "seed {seed}"
    );
    assert!(
        d.summary_lines().len() <= 20,
        "seed {seed}: summary too long"
    );
}

/// Tolerance on the error of the headline magnitude (units of the headline: N·m, ms, /s, or
/// `Flen`), 2.5 times the largest error measured on the seeds of these tests (`-- --nocapture`
/// prints them; base 20240601):
///
/// | effect | tests (seed) | largest error | tolerance |
/// |---|---|---|---|
/// | `torque_offset` | 20240604, 20240611 | 0.27 N·m (3.6 %) | 0.70 N·m |
/// | `passive_joint_torque` | 20240605 | 0.044 N·m (0.5 %) | 0.11 N·m |
/// | `gravity` | 20240606 | 0.44 N·m (8.5 %) | 1.1 N·m |
/// | `electromechanical_delay` | 20240607, 20240611, 20240612 | 1.75 ms (2.3 %) | 4.4 ms |
/// | `fatigue` | 20240608, 20240612 | 0.0008 /s (6.2 %) | 0.002 /s |
/// | `antagonist_coactivation` | 20240609 | 1.14 N·m (12 %) | 2.9 N·m |
/// | `eccentric_enhancement` | 20240610 | 0.035 (2.1 %) | 0.09 |
///
/// The factor leaves room for small shifts of where a fit stops while still catching a fit
/// that stopped in the wrong basin. Gravity and the antagonist have the largest errors because
/// each trades against muscle parameters over this protocol: gravity's `m·sin(q − φ)` against
/// the tendon slack lengths and an offset, the antagonist's gain against sol α0 and F0
/// (posterior r ≈ −0.8, identify-mcmc example `ta_posterior`). The errors over many seeds are
/// in docs/diagnosis.md, and `detection_rates.rs` prints them.
fn tolerance(kind: EffectKind) -> f64 {
    match kind {
        EffectKind::TorqueOffset => 0.70,
        EffectKind::PassiveJointTorque => 0.11,
        EffectKind::Gravity => 1.1,
        EffectKind::ElectromechanicalDelay => 4.4,
        EffectKind::Fatigue => 0.002,
        EffectKind::AntagonistCoactivation => 2.9,
        EffectKind::EccentricEnhancement => 0.09,
        EffectKind::ViscousDamping | EffectKind::Inertia => {
            panic!("no test in this file hides {}", kind.name())
        }
    }
}

fn check_named(kinds: &[EffectKind], with_ta: bool, offset: u64) {
    let (t, d) = diagnose_hidden(kinds, with_ta, offset);
    let seed = t.seed;
    let mut want: Vec<String> = kinds.iter().map(|k| k.name().to_string()).collect();
    want.sort();
    let mut got = d.causes.clone();
    got.sort();
    let ctx = format!(
        "seed {seed}, hidden {}, summary:\n{}",
        serde_json::to_string(&t.effects).unwrap_or_default(),
        d.summary_lines().join("\n")
    );
    assert_eq!(got, want, "named causes differ; {ctx}");
    assert_eq!(d.verdict, Verdict::Deficient, "{ctx}");
    assert!(
        d.gain.heldout_rms_reduction_pct > 0.0
            && d.gain.delta_bic < DiagnoseSettings::default().max_delta_bic,
        "no held-out / BIC gain; {ctx}"
    );
    let effects = d.extended.effects.as_ref().expect("extended effects");
    for k in kinds {
        let truth = headline(*k, t.effects.values(*k).unwrap_or_default());
        let fitted = effects.get(k.name()).expect("fitted effect");
        let mut v = k.null_values();
        for (j, p) in k.params().iter().enumerate() {
            v[j] = fitted[p.name];
        }
        let got = headline(*k, v);
        let tol = tolerance(*k);
        let err = (got - truth).abs();
        println!(
            "seed {seed} {}: recovered {got:.4}, true {truth:.4}, error {err:.4} ({:.1} %)",
            k.name(),
            100.0 * err / truth.abs()
        );
        assert!(
            err <= tol,
            "{}: recovered {got:.4}, true {truth:.4}, error {err:.4} > tolerance {tol}; {ctx}",
            k.name()
        );
        let unc = d
            .extended
            .effect_uncertainty
            .as_ref()
            .and_then(|u| u.get(k.name()));
        assert!(
            unc.is_some_and(|u| u.values().all(|s| s.is_finite() && *s > 0.0)),
            "{}: no finite uncertainty; {ctx}",
            k.name()
        );
    }
    check_intervals(&t, &d, &ctx);
}

/// The reported 68 % profile intervals of the final model: every parameter has one and it
/// holds the fitted value, and each hidden effect's true parameters lie within three times the
/// interval's half on that side. (The coverage of the muscle parameters' intervals is not
/// checked per trial: when a fit lands in a corner of the box several of them miss together,
/// so a per-trial count says little. It is measured over many trials by the confusion study,
/// docs/diagnosis.md.)
fn check_intervals(t: &HiddenTrial, d: &Diagnosis, ctx: &str) {
    let holds_fit = |name: &str, fit: f64, iv: &diagnose::ParamInterval| {
        assert!(
            iv.lower <= fit && fit <= iv.upper && iv.upper > iv.lower,
            "{name}: fit {fit} outside its interval {iv:?}; {ctx}"
        );
    };
    let ints = d.extended.param_interval.as_ref().expect("param_interval");
    for id in muscle_model::ParamId::identified() {
        let name = id.name();
        let iv = ints
            .get(&name)
            .unwrap_or_else(|| panic!("{name}: no interval; {ctx}"));
        holds_fit(&name, d.extended.params[&name], iv);
    }
    let effects = d.extended.effects.as_ref().expect("extended effects");
    let eints = d
        .extended
        .effect_interval
        .as_ref()
        .expect("effect_interval");
    for (kind, vals) in effects {
        let k = EffectKind::from_name(kind).expect("a catalogued effect");
        let Some(truth) = t.effects.values(k) else {
            continue; // not hidden: a wrong cause, which the callers report
        };
        let mut fitted = k.null_values();
        for (j, p) in k.params().iter().enumerate() {
            fitted[j] = vals[p.name];
        }
        let truth = align_to_fit(k, truth, fitted);
        for (j, p) in k.params().iter().enumerate() {
            let iv = eints
                .get(kind)
                .and_then(|m| m.get(p.name))
                .unwrap_or_else(|| panic!("{kind}.{}: no interval; {ctx}", p.name));
            let fit = vals[p.name];
            holds_fit(p.name, fit, iv);
            // an interval that reaches a bound on the truth's side holds it
            let (room, open) = if truth[j] < fit {
                (fit - iv.lower, iv.lower_at_bound)
            } else {
                (iv.upper - fit, iv.upper_at_bound)
            };
            assert!(
                open || (fit - truth[j]).abs() <= 3.0 * room,
                "{kind}.{}: truth {} is more than 3 half-intervals from the fit {fit} {iv:?}; {ctx}",
                p.name,
                truth[j]
            );
        }
    }
}

fn check_adequate(with_ta: bool, offset: u64) {
    let (t, d) = diagnose_hidden(&[], with_ta, offset);
    let ctx = format!(
        "seed {}, summary:\n{}",
        t.seed,
        d.summary_lines().join("\n")
    );
    assert_eq!(d.verdict, Verdict::Adequate, "{ctx}");
    assert!(d.causes.is_empty(), "{ctx}");
    assert!(!d.unexplained_structure, "{ctx}");
    assert_eq!(d.gain.delta_bic, 0.0, "{ctx}");
    // the baseline residual is at the noise level of the unloaded run
    assert!(d.baseline.rms_nm < 1.25 * d.noise.remainder_rms_nm, "{ctx}");
    check_intervals(&t, &d, &ctx);
}

#[test]
fn no_effect_is_adequate() {
    check_adequate(false, 1);
}

#[test]
fn no_effect_with_ta_channel_is_adequate() {
    check_adequate(true, 2);
}

#[test]
fn finds_torque_offset() {
    check_named(&[EffectKind::TorqueOffset], false, 3);
}

#[test]
fn finds_passive_joint_torque() {
    check_named(&[EffectKind::PassiveJointTorque], false, 4);
}

#[test]
fn finds_gravity() {
    check_named(&[EffectKind::Gravity], false, 5);
}

#[test]
fn finds_electromechanical_delay() {
    check_named(&[EffectKind::ElectromechanicalDelay], false, 6);
}

#[test]
fn finds_fatigue() {
    check_named(&[EffectKind::Fatigue], false, 7);
}

#[test]
fn finds_antagonist_coactivation() {
    check_named(&[EffectKind::AntagonistCoactivation], true, 8);
}

#[test]
fn finds_eccentric_enhancement() {
    check_named(&[EffectKind::EccentricEnhancement], false, 9);
}

#[test]
fn finds_two_effects_at_once() {
    check_named(
        &[EffectKind::ElectromechanicalDelay, EffectKind::TorqueOffset],
        false,
        10,
    );
}

/// A delay with fatigue: each alone may not lower the held-out error (each leaves the other's
/// error in the held-out cycles), so this also exercises the joint fit of pairs.
#[test]
fn finds_delay_with_fatigue() {
    check_named(
        &[EffectKind::ElectromechanicalDelay, EffectKind::Fatigue],
        false,
        11,
    );
}
