//! Trials sampled below `LOW_RATE_BELOW_HZ` (envelopes exported at 100–250 Hz): smooth
//! interpolants between samples, tables at 400 Hz or more, the damped step controller
//! (docs/model.md, "Low-rate trials"); and the 2048 Hz path unchanged.
//!
//! `cargo test --release -p muscle-model --test low_rate -- --nocapture` prints the figures.

use muscle_model::inputs::LOW_RATE_BELOW_HZ;
use muscle_model::{
    simulate, synthetic, Effects, Formulation, ModelParams, SimSettings, SimStats, TrialInputs,
};
use numerics::rms_diff;

/// Rejected attempts over all attempts.
fn rejected_share(s: SimStats) -> f64 {
    s.rejected as f64 / (s.accepted + s.rejected) as f64
}

#[test]
fn a_100_hz_gait_trial_rejects_few_steps_and_costs_what_the_same_signal_at_2048_hz_costs() {
    let (p, e, s) = (
        ModelParams::nominal(),
        Effects::none(),
        SimSettings::default(),
    );
    let low = synthetic::gait_like_trial(100.0, 20.0).unwrap();
    let high = synthetic::gait_like_trial(2048.0, 20.0).unwrap();
    assert!(low.is_low_rate() && !high.is_low_rate());
    let sl = simulate(&low, &p, &e, &s).unwrap().total_stats();
    let sh = simulate(&high, &p, &e, &s).unwrap().total_stats();
    eprintln!(
        "100 Hz: {sl:?}, {:.1} % rejected; 2048 Hz: {sh:?}, {:.1} % rejected",
        100.0 * rejected_share(sl),
        100.0 * rejected_share(sh)
    );
    // measured 6.1 % and 1.17 times the 2048 Hz trial's right-hand sides (with the envelopes
    // read linearly between 100 Hz samples, walk36 had 29 % of 35 192 attempts rejected)
    assert!(rejected_share(sl) < 0.10, "{sl:?}");
    assert!(
        (sl.rhs_calls as f64) < 1.3 * sh.rhs_calls as f64,
        "{sl:?} vs {sh:?}"
    );
}

#[test]
fn low_rate_default_settings_agree_with_a_tight_run() {
    let tr = synthetic::gait_like_trial(100.0, 20.0).unwrap();
    let (p, e) = (ModelParams::nominal(), Effects::none());
    let tight = simulate(&tr, &p, &e, &SimSettings::tight()).unwrap();
    let fast = simulate(&tr, &p, &e, &SimSettings::default()).unwrap();
    // the fast formulation's tables at tight tolerances: what the tabulation alone costs
    let fast_tight = SimSettings {
        formulation: Formulation::Fast,
        ..SimSettings::tight()
    };
    let tables = simulate(&tr, &p, &e, &fast_tight).unwrap();
    let four = SimSettings {
        formulation: Formulation::FourState,
        ..SimSettings::default()
    };
    let four = simulate(&tr, &p, &e, &four).unwrap();
    let (d_fast, d_tables, d_four) = (
        rms_diff(&fast.torque, &tight.torque),
        rms_diff(&tables.torque, &tight.torque),
        rms_diff(&four.torque, &tight.torque),
    );
    eprintln!(
        "RMS from tight: default {d_fast:.2e}, fast tables at tight tolerances {d_tables:.2e}, \
         four-state default {d_four:.2e} N·m"
    );
    // measured 7.9e-4, 2.7e-6 and 2.3e-3 N·m; the budget of the default settings is 0.01
    assert!(d_fast < 3e-3, "{d_fast:e}");
    assert!(d_tables < 1e-5, "{d_tables:e}");
    assert!(d_four < 1e-2, "{d_four:e}");
}

/// Linear interpolation of `v` (samples at `fs`) at `t`.
fn linear(v: &[f64], fs: f64, t: f64) -> f64 {
    let x = (t * fs).clamp(0.0, (v.len() - 1) as f64);
    let i = (x as usize).min(v.len() - 2);
    v[i] + (x - i as f64) * (v[i + 1] - v[i])
}

#[test]
fn a_low_rate_trial_reads_a_smooth_signal_closer_than_straight_lines_would() {
    // the same smooth signals at 1600 Hz (the truth), at 100 Hz (read by the low-rate
    // cubics), and at 1600 Hz through straight lines between the 100 Hz samples (the 100 Hz
    // trial as it was read before; the angle is the cubic Hermite in both)
    let (fine, coarse) = (1600.0, 100.0);
    let secs = 12.0;
    let truth = synthetic::gait_like_trial(fine, secs).unwrap();
    let low = synthetic::gait_like_trial(coarse, secs).unwrap();
    let t = truth.times();
    let env = |v: &[f64]| {
        t.iter()
            .map(|&ti| linear(v, coarse, ti))
            .collect::<Vec<_>>()
    };
    let envs = [0, 1, 2].map(|j| env(low.envelope(muscle_model::Muscle::ALL[j])));
    let knee = env(low.knee_angle().unwrap());
    let angle = t.iter().map(|&ti| low.angle_value_at(ti)).collect();
    let lines = TrialInputs::new(fine, 0.0, angle, envs, None)
        .unwrap()
        .with_knee_angle(knee)
        .unwrap();
    let (p, e, s) = (
        ModelParams::nominal(),
        Effects::none(),
        SimSettings::tight(),
    );
    let at_coarse = |v: Vec<f64>| v.into_iter().step_by(16).collect::<Vec<_>>();
    let tau_truth = at_coarse(simulate(&truth, &p, &e, &s).unwrap().torque);
    let tau_lines = at_coarse(simulate(&lines, &p, &e, &s).unwrap().torque);
    let tau_low = simulate(&low, &p, &e, &s).unwrap().torque;
    assert_eq!(tau_low.len(), tau_truth.len());
    let (d_low, d_lines) = (
        rms_diff(&tau_low, &tau_truth),
        rms_diff(&tau_lines, &tau_truth),
    );
    eprintln!("RMS from the 1600 Hz signal: cubics {d_low:.2e}, straight lines {d_lines:.2e} N·m");
    assert!(d_low < 0.5 * d_lines, "{d_low:e} vs {d_lines:e}");
}

#[test]
fn the_low_rate_threshold_and_envelope_reading() {
    let at = |fs: f64| synthetic::gait_like_trial(fs, 2.0).unwrap();
    assert!(at(LOW_RATE_BELOW_HZ * 0.999).is_low_rate());
    assert!(!at(LOW_RATE_BELOW_HZ).is_low_rate());
    for fs in [100.0, 2048.0] {
        let tr = at(fs);
        let u = tr.envelope(muscle_model::Muscle::Gm);
        for i in 0..tr.len() - 1 {
            let ti = tr.times()[i];
            // through the samples (to the rounding of `t·fs`)
            assert!((tr.envelope_at(1, ti) - u[i]).abs() < 1e-14);
            let mid = tr.envelope_at(1, ti + 0.5 / fs);
            let (lo, hi) = (u[i].min(u[i + 1]), u[i].max(u[i + 1]));
            assert!(mid >= lo && mid <= hi, "fs {fs}, interval {i}");
            if fs > LOW_RATE_BELOW_HZ {
                assert!((mid - 0.5 * (u[i] + u[i + 1])).abs() < 1e-14);
            }
        }
    }
}

/// FNV-1a over the bits of `v`.
fn fnv(v: &[f64]) -> u64 {
    v.iter().fold(0xcbf2_9ce4_8422_2325, |h, x| {
        (h ^ x.to_bits()).wrapping_mul(0x0100_0000_01b3)
    })
}

#[test]
fn a_2048_hz_trial_is_simulated_as_before_bit_for_bit() {
    // the torque of `surae simulate` on the bundled trial, as written before low-rate trials
    // had their own reading (hashed from its simulate.csv), without and with a delay and
    // fatigue (a shifted activation table and ∫â)
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../../fixtures/seed/trial.csv");
    let trial = experiment::read_trial(path).unwrap();
    let inputs = experiment::model_inputs(&trial, &Default::default()).unwrap();
    assert!(!inputs.is_low_rate());
    let p = ModelParams::nominal();
    let s = SimSettings::default();
    let effects = Effects::from_json_str(
        r#"{"electromechanical_delay": {"delay_ms": 40}, "fatigue": {"rate_per_s": 0.03}}"#,
    )
    .unwrap();
    for (e, want) in [
        (Effects::none(), 0x6fee_a1c5_e99b_c15d_u64),
        (effects, 0xf7f1_a1bd_9f44_191a),
    ] {
        let got = fnv(&simulate(&inputs, &p, &e, &s).unwrap().torque);
        assert_eq!(got, want, "{got:#x}");
    }
}
