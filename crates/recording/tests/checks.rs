//! The trial checks on synthetic signals built here, and on the project's seed fixture.

use std::f64::consts::PI;
use std::path::PathBuf;

use experiment::Trial;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use recording::checks::{
    check_trial, check_trial_in_context, CheckSettings, MotionCheck, SweepDirection, TrialChecks,
    TrialContext, TrialKind,
};

const FS: f64 = 2048.0;

fn gauss(rng: &mut ChaCha8Rng) -> f64 {
    let u1: f64 = rng.random::<f64>().max(1e-300);
    let u2: f64 = rng.random();
    (-2.0 * u1.ln()).sqrt() * (2.0 * PI * u2).cos()
}

/// Band-limited (20–450 Hz, 4th-order Butterworth) Gaussian noise of unit-ish amplitude.
fn emg_noise(n: usize, seed: u64) -> Vec<f64> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let white: Vec<f64> = (0..n).map(|_| gauss(&mut rng)).collect();
    let sos = signal::butter(4, signal::Band::Bandpass(20.0, 450.0), FS).unwrap();
    signal::sosfilt(&sos, &white).unwrap()
}

fn quantise(x: f64, q: f64) -> f64 {
    (x / q).round() * q
}

/// Velocity profile of the seed protocol: 0.5 s hold at 15°, a −30 °/s sweep to −20° and a
/// +30 °/s sweep back (50 ms ramps), 0.4 s hold.
fn trapezoid_velocity(t: f64) -> f64 {
    let (hold, ramp, speed) = (0.5, 0.05, 30.0);
    let sweep = 35.0 / speed + ramp; // ramp up + cruise + ramp down
    let profile = |tau: f64| -> f64 {
        if tau < 0.0 || tau > sweep {
            0.0
        } else if tau < ramp {
            speed * tau / ramp
        } else if tau > sweep - ramp {
            speed * (sweep - tau) / ramp
        } else {
            speed
        }
    };
    -profile(t - hold) + profile(t - hold - sweep)
}

struct Built {
    trial: Trial,
    prediction: Vec<f64>,
}

/// A trial moving with `velocity(t)` from 15°, angle quantised to 0.1° (an encoder), activation
/// high while moving, torque `150·a + 5` plus noise quantised to 0.331 N·m, EMG band-limited
/// noise modulated by the activation.
fn build(duration_s: f64, velocity: impl Fn(f64) -> f64, seed: u64) -> Built {
    let n = (duration_s * FS).round() as usize + 1;
    let dt = 1.0 / FS;
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut angle = Vec::with_capacity(n);
    let mut theta = 15.0;
    let mut time = Vec::with_capacity(n);
    let mut act = Vec::with_capacity(n);
    for i in 0..n {
        let t = i as f64 * dt;
        time.push(t);
        angle.push(quantise(theta, 0.1));
        let v = velocity(t);
        theta += v * dt;
        act.push(if v.abs() > 1.0 { 1.0 } else { 0.05 });
    }
    // Smooth the activation a little (first-order, 30 ms).
    let alpha = dt / 0.03;
    let mut a = act[0];
    for x in act.iter_mut() {
        a += alpha * (*x - a);
        *x = a;
    }
    let prediction: Vec<f64> = act.iter().map(|a| 150.0 * a + 5.0).collect();
    let torque: Vec<f64> = prediction
        .iter()
        .map(|p| quantise(p + 1.5 * gauss(&mut rng), 678.0 / 2048.0))
        .collect();
    let emg = |s: u64, gain: f64| -> Vec<f64> {
        emg_noise(n, s)
            .iter()
            .zip(&act)
            .map(|(e, a)| gain * e * (0.05 + a))
            .collect()
    };
    let trial = Trial {
        time_s: time,
        ankle_angle_deg: angle,
        torque_nm: torque,
        emg_sol: emg(seed + 1, 0.35),
        emg_gm: emg(seed + 2, 0.5),
        emg_gl: emg(seed + 3, 0.2),
        ..Trial::default()
    };
    Built { trial, prediction }
}

fn clean() -> Built {
    build(3.333, trapezoid_velocity, 11)
}

/// The motion check of a dynamometer trial.
fn m(c: &TrialChecks) -> &MotionCheck {
    c.motion
        .as_ref()
        .expect("a dynamometer trial's motion check")
}

fn has_warning(c: &TrialChecks, needle: &str) -> bool {
    c.warnings.iter().any(|w| w.contains(needle))
}

#[test]
fn clean_isokinetic_trial_has_no_warnings() {
    let b = clean();
    let c = check_trial(&b.trial, Some(&b.prediction));
    assert!(c.is_clean(), "{:#?}", c.warnings);
    assert!((c.angle.range_deg.unwrap() - 35.0).abs() < 0.2);
    assert!(m(&c).isokinetic);
    assert_eq!(m(&c).plateaus.len(), 2, "{:#?}", m(&c));
    let (p0, p1) = (&m(&c).plateaus[0], &m(&c).plateaus[1]);
    assert_eq!(p0.direction, SweepDirection::Concentric);
    assert_eq!(p1.direction, SweepDirection::Eccentric);
    assert!((p0.mean_velocity_deg_s + 30.0).abs() < 0.5, "{p0:?}");
    assert!((p1.mean_velocity_deg_s - 30.0).abs() < 0.5, "{p1:?}");
    assert!(p0.relative_sd < 0.05 && p1.relative_sd < 0.05);
    assert!(p0.duration_s > 1.0 && p1.duration_s > 1.0);
    assert!(m(&c).plateau_fraction.unwrap() > 0.85, "{:?}", c.motion);
    assert!(c.saturation.iter().all(|s| !s.clipped));
    for e in &c.emg {
        assert!(!e.flat && !e.power_line, "{e:?}");
        assert!(e.power_line_ratio.unwrap() < 0.1, "{e:?}");
    }
    let sign = c.sign.as_ref().unwrap();
    assert!(sign.correlation.unwrap() > 0.9 && !sign.flipped, "{sign:?}");

    let lines = c.summary_lines();
    assert!(
        lines.iter().any(|l| l == "angle: −20.0 … 15.0° (35.0°)"),
        "{lines:#?}"
    );
    assert!(
        lines
            .iter()
            .any(|l| l.starts_with("isokinetic: 2 plateaus at −29.9 and +29.9 °/s (9")),
        "{lines:#?}"
    );
    assert!(lines.iter().all(|l| !l.starts_with("warning")));
}

#[test]
fn json_has_the_documented_shape() {
    let b = clean();
    let c = check_trial(&b.trial, Some(&b.prediction));
    let v = serde_json::to_value(&c).unwrap();
    for key in [
        "samples",
        "sample_rate_hz",
        "duration_s",
        "angle",
        "motion",
        "saturation",
        "emg",
        "sign",
        "warnings",
        "settings",
    ] {
        assert!(v.get(key).is_some(), "missing {key}");
    }
    assert_eq!(v["motion"]["isokinetic"], true);
    assert_eq!(v["motion"]["plateaus"][0]["direction"], "concentric");
    assert_eq!(v["motion"]["plateaus"][1]["direction"], "eccentric");
    assert!(v["angle"]["range_deg"].as_f64().is_some());
    assert_eq!(v["saturation"][0]["channel"], "torque_nm");
    assert_eq!(v["emg"][0]["channel"], "emg_sol");
    assert!(v["emg"][0]["power_line_ratio"].as_f64().is_some());
    assert!(v["sign"]["correlation"].as_f64().is_some());
    assert!(v["warnings"].as_array().unwrap().is_empty());
    // Without a prediction the sign check is null.
    let c = check_trial(&b.trial, None);
    assert!(serde_json::to_value(&c).unwrap()["sign"].is_null());
    assert!(c
        .summary_lines()
        .contains(&"sign: not checked (no prediction)".to_string()));
}

#[test]
fn sinusoidal_motion_is_not_isokinetic() {
    let w = 2.0 * PI * 0.4;
    // θ = −2.5 + 17.5·cos(ωt) after the first sample: v = −17.5·ω·sin(ωt).
    let b = build(5.0, |t| -17.5 * w * (w * t).sin(), 12);
    let c = check_trial(&b.trial, Some(&b.prediction));
    assert!(!m(&c).isokinetic, "{:#?}", m(&c));
    assert!(m(&c).plateau_fraction.unwrap() < 0.5, "{:#?}", m(&c));
    assert!(
        has_warning(&c, "ankle_angle_deg: not isokinetic"),
        "{:#?}",
        c.warnings
    );
    assert_eq!(c.warnings.len(), 1, "{:#?}", c.warnings);
    assert!(c
        .summary_lines()
        .iter()
        .any(|l| l.starts_with("isokinetic: no: ")));
}

#[test]
fn constant_acceleration_motion_is_not_isokinetic() {
    // Triangular velocity: 0 → −60 °/s → 0 over 1.2 s, and back.
    let tri = |t: f64| -> f64 {
        let tau = t - 0.5;
        let v = |u: f64| {
            if (0.0..0.6).contains(&u) {
                100.0 * u
            } else if (0.6..1.2).contains(&u) {
                100.0 * (1.2 - u)
            } else {
                0.0
            }
        };
        -v(tau) + v(tau - 1.2)
    };
    let b = build(3.3, tri, 13);
    let c = check_trial(&b.trial, None);
    assert!(!m(&c).isokinetic);
    assert!(m(&c).plateau_fraction.unwrap() < 0.35, "{:#?}", m(&c));
}

#[test]
fn no_motion_is_a_warning() {
    let b = build(2.0, |_| 0.0, 14);
    let c = check_trial(&b.trial, None);
    assert!(!m(&c).isokinetic);
    assert!(m(&c).plateau_fraction.is_none());
    assert!(
        has_warning(&c, "ankle_angle_deg: no motion"),
        "{:#?}",
        c.warnings
    );
    assert!(
        has_warning(&c, "ankle_angle_deg: range only"),
        "{:#?}",
        c.warnings
    );
    assert!(c
        .summary_lines()
        .contains(&"isokinetic: no motion".to_string()));
}

#[test]
fn clipped_torque_is_flagged() {
    let mut b = clean();
    // The ADC's (or the dynamometer's) full scale at 140 N·m, on the quantisation grid.
    let rail = quantise(140.0, 678.0 / 2048.0);
    for x in &mut b.trial.torque_nm {
        *x = x.min(rail);
    }
    let c = check_trial(&b.trial, Some(&b.prediction));
    let s = &c.saturation[0];
    assert_eq!(s.channel, "torque_nm");
    assert!(s.clipped && s.high.as_ref().unwrap().clipped, "{s:?}");
    assert!(!s.low.as_ref().unwrap().clipped);
    assert!(
        has_warning(&c, "torque_nm: clipped at 140."),
        "{:#?}",
        c.warnings
    );
    assert_eq!(c.warnings.len(), 1, "{:#?}", c.warnings);
    assert!(c
        .summary_lines()
        .contains(&"saturation: torque_nm clipped".to_string()));
}

#[test]
fn clipped_emg_is_flagged() {
    let mut b = clean();
    for x in &mut b.trial.emg_gm {
        *x = x.clamp(-0.4, 0.4);
    }
    let c = check_trial(&b.trial, None);
    let s = c.saturation.iter().find(|s| s.channel == "emg_gm").unwrap();
    assert!(
        s.high.as_ref().unwrap().clipped && s.low.as_ref().unwrap().clipped,
        "{s:?}"
    );
    assert!(
        has_warning(&c, "emg_gm: clipped at 0.4000"),
        "{:#?}",
        c.warnings
    );
    assert!(
        has_warning(&c, "emg_gm: clipped at −0.4000"),
        "{:#?}",
        c.warnings
    );
}

#[test]
fn a_smooth_quantised_peak_is_not_clipping() {
    // A noise-free torque that dwells on its top ADC code around a rounded peak.
    let mut b = clean();
    let n = b.trial.len();
    b.trial.torque_nm = (0..n)
        .map(|i| {
            let t = i as f64 / FS;
            quantise(200.0 * (PI * t / 3.333).sin(), 678.0 / 4096.0)
        })
        .collect();
    let c = check_trial(&b.trial, None);
    let high = c.saturation[0].high.as_ref().unwrap();
    assert!(high.fraction > 0.005, "{high:?}"); // dwells, but…
    assert!(!high.clipped, "{high:?}"); // …is a rounded peak, not a flat top
}

#[test]
fn flat_emg_is_flagged() {
    let mut b = clean();
    b.trial.emg_gm = vec![0.0; b.trial.len()];
    b.trial.emg_gl = (0..b.trial.len())
        .map(|i| if i % 3 == 0 { 0.001 } else { 0.0 })
        .collect();
    let c = check_trial(&b.trial, None);
    let gm = c.emg.iter().find(|e| e.channel == "emg_gm").unwrap();
    let gl = c.emg.iter().find(|e| e.channel == "emg_gl").unwrap();
    assert!(gm.flat && gm.distinct_values == 1 && gm.power_line_ratio.is_none());
    assert!(gl.flat && gl.distinct_values == 2);
    assert!(
        has_warning(&c, "emg_gm: flat: 1 distinct value"),
        "{:#?}",
        c.warnings
    );
    assert!(
        has_warning(&c, "emg_gl: flat: 2 distinct values"),
        "{:#?}",
        c.warnings
    );
    // A flat channel is not also reported as clipped.
    assert!(
        !c.warnings.iter().any(|w| w.contains("clipped")),
        "{:#?}",
        c.warnings
    );
    assert_eq!(c.warnings.len(), 2, "{:#?}", c.warnings);
    assert!(c.summary_lines().iter().any(|l| l.contains("emg_gm flat")));
}

#[test]
fn power_line_dominated_emg_is_flagged_and_clean_emg_is_not() {
    let mut b = clean();
    let n = b.trial.len();
    let hum = |f: f64, amp: f64| -> Vec<f64> {
        (0..n)
            .map(|i| amp * (2.0 * PI * f * i as f64 / FS + 0.3).sin())
            .collect()
    };
    let add = |x: &mut Vec<f64>, h: &[f64]| {
        for (a, b) in x.iter_mut().zip(h) {
            *a += b;
        }
    };
    add(&mut b.trial.emg_sol, &hum(50.0, 0.5));
    add(&mut b.trial.emg_gm, &hum(59.9, 0.8)); // 60 Hz mains, slightly off
    add(&mut b.trial.emg_gl, &hum(50.0, 0.005)); // a trace of hum is fine
    let c = check_trial(&b.trial, None);
    let sol = &c.emg[0];
    let gm = &c.emg[1];
    let gl = &c.emg[2];
    assert!(sol.power_line && sol.power_line_hz == Some(50.0), "{sol:?}");
    assert!(sol.power_line_ratio.unwrap() > 0.5, "{sol:?}");
    assert!(gm.power_line && gm.power_line_hz == Some(60.0), "{gm:?}");
    assert!(
        !gl.power_line && gl.power_line_ratio.unwrap() < 0.1,
        "{gl:?}"
    );
    assert!(
        has_warning(&c, "emg_sol: 50 Hz power-line interference: "),
        "{:#?}",
        c.warnings
    );
    assert!(
        has_warning(&c, "emg_gm: 60 Hz power-line interference: "),
        "{:#?}",
        c.warnings
    );
    assert_eq!(c.warnings.len(), 2, "{:#?}", c.warnings);
}

#[test]
fn flipped_torque_is_flagged() {
    let mut b = clean();
    for x in &mut b.trial.torque_nm {
        *x = -*x;
    }
    let c = check_trial(&b.trial, Some(&b.prediction));
    let s = c.sign.as_ref().unwrap();
    assert!(s.flipped && s.correlation.unwrap() < -0.9, "{s:?}");
    assert!(s.slope.unwrap() < 0.0);
    assert!(
        has_warning(&c, "torque_nm: torque sign looks flipped"),
        "{:#?}",
        c.warnings
    );
    assert_eq!(c.warnings.len(), 1, "{:#?}", c.warnings);
}

#[test]
fn a_prediction_of_another_length_is_not_compared() {
    let b = clean();
    let c = check_trial(&b.trial, Some(&b.prediction[..100]));
    let s = c.sign.as_ref().unwrap();
    assert!(s.correlation.is_none() && !s.flipped);
    assert!(has_warning(&c, "sign not checked"), "{:#?}", c.warnings);
}

#[test]
fn degenerate_trials_do_not_panic() {
    // Empty.
    let c = check_trial(&Trial::default(), Some(&[]));
    assert!(!c.is_clean());
    assert!(c.angle.min_deg.is_none() && c.sample_rate_hz.is_none());
    serde_json::to_string(&c).unwrap();
    assert!(!c.summary_lines().is_empty());

    // One sample.
    let one = Trial {
        time_s: vec![0.0],
        ankle_angle_deg: vec![1.0],
        torque_nm: vec![2.0],
        emg_sol: vec![0.1],
        emg_gm: vec![0.1],
        emg_gl: vec![0.1],
        ..Trial::default()
    };
    let c = check_trial(&one, Some(&[1.0]));
    serde_json::to_string(&c).unwrap();
    let _ = c.summary_lines();

    // Columns of mismatched length, NaNs everywhere.
    let mut b = clean();
    b.trial.ankle_angle_deg[1000] = f64::NAN;
    b.trial.torque_nm[2000] = f64::INFINITY;
    b.trial.emg_sol[3000] = f64::NAN;
    b.trial.emg_gm.truncate(500);
    b.trial.emg_ta = Some(vec![f64::NAN; 10]);
    b.prediction[10] = f64::NAN;
    let c = check_trial(&b.trial, Some(&b.prediction));
    serde_json::to_string(&c).unwrap();
    assert!(
        has_warning(&c, "ankle_angle_deg: 1 non-finite"),
        "{:#?}",
        c.warnings
    );
    assert!(
        has_warning(&c, "torque_nm: 1 non-finite"),
        "{:#?}",
        c.warnings
    );
    assert!(
        has_warning(&c, "emg_gm: 500 samples but time_s has"),
        "{:#?}",
        c.warnings
    );
    assert!(
        has_warning(&c, "emg_ta: flat: 0 distinct values"),
        "{:#?}",
        c.warnings
    );
    // One NaN in the angle does not break the plateau analysis.
    assert!(m(&c).isokinetic, "{:#?}", m(&c));
    assert!(c.sign.as_ref().unwrap().correlation.unwrap() > 0.9);
    // NaN in the EMG: the segments without it still give a spectrum.
    assert!(c.emg[0].power_line_ratio.is_some());

    // All-NaN angle, non-increasing time.
    let mut b = clean();
    b.trial
        .ankle_angle_deg
        .iter_mut()
        .for_each(|x| *x = f64::NAN);
    b.trial.time_s.iter_mut().for_each(|x| *x = 0.0);
    let c = check_trial(&b.trial, None);
    serde_json::to_string(&c).unwrap();
    assert!(
        has_warning(&c, "ankle_angle_deg: no finite samples"),
        "{:#?}",
        c.warnings
    );
    assert!(has_warning(&c, "time_s: "), "{:#?}", c.warnings);
}

#[test]
fn angle_conventions_are_flagged() {
    // An angle in radians: 0.61 rad of range.
    let mut b = clean();
    b.trial
        .ankle_angle_deg
        .iter_mut()
        .for_each(|x| *x = x.to_radians());
    let c = check_trial(&b.trial, None);
    assert!(
        has_warning(&c, "ankle_angle_deg: range only 0.61°"),
        "{:#?}",
        c.warnings
    );
    // 90° at neutral.
    let mut b = clean();
    b.trial.ankle_angle_deg.iter_mut().for_each(|x| *x += 90.0);
    let c = check_trial(&b.trial, None);
    assert!(
        has_warning(&c, "ankle_angle_deg: reaches 105.0°"),
        "{:#?}",
        c.warnings
    );
    assert!(m(&c).isokinetic); // the motion itself is fine
}

fn fixture(name: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../../fixtures/seed")
        .join(name)
}

#[test]
fn seed_fixture_passes() {
    let trial = experiment::read_trial(fixture("trial.csv")).unwrap();
    // The prediction: the synthetic generator's model torque for the same configuration
    // (fixtures/seed was written by `cargo xtask gen-fixtures` from this one).
    let syn = experiment::synthesize(&experiment::SynthConfig::new(
        experiment::Protocol::Seed,
        2016,
    ))
    .unwrap();
    assert_eq!(syn.model_torque.len(), trial.len());
    let c = check_trial(&trial, Some(&syn.model_torque));
    assert!(c.is_clean(), "{:#?}\n{:#?}", c.warnings, c);
    assert!(m(&c).isokinetic);
    assert_eq!(m(&c).plateaus.len(), 2);
    assert!((m(&c).plateaus[0].mean_velocity_deg_s + 30.0).abs() < 0.5);
    assert!((m(&c).plateaus[1].mean_velocity_deg_s - 30.0).abs() < 0.5);
    assert!((c.angle.min_deg.unwrap() + 20.0).abs() < 1e-3);
    assert!((c.angle.max_deg.unwrap() - 15.0).abs() < 1e-3);
    assert!(c.sign.as_ref().unwrap().correlation.unwrap() > 0.9);
    for line in c.summary_lines() {
        println!("{line}");
    }
    println!("{}", serde_json::to_string_pretty(&c).unwrap());

    // The same file with its torque negated: the flipped leg.
    let mut flipped = trial.clone();
    flipped.torque_nm.iter_mut().for_each(|x| *x = -*x);
    let c = check_trial(&flipped, Some(&syn.model_torque));
    assert!(c.sign.as_ref().unwrap().flipped);
    assert_eq!(c.warnings.len(), 1, "{:#?}", c.warnings);
}

#[test]
fn power_line_at_1500_hz_between_bins() {
    // 1500 Hz: 2048-sample segments, 0.73 Hz bins, 50 Hz falls between two of them.
    let fs = 1500.0;
    let n = 6000;
    let mut rng = ChaCha8Rng::seed_from_u64(21);
    let noise: Vec<f64> = (0..n).map(|_| gauss(&mut rng)).collect();
    let with_hum = |amp: f64| -> Vec<f64> {
        noise
            .iter()
            .enumerate()
            .map(|(i, e)| 0.1 * e + amp * (2.0 * PI * 50.0 * i as f64 / fs).sin())
            .collect()
    };
    let trial = Trial {
        time_s: (0..n).map(|i| i as f64 / fs).collect(),
        ankle_angle_deg: vec![0.0; n],
        torque_nm: vec![0.0; n],
        emg_sol: with_hum(0.3),
        emg_gm: with_hum(0.0),
        emg_gl: with_hum(0.01),
        ..Trial::default()
    };
    let c = check_trial(&trial, None);
    assert!(
        c.emg[0].power_line && c.emg[0].power_line_hz == Some(50.0),
        "{:?}",
        c.emg[0]
    );
    assert!(c.emg[0].power_line_ratio.unwrap() > 0.7, "{:?}", c.emg[0]);
    // White noise: 3 line bands of ±1 Hz out of 340 Hz, about 2 %.
    assert!(c.emg[1].power_line_ratio.unwrap() < 0.05, "{:?}", c.emg[1]);
    assert!(!c.emg[2].power_line, "{:?}", c.emg[2]);
    // The constant torque is reported, not called clipped.
    assert!(
        has_warning(&c, "torque_nm: constant at 0.000 N·m"),
        "{:#?}",
        c.warnings
    );
    assert!(c.saturation.iter().all(|s| !s.clipped));
}

#[test]
fn a_dynamometer_trial_is_inferred_and_gets_the_isokinetic_checks() {
    let b = clean();
    let c = check_trial(&b.trial, Some(&b.prediction));
    assert_eq!(c.kind, TrialKind::Dynamometer);
    assert!(
        c.kind_reason
            .starts_with("no ground force; 100 % of the ankle's 2 sweeps span 70 %"),
        "{}",
        c.kind_reason
    );
    assert!(c.strides.is_none());
    assert_eq!(
        c.applied,
        vec![
            "angle",
            "isokinetic",
            "saturation",
            "emg_flat",
            "emg_rate",
            "power_line",
            "sign"
        ]
    );
    let v = serde_json::to_value(&c).unwrap();
    assert_eq!(v["kind"], "dynamometer");
    assert!(v["strides"].is_null());
    assert_eq!(v["emg_is_envelope"], false);
    // the sinusoidal and triangular motions of the tests above are dynamometer trials too:
    // their sweeps span the range, so "not isokinetic" is still a warning about them
    let w = 2.0 * PI * 0.4;
    let sine = build(5.0, |t| -17.5 * w * (w * t).sin(), 12);
    assert_eq!(check_trial(&sine.trial, None).kind, TrialKind::Dynamometer);
}

#[test]
fn a_protocol_of_many_sweeps_stays_a_dynamometer_trial_and_its_plateaus_are_summarised() {
    for protocol in [
        experiment::Protocol::Cycles { cycles: 3 },
        experiment::Protocol::Relaxed { cycles: 4 },
    ] {
        let syn = experiment::synthesize(&experiment::SynthConfig::new(protocol, 5)).unwrap();
        let c = check_trial(&syn.trial, Some(&syn.model_torque));
        assert_eq!(
            c.kind,
            TrialKind::Dynamometer,
            "{protocol}: {}",
            c.kind_reason
        );
        assert!(c.is_clean(), "{protocol}: {:#?}", c.warnings);
        let line = c
            .summary_lines()
            .into_iter()
            .find(|l| l.starts_with("isokinetic:"))
            .unwrap();
        let n = m(&c).plateaus.len();
        assert!(n > 4, "{protocol}: {n}");
        assert!(
            line.starts_with(&format!("isokinetic: {n} plateaus from −")) && line.contains(" to +"),
            "{line}"
        );
    }
}

#[test]
fn envelopes_skip_the_rate_and_power_line_checks() {
    // the clean trial resampled to 100 Hz and called envelopes: no rate warning, no spectrum
    let b = clean();
    let step = 20;
    let pick = |x: &[f64]| -> Vec<f64> { x.iter().step_by(step).map(|v| v.abs()).collect() };
    let t = Trial {
        time_s: b.trial.time_s.iter().step_by(step).copied().collect(),
        ankle_angle_deg: b
            .trial
            .ankle_angle_deg
            .iter()
            .step_by(step)
            .copied()
            .collect(),
        torque_nm: b.trial.torque_nm.iter().step_by(step).copied().collect(),
        emg_sol: pick(&b.trial.emg_sol),
        emg_gm: pick(&b.trial.emg_gm),
        emg_gl: pick(&b.trial.emg_gl),
        ..Trial::default()
    };
    let raw = check_trial(&t, None);
    assert!(
        has_warning(&raw, "time_s: sampled at 102 Hz, below the 700 Hz"),
        "{:#?}",
        raw.warnings
    );
    let env = check_trial_in_context(
        &t,
        None,
        &TrialContext {
            emg_is_envelope: true,
            ..TrialContext::default()
        },
        &CheckSettings::default(),
    );
    assert!(!has_warning(&env, "700 Hz"), "{:#?}", env.warnings);
    assert!(env.emg.iter().all(|e| e.power_line_ratio.is_none()));
    assert!(!env.applied.contains(&"power_line") && !env.applied.contains(&"emg_rate"));
    assert!(env.emg_is_envelope);
    assert_eq!(
        env.applied_text(),
        "angle range, isokinetic plateaus, saturation, flat EMG"
    );
    assert_eq!(
        check_trial(&b.trial, Some(&b.prediction)).applied_text(),
        "angle range, isokinetic plateaus, saturation, EMG, torque sign"
    );
}
