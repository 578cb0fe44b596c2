//! The synthetic experiment and the committed fixtures: the dynamometer-error statistics
//! (`docs/formats.md`, "Synthetic trials") of the residual of `fixtures/seed`, determinism
//! of `synthesize`, the `model_inputs` bridge, file round trips.

use std::path::PathBuf;

use experiment::{
    format_trial, format_unloaded, model_inputs, parse_trial, parse_unloaded, random_params,
    read_trial, read_unloaded, round_decimals, synthesize, systematic_error, DynamometerSettings,
    EmgMuscle, ErrorKind, ExperimentError, InputOptions, Protocol, SynthConfig,
};
use muscle_model::{simulate, EffectKind, Effects, ModelParams, ParamId, SimSettings};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use serde_json::Value;

fn fixtures_dir() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../fixtures")
}

fn mean(x: &[f64]) -> f64 {
    x.iter().sum::<f64>() / x.len() as f64
}

fn sd(x: &[f64]) -> f64 {
    let m = mean(x);
    (x.iter().map(|a| (a - m) * (a - m)).sum::<f64>() / (x.len() - 1) as f64).sqrt()
}

fn lag1(x: &[f64]) -> f64 {
    let m = mean(x);
    let v: f64 = x.iter().map(|a| (a - m) * (a - m)).sum();
    let c: f64 = x.windows(2).map(|w| (w[0] - m) * (w[1] - m)).sum();
    c / v
}

fn variance_pop(x: &[f64]) -> f64 {
    let m = mean(x);
    x.iter().map(|a| (a - m) * (a - m)).sum::<f64>() / x.len() as f64
}

fn read_truth(folder: &str) -> Value {
    let path = fixtures_dir().join(folder).join("truth.json");
    let text = std::fs::read_to_string(&path)
        .unwrap_or_else(|e| panic!("{}: {e} (run `cargo xtask gen-fixtures`)", path.display()));
    serde_json::from_str(&text).unwrap()
}

struct Truth {
    params: ModelParams,
    effects: Effects,
    sim: SimSettings,
    dynamometer: DynamometerSettings,
    protocol: Protocol,
}

fn parse_truth(v: &Value) -> Truth {
    Truth {
        params: ModelParams::nominal().merged_json(&v["params"]).unwrap(),
        effects: Effects::from_json(&v["effects"]).unwrap(),
        sim: serde_json::from_value(v["sim"].clone()).unwrap(),
        dynamometer: serde_json::from_value(v["dynamometer"].clone()).unwrap(),
        protocol: v["protocol"].as_str().unwrap().parse().unwrap(),
    }
}

/// Quantisation noise variance of the 12-bit ADC, `step²/12`.
fn quantisation_var(d: &DynamometerSettings) -> f64 {
    d.quantisation_step_nm().powi(2) / 12.0
}

/// The dynamometer error of the committed seed fixture. The residual `measured − simulate(truth)` is the
/// dynamometer error `ε` plus the ADC rounding, so:
/// * its mean is the offset (−1.5 N·m) plus the mean of the transients;
/// * its variance is the variance of the deterministic systematic part over the trial
///   (transients after the start, the reversal and the stop) plus `σ_AR² + σ_w²` plus `step²/12`;
///   we compare the standard deviation with the square root of that sum (not with the bare
///   `sqrt(1.2² + 0.4²)`, which ignores the transients) within 20 %;
/// * after removing the known systematic part, the lag-1 autocorrelation of an AR(1) with
///   `φ = exp(−dt/0.03 s)` plus independent white and rounding noise is
///   `σ_AR²·φ/(σ_AR² + σ_w² + step²/12)`; the sampling error of that estimate with an effective
///   ~50 independent AR(1) blocks in 3.3 s is about 0.02, so we allow ±0.05.
#[test]
fn seed_fixture_residual_has_the_dynamometer_error_statistics() {
    let truth_json = read_truth("seed");
    assert_eq!(truth_json["generator"], "cargo xtask gen-fixtures");
    let truth = parse_truth(&truth_json);
    assert_eq!(truth.protocol, Protocol::Seed);
    assert_eq!(truth.params, ModelParams::nominal());
    assert_eq!(truth.effects, Effects::none());
    assert_eq!(truth.dynamometer, DynamometerSettings::default());

    let trial = read_trial(fixtures_dir().join("seed/trial.csv")).unwrap();
    let inputs = model_inputs(&trial, &InputOptions::default()).unwrap();
    let model = simulate(&inputs, &truth.params, &truth.effects, &truth.sim).unwrap();
    let residual: Vec<f64> = trial
        .torque_nm
        .iter()
        .zip(&model.torque)
        .map(|(m, s)| m - s)
        .collect();

    let trace = truth.protocol.trace().unwrap();
    assert_eq!(trace.len(), trial.len());
    let systematic = systematic_error(&trace.time_s, &trace.events.all(), &truth.dynamometer);

    let d = &truth.dynamometer;
    let m = mean(&residual);
    let m_expected = mean(&systematic);
    println!("residual mean {m:.4} N·m (systematic part mean {m_expected:.4})");
    assert!(m > -4.0 && m < 1.0, "mean {m}");
    assert!((m - m_expected).abs() < 0.6, "mean {m} vs {m_expected}");

    let s = sd(&residual);
    let s_expected = (variance_pop(&systematic)
        + d.ar1_sd_nm.powi(2)
        + d.white_sd_nm.powi(2)
        + quantisation_var(d))
    .sqrt();
    println!(
        "residual sd {s:.4} N·m, expected {s_expected:.4} (bare random part {:.4})",
        d.random_sd_nm()
    );
    assert!(s > 0.8 && s < 4.0, "sd {s}");
    assert!((s / s_expected - 1.0).abs() < 0.2, "sd {s} vs {s_expected}");

    let random: Vec<f64> = residual
        .iter()
        .zip(&systematic)
        .map(|(r, e)| r - e)
        .collect();
    let phi = d.ar1_phi(trial.dt());
    let r1 = lag1(&random);
    let r1_expected = d.ar1_sd_nm.powi(2) * phi
        / (d.ar1_sd_nm.powi(2) + d.white_sd_nm.powi(2) + quantisation_var(d));
    println!("lag-1 autocorrelation {r1:.4}, expected {r1_expected:.4} (phi {phi:.5})");
    assert!(
        (r1 - r1_expected).abs() < 0.05,
        "lag-1 {r1} vs {r1_expected}"
    );
}

/// The unloaded run of the seed fixture: 3 cycles, torque sd in (0.8, 4) N·m and within 20 %
/// of `sqrt(var(systematic) + σ_AR² + σ_w² + step²/12)`.
#[test]
fn seed_fixture_unloaded_run_statistics() {
    let truth = parse_truth(&read_truth("seed"));
    let run = read_unloaded(fixtures_dir().join("seed/unloaded.csv")).unwrap();
    let trace = Protocol::unloaded().trace().unwrap();
    assert_eq!(run.len(), trace.len());
    assert_eq!(trace.events.reversals.len(), 5, "3 cycles back to back");
    let systematic = systematic_error(&trace.time_s, &trace.events.all(), &truth.dynamometer);
    let d = &truth.dynamometer;
    let s = sd(&run.torque_nm);
    let s_expected = (variance_pop(&systematic)
        + d.ar1_sd_nm.powi(2)
        + d.white_sd_nm.powi(2)
        + quantisation_var(d))
    .sqrt();
    println!("unloaded torque sd {s:.4} N·m, expected {s_expected:.4}");
    assert!(s > 0.8 && s < 4.0, "sd {s}");
    assert!((s / s_expected - 1.0).abs() < 0.2, "sd {s} vs {s_expected}");
    let m = mean(&run.torque_nm);
    assert!((m - mean(&systematic)).abs() < 0.6, "mean {m}");
}

/// Asserts that `params` moves every one of the 9 identified parameters off its nominal value
/// and keeps it strictly inside the identification bounds around nominal (LST ±5 %, F0 and
/// α0 ±20 %), and leaves every other parameter nominal.
fn assert_identified_off_nominal_inside_bounds(params: &ModelParams, folder: &str) {
    let nominal = ModelParams::nominal();
    let none = Effects::none();
    let mut rest = *params;
    let mut scratch = Effects::none();
    for id in ParamId::identified() {
        let v = id.get(params, &none);
        let v0 = id.get(&nominal, &none);
        let (lo, hi) = id.default_bounds(&nominal, &none);
        assert!(v != v0, "{folder}: {id} = {v} is the nominal value");
        assert!(
            lo < v && v < hi,
            "{folder}: {id} = {v} not inside ({lo}, {hi})"
        );
        id.set(&mut rest, &mut scratch, v0);
    }
    assert_eq!(
        rest, nominal,
        "{folder}: a parameter other than the 9 is off nominal"
    );
}

/// Every committed fixture reads back and writes again to exactly the committed bytes, its
/// truth names the right protocol, parameters and effect, and `emg_ta` is present exactly
/// when needed.
#[test]
fn committed_fixtures_are_canonical_and_consistent() {
    let mut folders = vec![("seed".to_string(), None), ("relaxed2".to_string(), None)];
    for k in EffectKind::ALL {
        folders.push((k.name().to_string(), Some(k)));
    }
    // the only fixture whose truth is not the nominal parameters
    folders.push(("offnominal".to_string(), None));
    for (folder, kind) in folders {
        let dir = fixtures_dir().join(&folder);
        let text = std::fs::read_to_string(dir.join("trial.csv")).unwrap();
        let trial = parse_trial(&text, "trial.csv").unwrap();
        assert_eq!(format_trial(&trial).unwrap(), text, "{folder}/trial.csv");
        assert_eq!(trial.comments.len(), 1, "{folder}: one comment line");
        assert!(trial.comments[0].contains("cargo xtask gen-fixtures"));
        let text = std::fs::read_to_string(dir.join("unloaded.csv")).unwrap();
        let run = parse_unloaded(&text, "unloaded.csv").unwrap();
        assert_eq!(
            format_unloaded(&run).unwrap(),
            text,
            "{folder}/unloaded.csv"
        );

        let truth_json = read_truth(&folder);
        assert_eq!(
            truth_json["generator"], "cargo xtask gen-fixtures",
            "{folder}"
        );
        let truth = parse_truth(&truth_json);
        if folder == "offnominal" {
            assert_eq!(truth.protocol, Protocol::Seed, "{folder}");
            assert_identified_off_nominal_inside_bounds(&truth.params, &folder);
        } else {
            assert_eq!(truth.params, ModelParams::nominal(), "{folder}");
        }
        match kind {
            None => assert_eq!(truth.effects, Effects::none(), "{folder}"),
            Some(k) => {
                assert_eq!(truth.effects.enabled(), vec![k], "{folder}");
                assert_eq!(truth.protocol, Protocol::Relaxed { cycles: 2 }, "{folder}");
                // A moderate magnitude: not the null value.
                let v = truth.effects.values(k).unwrap();
                assert!(
                    k.params().iter().zip(v).any(|(p, x)| x != p.null),
                    "{folder}: effect at its null value"
                );
            }
        }
        assert_eq!(
            trial.emg_ta.is_some(),
            kind == Some(EffectKind::AntagonistCoactivation),
            "{folder}: emg_ta"
        );
    }
}

#[test]
fn synthesize_is_deterministic_and_seeds_differ() {
    let a = synthesize(&SynthConfig::new(Protocol::Seed, 11)).unwrap();
    let b = synthesize(&SynthConfig::new(Protocol::Seed, 11)).unwrap();
    assert_eq!(a, b);
    assert_eq!(
        format_trial(&a.trial).unwrap(),
        format_trial(&b.trial).unwrap()
    );
    let c = synthesize(&SynthConfig::new(Protocol::Seed, 12)).unwrap();
    assert_ne!(a.trial.torque_nm, c.trial.torque_nm);
    assert_ne!(a.trial.emg_sol, c.trial.emg_sol);
    assert_ne!(a.unloaded.torque_nm, c.unloaded.torque_nm);
    // Same protocol: same time and angle columns.
    assert_eq!(a.trial.time_s, c.trial.time_s);
    assert_eq!(a.trial.ankle_angle_deg, c.trial.ankle_angle_deg);
    assert_eq!(a.truth_json["seed"], 11);
}

/// The truth is computed from exactly what a user's program reads: re-reading the written
/// trial and simulating gives the stored model torque bit for bit, and the measured torque is
/// that torque plus an error of a few N·m.
#[test]
fn model_torque_is_reproduced_from_the_written_file() {
    let mut effects = Effects::none();
    effects.set_values(EffectKind::AntagonistCoactivation, [6.0, 0.0]);
    let cfg = SynthConfig::new(Protocol::Seed, 5).with_effects(effects);
    let syn = synthesize(&cfg).unwrap();
    assert!(syn.trial.emg_ta.is_some(), "TA forced on by the effect");
    let back = parse_trial(&format_trial(&syn.trial).unwrap(), "t.csv").unwrap();
    let inputs = model_inputs(&back, &InputOptions::default()).unwrap();
    assert_eq!(inputs, syn.inputs);
    let out = simulate(&inputs, &cfg.params, &cfg.effects, &cfg.sim).unwrap();
    assert_eq!(out.torque, syn.model_torque);
    let peak = syn.model_torque.iter().copied().fold(f64::MIN, f64::max);
    assert!(peak > 50.0, "peak model torque {peak}");
    let worst = syn
        .trial
        .torque_nm
        .iter()
        .zip(&syn.model_torque)
        .map(|(m, t)| (m - t).abs())
        .fold(0.0, f64::max);
    assert!(worst < 15.0, "largest |measured − model| {worst}");
}

#[test]
fn synthetic_trial_round_trips_through_the_file_format() {
    let syn = synthesize(&SynthConfig::new(Protocol::Relaxed { cycles: 1 }, 3)).unwrap();
    let text = format_trial(&syn.trial).unwrap();
    let back = parse_trial(&text, "t.csv").unwrap();
    assert_eq!(back, syn.trial);
    assert_eq!(format_trial(&back).unwrap(), text);
    let text = format_unloaded(&syn.unloaded).unwrap();
    let back = parse_unloaded(&text, "u.csv").unwrap();
    assert_eq!(back, syn.unloaded);
    assert_eq!(format_unloaded(&back).unwrap(), text);
    // Rounded columns print with at most 4 (EMG) / 7 (angle) decimals.
    for line in text.lines().skip(1).take(50) {
        let angle = line.split(',').nth(1).unwrap();
        let decimals = angle.split('.').nth(1).map_or(0, str::len);
        assert!(decimals <= 7, "{angle}");
    }
    let text = format_trial(&syn.trial).unwrap();
    for line in text.lines().skip(1).step_by(97) {
        for cell in line.split(',').skip(3) {
            let decimals = cell.split('.').nth(1).map_or(0, str::len);
            assert!(decimals <= 4 && !cell.contains('e'), "EMG cell {cell}");
        }
    }
}

#[test]
fn round_decimals_gives_short_exact_decimals() {
    assert_eq!(round_decimals(0.123_456_78, 4), 0.1235);
    assert_eq!(round_decimals(-0.000_04, 4), 0.0);
    assert!(round_decimals(-0.000_04, 4).is_sign_positive());
    assert_eq!(round_decimals(3.0e-4 + 1e-12, 4).to_string(), "0.0003");
    assert_eq!(round_decimals(-13.151_367_187_5, 7), -13.151_367_2);
}

#[test]
fn model_inputs_rejects_an_all_zero_channel_naming_it() {
    let syn = synthesize(&SynthConfig::new(Protocol::Seed, 1)).unwrap();
    let mut trial = syn.trial.clone();
    trial.emg_gl = vec![0.0; trial.len()];
    let err = model_inputs(&trial, &InputOptions::default()).unwrap_err();
    assert_eq!(err.kind(), ErrorKind::ZeroChannel);
    match &err {
        ExperimentError::Column { name, column, .. } => {
            assert_eq!(name, "emg_gl");
            assert_eq!(*column, 6);
        }
        other => panic!("expected a column error, got {other:?}"),
    }
    assert!(err.to_string().contains("emg_gl"), "{err}");
    // Also when the columns are declared envelopes.
    let opts = InputOptions {
        emg_is_envelope: true,
        ..InputOptions::default()
    };
    let err = model_inputs(&trial, &opts).unwrap_err();
    assert_eq!(err.kind(), ErrorKind::ZeroChannel);
    assert!(err.to_string().contains("emg_gl"), "{err}");
}

#[test]
fn model_inputs_envelopes_angle_and_mvc() {
    let syn = synthesize(&SynthConfig::new(Protocol::Seed, 2)).unwrap();
    let trial = &syn.trial;
    let inputs = model_inputs(trial, &InputOptions::default()).unwrap();
    assert_eq!(inputs.len(), trial.len());
    assert!((inputs.fs() - 2048.0).abs() < 1e-9);
    for (q, d) in inputs.angle().iter().zip(&trial.ankle_angle_deg) {
        assert_eq!(*q, d.to_radians());
    }
    for m in muscle_model::Muscle::ALL {
        let e = inputs.envelope(m);
        let max = e.iter().copied().fold(f64::MIN, f64::max);
        assert_eq!(max, 1.0, "trial-max normalisation of {m}");
        assert!(e.iter().all(|&x| (0.0..=1.0).contains(&x)));
        // Rest (first 50 ms) well below the active level (middle of the concentric sweep).
        let rest = mean(&e[..100]);
        let active = e[(1.1 * 2048.0) as usize];
        assert!(
            rest < 0.1 && active > 0.7,
            "{m}: rest {rest}, active {active}"
        );
    }
    assert!(inputs.envelope_ta().is_none());

    // An MVC reference twice the trial maximum halves the soleus envelope.
    let raw_env = signal::EnvelopeFilter::new(2048.0, &signal::EnvelopeSettings::default())
        .unwrap()
        .envelope(&trial.emg_sol)
        .unwrap();
    let max = raw_env.iter().copied().fold(f64::MIN, f64::max);
    let opts = InputOptions::default().with_mvc(EmgMuscle::Sol, 2.0 * max);
    let half = model_inputs(trial, &opts).unwrap();
    for (a, b) in half
        .envelope(muscle_model::Muscle::Sol)
        .iter()
        .zip(inputs.envelope(muscle_model::Muscle::Sol))
    {
        assert!((a - 0.5 * b).abs() < 1e-12);
    }
    // A bad MVC is an error naming the column.
    let err = model_inputs(
        trial,
        &InputOptions::default().with_mvc(EmgMuscle::Gm, -1.0),
    )
    .unwrap_err();
    assert_eq!(err.kind(), ErrorKind::InvalidSettings);
    assert!(err.to_string().contains("emg_gm"), "{err}");

    // Envelope columns: no filtering, just the clamp.
    let mut env_trial = trial.clone();
    env_trial.emg_sol = vec![0.5; trial.len()];
    env_trial.emg_gm = vec![1.5; trial.len()];
    env_trial.emg_gl = vec![-0.2; trial.len()];
    env_trial.emg_gl[10] = 0.3;
    let opts = InputOptions {
        emg_is_envelope: true,
        ..InputOptions::default()
    };
    let inp = model_inputs(&env_trial, &opts).unwrap();
    assert!(inp
        .envelope(muscle_model::Muscle::Sol)
        .iter()
        .all(|&x| x == 0.5));
    assert!(inp
        .envelope(muscle_model::Muscle::Gm)
        .iter()
        .all(|&x| x == 1.0));
    assert_eq!(inp.envelope(muscle_model::Muscle::Gl)[9], 0.0);
    assert_eq!(inp.envelope(muscle_model::Muscle::Gl)[10], 0.3);
}

#[test]
fn random_params_stay_inside_the_identification_bounds() {
    let nominal = ModelParams::nominal();
    let mut rng = ChaCha8Rng::seed_from_u64(9);
    let draws: Vec<ModelParams> = (0..200)
        .map(|_| random_params(&mut rng, &nominal))
        .collect();
    for p in &draws {
        for id in ParamId::identified() {
            let v = id.get(p, &Effects::none());
            let n = id.get(&nominal, &Effects::none());
            let rel = (v / n - 1.0).abs();
            let limit = if id.name().ends_with("lst_m") {
                0.05
            } else {
                0.20
            };
            assert!(rel <= limit * (1.0 + 1e-12), "{} = {v} ({rel})", id.name());
        }
        // Everything else is nominal.
        for (a, b) in p.muscles.iter().zip(&nominal.muscles) {
            assert_eq!(a.lom_m, b.lom_m);
            assert_eq!(a.lmt_poly_m, b.lmt_poly_m);
        }
        assert_eq!(p.curves, nominal.curves);
        assert_eq!(p.activation, nominal.activation);
    }
    // The draws fill the box: each parameter reaches both outer fifths of its range.
    for id in ParamId::identified() {
        let (lo, hi) = id.default_bounds(&nominal, &Effects::none());
        let vals: Vec<f64> = draws.iter().map(|p| id.get(p, &Effects::none())).collect();
        let min = vals.iter().copied().fold(f64::MAX, f64::min);
        let max = vals.iter().copied().fold(f64::MIN, f64::max);
        assert!(
            min < lo + 0.2 * (hi - lo) && max > hi - 0.2 * (hi - lo),
            "{}",
            id.name()
        );
    }
    // Seeded: same seed, same draws.
    let mut rng2 = ChaCha8Rng::seed_from_u64(9);
    assert_eq!(random_params(&mut rng2, &nominal), draws[0]);
    // A synthetic trial with random parameters simulates fine.
    let cfg = SynthConfig::new(Protocol::Seed, 4).with_params(draws[1]);
    let syn = synthesize(&cfg).unwrap();
    assert_eq!(syn.truth_json["params"], draws[1].to_json_value());
}

#[test]
fn model_inputs_rejects_a_constant_emg_channel_naming_it() {
    let cfg = experiment::SynthConfig::new("seed".parse().unwrap(), 5);
    let mut trial = experiment::synthesize(&cfg).unwrap().trial;
    trial.emg_gm.iter_mut().for_each(|x| *x = 0.37);
    let e = experiment::model_inputs_named(&trial, &experiment::InputOptions::default(), "t.csv")
        .unwrap_err();
    assert_eq!(e.kind(), experiment::ErrorKind::ZeroChannel);
    let msg = e.to_string();
    assert!(msg.starts_with("t.csv") && msg.contains("emg_gm"), "{msg}");
}
