//! Effects outside the catalogue (`diagnose::scenarios::Uncatalogued`: Coulomb friction in the
//! bearing, a linear drift of the torque cell, TA crosstalk into the soleus electrode, and a
//! strap that slips partway through the trial), hidden one per trial in a relaxed+2 trial with
//! random true muscle parameters, the synthetic dynamometer noise and its unloaded run.
//!
//! For friction and the drift the tests assert what docs/diagnosis.md ("Beyond the
//! catalogue") promises for them: no catalogued effect is named, the verdict is deficient with
//! `unexplained` set, `depends_on` starts with the variable the effect lives in (direction,
//! time), and the model extended with the flexible terms predicts held-out data better than
//! the final catalogued model (held-out deviance and RMS). For crosstalk and the slipping strap
//! the diagnosis does not keep that promise reliably (docs/diagnosis.md, "Known limits": on
//! the development seeds crosstalk was read as time or activation with catalogued effects
//! named beside it in 2 of 3 trials, the slip as time in 2 of 3 with a catalogued effect
//! named in 2 of 3); their tests assert what does hold, that such a trial is not called
//! adequate.
//!
//! Seeds: base 20251127; effect slot `s` (in `Uncatalogued::ALL` order) uses `base + 1000·s`.
//! `SURAE_DIAG_SEEDS=fresh` draws the base from the clock, `SURAE_DIAG_SEEDS=<number>` uses that
//! number; anything else fails. How often each passes on fresh seeds:
//! `cargo run --release -p diagnose --example uncatalogued -- 10 <base>` (docs/diagnosis.md).

mod common;

use diagnose::scenarios::{uncatalogued_trial, Uncatalogued};
use diagnose::Verdict;

/// The default base seed.
const BASE: u64 = 20_251_127;

/// The diagnosis of effect `kind`'s trial (slot `s` of `Uncatalogued::ALL`: seed
/// `base + 1000·s`), and a context line with the seed and the summary for failures.
fn diagnosed(kind: Uncatalogued) -> (diagnose::Diagnosis, String) {
    let slot = Uncatalogued::ALL
        .iter()
        .position(|k| *k == kind)
        .expect("in ALL") as u64;
    let seed = common::base_seed(BASE) + 1000 * slot;
    let t = uncatalogued_trial(kind, seed)
        .unwrap_or_else(|e| panic!("seed {seed}: synthesis failed: {e}"));
    let s = &t.hidden.synthetic;
    let d = common::diagnose_with_defaults(&s.trial, &s.unloaded, seed);
    let ctx = format!(
        "seed {seed}, {}; summary:\n{}",
        t.description,
        d.summary_lines().join("\n")
    );
    println!("{ctx}");
    (d, ctx)
}

fn check(kind: Uncatalogued) {
    let (d, ctx) = diagnosed(kind);
    assert!(
        d.causes.is_empty(),
        "a catalogued effect is named: {:?}; {ctx}",
        d.causes
    );
    assert_eq!(d.verdict, Verdict::Deficient, "{ctx}");
    assert!(d.unexplained_structure, "{ctx}");
    let u = d
        .unexplained
        .as_ref()
        .unwrap_or_else(|| panic!("no `unexplained`; {ctx}"));
    assert_eq!(
        u.depends_on.first(),
        Some(&kind.lives_in()),
        "depends_on {:?}; {ctx}",
        u.depends_on
    );
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
}

#[test]
fn coulomb_friction_lives_in_the_direction() {
    check(Uncatalogued::CoulombFriction);
}

#[test]
fn torque_drift_lives_in_time() {
    check(Uncatalogued::TorqueDrift);
}

/// The weaker promise: the trial is not called adequate.
fn noticed(kind: Uncatalogued) {
    let (d, ctx) = diagnosed(kind);
    assert_eq!(d.verdict, Verdict::Deficient, "{ctx}");
}

#[test]
fn emg_crosstalk_is_noticed() {
    noticed(Uncatalogued::EmgCrosstalk);
}

#[test]
fn strap_slip_is_noticed() {
    noticed(Uncatalogued::StrapSlip);
}
