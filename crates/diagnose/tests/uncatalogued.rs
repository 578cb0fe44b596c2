//! A hidden effect that is **not** in the catalogue of docs/diagnosis.md: a slow sinusoidal
//! drift of the measured torque (amplitude 3–5 N·m, period 2–4 s, random phase), added to the
//! synthetic measured torque of a relaxed+2 trial (random true parameters, the noise of the
//! synthetic trials, unloaded run supplied, no catalogued effect).
//!
//! Rule (docs/studies/uncatalogued.md): the diagnosis must say the model is
//! deficient and set `unexplained_structure`, with a structure p-value well below the
//! threshold (≤ 10⁻⁴, threshold 10⁻³). It *may* name a catalogued cause that partly explains
//! the drift (observed: `viscous_damping`, `torque_offset`), because such a cause passed the
//! held-out/BIC rule on its own; the guard against reading it as the whole story is the flag,
//! and the final residual must still carry the structure (its time-block statistic above the
//! 10⁻³ χ² quantile).
//!
//! The test is one trial on a fixed seed. Over other base seeds the drift is flagged in about
//! 24 of 28 trials at 3–5 N·m (docs/studies/uncatalogued.md; in the misses viscous damping, with or
//! without gravity, absorbed most of the drift) and in about 15 of 21 at 1.5–3 N·m, which is
//! why the amplitude is drawn from 3–5 N·m.
//!
//! Seeds: base 20240601 (plus 41). `SURAE_DIAG_SEEDS=fresh` draws the base from the clock,
//! `SURAE_DIAG_SEEDS=<number>` uses that number; anything else fails. The seed is in every
//! failure.

mod common;

use diagnose::analysis::chi2_survival;
use diagnose::scenarios::hidden_trial;
use diagnose::Verdict;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// The base seed of the fixed trial.
const BASE: u64 = 20_240_601;

#[test]
fn slow_drift_is_flagged_as_unexplained_structure() {
    let seed = common::base_seed(BASE) + 41;
    let mut t = hidden_trial(&[], false, seed)
        .unwrap_or_else(|e| panic!("seed {seed}: synthesis failed: {e}"));
    // the drift's own draws come from a separate stream of the same seed
    let mut rng = ChaCha8Rng::seed_from_u64(seed ^ 0x5eed_d71f);
    let amp = 3.0 + 2.0 * rng.random::<f64>();
    let period = 2.0 + 2.0 * rng.random::<f64>();
    let phase = std::f64::consts::TAU * rng.random::<f64>();
    let times = t.synthetic.trial.time_s.clone();
    for (y, ti) in t.synthetic.trial.torque_nm.iter_mut().zip(&times) {
        *y += amp * (std::f64::consts::TAU * ti / period + phase).sin();
    }
    let d = common::diagnose_with_defaults(&t.synthetic.trial, &t.synthetic.unloaded, seed);
    let ra = &d.residual_analysis;
    // one line per run (`-- --nocapture`), for the pass-rate study of docs/studies/uncatalogued.md
    let line = format!(
        "drift seed {seed}: {amp:.2} N·m, {period:.2} s, structure p {:.2e} (motion LM {:.1}/{}, \
         time LM {:.1}/{}, ν {:.1}), causes {:?}",
        ra.structure_p_value,
        ra.extended_structure_lm,
        ra.structure_df,
        ra.extended_time_structure_lm,
        ra.time_structure_df,
        ra.noise_level_dof,
        d.causes
    );
    println!("{line}");
    let ctx = format!("{line}; summary:\n{}", d.summary_lines().join("\n"));
    assert!(d.unexplained_structure, "not flagged; {ctx}");
    assert_eq!(d.verdict, Verdict::Deficient, "{ctx}");
    assert!(
        ra.structure_p_value <= 1e-4,
        "weak structure evidence; {ctx}"
    );
    // the structure is still in the final residual, whatever was named
    assert!(
        chi2_survival(ra.extended_time_structure_lm, ra.time_structure_df) < 1e-3
            || chi2_survival(ra.extended_structure_lm, ra.structure_df) < 1e-3,
        "{ctx}"
    );
    // any named cause passed the acceptance rule (held-out gain and BIC) on its own
    for c in &d.causes {
        let rep = d
            .candidates
            .iter()
            .find(|r| &r.effect == c)
            .unwrap_or_else(|| panic!("{c} has no candidate report; {ctx}"));
        assert!(
            rep.accepted && rep.heldout_gain_pct.is_some_and(|g| g > 0.0),
            "{c}: named without passing the rule; {ctx}"
        );
    }
}

#[test]
fn chi2_survival_matches_known_values() {
    // χ²(2): exactly exp(−x/2)
    for x in [0.5, 2.0, 7.0, 30.0] {
        let p = chi2_survival(x, 2);
        assert!((p - (-x / 2.0_f64).exp()).abs() < 1e-12, "x {x}: {p}");
    }
    // table quantiles
    for (x, df, p) in [
        (3.841_459, 1, 0.05),
        (23.209_25, 10, 0.01),
        (65.170_76, 48, 0.05),
        (84.037_4, 48, 0.001),
    ] {
        let q = chi2_survival(x, df);
        assert!((q - p).abs() < 0.01 * p, "χ²({df}) > {x}: {q}, want {p}");
    }
    assert_eq!(chi2_survival(0.0, 5), 1.0);
    assert_eq!(chi2_survival(3.0, 0), 1.0);
}
