//! Component tests: segmentation, the dynamometer noise model and its whitening, the LM solver.

use diagnose::noise::{NoiseModelSource, Transient, TrialNoiseModel};
use diagnose::{lm, CvFolds, PhaseLabel, Segmentation};
use experiment::{
    unloaded_run, DynamometerCorrection, DynamometerSettings, Protocol, ProtocolTrace, Unloaded,
};
use muscle_model::EffectKind;

/// The protocol's trace and its segmentation with an envelope at rest in the relaxed parts
/// and 1 in the active ones.
fn segmented(protocol: &str) -> (ProtocolTrace, Segmentation) {
    let tr = protocol.parse::<Protocol>().unwrap().trace().unwrap();
    let env: Vec<f64> = tr
        .active
        .iter()
        .map(|a| if *a { 1.0 } else { 0.02 })
        .collect();
    let seg = Segmentation::new(&tr.angle_deg, tr.sample_rate_hz, Some(&env)).unwrap();
    (tr, seg)
}

#[test]
fn segments_relaxed_plus_two() {
    let (tr, seg) = segmented("relaxed+2");
    assert_eq!(seg.cycles.len(), 3);
    assert!(seg.cycles[0].relaxed && !seg.cycles[1].relaxed && !seg.cycles[2].relaxed);
    let truth = tr.events.all();
    assert_eq!(seg.events.len(), truth.len());
    for (a, b) in seg.events.iter().zip(&truth) {
        assert!((a - b).abs() < 1e-3, "event {a} vs {b}");
    }
    let n_relaxed = seg
        .phase
        .iter()
        .filter(|p| **p == PhaseLabel::Relaxed)
        .count();
    assert!((n_relaxed as f64 / tr.sample_rate_hz - 2.0 * 1.2167).abs() < 0.01);
}

/// The noise model of an unloaded run, as a diagnosis makes it.
fn unloaded_model(u: &Unloaded) -> TrialNoiseModel {
    let c = DynamometerCorrection::from_unloaded(u).unwrap();
    TrialNoiseModel::from_correction(&c, NoiseModelSource::Unloaded, u.len())
}

#[test]
fn noise_model_recovers_the_dynamometer_error() {
    let s = DynamometerSettings::default();
    let u = unloaded_run(&s, 5).unwrap();
    let fs = u.sample_rate_hz();
    let seg = Segmentation::new(&u.ankle_angle_deg, fs, None).unwrap();
    let m = unloaded_model(&u);
    assert!((m.offset_nm - s.offset_nm).abs() < 0.3, "{m:?}");
    let amp = m.transient.b_nm.hypot(m.transient.c_nm);
    assert!((amp - s.transient_amplitude_nm).abs() < 1.5, "{m:?}");
    assert!(
        (m.transient.freq_hz - s.transient_freq_hz).abs() < 1.0,
        "{m:?}"
    );
    let phi = s.ar1_phi(1.0 / fs);
    assert!((m.phi - phi).abs() < 0.01, "{m:?}");
    assert!((m.sd_ar_nm - s.ar1_sd_nm).abs() < 0.3, "{m:?}");
    assert!((m.sd_white_nm - s.white_sd_nm).abs() < 0.2, "{m:?}");
    // whitened remainder: unit variance, no lag-one correlation
    let times: Vec<f64> = (0..u.len()).map(|i| i as f64 / fs).collect();
    let sys = m.systematic(&times, &seg.events);
    let e: Vec<f64> = u.torque_nm.iter().zip(&sys).map(|(a, b)| a - b).collect();
    let plan = m.plan(e.len(), None);
    let mut w = vec![0.0; e.len()];
    plan.whiten(&e, &mut w);
    let n = w.len() as f64;
    let var = w.iter().map(|x| x * x).sum::<f64>() / n;
    let r1 = w.windows(2).map(|p| p[0] * p[1]).sum::<f64>() / n / var;
    assert!((var - 1.0).abs() < 0.1, "whitened variance {var}");
    assert!(r1.abs() < 0.05, "whitened lag-1 correlation {r1}");
}

#[test]
fn auto_folds_are_cycles_from_three_cycles_on_and_blocks_below() {
    for (protocol, cycles) in [("seed", 1), ("relaxed+1", 2), ("relaxed+2", 3)] {
        let (tr, seg) = segmented(protocol);
        assert_eq!(seg.cycles.len(), cycles, "{protocol}");
        let n = tr.len();
        let masks = CvFolds::Auto.held_out_masks(n, tr.sample_rate_hz, &seg.cycle);
        // every sample is held out exactly once
        for i in 0..n {
            assert_eq!(
                masks.iter().filter(|m| m[i]).count(),
                1,
                "{protocol} sample {i}"
            );
        }
        if cycles >= diagnose::MIN_CV_CYCLES {
            assert_eq!(
                masks,
                CvFolds::Cycles.held_out_masks(n, tr.sample_rate_hz, &seg.cycle)
            );
            assert_eq!(masks.len(), cycles, "{protocol}");
            // a cycle is held out with the hold after it, the first also with the hold
            // before it
            for (k, c) in seg.cycles.iter().enumerate() {
                assert!(
                    (c.start..c.end).all(|i| masks[k][i]),
                    "{protocol} cycle {k}"
                );
                if c.end < n && seg.cycle[c.end].is_none() {
                    assert!(masks[k][c.end], "{protocol}: the hold after cycle {k}");
                }
            }
            let first = seg.cycles[0].start;
            assert!(first > 0 && masks[0][0], "{protocol}: the opening hold");
            assert!(masks[cycles - 1][n - 1], "{protocol}: the closing hold");
            // the hold where the drive ramps up, between the relaxed cycle and the first
            // maximal one, goes with the relaxed cycle
            let ramp = seg.cycles[1].start - 1;
            assert!(
                seg.cycle[ramp].is_none() && masks[0][ramp],
                "{protocol}: the ramp-up hold"
            );
        } else {
            assert_eq!(masks.len(), 5, "{protocol}");
            // in runs of 0.5 s
            let first_switch = (1..n).find(|&i| masks[0][i] != masks[0][i - 1]).unwrap();
            assert_eq!(first_switch, (0.5 * tr.sample_rate_hz).round() as usize);
        }
    }
}

/// Relative L2 error of a fitted event transient against the true one over 0.5 s.
fn transient_error(m: &TrialNoiseModel, s: &DynamometerSettings) -> f64 {
    m.transient.relative_error(&spec_transient(s), 0.5, 2048.0)
}

fn spec_transient(s: &DynamometerSettings) -> Transient {
    Transient {
        b_nm: s.transient_amplitude_nm,
        c_nm: 0.0,
        tau_s: s.transient_tau_s,
        freq_hz: s.transient_freq_hz,
    }
}

#[test]
fn transient_is_fitted_by_generalised_least_squares() {
    // The AR(1) part (correlation time 30 ms) has much of its power where the transient
    // (12 Hz, 60 ms decay) lives. On these 16 unloaded runs the ordinary least-squares fit
    // of the template (before the GLS refit) had relative L2 errors of mean 0.24, largest
    // 0.45 (f as low as 10.3 Hz); the whitened (GLS) fit: mean 0.19, largest 0.35.
    let s = DynamometerSettings::default();
    let mut errs = Vec::new();
    for seed in 1..=16 {
        let u = unloaded_run(&s, seed).unwrap();
        let m = unloaded_model(&u);
        errs.push((seed, transient_error(&m, &s), m.transient.freq_hz));
    }
    eprintln!("seed, relative template error, f: {errs:?}");
    for (seed, e, f) in &errs {
        assert!(*e < 0.4, "seed {seed}: template error {e:.3} (f {f:.2} Hz)");
    }
    let mean = errs.iter().map(|e| e.1).sum::<f64>() / errs.len() as f64;
    assert!(mean < 0.22, "mean template error {mean:.3}");
}

#[test]
fn a_least_squares_start_in_the_wrong_basin_is_searched_again() {
    // On these two unloaded runs with the default dynamometer settings (of confusion-study
    // trials) the ordinary least-squares grid ends near 2.5 and 9.3 Hz, and a whitened
    // refinement around it alone stays there: the first would lose its transient (relative
    // template error 1.0), the second keep an error of 0.53.
    // The whitened search over the whole coarse grid finds the 12 Hz transient.
    let s = DynamometerSettings::default();
    for seed in [1_100_712, 500_711] {
        let u = unloaded_run(&s, seed).unwrap();
        let m = unloaded_model(&u);
        let e = transient_error(&m, &s);
        assert!(e < 0.3, "seed {seed}: template error {e:.3}: {m:?}");
        assert!(
            (m.transient.freq_hz - 12.0).abs() < 1.0,
            "seed {seed}: {m:?}"
        );
    }
}

#[test]
fn a_recording_without_a_transient_gets_none() {
    // Without the test of `experiment::TRANSIENT_MIN_EVIDENCE` the grid search fits the AR(1)
    // wander of such a run (τ near 1 s, B and C up to 300 N·m and nearly cancelling), and
    // that shape would be subtracted after every event of the trial.
    let s = DynamometerSettings {
        transient_amplitude_nm: 0.0,
        ..Default::default()
    };
    for seed in 5000..5004 {
        let u = unloaded_run(&s, seed).unwrap();
        let m = unloaded_model(&u);
        assert_eq!(m.transient, Transient::none(), "seed {seed}: {m:?}");
        assert!(
            (m.offset_nm - s.offset_nm).abs() < 0.5,
            "seed {seed}: {m:?}"
        );
    }
    // the default transient is kept, from the same noise
    let s = DynamometerSettings::default();
    for seed in 5000..5004 {
        let u = unloaded_run(&s, seed).unwrap();
        let m = unloaded_model(&u);
        let amp = m.transient.b_nm.hypot(m.transient.c_nm);
        assert!(
            (amp - 4.0).abs() < 1.5,
            "seed {seed}: amplitude {amp:.2}: {m:?}"
        );
    }
}

#[test]
fn levenberg_marquardt_solves_a_bounded_curve_fit() {
    // y = a·exp(−b t) with (a, b) = (2, 3), b bounded to [0, 2.5]: the fit sits on the bound.
    let t: Vec<f64> = (0..50).map(|i| i as f64 * 0.02).collect();
    let y: Vec<f64> = t.iter().map(|t| 2.0 * (-3.0 * t).exp()).collect();
    let f = |x: &[f64]| -> Option<Vec<f64>> {
        Some(
            t.iter()
                .zip(&y)
                .map(|(t, y)| x[0] * (-x[1] * t).exp() - y)
                .collect(),
        )
    };
    let free = lm::minimise(
        &f,
        &[1.0, 1.0],
        &[(0.0, 5.0), (0.0, 5.0)],
        &numerics::LevenbergMarquardtSettings::default(),
    )
    .unwrap();
    assert!(
        (free.x[0] - 2.0).abs() < 1e-4 && (free.x[1] - 3.0).abs() < 1e-4,
        "{:?}",
        free.x
    );
    let bounded = lm::minimise(
        &f,
        &[1.0, 1.0],
        &[(0.0, 5.0), (0.0, 2.5)],
        &numerics::LevenbergMarquardtSettings::default(),
    )
    .unwrap();
    assert!((bounded.x[1] - 2.5).abs() < 1e-12, "{:?}", bounded.x);
    assert!(bounded.cost > free.cost);
}

/// The fitting's integration settings reproduce the generator's reference integration with
/// every catalogued effect present.
///
/// Both sides are `muscle_model::simulate` on the same model inputs (the generator reads its
/// own trial back through `experiment::model_inputs`) with the same true parameters and
/// effects; they differ only in the settings: the generator's noise-free torque uses
/// `SimSettings::tight()` (reduced formulation, rtol 1e-10), the fits use
/// `SimSettings::default()` (fast formulation with precomputed activation, rtol 1e-6, the
/// settings of every `Problem`). So this checks the integration error of the default
/// settings and the agreement of the two formulations, per effect (TA channel on, random
/// parameters); it is not an independent check of the model's equations (that is
/// `tests/tests/independent_model.rs`). Measured RMS 0.8e-3 (electromechanical_delay) to
/// 2.8e-3 N·m (torque_offset); the tolerance, 0.01 N·m, is about 3.5 times the largest.
#[test]
fn default_settings_reproduce_the_generators_tight_integration_on_every_effect() {
    use muscle_model::{simulate, SimSettings};
    for (i, &kind) in EffectKind::ALL.iter().enumerate() {
        let t = diagnose::scenarios::hidden_trial(&[kind], true, 4242 + i as u64).unwrap();
        let inputs =
            experiment::model_inputs(&t.synthetic.trial, &experiment::InputOptions::default())
                .unwrap();
        let out = simulate(&inputs, &t.params, &t.effects, &SimSettings::default()).unwrap();
        let n = out.torque.len() as f64;
        let rms = (out
            .torque
            .iter()
            .zip(&t.synthetic.model_torque)
            .map(|(a, b)| (a - b) * (a - b))
            .sum::<f64>()
            / n)
            .sqrt();
        assert!(
            rms < 0.01,
            "{}: model vs generator RMS {rms} N·m",
            kind.name()
        );
    }
}

/// The structure test at an identified point with the activation's shape at zero, its lower
/// bound (where the calibration of a gait recording often puts it). The default bounds, which
/// set the difference step, keep an interval there (`[0, 0.016]`), and the step goes inward
/// from the bound.
#[test]
fn the_structure_test_runs_with_a_parameter_at_zero_on_its_bound() {
    use muscle_model::ParamId;
    let h = diagnose::scenarios::hidden_trial(&[], false, 7_301).unwrap();
    let (mut params, mut effects) = (h.params, h.effects);
    let shape = ParamId::Activation(2);
    shape.set(&mut params, &mut effects, 0.0);
    let mut free = ParamId::identified().to_vec();
    free.push(shape);
    let rec = diagnose::DiagnosisRecording::new(
        h.synthetic.inputs.clone(),
        h.synthetic.trial.torque_nm.clone(),
    )
    .with_model(params, effects);
    let settings = diagnose::DiagnoseSettings::default();
    let a = diagnose::adequacy_of_recording(&rec, None, &free, &settings)
        .unwrap_or_else(|e| panic!("the test did not run: {e}"));
    assert!(
        a.structure_p.is_finite() && (0.0..=1.0).contains(&a.structure_p),
        "{a:?}"
    );
    assert!(a.motion_df > 0 && a.time_df > 0, "{a:?}");
    let (lo, hi) = shape.default_bounds(&params, &effects);
    assert!(lo == 0.0 && hi > 0.0, "[{lo}, {hi}]");
}
