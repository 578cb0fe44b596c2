//! The checks on fixtures/walk36 (61 s of treadmill walking at 3.6 km/h, 100 Hz, CEINMS-RT's
//! LowerLimbModel): what the trial is with and without its force file, which strides are
//! flagged and why, and the envelope scales of its two halves.

use std::path::PathBuf;

use experiment::Trial;
use recording::checks::{
    check_envelope_scales, check_trial_in_context, CheckSettings, ScaleTrial, TrialChecks,
    TrialContext, TrialKind,
};

/// The trial as fixtures/walk36/map.json reads it (the moment and the knee angle with sign
/// −1, the right foot's vertical ground reaction force), and whether the map says its EMG is
/// envelopes.
fn walk36() -> (Trial, bool) {
    let p = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../fixtures/walk36/map.json");
    let rec = recording::read_trial_recording(&recording::read_map(&p).unwrap()).unwrap();
    (rec.trial, rec.emg_is_envelope)
}

fn checks(trial: &Trial, envelope: bool) -> TrialChecks {
    check_trial_in_context(
        trial,
        None,
        &TrialContext {
            emg_is_envelope: envelope,
            ..TrialContext::default()
        },
        &CheckSettings::default(),
    )
}

#[test]
fn walk36_is_gait_with_or_without_its_force_file() {
    let (mut trial, envelope) = walk36();
    assert!(envelope && trial.grf_vertical_n.is_some());
    // without XLD.mot (as `surae inspect emgFilt.sto ik.sto id.sto` reads it): gait from the
    // sweeps; no isokinetic warning and no plateau list
    trial.grf_vertical_n = None;
    let c = checks(&trial, false);
    assert_eq!(c.kind, TrialKind::Gait, "{}", c.kind_reason);
    assert!(
        c.kind_reason
            .contains("only 30 % of the ankle's 215 sweeps span 70 %"),
        "{}",
        c.kind_reason
    );
    assert!(c.motion.is_none() && c.strides.is_none());
    // the envelopes taken for raw EMG: the rate warning says what to do
    assert_eq!(c.warnings.len(), 1, "{:#?}", c.warnings);
    assert!(
        c.warnings[0].contains("below the 700 Hz") && c.warnings[0].contains("emg_is_envelope")
    );
    // as envelopes: no warning from the EMG
    let c = checks(&trial, true);
    assert!(c.is_clean(), "{:#?}", c.warnings);
    for l in c.summary_lines() {
        assert!(
            !l.contains("isokinetic: no:") && !l.contains("plateaus"),
            "{l}"
        );
    }
}

#[test]
fn walk36_strides_flagged_and_why() {
    let (trial, envelope) = walk36();
    let c = checks(&trial, envelope);
    assert_eq!(c.kind, TrialKind::Gait);
    let g = c.strides.as_ref().unwrap();
    assert_eq!(g.strides, 49);
    assert!((g.median_stride_s.unwrap() - 1.15).abs() < 0.01);
    assert!((g.median_stance_s.unwrap() - 0.75).abs() < 0.01);
    let got: Vec<(usize, Vec<&str>)> = g
        .flagged
        .iter()
        .map(|f| (f.stride, f.reasons.iter().map(|r| r.measure).collect()))
        .collect();
    // Not tuned: these are what the rules find. Three double strides (the force stays above
    // 20 N between two steps: the other foot on this belt) and the two strides around a
    // strike at 6.06 s, where the force creeps up to 50 N 0.2 s before the foot loads.
    assert_eq!(
        got,
        vec![
            (4, vec!["duration_s"]),
            (5, vec!["duration_s", "stance_s"]),
            (28, vec!["duration_s", "stance_s"]),
            (33, vec!["duration_s", "stance_s"]),
            (45, vec!["duration_s", "stance_s"]),
        ],
        "{:#?}",
        g.flagged
    );
    let starts: Vec<f64> = g.flagged.iter().map(|f| f.start_s).collect();
    assert_eq!(starts, vec![5.17, 6.06, 32.66, 39.57, 54.48]);
    // the moment itself is plausible in every stride: peak 72–82 N·m, no spike, no swing moment
    for m in &g.measures {
        let p = m.peak_moment_nm.unwrap();
        assert!((70.0..85.0).contains(&p), "{m:?}");
        assert!(m.swing_moment_nm.unwrap() < 5.0, "{m:?}");
    }
    // five warnings, one per stride, then nothing else
    assert_eq!(c.warnings.len(), 5, "{:#?}", c.warnings);
    assert!(c.warnings[2].starts_with("stride 28 (32.66–34.97 s): stride 2.31 s (median 1.15 s: a missed strike?); stance 1.91 s (median 0.75 s: the other foot on this belt?)"), "{}", c.warnings[2]);
    for l in c.summary_lines() {
        println!("{l}");
    }
}

/// One half of walk36 as a trial of a session.
struct Half {
    name: &'static str,
    moment: Vec<f64>,
    emg: Vec<(String, Vec<f64>)>,
}

impl Half {
    fn new(name: &'static str, t: &Trial, a: usize, b: usize) -> Self {
        Self {
            name,
            moment: t.torque_nm[a..b].to_vec(),
            emg: t
                .emg_channels()
                .into_iter()
                .map(|(n, x)| (n, x[a..b].to_vec()))
                .collect(),
        }
    }

    fn input(&self) -> ScaleTrial<'_> {
        ScaleTrial {
            name: self.name,
            moment_nm: &self.moment,
            emg: self
                .emg
                .iter()
                .map(|(n, x)| (n.clone(), x.as_slice()))
                .collect(),
        }
    }
}

#[test]
fn walk36_halves_have_the_same_envelope_scale() {
    let (t, _) = walk36();
    let n = t.len();
    let first = Half::new("first", &t, 0, n / 2);
    let mut second = Half::new("second", &t, n / 2, n);
    let s = CheckSettings::default();
    let c = check_envelope_scales(&[first.input(), second.input()], &s);
    assert!(c.flagged.is_empty(), "{c:#?}");
    // the soleus of the second half at 4 times the scale is flagged, against the first
    second.emg[0].1.iter_mut().for_each(|x| *x *= 4.0);
    let c = check_envelope_scales(&[first.input(), second.input()], &s);
    assert_eq!(c.flagged.len(), 1, "{c:#?}");
    let f = &c.flagged[0];
    assert_eq!(
        (f.trial.as_str(), f.against.as_deref(), f.channel.as_str()),
        ("second", Some("first"), "emg_sol")
    );
    assert!((f.factor - 4.0).abs() < 0.6, "{f:?}");
}
