//! Session-wide EMG normalisation: one reference per channel across trials.

use experiment::{
    envelope_peaks, model_inputs, model_inputs_referenced, synthesize, EmgReferences, InputOptions,
    SynthConfig,
};
use muscle_model::Muscle;

fn peak(v: &[f64]) -> f64 {
    v.iter().copied().fold(f64::NEG_INFINITY, f64::max)
}

#[test]
fn a_trial_referenced_to_its_own_peaks_is_normalised_exactly_as_alone() {
    let syn = synthesize(&SynthConfig::for_protocol("knee0@30".parse().unwrap(), 3)).unwrap();
    let opts = InputOptions::default();
    let refs = envelope_peaks(&syn.trial, &opts, "t.csv").unwrap();
    for ch in ["sol", "gm", "gl"] {
        assert!(refs.get(ch).unwrap() > 0.0, "{ch}");
    }
    let alone = model_inputs(&syn.trial, &opts).unwrap();
    let referenced = model_inputs_referenced(&syn.trial, &opts, &refs, "t.csv").unwrap();
    assert_eq!(alone, referenced);
}

#[test]
fn across_a_session_the_flexed_knee_keeps_its_weaker_gastrocnemius_drive() {
    let opts = InputOptions::default();
    let straight = synthesize(&SynthConfig::for_protocol("knee0@30".parse().unwrap(), 8)).unwrap();
    let flexed = synthesize(&SynthConfig::for_protocol("knee90@30".parse().unwrap(), 8)).unwrap();
    let peaks = [
        envelope_peaks(&straight.trial, &opts, "a").unwrap(),
        envelope_peaks(&flexed.trial, &opts, "b").unwrap(),
    ];
    let refs = EmgReferences::largest(&peaks);
    for (ch, v) in refs.iter() {
        assert_eq!(v, peaks[0].get(ch).unwrap().max(peaks[1].get(ch).unwrap()));
    }
    let a = model_inputs_referenced(&straight.trial, &opts, &refs, "a").unwrap();
    let b = model_inputs_referenced(&flexed.trial, &opts, &refs, "b").unwrap();
    // The soleus is driven alike in both trials; the gastrocnemii at 0.7 of it at 90°.
    let sol = peak(b.envelope(Muscle::Sol)) / peak(a.envelope(Muscle::Sol));
    assert!((sol - 1.0).abs() < 0.08, "sol {sol}");
    for m in [Muscle::Gm, Muscle::Gl] {
        let r = peak(b.envelope(m)) / peak(a.envelope(m));
        assert!((r - 0.7).abs() < 0.08, "{m:?} {r}");
    }
    // Per-trial normalisation would have put both peaks at 1.
    let alone = model_inputs(&flexed.trial, &opts).unwrap();
    assert_eq!(peak(alone.envelope(Muscle::Gm)), 1.0);
}

#[test]
fn a_bad_reference_is_an_error_naming_the_column() {
    let syn = synthesize(&SynthConfig::for_protocol("knee0@30".parse().unwrap(), 3)).unwrap();
    let mut refs = EmgReferences::default();
    refs.set("gm", -1.0);
    let e = model_inputs_referenced(&syn.trial, &InputOptions::default(), &refs, "t.csv")
        .unwrap_err()
        .to_string();
    assert!(e.contains("t.csv") && e.contains("emg_gm"), "{e}");
}
