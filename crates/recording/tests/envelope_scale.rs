//! The envelope-scale check across a session's trials: the bundled three-trial session
//! (knee extended at 30 and 60 °/s, knee flexed at 30 °/s) passes, and passes no longer when
//! one trial's channel is rescaled.

use std::path::PathBuf;

use experiment::Trial;
use recording::checks::{check_envelope_scales, CheckSettings, ScaleTrial};

fn session3(name: &str) -> Trial {
    let p = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../../fixtures/session3")
        .join(format!("{name}.csv"));
    experiment::read_trial(&p).unwrap()
}

fn scale_trial<'a>(name: &'a str, t: &'a Trial) -> ScaleTrial<'a> {
    ScaleTrial {
        name,
        moment_nm: &t.torque_nm,
        emg: t.emg_channels().into_iter().collect(),
    }
}

const NAMES: [&str; 3] = ["knee0_30", "knee90_30", "knee0_60"];

#[test]
fn the_bundled_session_passes_and_a_rescaled_channel_does_not() {
    let trials: Vec<Trial> = NAMES.iter().map(|n| session3(n)).collect();
    let s = CheckSettings::default();
    let input: Vec<ScaleTrial> = NAMES
        .iter()
        .zip(&trials)
        .map(|(n, t)| scale_trial(n, t))
        .collect();
    let c = check_envelope_scales(&input, &s);
    assert!(c.flagged.is_empty() && c.warnings.is_empty(), "{c:#?}");
    assert_eq!(c.trials.len(), 3);
    assert!(c
        .trials
        .iter()
        .all(|t| t.moment_peak_nm.is_some() && t.envelope_peaks.len() == 3));
    assert_eq!((c.percentile, c.max_factor), (0.95, 3.0));

    // knee90_30's gastrocnemius medialis recorded at 5 times the gain
    let mut scaled = trials.clone();
    scaled[1].emg_gm.iter_mut().for_each(|x| *x *= 5.0);
    let input: Vec<ScaleTrial> = NAMES
        .iter()
        .zip(&scaled)
        .map(|(n, t)| scale_trial(n, t))
        .collect();
    let c = check_envelope_scales(&input, &s);
    assert_eq!(c.flagged.len(), 1, "{c:#?}");
    let f = &c.flagged[0];
    assert_eq!(
        (f.trial.as_str(), f.channel.as_str()),
        ("knee90_30", "emg_gm")
    );
    assert!(f.against.is_none());
    assert!(f.factor > 3.0 && f.factor < 8.0, "{f:?}");
    assert_eq!(c.warnings.len(), 1);
    assert!(
        c.warnings[0].starts_with("knee90_30: emg_gm: envelope ")
            && c.warnings[0].contains("× the session's median while the moment is "),
        "{}",
        c.warnings[0]
    );
    // a gain of two stays within the factor three
    let mut twice = trials.clone();
    twice[1].emg_gm.iter_mut().for_each(|x| *x *= 2.0);
    let input: Vec<ScaleTrial> = NAMES
        .iter()
        .zip(&twice)
        .map(|(n, t)| scale_trial(n, t))
        .collect();
    assert!(check_envelope_scales(&input, &s).flagged.is_empty());
}

#[test]
fn two_trials_are_compared_as_a_pair() {
    let (a, b) = (session3("knee0_30"), session3("knee0_60"));
    let mut b10 = b.clone();
    b10.emg_sol.iter_mut().for_each(|x| *x *= 0.1);
    let s = CheckSettings::default();
    let c = check_envelope_scales(&[scale_trial("a", &a), scale_trial("b", &b10)], &s);
    // one flag, on the trial with the larger envelope per moment, against the other
    assert_eq!(c.flagged.len(), 1, "{c:#?}");
    let f = &c.flagged[0];
    assert_eq!((f.trial.as_str(), f.against.as_deref()), ("a", Some("b")));
    assert_eq!(f.channel, "emg_sol");
    assert!(f.factor > 8.0 && f.factor < 12.0, "{f:?}");
    assert!(
        c.warnings[0].contains("× b's while the moment is"),
        "{}",
        c.warnings[0]
    );
    let clean = check_envelope_scales(&[scale_trial("a", &a), scale_trial("b", &b)], &s);
    assert!(clean.flagged.is_empty(), "{clean:#?}");
}

#[test]
fn a_trial_without_a_plantarflexion_moment_is_left_out() {
    let a = session3("knee0_30");
    let mut neg = session3("knee0_60");
    neg.torque_nm.iter_mut().for_each(|x| *x = -x.abs());
    let s = CheckSettings::default();
    let c = check_envelope_scales(&[scale_trial("a", &a), scale_trial("neg", &neg)], &s);
    assert!(c.flagged.is_empty());
    assert!(c.trials[1].moment_peak_nm.is_none());
    assert!(
        c.warnings[0].starts_with("neg: torque_nm: no positive"),
        "{:?}",
        c.warnings
    );
    // nothing at all, one trial, empty channels: no panic, nothing flagged
    assert!(check_envelope_scales(&[], &s).flagged.is_empty());
    assert!(check_envelope_scales(&[scale_trial("a", &a)], &s)
        .flagged
        .is_empty());
    let empty = Trial::default();
    let c = check_envelope_scales(&[scale_trial("a", &a), scale_trial("e", &empty)], &s);
    assert!(c.flagged.is_empty());
    serde_json::to_string(&c).unwrap();
}
