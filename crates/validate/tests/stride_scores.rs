//! Per-stride scores through [`validate`]: a trial with known strides has each stride inside
//! a held-out part scored alone, with the recording checks' flag carried through, and a trial
//! without strides has none.

use muscle_model::Problem;
use validate::{validate, FoldScheme, ValidateSettings, ValidationTrial};

#[test]
fn the_later_strides_of_a_trial_are_scored_one_by_one() {
    let syn = experiment::synthesize(&experiment::SynthConfig::new(experiment::Protocol::Seed, 3))
        .unwrap();
    // measured = the model's torque plus an offset that grows stride by stride
    let n = syn.model_torque.len();
    let stride = n / 10;
    let starts: Vec<usize> = (0..10).map(|k| k * stride).collect();
    // the last stride takes the remainder, so the strides tile the trial
    let ends: Vec<usize> = (1..=10)
        .map(|k| if k == 10 { n } else { k * stride })
        .collect();
    let flagged: Vec<bool> = (0..10).map(|k| k == 7).collect();
    let measured: Vec<f64> = syn
        .model_torque
        .iter()
        .enumerate()
        .map(|(i, t)| t + 0.5 * (i / stride) as f64)
        .collect();
    let with_strides = Problem::standard(syn.inputs.clone(), measured).unwrap();
    let without = Problem::standard(syn.inputs.clone(), syn.model_torque.clone()).unwrap();
    let trials = [
        ValidationTrial {
            name: "strided",
            condition: None,
            problem: &with_strides,
            stride_starts: Some(&starts),
            stride_ends: Some(&ends),
            stride_flagged: Some(&flagged),
        },
        ValidationTrial {
            name: "plain",
            condition: None,
            problem: &without,
            stride_starts: None,
            stride_ends: None,
            stride_flagged: None,
        },
    ];
    let mut settings = ValidateSettings::default();
    settings.sa = settings.sa.with_chains(1).with_chain_evaluations(300);
    let v = validate(&trials, &[FoldScheme::LaterStrides], &[], &settings).unwrap();
    let fold = &v.folds[0];
    let strided = fold.held_out.iter().find(|h| h.trial == "strided").unwrap();
    let plain = fold.held_out.iter().find(|h| h.trial == "plain").unwrap();
    assert!(plain.strides.is_empty());
    // split at the stride start nearest to half the trial: strides 5–9 are held out
    assert_eq!(strided.samples_range, 5 * stride..n);
    let idx: Vec<usize> = strided.strides.iter().map(|s| s.stride).collect();
    assert_eq!(idx, vec![5, 6, 7, 8, 9]);
    let times = with_strides.inputs().times();
    for s in &strided.strides {
        assert_eq!(s.flagged, s.stride == 7, "{s:?}");
        assert_eq!(
            s.samples,
            if s.stride == 9 {
                n - 9 * stride
            } else {
                stride
            }
        );
        assert_eq!(s.start_s, times[s.stride * stride]);
        assert!(s.end_s > s.start_s);
        assert!(s.model.rms_nm.is_finite() && s.linear.rms_nm.is_finite());
        assert!(s.peers.is_empty());
    }
    // the held-out strides tile the held-out part: their mean square errors, weighted by
    // samples, make the part's
    let (sw, ss) = strided.strides.iter().fold((0.0, 0.0), |(sw, ss), s| {
        (
            sw + s.samples as f64,
            ss + s.samples as f64 * s.model.rms_nm.powi(2),
        )
    });
    assert_eq!(sw as usize, strided.samples);
    assert!(((ss / sw).sqrt() - strided.model.rms_nm).abs() < 1e-9 * strided.model.rms_nm.max(1.0));
}
