//! Event detection and the dynamometer correction estimated from an unloaded run against the
//! synthetic truth.

use experiment::{
    detect_events, quantise, systematic_error, unloaded_run, DynamometerCorrection,
    DynamometerSettings, ErrorKind, Events, Protocol, Unloaded,
};
use numerics::rms_diff;

fn max_event_error(a: &Events, b: &Events) -> f64 {
    assert_eq!(a.starts.len(), b.starts.len(), "starts {a:?} vs {b:?}");
    assert_eq!(
        a.reversals.len(),
        b.reversals.len(),
        "reversals {a:?} vs {b:?}"
    );
    assert_eq!(a.stops.len(), b.stops.len(), "stops {a:?} vs {b:?}");
    a.all()
        .iter()
        .zip(b.all())
        .map(|(x, y)| (x - y).abs())
        .fold(0.0, f64::max)
}

#[test]
fn detected_events_match_the_protocols() {
    for p in ["seed", "relaxed+2", "cycles+3", "cycles+5"] {
        let tr = p.parse::<Protocol>().unwrap().trace().unwrap();
        let ev = detect_events(&tr.time_s, &tr.angle_deg).unwrap();
        let err = max_event_error(&ev, &tr.events);
        println!("{p}: max event error {:.3} ms", err * 1e3);
        assert!(err < 0.5e-3, "{p}: {err} s");
    }
}

#[test]
fn detected_events_survive_a_coarse_noisy_encoder() {
    // 0.01° encoder resolution plus ±0.01° jitter (deterministic pseudo-noise).
    let tr = Protocol::Cycles { cycles: 3 }.trace().unwrap();
    let mut state = 12345u64;
    let angle: Vec<f64> = tr
        .angle_deg
        .iter()
        .map(|a| {
            state = state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            let u = (state >> 11) as f64 / (1u64 << 53) as f64 - 0.5;
            ((a + 0.02 * u) / 0.01).round() * 0.01
        })
        .collect();
    let ev = detect_events(&tr.time_s, &angle).unwrap();
    let err = max_event_error(&ev, &tr.events);
    println!("noisy encoder: max event error {:.3} ms", err * 1e3);
    assert!(err < 3e-3, "{err} s");
}

#[test]
fn event_detection_rejects_bad_input() {
    let t: Vec<f64> = (0..100).map(|i| i as f64 / 2048.0).collect();
    let flat = vec![15.0; 100];
    let e = detect_events(&t, &flat).unwrap_err();
    assert_eq!(e.kind(), ErrorKind::InvalidSettings);
    let e = detect_events(&t, &flat[..50]).unwrap_err();
    assert_eq!(e.kind(), ErrorKind::LengthMismatch);
    let mut bad = flat.clone();
    bad[3] = f64::NAN;
    assert_eq!(
        detect_events(&t, &bad).unwrap_err().kind(),
        ErrorKind::NotFinite
    );
}

/// Theory for the nominal dynamometer noise at 2048 Hz.
struct Theory {
    sigma: f64,
    lag1: f64,
    phi: f64,
}

fn theory(s: &DynamometerSettings) -> Theory {
    let q = s.quantisation_step_nm();
    let var = s.ar1_sd_nm.powi(2) + s.white_sd_nm.powi(2) + q * q / 12.0;
    let phi = s.ar1_phi(1.0 / 2048.0);
    Theory {
        sigma: var.sqrt(),
        lag1: phi * s.ar1_sd_nm.powi(2) / var,
        phi,
    }
}

/// The remainder of an unloaded run after the correction's systematic part, at its own events.
fn remainder(u: &Unloaded, c: &DynamometerCorrection) -> Vec<f64> {
    let ev = detect_events(&u.time_s, &u.ankle_angle_deg).unwrap();
    let sys = c.systematic_for(&u.time_s, &ev);
    u.torque_nm.iter().zip(&sys).map(|(a, b)| a - b).collect()
}

/// Autocorrelation of `x` about its mean at lag `k` (biased autocovariances).
fn autocorrelation(x: &[f64], k: usize) -> f64 {
    let n = x.len() as f64;
    let m = x.iter().sum::<f64>() / n;
    let c = |k: usize| {
        x.iter()
            .zip(&x[k..])
            .map(|(a, b)| (a - m) * (b - m))
            .sum::<f64>()
            / n
    };
    c(k) / c(0)
}

#[test]
fn unloaded_estimate_recovers_the_systematic_part_and_the_noise() {
    let s = DynamometerSettings::default();
    let th = theory(&s);
    let seed_trace = Protocol::Seed.trace().unwrap();
    let true_sys = systematic_error(&seed_trace.time_s, &seed_trace.events.all(), &s);
    let offset_only = vec![s.offset_nm; true_sys.len()];
    let seeds = 1..=8u64;
    let mut sum_trans = 0.0;
    let mut sum_offset = 0.0;
    let mut worst = (0.0f64, 0.0f64, 0.0f64, 0.0f64, 0.0f64);
    for seed in seeds {
        let u = unloaded_run(&s, seed).unwrap();
        let est = DynamometerCorrection::from_unloaded(&u).unwrap();
        // Placed at the seed trial's own (detected) events.
        let ev = detect_events(&seed_trace.time_s, &seed_trace.angle_deg).unwrap();
        let sys = est.systematic_for(&seed_trace.time_s, &ev);
        let e_sys = rms_diff(&sys, &true_sys);
        let e_none = rms_diff(&offset_only, &true_sys);
        let trans_est: Vec<f64> = sys.iter().map(|v| v - est.offset_nm).collect();
        let trans_true: Vec<f64> = true_sys.iter().map(|v| v - s.offset_nm).collect();
        let e_trans = rms_diff(&trans_est, &trans_true);
        let r = est.random;
        let e_sigma = (r.marginal_sd() / th.sigma - 1.0).abs();
        let e_lag1 = (r.autocorrelation(1) - th.lag1).abs();
        let e_phi = (r.phi - th.phi).abs();
        println!(
            "seed {seed}: offset {:.3} sys rms err {e_sys:.3} transients {e_trans:.3} (none {e_none:.3}) \
             sigma {:.3}/{:.3} lag1 {:.4}/{:.4} phi {:.4}/{:.4} ar1 {:.3} white {:.3}",
            est.offset_nm,
            r.marginal_sd(),
            th.sigma,
            r.autocorrelation(1),
            th.lag1,
            r.phi,
            th.phi,
            r.sigma_ar,
            r.sigma_white,
        );
        let own = detect_events(&u.time_s, &u.ankle_angle_deg).unwrap();
        assert_eq!(own.all().len(), 7, "3 cycles: 1 start, 5 reversals, 1 stop");
        worst = (
            worst.0.max(e_sys),
            worst.1.max(e_sigma),
            worst.2.max(e_lag1),
            worst.3.max(e_phi),
            worst.4.max((est.offset_nm - s.offset_nm).abs()),
        );
        // The fitted transient removes most of the true one.
        assert!(
            e_trans < 0.75 * e_none,
            "seed {seed}: {e_trans} vs {e_none}"
        );
        sum_trans += e_trans / e_none;
        sum_offset += (est.offset_nm - s.offset_nm).abs();
    }
    println!(
        "worst: sys {:.3} N·m, sigma {:.3} rel, lag1 {:.4}, phi {:.4}, offset {:.3}",
        worst.0, worst.1, worst.2, worst.3, worst.4
    );
    let mean_trans = sum_trans / 8.0;
    println!("mean transient error / transient RMS: {mean_trans:.3}");
    assert!(mean_trans < 0.5, "{mean_trans}");
    // The offset is the mean of an AR(1) (correlation time 0.03 s) over ~7.5 s: sd ≈ 0.13 N·m.
    let mean_offset = sum_offset / 8.0;
    println!("mean |offset error| {mean_offset:.3} N·m");
    assert!(mean_offset < 0.2, "{mean_offset}");
    assert!(worst.0 < 0.4, "systematic part RMS error {} N·m", worst.0);
    assert!(worst.1 < 0.10, "sigma relative error {}", worst.1);
    assert!(worst.2 < 0.03, "lag-one autocorrelation error {}", worst.2);
    assert!(worst.3 < 0.01, "AR(1) phi error {}", worst.3);
    assert!(worst.4 < 0.4, "offset error {} N·m", worst.4);
}

#[test]
fn autocorrelation_follows_ar1_plus_white() {
    let s = DynamometerSettings::default();
    let u = unloaded_run(&s, 11).unwrap();
    let est = DynamometerCorrection::from_unloaded(&u).unwrap();
    let rem = remainder(&u, &est);
    for lag in [1usize, 5, 20, 60] {
        let measured = autocorrelation(&rem, lag);
        let model = est.random.autocorrelation(lag as u32);
        let ar1 = autocorrelation(&rem, 1).powi(lag as i32);
        println!("lag {lag}: measured {measured:.3} ar1+white {model:.3} ar1 {ar1:.3}");
        assert!(
            (measured - model).abs() < 0.06,
            "lag {lag}: {measured} vs {model}"
        );
    }
    // The fit reproduces the remainder's lag-one correlation and marginal σ exactly.
    let n = rem.len() as f64;
    let mean = rem.iter().sum::<f64>() / n;
    let sd = (rem.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / n).sqrt();
    assert!((est.random.autocorrelation(1) - autocorrelation(&rem, 1)).abs() < 1e-9);
    assert!((est.random.marginal_sd() - sd).abs() < 1e-9);
}

#[test]
fn estimate_of_a_pure_systematic_run_is_exact_up_to_quantisation() {
    // No random part: the fitted transient is the transient itself, the remainder is
    // quantisation.
    let s = DynamometerSettings {
        ar1_sd_nm: 0.0,
        white_sd_nm: 0.0,
        ..DynamometerSettings::default()
    };
    let u = unloaded_run(&s, 1).unwrap();
    let est = DynamometerCorrection::from_unloaded(&u).unwrap();
    let events = Protocol::unloaded().trace().unwrap().events;
    let truth = systematic_error(&u.time_s, &events.all(), &s);
    let ev = detect_events(&u.time_s, &u.ankle_angle_deg).unwrap();
    let sys = est.systematic_for(&u.time_s, &ev);
    // The ADC turns the constant offset into a constant (−1.5 → −1.655 N·m): compare the
    // transients and the offset separately.
    let transient_truth: Vec<f64> = truth.iter().map(|v| v - s.offset_nm).collect();
    let transient_est: Vec<f64> = sys.iter().map(|v| v - est.offset_nm).collect();
    let e = rms_diff(&transient_est, &transient_truth);
    let sigma = est.random.marginal_sd();
    println!("noise-free: systematic RMS error {e:.4} N·m, sigma {sigma:.4}");
    // The quantisation step is 0.33 N·m (its RMS 0.096 N·m); the estimate is within that.
    assert!(e < 0.1, "{e}");
    assert!(sigma < 0.15, "{sigma}");
    assert!((est.offset_nm - quantise(s.offset_nm, &s)).abs() < 0.2);
}

#[test]
fn the_report_states_what_is_subtracted() {
    let s = DynamometerSettings::default();
    let u = unloaded_run(&s, 4).unwrap();
    let est = DynamometerCorrection::from_unloaded(&u).unwrap();
    let r = est.report();
    assert_eq!(r.offset_nm, est.offset_nm);
    let t = r.transient.expect("the default run has a transient");
    assert_eq!(t.amplitude_nm, est.transient.b_nm.hypot(est.transient.c_nm));
    assert!((t.freq_hz - s.transient_freq_hz).abs() < 1.0, "{r:?}");
    assert!((t.tau_s / s.transient_tau_s - 1.0).abs() < 0.3, "{r:?}");
    assert!(
        (r.ar1_corr_time_s / s.ar1_corr_time_s - 1.0).abs() < 0.3,
        "{r:?}"
    );
    assert!((r.ar1_sd_nm / s.ar1_sd_nm - 1.0).abs() < 0.2, "{r:?}");
    // the AR(1) coefficient per sample back from the correlation time
    let phi = (-est.dt_s / r.ar1_corr_time_s).exp();
    assert!((phi - est.random.phi).abs() < 1e-12);
    // a trial corrected at its own events: measured − systematic
    let trace = Protocol::Seed.trace().unwrap();
    let trial = experiment::synthesize(&experiment::SynthConfig::new(Protocol::Seed, 4))
        .unwrap()
        .trial;
    let corrected = est.correct(&trial).unwrap();
    assert_eq!(corrected.events.all().len(), trace.events.all().len());
    for ((m, c), s) in trial
        .torque_nm
        .iter()
        .zip(&corrected.torque_nm)
        .zip(&corrected.systematic_nm)
    {
        assert_eq!(*c, m - s);
    }
}

#[test]
fn a_run_without_a_transient_reports_none() {
    let s = DynamometerSettings {
        transient_amplitude_nm: 0.0,
        ..DynamometerSettings::default()
    };
    let u = unloaded_run(&s, 5001).unwrap();
    let est = DynamometerCorrection::from_unloaded(&u).unwrap();
    assert!(est.transient.is_none(), "{est:?}");
    assert_eq!(est.report().transient, None);
}

#[test]
fn estimate_rejects_a_run_without_motion() {
    let n = 4096;
    let u = Unloaded {
        time_s: (0..n).map(|i| i as f64 / 2048.0).collect(),
        ankle_angle_deg: vec![15.0; n],
        torque_nm: vec![-1.5; n],
        comments: Vec::new(),
        ignored_columns: Vec::new(),
    };
    assert!(DynamometerCorrection::from_unloaded(&u).is_err());
    // too short, and non-finite values, are errors too, not panics
    assert!(DynamometerCorrection::fit(&[0.0; 8], 2048.0, &[], true).is_err());
    assert!(DynamometerCorrection::fit(&[f64::NAN; 64], 2048.0, &[], true).is_err());
    assert!(DynamometerCorrection::fit(&[0.0; 64], f64::NAN, &[], true).is_err());
}
