//! Knee-flexed synthetic trials and a synthetic trial whose model has a fixed `ta`: the
//! gastrocnemii's drive factor, the protocol strings, the synthesis, the `knee90` fixture.

use std::path::PathBuf;

use experiment::{
    gastrocnemius_drive_factor, model_inputs, parse_trial, read_trial, synthesize, synthetic_emg,
    synthetic_emg_at_knee, EmgMuscle, EmgSettings, ErrorKind, InputOptions, Protocol, SynthConfig,
    SynthProtocol, GASTROCNEMIUS_DRIVE_AT_90_DEG,
};
use muscle_model::{simulate, Effects, ModelParams};
use serde_json::Value;

fn fixtures_dir() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../fixtures")
}

#[test]
fn the_drive_factor_is_one_extended_and_seven_tenths_at_90_degrees() {
    assert_eq!(gastrocnemius_drive_factor(0.0), 1.0);
    assert_eq!(gastrocnemius_drive_factor(-20.0), 1.0);
    assert_eq!(
        gastrocnemius_drive_factor(90.0),
        GASTROCNEMIUS_DRIVE_AT_90_DEG
    );
    assert_eq!(GASTROCNEMIUS_DRIVE_AT_90_DEG, 0.7);
    assert_eq!(gastrocnemius_drive_factor(120.0), 0.7);
    assert!((gastrocnemius_drive_factor(60.0) - 0.85).abs() < 1e-12);
    assert!(
        (gastrocnemius_drive_factor(30.0) - (1.0 - 0.3 * (1.0 - 0.75f64.sqrt()))).abs() < 1e-12
    );
    // decreasing from 0° to 90°
    let f: Vec<f64> = (0..=90)
        .map(|k| gastrocnemius_drive_factor(f64::from(k)))
        .collect();
    assert!(f.windows(2).all(|w| w[1] < w[0]), "{f:?}");
}

#[test]
fn a_flexed_knee_lowers_only_the_gastrocnemii_drive() {
    let trace = Protocol::Seed.trace().unwrap();
    let st = EmgSettings {
        include_ta: true,
        ..EmgSettings::default()
    };
    let straight = synthetic_emg(&trace, &st, 9).unwrap();
    assert_eq!(
        synthetic_emg_at_knee(&trace, &st, 9, 0.0).unwrap(),
        straight
    );
    let flexed = synthetic_emg_at_knee(&trace, &st, 9, 90.0).unwrap();
    for m in [EmgMuscle::Sol, EmgMuscle::Ta] {
        assert_eq!(flexed.channel(m), straight.channel(m), "{m:?}");
    }
    let peak = |v: &[f64]| v.iter().copied().fold(0.0, f64::max);
    for m in [EmgMuscle::Gm, EmgMuscle::Gl] {
        let (a, b) = (straight.channel(m).unwrap(), flexed.channel(m).unwrap());
        // the same carrier and wobble (same streams), a lower drive
        let ratio = peak(&b.drive) / peak(&a.drive);
        assert!(
            (ratio - 0.7).abs() < 0.02,
            "{m:?}: peak drive ratio {ratio}"
        );
        assert_eq!(b.drive[0], st.rest_level, "{m:?}: the rest level is kept");
        for i in (0..a.raw.len()).step_by(97) {
            let (ca, cb) = (a.raw[i] / a.drive[i], b.raw[i] / b.drive[i]);
            assert!(
                (ca - cb).abs() <= 1e-12 * ca.abs().max(1.0),
                "{m:?} sample {i}"
            );
        }
    }
    let e = synthetic_emg_at_knee(&trace, &st, 9, 181.0).unwrap_err();
    assert_eq!(e.kind(), ErrorKind::InvalidSettings);
}

#[test]
fn knee_protocol_strings_read_and_write_back() {
    for (text, shown, protocol, knee) in [
        ("knee90", "knee90", Protocol::Seed, 90.0),
        ("seed@knee90", "knee90", Protocol::Seed, 90.0),
        (
            "relaxed+2@knee60",
            "relaxed+2@knee60",
            Protocol::Relaxed { cycles: 2 },
            60.0,
        ),
        (
            "cycles+3 @ knee 45.5",
            "cycles+3@knee45.5",
            Protocol::Cycles { cycles: 3 },
            45.5,
        ),
        ("seed", "seed", Protocol::Seed, 0.0),
        ("knee0", "seed", Protocol::Seed, 0.0),
        ("knee0@30", "seed", Protocol::Seed, 0.0),
        ("knee0x3", "cycles+3", Protocol::Cycles { cycles: 3 }, 0.0),
        (
            "knee0@30x3",
            "cycles+3",
            Protocol::Cycles { cycles: 3 },
            0.0,
        ),
        ("knee90@30", "knee90", Protocol::Seed, 90.0),
    ] {
        let p: SynthProtocol = text.parse().unwrap();
        assert_eq!((p.protocol, p.knee_angle_deg), (protocol, knee), "{text}");
        assert_eq!(p.to_string(), shown, "{text}");
        assert_eq!(shown.parse::<SynthProtocol>().unwrap(), p, "{text}");
    }
    for bad in [
        "knee",
        "kneeabc",
        "knee200",
        "seed@knee90@knee30",
        "seed@60@90",
        "knee0@1000",
        "knee0@2",
        "knee0@fast",
        "knee0@30x0",
        "knee0@30@60",
        "walk@knee90",
        "knee-40",
    ] {
        let e = bad.parse::<SynthProtocol>().unwrap_err();
        assert_eq!(e.kind(), ErrorKind::InvalidProtocol, "{bad}");
        assert!(!e.to_string().contains('\n'));
    }
}

#[test]
fn a_knee_flexed_synthesis_writes_the_column_and_records_the_angle() {
    let cfg = SynthConfig::for_protocol("knee90".parse().unwrap(), 12);
    assert_eq!(cfg.knee_angle_deg, 90.0);
    let syn = synthesize(&cfg).unwrap();
    assert_eq!(syn.trial.knee_angle_deg, Some(vec![90.0; syn.trial.len()]));
    let k = syn.inputs.knee_angle().unwrap();
    assert!(k.iter().all(|&x| x == std::f64::consts::FRAC_PI_2));
    assert_eq!(syn.truth_json["knee_angle_deg"], 90.0);
    assert_eq!(syn.truth_json["protocol"], "seed");
    // the extended knee: no column, no key (the other fixtures' truth is unchanged)
    let straight = synthesize(&SynthConfig::new(Protocol::Seed, 12)).unwrap();
    assert_eq!(straight.trial.knee_angle_deg, None);
    assert!(straight.truth_json.get("knee_angle_deg").is_none());
    assert_eq!(straight.trial.emg_sol, syn.trial.emg_sol);
    assert_ne!(straight.trial.emg_gm, syn.trial.emg_gm);
}

/// With the knee flexed 90° the gastrocnemii are 31 mm shorter (0.020 m × π/2): their tendons
/// go slack over much of the sweep, so the model's torque falls. Needs the simulation to use
/// the knee angle.
#[test]
fn the_knee_flexed_model_torque_is_lower() {
    let straight = synthesize(&SynthConfig::new(Protocol::Seed, 12)).unwrap();
    let flexed =
        synthesize(&SynthConfig::new(Protocol::Seed, 12).with_knee_angle_deg(90.0)).unwrap();
    let peak = |v: &[f64]| v.iter().copied().fold(f64::MIN, f64::max);
    let (a, b) = (peak(&straight.model_torque), peak(&flexed.model_torque));
    assert!(
        b < a - 5.0,
        "peak model torque {b} N·m at 90° vs {a} N·m extended"
    );
}

/// The params JSON of a model with a fixed tibialis anterior (gait2392's F0, LOM, LST and
/// pennation; a length that shortens with dorsiflexion, moment arm −0.037 m).
const TA_PARAMS: &str = r#"{"muscles": {"ta": {"fom_n": 905, "lom_m": 0.098, "lst_m": 0.223,
    "alpha_deg": 5, "lmt_poly_m": [0.32, -0.037, 0.0, 0.0]}}}"#;

#[test]
fn a_fixed_ta_in_the_true_model_makes_the_trial_carry_emg_ta() {
    let params = ModelParams::from_json_str(TA_PARAMS).unwrap();
    let cfg = SynthConfig::new(Protocol::Seed, 21).with_params(params);
    assert!(cfg.effective_emg().include_ta);
    let syn = synthesize(&cfg).unwrap();
    assert!(syn.trial.emg_ta.is_some());
    assert!(syn.inputs.envelope_named("ta").is_some());
    assert_eq!(syn.truth_json["params"]["muscles"]["ta"]["fom_n"], 905.0);
    // without the fixed muscle: the same triceps EMG, no emg_ta
    let plain = synthesize(&SynthConfig::new(Protocol::Seed, 21)).unwrap();
    assert!(plain.trial.emg_ta.is_none());
    assert_eq!(plain.trial.emg_gm, syn.trial.emg_gm);
}

/// The four-muscle model end to end: the TA's torque is negative (a dorsiflexor), so the total
/// is below the triceps-only torque at every sample (up to the integrator's tolerance, as the
/// muscles may share its steps) and clearly below it when the TA is active. Needs the
/// simulation to use fixed muscles.
#[test]
fn a_fixed_ta_pulls_the_torque_down() {
    let params = ModelParams::from_json_str(TA_PARAMS).unwrap();
    let four = synthesize(&SynthConfig::new(Protocol::Seed, 21).with_params(params)).unwrap();
    let three = simulate(
        &four.inputs,
        &ModelParams::nominal(),
        &Effects::none(),
        &SynthConfig::new(Protocol::Seed, 21).sim,
    )
    .unwrap()
    .torque;
    let diff: Vec<f64> = four
        .model_torque
        .iter()
        .zip(&three)
        .map(|(a, b)| a - b)
        .collect();
    let max = diff.iter().copied().fold(f64::MIN, f64::max);
    let min = diff.iter().copied().fold(f64::MAX, f64::min);
    assert!(max <= 1e-3, "the TA added {max} N·m somewhere");
    assert!(min < -5.0, "the TA's largest pull is only {min} N·m");
}

#[test]
fn the_synthetic_subject_has_emg_only_for_ta_among_fixed_muscles() {
    let other = ModelParams::from_json_str(
        r#"{"muscles": {"perlong": {"fom_n": 435, "lom_m": 0.049, "lst_m": 0.345,
            "alpha_deg": 10, "lmt_poly_m": [0.39, 0.01, 0.0, 0.0]}}}"#,
    )
    .unwrap();
    let e = synthesize(&SynthConfig::new(Protocol::Seed, 1).with_params(other)).unwrap_err();
    assert_eq!(e.kind(), ErrorKind::InvalidSettings);
    assert!(e.to_string().contains("perlong"), "{e}");
    let no_geometry = ModelParams::from_json_str(
        r#"{"muscles": {"ta": {"fom_n": 905, "lom_m": 0.098, "lst_m": 0.223, "alpha_deg": 5}}}"#,
    )
    .unwrap();
    let e = synthesize(&SynthConfig::new(Protocol::Seed, 1).with_params(no_geometry)).unwrap_err();
    assert!(e.to_string().contains("lmt_poly_m"), "{e}");
}

/// `fixtures/knee90`: canonical, with a constant 90° column and a truth that says so, and a
/// measured torque that is the true model on the file's own inputs plus the dynamometer error
/// (mean near the −1.5 N·m offset, a few N·m RMS).
#[test]
fn the_knee90_fixture_is_consistent() {
    let dir = fixtures_dir().join("knee90");
    let text = std::fs::read_to_string(dir.join("trial.csv")).unwrap();
    let trial = parse_trial(&text, "trial.csv").unwrap();
    assert_eq!(experiment::format_trial(&trial).unwrap(), text);
    assert_eq!(trial.knee_angle_deg, Some(vec![90.0; trial.len()]));
    assert!(
        trial.comments[0].contains("protocol knee90"),
        "{}",
        trial.comments[0]
    );
    let truth: Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("truth.json")).unwrap()).unwrap();
    assert_eq!(truth["knee_angle_deg"], 90.0);
    assert_eq!(truth["protocol"], "seed");
    let params = ModelParams::nominal()
        .merged_json(&truth["params"])
        .unwrap();
    assert_eq!(params, ModelParams::nominal());
    let sim = serde_json::from_value(truth["sim"].clone()).unwrap();
    let trial = read_trial(dir.join("trial.csv")).unwrap();
    let inputs = model_inputs(&trial, &InputOptions::default()).unwrap();
    let model = simulate(&inputs, &params, &Effects::none(), &sim).unwrap();
    let r: Vec<f64> = trial
        .torque_nm
        .iter()
        .zip(&model.torque)
        .map(|(m, s)| m - s)
        .collect();
    let n = r.len() as f64;
    let mean = r.iter().sum::<f64>() / n;
    let rms = numerics::rms(&r);
    assert!((-3.0..0.0).contains(&mean), "mean residual {mean} N·m");
    assert!(rms < 4.0, "residual RMS {rms} N·m");
}

#[test]
fn protocol_speeds_parse_print_and_move_the_trial_and_its_unloaded_run() {
    for (text, shown, protocol, knee, speed) in [
        ("knee0@60", "knee0@60", Protocol::Seed, 0.0, 60.0),
        ("seed@60", "knee0@60", Protocol::Seed, 0.0, 60.0),
        ("seed@knee90@60", "knee90@60", Protocol::Seed, 90.0, 60.0),
        (
            "knee90@120x2",
            "knee90@120x2",
            Protocol::Cycles { cycles: 2 },
            90.0,
            120.0,
        ),
        (
            "relaxed+2@knee45@60",
            "relaxed+2@knee45@60",
            Protocol::Relaxed { cycles: 2 },
            45.0,
            60.0,
        ),
    ] {
        let p: SynthProtocol = text.parse().unwrap();
        assert_eq!(
            (p.protocol, p.knee_angle_deg, p.speed_deg_s),
            (protocol, knee, speed),
            "{text}"
        );
        assert_eq!(p.to_string(), shown, "{text}");
        assert_eq!(shown.parse::<SynthProtocol>().unwrap(), p, "{text}");
    }
    // At 60 °/s the sweeps take half as long; the unloaded run follows the trial's speed.
    let slow = synthesize(&SynthConfig::for_protocol("knee0@30".parse().unwrap(), 5)).unwrap();
    let fast = synthesize(&SynthConfig::for_protocol("knee0@60".parse().unwrap(), 5)).unwrap();
    let sweep = |t: &[f64], a: &[f64]| {
        let moving: Vec<f64> = t
            .iter()
            .zip(a.windows(2))
            .filter(|(_, w)| w[0] != w[1])
            .map(|(t, _)| *t)
            .collect();
        moving.last().unwrap() - moving.first().unwrap()
    };
    let (ts, tf) = (
        sweep(&slow.trial.time_s, &slow.trial.ankle_angle_deg),
        sweep(&fast.trial.time_s, &fast.trial.ankle_angle_deg),
    );
    // 2 × (35° / v + 0.05 s ramp): 2.433 s at 30 °/s, 1.267 s at 60 °/s.
    assert!((ts - 2.0 * (35.0 / 30.0 + 0.05)).abs() < 0.01, "{ts}");
    assert!((tf - 2.0 * (35.0 / 60.0 + 0.05)).abs() < 0.01, "{tf}");
    let (us, uf) = (
        sweep(&slow.unloaded.time_s, &slow.unloaded.ankle_angle_deg),
        sweep(&fast.unloaded.time_s, &fast.unloaded.ankle_angle_deg),
    );
    assert!(uf < 0.6 * us, "{uf} {us}");
    assert_eq!(fast.truth_json["speed_deg_s"], 60.0);
    assert!(slow.truth_json.get("speed_deg_s").is_none());
}
