//! `validate` on a synthetic session whose truth is known: four isokinetic trials of one
//! subject (off-nominal parameters; the knee extended and flexed at two speeds, the speed the
//! condition), the model's torque plus white noise of σ = 1.5 N·m. A calibration that
//! generalises predicts every held-out part at the noise level; the truth, given as a peer,
//! scores σ; the linear baseline, which has no force–length or force–velocity relation, scores
//! worse. Every fold keeps a flexed-knee trial in its calibration: without one the
//! gastrocnemii cannot be told from the soleus, and a calibration on extended-knee trials alone
//! predicts a flexed-knee trial at about twice the noise (3.2 N·m measured with seed 2026).

use experiment::synth_session::{session_trial_config, synthesize_session_configs};
use experiment::{random_params, SynthProtocol};
use muscle_model::{Effects, ModelParams, Problem};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr_free::normal;
use validate::{validate, FoldScheme, Peer, ValidateSettings, ValidationTrial};

const SIGMA_NM: f64 = 1.5;

/// Standard normal draws by Box–Muller, so the test needs no distribution crate.
mod rand_distr_free {
    use rand::Rng;

    pub fn normal(rng: &mut impl Rng) -> f64 {
        let u1: f64 = rng.random::<f64>().max(f64::MIN_POSITIVE);
        let u2: f64 = rng.random();
        (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos()
    }
}

const NAMES: [&str; 4] = ["knee0_30", "knee90_30", "knee0_60", "knee90_60"];
const PROTOCOLS: [(&str, &str); 4] = [
    ("knee0@30", "slow"),
    ("knee90@30", "slow"),
    ("knee0@60", "fast"),
    ("knee90@60", "fast"),
];

/// The session's truth and its four trials' problems, the measured moment of trial `k` times
/// `gains[k]` (1: as simulated).
fn session(seed: u64, gains: [f64; 4]) -> (ModelParams, Vec<Problem>) {
    let truth = random_params(
        &mut ChaCha8Rng::seed_from_u64(seed),
        &ModelParams::nominal(),
    );
    let configs: Vec<_> = PROTOCOLS
        .iter()
        .enumerate()
        .map(|(k, (p, _))| {
            let p: SynthProtocol = p.parse().unwrap();
            session_trial_config(&p, k, seed, &truth, &Effects::none())
        })
        .collect();
    let syn = synthesize_session_configs(&configs).unwrap();
    let mut rng = ChaCha8Rng::seed_from_u64(seed + 1);
    let problems: Vec<Problem> = syn
        .iter()
        .zip(gains)
        .map(|(s, g)| {
            let measured = s
                .model_torque
                .iter()
                .map(|t| g * t + SIGMA_NM * normal(&mut rng))
                .collect();
            Problem::standard(s.inputs.clone(), measured).unwrap()
        })
        .collect();
    (truth, problems)
}

fn trials(problems: &[Problem]) -> Vec<ValidationTrial<'_>> {
    problems
        .iter()
        .zip(NAMES)
        .zip(PROTOCOLS)
        .map(|((p, name), (_, condition))| ValidationTrial {
            name,
            condition: Some(condition),
            problem: p,
            stride_starts: None,
            stride_ends: None,
            stride_flagged: None,
        })
        .collect()
}

#[test]
fn held_out_errors_are_at_the_noise_level_on_a_session_with_a_known_truth() {
    let seed = 2026;
    let (truth, problems) = session(seed, [1.0; 4]);
    let trials = trials(&problems);
    let mut settings = ValidateSettings::default();
    settings.sa = settings.sa.with_chains(2).with_chain_evaluations(2500);
    let peers = [Peer {
        name: "truth".into(),
        params: truth,
        effects: Effects::none(),
    }];
    let v = validate(&trials, &FoldScheme::ALL, &peers, &settings).unwrap();
    assert_eq!(v.folds.len(), 4 + 1 + 2);
    for s in &v.schemes {
        let name = s.scheme.name();
        println!(
            "{name}: model {:.3} N·m / R² {:.4}; truth {:.3}; linear {:.3} / {:.4} ({} parts)",
            s.model.rms_nm,
            s.model.r2,
            s.peers["truth"].rms_nm,
            s.linear.rms_nm,
            s.linear.r2,
            s.parts
        );
        let truth_rms = s.peers["truth"].rms_nm;
        assert!(
            (truth_rms / SIGMA_NM - 1.0).abs() < 0.05,
            "{name}: truth {truth_rms}"
        );
        assert!(
            s.model.rms_nm < 1.15 * SIGMA_NM,
            "{name}: held-out RMS {} against σ {SIGMA_NM}",
            s.model.rms_nm
        );
        assert!(
            s.model.rms_nm >= 0.95 * SIGMA_NM,
            "{name}: below the noise: {}",
            s.model.rms_nm
        );
        assert!(
            s.linear.rms_nm > s.model.rms_nm,
            "{name}: linear {}",
            s.linear.rms_nm
        );
    }
    // the later-strides fold calibrates on the first half of every trial and predicts the rest
    let later = v
        .folds
        .iter()
        .find(|f| f.scheme == FoldScheme::LaterStrides)
        .unwrap();
    assert_eq!(later.held_out.len(), 4);
    for h in &later.held_out {
        assert!(h.span_s.0 > 0.0 && h.span_s.1 > h.span_s.0, "{h:?}");
    }
    // the calibration's gain is right everywhere: no held-out part asks for another
    for f in &v.folds {
        for h in &f.held_out {
            let k = h.scale.expect("every part can be cut in two");
            assert!(!k.differs, "{} in {}: {k:?}", h.trial, f.name);
            assert!(
                (k.factor - 1.0).abs() < 0.03,
                "{} in {}: {k:?}",
                h.trial,
                f.name
            );
        }
    }
}

#[test]
fn a_trial_whose_moment_comes_at_another_gain_is_told_when_held_out() {
    // the last trial's moment at 0.75 times the others' (an EMG-to-moment gain that changed)
    let (_, problems) = session(2026, [1.0, 1.0, 1.0, 0.75]);
    let trials = trials(&problems);
    let mut settings = ValidateSettings::default();
    settings.sa = settings.sa.with_chains(2).with_chain_evaluations(2500);
    let v = validate(&trials, &[FoldScheme::LeaveOneTrialOut], &[], &settings).unwrap();
    let part = |name: &str| {
        v.folds
            .iter()
            .flat_map(|f| &f.held_out)
            .find(|h| h.trial == name)
            .unwrap()
    };
    let k = part("knee90_60").scale.unwrap();
    assert!(k.differs, "{k:?}");
    assert!((k.factor - 0.75).abs() < 0.05, "{k:?}");
    assert!(k.cross_validated_rms_nm < 0.5 * k.rms_nm, "{k:?}");
}

#[test]
fn folds_that_cannot_be_formed_are_one_line_errors() {
    let syn = experiment::synthesize(&experiment::SynthConfig::new(experiment::Protocol::Seed, 3))
        .unwrap();
    let p = Problem::standard(syn.inputs.clone(), syn.model_torque.clone()).unwrap();
    let one = [ValidationTrial {
        name: "only",
        condition: None,
        problem: &p,
        stride_starts: None,
        stride_ends: None,
        stride_flagged: None,
    }];
    let s = ValidateSettings::default();
    let e = validate(&one, &[FoldScheme::LeaveOneTrialOut], &[], &s).unwrap_err();
    assert_eq!(
        e.to_string(),
        "leave_one_trial_out: needs at least two trials"
    );
    let e = validate(&one, &[FoldScheme::LeaveOneConditionOut], &[], &s).unwrap_err();
    assert!(
        e.to_string().starts_with("only: has no condition label"),
        "{e}"
    );
    let mut bad = ValidateSettings::default();
    bad.later_fraction = 1.0;
    let e = validate(&one, &[FoldScheme::LaterStrides], &[], &bad).unwrap_err();
    assert!(e.to_string().contains("not within (0, 1)"), "{e}");
}
