//! A window of a trial, as a calibration's search on a long recording uses it: after its
//! lead-in it simulates what the whole trial simulates there, and only its range is judged.

use muscle_model::{simulate, synthetic, Effects, ModelParams, Problem, SimSettings};

#[test]
fn a_window_after_its_lead_in_simulates_what_the_whole_trial_does() {
    let fs = 100.0;
    let inputs = synthetic::gait_like_trial(fs, 12.0).unwrap();
    let (p, e, s) = (
        ModelParams::nominal(),
        Effects::none(),
        SimSettings::default(),
    );
    let whole = simulate(&inputs, &p, &e, &s).unwrap().torque;
    let problem = Problem::standard(inputs.clone(), whole.clone()).unwrap();
    let (range, lead_in) = (400..700, 50);
    let w = problem.window(range.clone(), lead_in).unwrap();
    assert_eq!(w.inputs().len(), range.end - (range.start - lead_in));
    assert_eq!(w.inputs().t0(), inputs.times()[range.start - lead_in]);
    let weights = w.weights().unwrap();
    assert!(weights[..lead_in].iter().all(|&x| x == 0.0));
    assert!(weights[lead_in..].iter().all(|&x| x == 1.0));
    let windowed = w.predict(&w.base_vector()).unwrap();
    let worst = windowed[lead_in..]
        .iter()
        .zip(&whole[range.clone()])
        .map(|(a, b)| (a - b).abs())
        .fold(0.0, f64::max);
    let peak = whole.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    // the state forgets its start within the 0.5 s lead-in (activation τ 15–50 ms)
    assert!(worst < 1e-3 * peak, "{worst} N·m against a peak of {peak}");
    // the truth in the range and a wrong lead-in: the cost sees only the range
    let mut measured = whole[range.start - lead_in..range.end].to_vec();
    for m in &mut measured[..lead_in] {
        *m += 100.0;
    }
    let shifted = Problem::standard(w.inputs().clone(), measured)
        .unwrap()
        .with_weights(weights.to_vec())
        .unwrap();
    assert!(shifted.rms(&shifted.base_vector()).unwrap() < 1e-3 * peak);
}

#[test]
fn a_window_outside_the_trial_or_of_one_sample_is_refused() {
    let inputs = synthetic::gait_like_trial(100.0, 3.0).unwrap();
    let n = inputs.len();
    let problem = Problem::standard(inputs, vec![0.0; n]).unwrap();
    assert!(problem.window(n - 1..n + 5, 0).is_err());
    assert!(problem.window(10..11, 0).is_err());
    assert!(
        problem.window(10..20, 30).is_ok(),
        "a lead-in is cut at the start"
    );
}
