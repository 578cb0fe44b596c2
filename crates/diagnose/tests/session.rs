//! The joint diagnosis of synthetic 3-trial sessions (`knee0@30`, `knee90@30`, `knee0@60`,
//! each with its unloaded run at its own speed, nominal true parameters, the default
//! dynamometer noise): a delay hidden in every trial is named once, for the subject, near its
//! true value; an offset hidden in one trial is named for that trial only; a session without
//! an effect is adequate; a session of one trial is that trial's own diagnosis. The
//! `#[ignore]`d study repeats the three sessions over more seeds.

use diagnose::{
    diagnose_session, no_observer, run, DiagnoseSettings, DiagnosisRecording, EffectScope,
    HeldoutScheme, SessionDiagnosis, SessionMember, Verdict,
};
use experiment::synth_session::{session_trial_config, synthesize_session_configs};
use experiment::{
    model_inputs, synthesize, InputOptions, SynthConfig, SynthProtocol, Synthetic,
    UnloadedCorrection,
};
use muscle_model::{Effects, ModelParams};

/// The session's protocols and the names its trials take.
const PROTOCOLS: [(&str, &str); 3] = [
    ("knee0@30", "knee0_30"),
    ("knee90@30", "knee90_30"),
    ("knee0@60", "knee0_60"),
];

/// The three trials of one synthetic subject, trial `k` made from seed `seed + k` with
/// `effects(k)` hidden in it, the EMG normalised over the three trials as a session is read
/// (the flexed knee's gastrocnemius envelopes stay at about 0.7 of the extended knee's).
fn session(seed: u64, effects: impl Fn(usize) -> Effects) -> Vec<Synthetic> {
    let protocols: Vec<SynthProtocol> = PROTOCOLS.iter().map(|(p, _)| p.parse().unwrap()).collect();
    let configs: Vec<SynthConfig> = protocols
        .iter()
        .enumerate()
        .map(|(k, p)| {
            session_trial_config(p, k, seed, &ModelParams::nominal(), &Effects::none())
                .with_effects(effects(k))
        })
        .collect();
    synthesize_session_configs(&configs).unwrap()
}

/// The joint diagnosis with default settings, on the session-normalised inputs.
fn diagnose(trials: &[Synthetic]) -> SessionDiagnosis {
    let corrections: Vec<UnloadedCorrection> = trials
        .iter()
        .map(|s| UnloadedCorrection::fit(&s.unloaded).unwrap())
        .collect();
    let members: Vec<SessionMember<'_>> = trials
        .iter()
        .zip(&corrections)
        .zip(PROTOCOLS)
        .map(|((s, c), (_, name))| SessionMember {
            name: name.to_string(),
            recording: DiagnosisRecording::new(s.inputs.clone(), s.trial.torque_nm.clone())
                .with_model(ModelParams::nominal(), Effects::none()),
            unloaded: Some(c),
        })
        .collect();
    diagnose_session(&members, &DiagnoseSettings::default(), &mut no_observer).unwrap()
}

fn effects(json: &str) -> Effects {
    Effects::from_json_str(json).unwrap()
}

/// Tolerance on the shared delay (ms): over seed 7 and the study's 10 seeds the estimate was
/// 39.1–40.8 ms.
const DELAY_TOLERANCE_MS: f64 = 5.0;

/// Tolerance on a one-trial offset of 4 N·m (N·m): on the flexed knee the offset is nearly
/// collinear with the soleus's parameters (cosine 0.93), which take part of it; over seed 7 and
/// the study's 10 seeds the estimate was 3.15–4.73 N·m.
const OFFSET_TOLERANCE_NM: f64 = 1.0;

fn check_delay(d: &SessionDiagnosis, seed: u64) {
    assert_eq!(d.verdict, Verdict::Deficient, "seed {seed}");
    assert_eq!(d.causes.len(), 1, "seed {seed}: {:?}", d.causes);
    let c = &d.causes[0];
    assert_eq!(
        (c.effect.as_str(), c.scope),
        ("electromechanical_delay", EffectScope::Subject)
    );
    assert!(c.per_trial.is_none());
    let ms = c.values.as_ref().unwrap()["delay_ms"];
    assert!(
        (ms - 40.0).abs() < DELAY_TOLERANCE_MS,
        "seed {seed}: delay {ms} ms"
    );
    assert_eq!(d.heldout.scheme, HeldoutScheme::LeaveOneTrialOut);
    assert!(d.heldout.rms_reduction_pct > 0.0, "{:?}", d.heldout);
    assert!(d.heldout.deviance_reduction > 0.0);
    assert!(d.delta_bic < -10.0);
    for (t, h) in d.trial_fits.iter().zip(&d.heldout.per_trial) {
        assert!(t.extended_rms_nm < t.baseline_rms_nm, "{t:?}");
        assert!(h.extended_rms_nm < h.baseline_rms_nm, "{h:?}");
    }
}

fn check_offset(d: &SessionDiagnosis, seed: u64) {
    assert_eq!(d.verdict, Verdict::Deficient, "seed {seed}");
    assert_eq!(d.causes.len(), 1, "seed {seed}: {:?}", d.causes);
    let c = &d.causes[0];
    assert_eq!(
        (c.effect.as_str(), c.scope),
        ("torque_offset", EffectScope::Trial)
    );
    assert!(c.values.is_none());
    let per = c.per_trial.as_ref().unwrap();
    assert_eq!(
        per.keys().map(String::as_str).collect::<Vec<_>>(),
        ["knee90_30"]
    );
    let nm = per["knee90_30"]["offset_nm"];
    assert!(
        (nm - 4.0).abs() < OFFSET_TOLERANCE_NM,
        "seed {seed}: offset {nm} N·m"
    );
    assert!(d.heldout.rms_reduction_pct > 0.0, "{:?}", d.heldout);
}

fn check_clean(d: &SessionDiagnosis, seed: u64) {
    assert_eq!(
        d.verdict,
        Verdict::Adequate,
        "seed {seed}: {:?} {:?}",
        d.causes,
        d.candidates.first()
    );
    assert!(d.causes.is_empty());
    assert_eq!(d.heldout.rms_reduction_pct, 0.0);
    assert_eq!(d.trial_fits.len(), 3);
}

const DELAY: &str = r#"{"electromechanical_delay": {"delay_ms": 40}}"#;
const OFFSET: &str = r#"{"torque_offset": {"offset_nm": 4.0}}"#;

#[test]
fn a_delay_hidden_in_every_trial_is_named_once_for_the_subject() {
    let d = diagnose(&session(7, |_| effects(DELAY)));
    check_delay(&d, 7);
}

#[test]
fn an_offset_hidden_in_one_trial_is_named_for_that_trial() {
    let d = diagnose(&session(7, |k| {
        if k == 1 {
            effects(OFFSET)
        } else {
            Effects::none()
        }
    }));
    check_offset(&d, 7);
}

#[test]
fn a_session_without_an_effect_is_adequate() {
    let d = diagnose(&session(7, |_| Effects::none()));
    check_clean(&d, 7);
}

#[test]
fn a_session_of_one_trial_is_its_own_diagnosis() {
    let cfg =
        SynthConfig::for_protocol(PROTOCOLS[0].0.parse().unwrap(), 7).with_effects(effects(DELAY));
    let s = &synthesize(&cfg).unwrap();
    let correction = UnloadedCorrection::fit(&s.unloaded).unwrap();
    let one = SessionMember {
        name: "knee0_30".into(),
        recording: DiagnosisRecording::new(
            model_inputs(&s.trial, &InputOptions::default()).unwrap(),
            s.trial.torque_nm.clone(),
        ),
        unloaded: Some(&correction),
    };
    let settings = DiagnoseSettings::default();
    let d = diagnose_session(&[one], &settings, &mut no_observer).unwrap();
    let alone = run(&s.trial, Some(&s.unloaded), &settings, &mut no_observer).unwrap();
    assert_eq!(d, SessionDiagnosis::of_one_trial("knee0_30", &alone));
    assert_eq!(d.verdict, Verdict::Deficient);
    assert_eq!(d.causes[0].effect, "electromechanical_delay");
    assert_eq!(d.heldout.scheme, HeldoutScheme::WithinTrial);
}

/// The three cases over 10 further seeds each (about 3 minutes on 2 cores):
/// `cargo test --release -p diagnose --test session -- --ignored --nocapture`.
#[test]
#[ignore]
fn study_over_seeds() {
    for seed in (100..110).map(|s| s * 3) {
        let d = diagnose(&session(seed, |_| effects(DELAY)));
        let c = d.causes.first();
        eprintln!(
            "seed {seed} delay: {:?} {:?}",
            d.causes.iter().map(|c| &c.effect).collect::<Vec<_>>(),
            c.and_then(|c| c.values.clone())
        );
        check_delay(&d, seed);
        let d = diagnose(&session(seed, |k| {
            if k == 1 {
                effects(OFFSET)
            } else {
                Effects::none()
            }
        }));
        eprintln!(
            "seed {seed} offset: {:?} {:?}",
            d.causes.iter().map(|c| &c.effect).collect::<Vec<_>>(),
            d.causes.first().and_then(|c| c.per_trial.clone())
        );
        check_offset(&d, seed);
        let d = diagnose(&session(seed, |_| Effects::none()));
        eprintln!(
            "seed {seed} clean: {:?}",
            d.causes.iter().map(|c| &c.effect).collect::<Vec<_>>()
        );
        check_clean(&d, seed);
    }
}
