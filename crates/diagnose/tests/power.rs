//! The information limit (`diagnose::power`) on hidden-effect trials.

use diagnose::power::{noncentrality, rule_power, true_noise};
use diagnose::scenarios::{hidden_trial, hidden_trial_sized};
use diagnose::{DiagnoseError, DiagnoseSettings};
use experiment::DynamometerSettings;
use muscle_model::{Ar1White, EffectKind};

fn spec_noise() -> Ar1White {
    true_noise(&DynamometerSettings::default(), 2048.0).expect("valid noise")
}

#[test]
fn the_baseline_leaves_nothing_of_a_trial_without_effect() {
    let t = hidden_trial(&[], false, 4242).expect("trial");
    let info = noncentrality(
        &t.synthetic.trial,
        &t.synthetic.model_torque,
        &[],
        &spec_noise(),
        &DiagnoseSettings::default(),
    )
    .expect("fit");
    // the true parameters are inside the box: the fit run to convergence reaches them (λ = 1
    // would be a one-sigma effect; the rule needs about 20). The default stopping rule of the
    // diagnosis's fits leaves λ ≈ 0.5 on this trial.
    assert!(info.lambda < 0.1, "λ = {}", info.lambda);
    assert!(info.rms_nm < 0.02, "RMS {} N·m", info.rms_nm);
    assert!(info.n_obs > 10_000);
}

#[test]
fn noncentrality_grows_with_the_square_of_a_small_effect() {
    let settings = DiagnoseSettings::default();
    let lambda = |kind, size| {
        let t = hidden_trial_sized(kind, size, 977).expect("trial");
        noncentrality(
            &t.synthetic.trial,
            &t.synthetic.model_torque,
            &[],
            &spec_noise(),
            &settings,
        )
        .expect("fit")
        .lambda
    };
    for (kind, size) in [
        (EffectKind::Inertia, 0.1),
        (EffectKind::ElectromechanicalDelay, 5.0),
    ] {
        let (l1, l2) = (lambda(kind, size), lambda(kind, 2.0 * size));
        assert!(l1 > 1.0, "{}: λ = {l1}", kind.name());
        let ratio = l2 / l1;
        assert!(
            (3.4..4.6).contains(&ratio),
            "{}: λ {l1} at {size}, {l2} at twice that (ratio {ratio})",
            kind.name()
        );
    }
    // a 10 ms delay is far above the rule's reach; a 0.05 kg·m² inertia mostly below it
    let n = 17_000;
    assert!(
        rule_power(
            lambda(EffectKind::ElectromechanicalDelay, 10.0),
            1,
            n,
            -10.0
        ) > 0.99
    );
    assert!(rule_power(lambda(EffectKind::Inertia, 0.05), 1, n, -10.0) < 0.5);
}

#[test]
fn a_clean_torque_of_the_wrong_length_is_refused() {
    let t = hidden_trial(&[], false, 4243).expect("trial");
    let short = &t.synthetic.model_torque[..100];
    let err = noncentrality(
        &t.synthetic.trial,
        short,
        &[],
        &spec_noise(),
        &DiagnoseSettings::default(),
    )
    .expect_err("length");
    assert!(
        matches!(
            err,
            DiagnoseError::Settings {
                name: "clean_torque",
                ..
            }
        ),
        "{err}"
    );
    assert!(err.to_string().contains("got 100"), "{err}");
}

#[test]
fn an_effect_in_the_null_model_leaves_only_what_the_other_adds() {
    let settings = DiagnoseSettings::default();
    let lambda = |kind, size, null: &[EffectKind]| {
        let t = hidden_trial_sized(kind, size, 978).expect("trial");
        noncentrality(
            &t.synthetic.trial,
            &t.synthetic.model_torque,
            null,
            &spec_noise(),
            &settings,
        )
        .expect("fit")
        .lambda
    };
    // an offset against a null model with an offset: nothing left
    let offset = EffectKind::TorqueOffset;
    assert!(lambda(offset, 5.0, &[offset]) < 0.1);
    // a gravity term: the offset takes part of it, not all
    let g = EffectKind::Gravity;
    let (alone, beyond) = (lambda(g, 5.0, &[]), lambda(g, 5.0, &[offset]));
    assert!(
        beyond < alone && beyond > 0.5,
        "gravity 5 N·m: λ {alone} against the baseline, {beyond} against baseline + offset"
    );
}

#[test]
fn a_trials_detection_limit_is_where_the_rule_finds_the_effect_in_most_trials() {
    // The diagnosis of a no-effect trial reports, per effect it did not name, the size the
    // ΔBIC rule would name in 95 % of such trials. Hiding exactly that size in the same
    // subject and noise (the same seed draws the same parameters and noise), the information
    // limit of `power` must give the rule a high but not certain chance: the reported limit is
    // computed from the diagnosis's own fit and noise model, `power` from the true ones.
    let settings = DiagnoseSettings::default();
    let seed = 2026;
    let t = hidden_trial(&[], false, seed).expect("trial");
    let d = diagnose::run(
        &t.synthetic.trial,
        Some(&t.synthetic.unloaded),
        &settings,
        &mut diagnose::no_observer,
    )
    .expect("diagnosis");
    assert!(d.causes.is_empty(), "{:?}", d.causes);
    for kind in [EffectKind::TorqueOffset, EffectKind::Inertia] {
        let limit = d
            .candidates
            .iter()
            .find(|c| c.effect == kind.name())
            .and_then(|c| c.detection_limit)
            .expect("a detection limit");
        let hidden = hidden_trial_sized(kind, limit, seed).expect("trial");
        assert_eq!(hidden.params, t.params);
        let info = noncentrality(
            &hidden.synthetic.trial,
            &hidden.synthetic.model_torque,
            &[],
            &spec_noise(),
            &settings,
        )
        .expect("fit");
        let power = rule_power(
            info.lambda,
            kind.params().len(),
            info.n_obs,
            settings.max_delta_bic,
        );
        eprintln!(
            "{}: limit {limit:.4}, λ {:.1}, rule power {power:.3}",
            kind.name(),
            info.lambda
        );
        assert!((0.6..=0.999).contains(&power), "{}: {power}", kind.name());
    }
}
