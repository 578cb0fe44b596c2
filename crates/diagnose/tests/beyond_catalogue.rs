//! Effects outside the catalogue (`diagnose::scenarios::Uncatalogued`: Coulomb friction in the
//! bearing, a linear drift of the torque cell, TA crosstalk into the soleus electrode, and a
//! strap that slips partway through the trial), hidden one per trial in a relaxed+2 trial with
//! random true muscle parameters, the synthetic dynamometer noise and its unloaded run.
//!
//! For friction, the drift and the slipping strap the tests assert what docs/studies/uncatalogued.md ("Beyond the
//! catalogue") promises for them: no catalogued effect is named, the verdict is deficient with
//! `unexplained` set, `depends_on` starts with the variable the effect lives in (direction,
//! time, time), and the model extended with the flexible terms predicts held-out data better than
//! the final catalogued model (held-out deviance and RMS).
//!
//! Crosstalk is found in the raw EMG ("EMG crosstalk"): the soleus channel is corrected and
//! reported with its share of the TA's signal (within 5 standard errors of the true one), the
//! gastrocnemii are left alone, no catalogued effect is named, `depends_on` starts with
//! `activation`, and the model on the corrected EMG predicts held-out data better than on the
//! uncorrected. On trials whose TA is active without crosstalk the check corrects nothing and
//! its z statistics have the spread of a standard normal.
//!
//! The slipping strap gets the full promise of friction and the drift, with `time`.
//!
//! Seeds: base 20251127; effect slot `s` (in `Uncatalogued::ALL` order) uses `base + 1000·s`;
//! the null check of the crosstalk test uses `base + 5000 + i`, `i < 30`.
//! `SURAE_DIAG_SEEDS=fresh` draws the base from the clock, `SURAE_DIAG_SEEDS=<number>` uses that
//! number; anything else fails. How often each passes on fresh seeds:
//! `cargo run --release -p diagnose --example uncatalogued -- 10 <base>` (docs/studies/uncatalogued.md).

mod common;

use diagnose::scenarios::{hidden_trial, uncatalogued_trial, Uncatalogued, UncataloguedTrial};
use diagnose::{DiagnoseSettings, StateVariable, Verdict};
use experiment::emg_crosstalk;

/// The default base seed.
const BASE: u64 = 20_251_127;

/// The diagnosis of effect `kind`'s trial (slot `s` of `Uncatalogued::ALL`: seed
/// `base + 1000·s`), and a context line with the seed and the summary for failures.
fn diagnosed(kind: Uncatalogued) -> (diagnose::Diagnosis, String, UncataloguedTrial) {
    let slot = Uncatalogued::ALL
        .iter()
        .position(|k| *k == kind)
        .expect("in ALL") as u64;
    let out = diagnosed_at(kind, common::base_seed(BASE) + 1000 * slot);
    println!("{}", out.1);
    out
}

/// The diagnosis of the trial `seed` hiding `kind`, with a context line (the seed, the effect
/// and the summary) for failures.
fn diagnosed_at(kind: Uncatalogued, seed: u64) -> (diagnose::Diagnosis, String, UncataloguedTrial) {
    let t = uncatalogued_trial(kind, seed)
        .unwrap_or_else(|e| panic!("seed {seed}: synthesis failed: {e}"));
    let (d, ctx) = diagnosed_hidden(&t.hidden, &t.description, seed);
    (d, ctx, t)
}

/// The diagnosis of a trial `hidden` (made from `seed`, hiding what `description` says) with
/// its context line for failures.
fn diagnosed_hidden(
    hidden: &diagnose::scenarios::HiddenTrial,
    description: &str,
    seed: u64,
) -> (diagnose::Diagnosis, String) {
    let s = &hidden.synthetic;
    let d = common::diagnose_with_defaults(&s.trial, &s.unloaded, seed);
    let ctx = format!(
        "seed {seed}, {description}; summary:\n{}",
        d.summary_lines().join("\n")
    );
    (d, ctx)
}

/// The diagnosis of generated trial `seed` (an effect outside the catalogue) and its context,
/// asserting that no catalogued cause is named.
fn diagnosed_generated_without_a_cause(seed: u64) -> (diagnose::Diagnosis, String) {
    let t = diagnose::scenarios::generated_trial(seed)
        .unwrap_or_else(|e| panic!("seed {seed}: synthesis failed: {e}"));
    let (d, ctx) = diagnosed_hidden(&t.hidden, &t.description, seed);
    assert!(d.causes.is_empty(), "{:?}; {ctx}", d.causes);
    (d, ctx)
}

/// `d.unexplained`, asserting that `depends_on` starts with `v`.
fn depends_first<'a>(
    d: &'a diagnose::Diagnosis,
    v: StateVariable,
    ctx: &str,
) -> &'a diagnose::Unexplained {
    let u = d
        .unexplained
        .as_ref()
        .unwrap_or_else(|| panic!("no `unexplained`; {ctx}"));
    assert_eq!(
        u.depends_on.first(),
        Some(&v),
        "depends_on {:?}; {ctx}",
        u.depends_on
    );
    u
}

/// `u`'s extension and the level its term in `v` searched for a step.
fn searched_step_level<'a>(
    u: &'a diagnose::Unexplained,
    v: StateVariable,
    ctx: &str,
) -> (&'a diagnose::FlexibleExtension, &'a diagnose::SearchedValue) {
    let e = u
        .extension
        .as_ref()
        .unwrap_or_else(|| panic!("no extension; {ctx}"));
    let term = e
        .terms
        .iter()
        .find(|t| t.variable == v)
        .unwrap_or_else(|| panic!("no term in {v:?}; {ctx}"));
    let level = term
        .searched
        .iter()
        .find(|s| s.name == "step_level")
        .unwrap_or_else(|| panic!("no level searched: {:?}; {ctx}", term.searched));
    (e, level)
}

/// The lowest value of `v` at which generated trial `seed`'s disturbance is on (the step's
/// true level), and the range `v` spans in the trial.
fn lowest_on(seed: u64, v: StateVariable) -> (f64, f64) {
    let t = diagnose::scenarios::generated_trial(seed).unwrap();
    let x = v.samples(&t.hidden.synthetic.inputs).unwrap();
    let disturbance = t.disturbance_nm.as_ref().expect("a torque disturbance");
    let on = x
        .iter()
        .zip(disturbance)
        .filter(|(_, d)| d.abs() > 1e-9)
        .map(|(a, _)| *a)
        .fold(f64::INFINITY, f64::min);
    let span = x.iter().fold(f64::NEG_INFINITY, |m, a| m.max(*a))
        - x.iter().fold(f64::INFINITY, |m, a| m.min(*a));
    (on, span)
}

fn check(kind: Uncatalogued) {
    let (d, ctx, t) = diagnosed(kind);
    assert!(
        d.causes.is_empty(),
        "a catalogued effect is named: {:?}; {ctx}",
        d.causes
    );
    assert_eq!(d.verdict, Verdict::Deficient, "{ctx}");
    assert!(d.unexplained_structure, "{ctx}");
    let u = depends_first(&d, kind.lives_in(), &ctx);
    let e = u
        .extension
        .as_ref()
        .unwrap_or_else(|| panic!("no extension; {ctx}"));
    assert!(e.heldout_deviance_gain > 0.0, "{ctx}");
    assert!(
        e.heldout_rms_nm < d.extended.heldout_rms_nm && e.heldout_rms_reduction_pct > 0.0,
        "held-out RMS {} against {}; {ctx}",
        e.heldout_rms_nm,
        d.extended.heldout_rms_nm
    );
    // the term's shape has a finite band at every point it is reported at
    for term in &e.terms {
        assert_eq!(term.points.len(), term.value_nm.len());
        assert!(
            term.band_nm.iter().all(|b| b.is_finite() && *b >= 0.0),
            "{ctx}"
        );
    }
    // the values searched on the data: where the strap slipped, at which speed the friction
    // sets in (simulated as tanh(q̇ / 1 °/s))
    let searched = |name: &str| {
        e.terms
            .iter()
            .flat_map(|t| &t.searched)
            .find(|v| v.name == name)
            .map(|v| v.value)
    };
    match kind {
        Uncatalogued::StrapSlip => {
            let at = t.step_at_s.expect("a slip has a time");
            let found = searched("change_point");
            assert!(
                found.is_some_and(|c| (c - at).abs() < 0.1),
                "change point {found:?} for a slip at {at:.3} s; {ctx}"
            );
        }
        Uncatalogued::CoulombFriction => {
            let found = searched("transition_width");
            assert!(
                found.is_some_and(|w| (0.5..2.0).contains(&w)),
                "transition width {found:?} °/s for friction simulated at 1 °/s; {ctx}"
            );
        }
        _ => {}
    }
}

/// Trial `seed` hiding `kind`: no cause named, `depends_on` starts with `variable`, and the
/// review handed the catalogued `effect` the selection named to `variable`.
fn handed_over(kind: Uncatalogued, seed: u64, effect: &str, variable: StateVariable) {
    let (d, ctx, _) = diagnosed_at(kind, seed);
    assert!(d.causes.is_empty(), "{:?}; {ctx}", d.causes);
    let u = depends_first(&d, variable, &ctx);
    assert!(
        u.replaced
            .iter()
            .any(|r| r.effect == effect && r.variable == variable),
        "{:?}; {ctx}",
        u.replaced
    );
}

#[test]
fn coulomb_friction_lives_in_the_direction() {
    check(Uncatalogued::CoulombFriction);
}

#[test]
fn torque_drift_lives_in_time() {
    check(Uncatalogued::TorqueDrift);
}

#[test]
fn emg_crosstalk_is_found_in_the_raw_emg_and_corrected() {
    let (d, ctx, t) = diagnosed(Uncatalogued::EmgCrosstalk);
    assert!(d.causes.is_empty(), "named {:?}; {ctx}", d.causes);
    assert_eq!(d.verdict, Verdict::Deficient, "{ctx}");
    let checks = &d.emg_crosstalk;
    assert_eq!(checks.len(), 3, "{ctx}");
    let sol = &checks[0];
    assert_eq!(sol.channel, "emg_sol");
    assert!(sol.corrected, "{sol:?}; {ctx}");
    assert!(
        (sol.fraction - t.size).abs() < 5.0 * sol.fraction_se,
        "share {} ± {} for a true {}; {ctx}",
        sol.fraction,
        sol.fraction_se,
        t.size
    );
    for c in &checks[1..] {
        assert!(!c.corrected, "{c:?}; {ctx}");
    }
    depends_first(&d, StateVariable::Activation, &ctx);
    let c = d
        .emg_correction
        .as_ref()
        .unwrap_or_else(|| panic!("no correction; {ctx}"));
    assert_eq!(c.channels, ["emg_sol"], "{ctx}");
    assert!(c.heldout_deviance_gain > 0.0, "{c:?}; {ctx}");
    assert!(
        c.heldout_rms_nm < c.heldout_rms_uncorrected_nm && c.heldout_rms_reduction_pct > 0.0,
        "{c:?}; {ctx}"
    );
    // every fit of the diagnosis used the corrected envelopes
    assert_eq!(d.extended.heldout_rms_nm, c.heldout_rms_nm, "{ctx}");
}

/// TA active with the triceps (co-contraction, so the envelopes correlate) but no crosstalk:
/// 30 trials, 90 channel tests at a 10⁻³ false-alarm rate each.
#[test]
fn crosstalk_check_is_quiet_without_crosstalk() {
    let base = common::base_seed(BASE) + 5000;
    let settings = DiagnoseSettings::default();
    let mut z2 = Vec::new();
    for i in 0..30 {
        let seed = base + i;
        let t = hidden_trial(
            &[muscle_model::EffectKind::AntagonistCoactivation],
            true,
            seed,
        )
        .unwrap_or_else(|e| panic!("seed {seed}: synthesis failed: {e}"));
        let checks = emg_crosstalk(
            &t.synthetic.trial,
            &settings.crosstalk_settings(),
            settings.input_options.emg_is_envelope,
            "trial",
        )
        .unwrap_or_else(|e| panic!("seed {seed}: {e}"));
        assert_eq!(checks.len(), 3, "seed {seed}");
        for c in checks {
            assert!(!c.corrected, "seed {seed}: {c:?}");
            z2.push(c.z * c.z);
        }
    }
    // E z² = 1 under the null; the mean of 90 has a standard deviation of about 0.15
    let m = z2.iter().sum::<f64>() / z2.len() as f64;
    assert!((0.55..1.45).contains(&m), "mean z² {m} (base {base})");
}

/// A drift that fatigue's rate mimics in part (trial 9 301 001, −4.04 N·m over the trial:
/// the selection names fatigue) is handed to time by the review's ramp: twelve hats alone
/// cost eleven parameters more than the rate and left it named.
#[test]
fn a_drift_fatigue_mimics_is_handed_to_time() {
    handed_over(
        Uncatalogued::TorqueDrift,
        9_301_001,
        "fatigue",
        StateVariable::Time,
    );
}

#[test]
fn strap_slip_lives_in_time() {
    check(Uncatalogued::StrapSlip);
}

/// A friction that sets in below the direction term's still band (trial 9 500 000, 2.49 N·m:
/// the selection names viscous damping) is handed to `direction` by the term with its searched
/// transition width: with the fixed `sign(q̇)` damping kept its name beside it.
#[test]
fn a_friction_damping_mimics_is_handed_to_direction() {
    handed_over(
        Uncatalogued::CoulombFriction,
        9_500_000,
        "viscous_damping",
        StateVariable::Direction,
    );
}

/// A cause that only helps the extension along is not named: on trial 9 503 010 (a strap
/// that slips by +3.24 N·m at 5.1 s) an electromechanical delay lowers the BIC by more than
/// the margin, but either predicts the held-out cycles and holds worse than the model without
/// it, or the review hands it over to the term in time.
#[test]
fn a_delay_beside_a_slip_is_not_named() {
    let (d, ctx, _) = diagnosed_at(Uncatalogued::StrapSlip, 9_503_010);
    assert!(d.causes.is_empty(), "{:?}; {ctx}", d.causes);
    let u = depends_first(&d, StateVariable::Time, &ctx);
    let delay = d
        .candidates
        .iter()
        .find(|c| c.effect == "electromechanical_delay")
        .unwrap_or_else(|| panic!("no delay candidate; {ctx}"));
    let settings = DiagnoseSettings::default();
    assert!(
        delay.delta_bic.is_some_and(|b| b < settings.max_delta_bic),
        "the delay's refit does not pass the BIC margin; {ctx}"
    );
    let stays_out = delay
        .heldout_dev_gain
        .is_some_and(|g| g < settings.min_heldout_dev_gain);
    let handed = u
        .replaced
        .iter()
        .any(|r| r.effect == "electromechanical_delay" && r.variable == StateVariable::Time);
    assert!(stays_out || handed, "{:?}; {ctx}", u.replaced);
}

/// The vocabulary is ranked on one set of folds (0.5 s blocks) by the held-out deviance gain,
/// and `depends_on` is led by the best variable. On generated trial 63 717 492 (a logistic
/// function of the velocity, −4.85 N·m) the term in time on the blocks gained more held-out
/// deviance than the term in velocity on the cycles (1 043 against 993) while leaving a held-out
/// RMS of 2.3 N·m against the velocity's 1.6: with the two on different folds the structure was
/// put on `time`.
#[test]
fn a_function_of_the_velocity_is_put_on_the_velocity_when_ranked_on_one_set_of_folds() {
    let (d, ctx) = diagnosed_generated_without_a_cause(63_717_492);
    let u = depends_first(&d, StateVariable::Velocity, &ctx);
    let gains: Vec<f64> = u.ranking.iter().map(|r| r.heldout_deviance_gain).collect();
    assert!(
        gains.windows(2).all(|w| w[0] >= w[1]),
        "ranking not by the held-out gain: {gains:?}; {ctx}"
    );
    let of = |v: StateVariable| {
        u.ranking
            .iter()
            .find(|r| r.variable == v)
            .unwrap_or_else(|| panic!("{v:?} not ranked; {ctx}"))
    };
    // on the same blocks the velocity's term also leaves the lower held-out RMS
    let (velocity, time) = (of(StateVariable::Velocity), of(StateVariable::Time));
    assert!(
        velocity.heldout_rms_nm < time.heldout_rms_nm
            && velocity.heldout_rms_reduction_pct > time.heldout_rms_reduction_pct,
        "velocity {} N·m ({} %), time {} N·m ({} %); {ctx}",
        velocity.heldout_rms_nm,
        velocity.heldout_rms_reduction_pct,
        time.heldout_rms_nm,
        time.heldout_rms_reduction_pct
    );
}

/// A smooth step in the angle (generated trial 38 631 530) that gravity's sine follows in
/// part: the BIC held `gravity` against a term in the angle (two parameters against five),
/// while the term predicted the held-out cycles better. The contest now lets the held-out
/// samples decide in the cause's own variable (other than time), so the structure is reported
/// in `angle` with gravity among the replaced, and no cause is named.
#[test]
fn a_smooth_step_in_the_angle_is_not_told_as_gravity() {
    let (d, ctx) = diagnosed_generated_without_a_cause(38_631_530);
    let u = depends_first(&d, StateVariable::Angle, &ctx);
    let gravity = u
        .replaced
        .iter()
        .find(|r| r.effect == "gravity")
        .unwrap_or_else(|| panic!("gravity not among the replaced {:?}; {ctx}", u.replaced));
    assert_eq!(gravity.variable, StateVariable::Angle, "{ctx}");
    // replaced held out although the BIC held it
    let gain = gravity
        .heldout_deviance_gain
        .unwrap_or_else(|| panic!("replaced by the BIC review, not held out; {ctx}"));
    assert!(
        gain > DiagnoseSettings::default().min_flexible_gain,
        "{gain}; {ctx}"
    );
    assert!(
        gravity.delta_bic <= -DiagnoseSettings::default().flexible_margin_bic,
        "the BIC would have replaced it too: {}; {ctx}",
        gravity.delta_bic
    );
}

/// Generated trial `seed` with its disturbance rescaled to twice its detection size, its
/// diagnosis, the p-value of the wide bases (the smaller of the motion steps' and the time
/// blocks', Bonferroni-corrected over the two) and a context line for failures.
fn at_twice_detection(seed: u64) -> (diagnose::Diagnosis, f64, String) {
    use diagnose::analysis::{chi2_survival, f_survival};
    let g = diagnose::scenarios::generated_trial(seed)
        .unwrap_or_else(|e| panic!("seed {seed}: synthesis failed: {e}"));
    let settings = DiagnoseSettings::default();
    let disturbance = g.disturbance_nm.as_ref().expect("a torque disturbance");
    let unloaded = &g.hidden.synthetic.unloaded;
    let mut trial = g.hidden.synthetic.trial.clone();
    for (y, a) in trial.torque_nm.iter_mut().zip(disturbance) {
        *y -= a;
    }
    let detection =
        diagnose::power::disturbance_detection_size(&trial, Some(unloaded), disturbance, &settings)
            .unwrap_or_else(|e| panic!("seed {seed}: {e}"));
    let ratio = 2.0 * detection / g.size.abs();
    for (y, a) in trial.torque_nm.iter_mut().zip(disturbance) {
        *y += a * ratio;
    }
    let d = diagnose::run(
        &trial,
        Some(unloaded),
        &settings,
        &mut diagnose::no_observer,
    )
    .unwrap_or_else(|e| panic!("seed {seed}: {e}"));
    let ctx = format!(
        "seed {seed}, {} at {:.2} N·m; summary:\n{}",
        g.description,
        2.0 * detection,
        d.summary_lines().join("\n")
    );
    let ra = &d.residual_analysis;
    let p_motion = chi2_survival(ra.extended_structure_lm, ra.structure_df);
    let p_time = f_survival(
        ra.extended_time_structure_lm / ra.time_structure_df as f64,
        ra.time_structure_df,
        ra.noise_level_dof,
    );
    (d, 2.0 * p_motion.min(p_time), ctx)
}

/// Generated trial `seed` at twice its detection size: the wide bases alone stay above 10⁻³,
/// the vocabulary test's smallest p-value is on `variable`'s basis (split by the direction of
/// motion or not, as `by_direction` says), the trial is not called adequate, and no cause is
/// named. Returns the diagnosis and the trial's description.
fn flagged_by_the_vocabulary_alone(
    seed: u64,
    variable: StateVariable,
    by_direction: bool,
) -> (diagnose::Diagnosis, String) {
    let (d, p_wide, ctx) = at_twice_detection(seed);
    assert!(
        p_wide > 1e-3,
        "the wide bases alone find it (p {p_wide:.1e}); {ctx}"
    );
    let ra = &d.residual_analysis;
    assert_eq!(ra.vocabulary_structure_variable, Some(variable), "{ctx}");
    assert_eq!(ra.vocabulary_structure_by_direction, by_direction, "{ctx}");
    assert!(ra.structure_p_value < 1e-3, "{ctx}");
    assert_ne!(d.verdict, Verdict::Adequate, "{ctx}");
    assert!(d.causes.is_empty(), "{ctx}");
    (d, ctx)
}

/// A periodic function of the triceps activation (generated trial 61 813 641) at twice its
/// detection size: the motion steps (48 columns) and the time blocks (9) spread it thin and
/// together stay above 10⁻³; the activation's own flexible basis (four columns once centred)
/// sees it, so the trial is not called adequate.
#[test]
fn a_function_of_the_activation_at_twice_its_detection_size_is_flagged_by_its_own_basis() {
    flagged_by_the_vocabulary_alone(61_813_641, StateVariable::Activation, false);
}

/// A moment proportional to the acceleration with opposite signs in the two directions of
/// motion (generated trial 60 607 068, a direction × acceleration product) at twice its
/// detection size: it is odd in the direction, so the acceleration's hats (even in it) and the
/// direction's single column miss it, and the wide bases spread it thin; the acceleration's
/// hats split by the direction see it, and the trial is not called adequate. The structure is
/// told first by the acceleration's term fitted separately in each direction (the direction's
/// own term led before that form existed), with one shape per direction, and the extension
/// predicts the held-out samples better.
#[test]
fn a_product_of_the_direction_and_the_acceleration_is_flagged_by_the_split_basis() {
    let (d, ctx) = flagged_by_the_vocabulary_alone(60_607_068, StateVariable::Acceleration, true);
    let u = d.unexplained.as_ref().expect("unexplained");
    assert_eq!(u.depends_on[0], StateVariable::Acceleration, "{ctx}");
    assert!(u.depends_on.contains(&StateVariable::Direction), "{ctx}");
    assert!(u.ranking[0].by_direction, "{ctx}");
    assert_eq!(
        u.told_variables()[0],
        (StateVariable::Acceleration, true),
        "{ctx}"
    );
    let e = u.extension.as_ref().expect("an extension");
    let shapes: Vec<(StateVariable, Option<f64>)> =
        e.terms.iter().map(|t| (t.variable, t.direction)).collect();
    assert_eq!(
        shapes[..2],
        [
            (StateVariable::Acceleration, Some(-1.0)),
            (StateVariable::Acceleration, Some(1.0))
        ],
        "{ctx}"
    );
    assert!(e.heldout_deviance_gain > 0.0, "{ctx}");
}

/// A step of −3.04 N·m at one angle (generated trial 20 737 421). Five hats over the angle's
/// range only ramp through it, and the time term, which has a searched step, took it first
/// (`depends_on` time, angle). With a step at a searched level beside the angle's hats, the
/// angle leads, its term reports the level it found, and no cause is named.
#[test]
fn a_step_in_the_angle_is_put_on_the_angle_with_its_level() {
    let seed = 20_737_421;
    let (d, ctx) = diagnosed_generated_without_a_cause(seed);
    let u = depends_first(&d, StateVariable::Angle, &ctx);
    let (e, level) = searched_step_level(u, StateVariable::Angle, &ctx);
    let (truth, _) = lowest_on(seed, StateVariable::Angle);
    assert!(
        (level.value - truth).abs() < 1.0,
        "level {:.2}° found, the step is at {truth:.2}°; {ctx}",
        level.value
    );
    assert!(e.heldout_deviance_gain > 0.0, "{ctx}");
}

/// A step of the torque at one level of the triceps activation (a recruitment threshold), on
/// a trial whose activation reaches the levels near the step in one contraction only. Its
/// held-out blocks then hold nearly all the samples of one hat, and the step beside the hats
/// was carried into them with coefficients the training samples did not fix (held-out
/// deviance gain −1.7·10⁷): the time term's change point took the step (`depends_on` time).
/// Carried only along the directions the training samples fix at least half as well as the
/// full fit fixes its least determined one, the activation leads with its level near the
/// generator's.
#[test]
fn a_step_in_the_activation_is_put_on_the_activation_with_its_level() {
    let seed = 83_242_660;
    let (d, ctx) = diagnosed_generated_without_a_cause(seed);
    let u = depends_first(&d, StateVariable::Activation, &ctx);
    let ranked = &u.ranking[0];
    assert_eq!(ranked.variable, StateVariable::Activation, "{ctx}");
    assert!(ranked.heldout_deviance_gain > 0.0, "{ranked:?}; {ctx}");
    let (e, level) = searched_step_level(u, StateVariable::Activation, &ctx);
    let (on, span) = lowest_on(seed, StateVariable::Activation);
    assert!(
        (level.value - on).abs() < 0.05 * span,
        "level {:.4} found, the step is at {on:.4} (range {span:.4}); {ctx}",
        level.value
    );
    assert!(e.heldout_deviance_gain > 0.0, "{ctx}");
}
