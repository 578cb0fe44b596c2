//! Trials with a single cycle (the `seed` protocol, as in the dissertation): the held-out error
//! comes from blocked folds (holding out the only cycle would leave nothing but holds to fit),
//! so it stays at the noise level for a correct model, and a clear effect is still named. The
//! folds themselves are tested in `components.rs`.

use diagnose::{no_observer, run, DiagnoseSettings, Verdict};
use experiment::{random_params, synthesize, Protocol, SynthConfig};
use muscle_model::{Effects, ModelParams};
use rand::SeedableRng;

fn seed_trial(seed: u64, effects: &str) -> experiment::Synthetic {
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
    let params = random_params(&mut rng, &ModelParams::nominal());
    let cfg = SynthConfig::new(Protocol::Seed, seed)
        .with_params(params)
        .with_effects(Effects::from_json_str(effects).unwrap());
    synthesize(&cfg).unwrap()
}

#[test]
fn one_cycle_trials_cross_validate_in_blocks() {
    let settings = DiagnoseSettings::default();
    for seed in [1, 2] {
        let syn = seed_trial(seed, "{}");
        let d = run(&syn.trial, Some(&syn.unloaded), &settings, &mut no_observer).unwrap();
        let summary = d.summary_lines().join("\n");
        assert_eq!(d.verdict, Verdict::Adequate, "seed {seed}:\n{summary}");
        assert_eq!(d.cv_folds, "5 folds of 0.5 s blocks");
        assert_eq!(d.to_json_value()["cv_folds"], "5 folds of 0.5 s blocks");
        // held out by cycle it is 2.0–2.5 N·m on seeds 1–3 (5.3 on the bundled seed trial)
        // against 1.1–1.2 N·m in sample
        assert!(
            d.baseline.heldout_rms_nm < 1.25 * d.baseline.rms_nm,
            "seed {seed}: held-out {} vs {} in sample",
            d.baseline.heldout_rms_nm,
            d.baseline.rms_nm
        );
    }
    let syn = seed_trial(3, r#"{"electromechanical_delay": {"delay_ms": 40}}"#);
    let d = run(&syn.trial, Some(&syn.unloaded), &settings, &mut no_observer).unwrap();
    let summary = d.summary_lines().join("\n");
    assert_eq!(
        d.causes,
        vec!["electromechanical_delay".to_string()],
        "{summary}"
    );
    assert!(d.gain.heldout_rms_reduction_pct > 50.0, "{summary}");
    let delay = d.extended.effects.as_ref().unwrap()["electromechanical_delay"]["delay_ms"];
    assert!((delay - 40.0).abs() < 8.0, "delay {delay}; {summary}");
}
