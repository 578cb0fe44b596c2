//! Physical properties of the designed filters and of the filtering routines.

use signal::{
    butter, envelope, normalise, rectify, sosfilt, sosfilt_inplace, sosfilt_into, sosfilt_zi,
    sosfiltfilt, sosfiltfilt_inplace, sosfiltfilt_into, sosfiltfilt_padlen, Band, EnvelopeFilter,
    EnvelopeSettings, Normalisation, Sos,
};
use std::f64::consts::PI;

/// |H(e^{iω})| of the cascade at frequency `f` Hz.
fn gain(sos: &Sos, f: f64, fs: f64) -> f64 {
    let w = 2.0 * PI * f / fs;
    // z^{-1} = e^{-iω}
    let (c1, s1) = (w.cos(), -w.sin());
    let (c2, s2) = ((2.0 * w).cos(), -(2.0 * w).sin());
    sos.sections()
        .iter()
        .map(|r| {
            let (nr, ni) = (r[0] + r[1] * c1 + r[2] * c2, r[1] * s1 + r[2] * s2);
            let (dr, di) = (r[3] + r[4] * c1 + r[5] * c2, r[4] * s1 + r[5] * s2);
            (nr.hypot(ni)) / (dr.hypot(di))
        })
        .product()
}

/// Phase of H(e^{iω}) at `f` Hz.
fn phase(sos: &Sos, f: f64, fs: f64) -> f64 {
    let w = 2.0 * PI * f / fs;
    sos.sections()
        .iter()
        .map(|r| {
            let n = (
                r[0] + r[1] * w.cos() + r[2] * (2.0 * w).cos(),
                -r[1] * w.sin() - r[2] * (2.0 * w).sin(),
            );
            let d = (
                r[3] + r[4] * w.cos() + r[5] * (2.0 * w).cos(),
                -r[4] * w.sin() - r[5] * (2.0 * w).sin(),
            );
            n.1.atan2(n.0) - d.1.atan2(d.0)
        })
        .sum()
}

const FS: f64 = 2048.0;

#[test]
fn lowpass_has_unit_dc_gain_and_minus_3db_at_cutoff_for_orders_1_to_12() {
    for n in 1..=12 {
        let sos = butter(n, Band::Lowpass(40.0), FS).unwrap();
        assert_eq!(sos.len(), n.div_ceil(2), "order {n}");
        assert!((gain(&sos, 0.0, FS) - 1.0).abs() < 1e-10, "order {n} DC");
        let g = gain(&sos, 40.0, FS);
        assert!(
            (g - 0.5_f64.sqrt()).abs() < 1e-9,
            "order {n}: |H(fc)| = {g}"
        );
        assert!(gain(&sos, FS / 2.0, FS) < 1e-10, "order {n}: Nyquist");
    }
}

#[test]
fn highpass_blocks_dc_and_passes_nyquist() {
    for n in 1..=9 {
        let sos = butter(n, Band::Highpass(20.0), FS).unwrap();
        assert!(gain(&sos, 0.0, FS) < 1e-12, "order {n} DC");
        assert!(
            (gain(&sos, FS / 2.0, FS) - 1.0).abs() < 1e-10,
            "order {n} Nyquist"
        );
        let g = gain(&sos, 20.0, FS);
        assert!(
            (g - 0.5_f64.sqrt()).abs() < 1e-9,
            "order {n}: |H(fc)| = {g}"
        );
    }
}

#[test]
fn bandpass_and_bandstop_are_minus_3db_at_both_edges() {
    for n in 1..=6 {
        let bp = butter(n, Band::Bandpass(10.0, 350.0), FS).unwrap();
        let bs = butter(n, Band::Bandstop(10.0, 350.0), FS).unwrap();
        assert_eq!(bp.len(), n);
        assert_eq!(bs.len(), n);
        for f in [10.0, 350.0] {
            assert!(
                (gain(&bp, f, FS) - 0.5_f64.sqrt()).abs() < 1e-9,
                "bp order {n} at {f}"
            );
            assert!(
                (gain(&bs, f, FS) - 0.5_f64.sqrt()).abs() < 1e-9,
                "bs order {n} at {f}"
            );
        }
        assert!(gain(&bp, 0.0, FS) < 1e-12);
        assert!((gain(&bs, 0.0, FS) - 1.0).abs() < 1e-10);
        assert!((gain(&bs, FS / 2.0, FS) - 1.0).abs() < 1e-10);
    }
}

#[test]
fn every_designed_filter_is_stable() {
    for n in 1..=10 {
        for band in [
            Band::Lowpass(3.0),
            Band::Highpass(500.0),
            Band::Bandpass(1.0, 1000.0),
            Band::Bandstop(45.0, 55.0),
        ] {
            let sos = butter(n, band, FS).unwrap();
            for r in sos.sections() {
                // Roots of z² + a1 z + a2 inside the unit circle (Jury conditions).
                assert!(r[5].abs() < 1.0, "{band:?} order {n}: a2 = {}", r[5]);
                assert!(r[4].abs() < 1.0 + r[5], "{band:?} order {n}: a1 = {}", r[4]);
            }
        }
    }
}

#[test]
fn passband_sinusoid_survives_filtfilt_without_phase_shift() {
    let sos = butter(2, Band::Bandpass(10.0, 350.0), FS).unwrap();
    let f = 80.0;
    let x: Vec<f64> = (0..8192)
        .map(|i| (2.0 * PI * f * i as f64 / FS).sin())
        .collect();
    let y = sosfiltfilt(&sos, &x).unwrap();
    let g2 = gain(&sos, f, FS).powi(2);
    assert!(g2 > 0.99, "80 Hz is in the passband: |H|² = {g2}");
    // Away from the ends, y = |H|² x exactly in steady state: same zero crossings.
    let err = (2000..6000)
        .map(|i| (y[i] - g2 * x[i]).abs())
        .fold(0.0, f64::max);
    assert!(err < 1e-6, "zero-phase steady state error {err}");
    // The causal filter does shift the phase (sanity check of the comparison).
    let yc = sosfilt(&sos, &x).unwrap();
    let ph = phase(&sos, f, FS);
    assert!(ph.abs() > 0.05);
    let errc = (2000..6000)
        .map(|i| (yc[i] - g2.sqrt() * x[i]).abs())
        .fold(0.0, f64::max);
    assert!(
        errc > 0.05,
        "causal output should be phase shifted, err {errc}"
    );
}

#[test]
fn sosfilt_zi_gives_step_steady_state() {
    for band in [
        Band::Lowpass(2.0),
        Band::Bandpass(10.0, 350.0),
        Band::Highpass(20.0),
    ] {
        let sos = butter(4, band, FS).unwrap();
        let dc = gain(&sos, 0.0, FS);
        let c = 2.5;
        let mut zi: Vec<[f64; 2]> = sosfilt_zi(&sos)
            .into_iter()
            .map(|z| [z[0] * c, z[1] * c])
            .collect();
        let mut x = vec![c; 300];
        sosfilt_inplace(&sos, &mut x, &mut zi).unwrap();
        for (i, v) in x.iter().enumerate() {
            assert!(
                (v - c * dc).abs() < 1e-8,
                "{band:?} sample {i}: {v} vs {}",
                c * dc
            );
        }
    }
}

#[test]
fn chunked_sosfilt_equals_one_pass() {
    let sos = butter(5, Band::Lowpass(100.0), FS).unwrap();
    let x: Vec<f64> = (0..1000).map(|i| ((i * 37 % 101) as f64).sin()).collect();
    let whole = sosfilt(&sos, &x).unwrap();
    let mut zi = vec![[0.0; 2]; sos.len()];
    let mut y = vec![0.0; x.len()];
    let (a, b) = x.split_at(333);
    let (ya, yb) = y.split_at_mut(333);
    sosfilt_into(&sos, a, &mut zi, ya).unwrap();
    sosfilt_into(&sos, b, &mut zi, yb).unwrap();
    assert_eq!(y, whole);
}

#[test]
fn filtfilt_variants_agree() {
    let sos = butter(3, Band::Bandpass(20.0, 450.0), FS).unwrap();
    let x: Vec<f64> = (0..700).map(|i| ((i * 13 % 29) as f64) - 14.0).collect();
    let y = sosfiltfilt(&sos, &x).unwrap();
    let mut y2 = vec![0.0; x.len()];
    let mut scratch = Vec::new();
    sosfiltfilt_into(&sos, &x, &mut y2, &mut scratch).unwrap();
    let mut y3 = x.clone();
    sosfiltfilt_inplace(&sos, &mut y3, &mut scratch).unwrap();
    assert_eq!(y, y2);
    assert_eq!(y, y3);
    assert_ne!(y, x);
}

#[test]
fn padlen_follows_scipy_rule() {
    // 2 full sections: 3·(2·2 + 1) = 15.
    let lp4 = butter(4, Band::Lowpass(2.0), FS).unwrap();
    assert_eq!(sosfiltfilt_padlen(&lp4), 15);
    // Order 5: 3 sections, one with b2 = 0 and one with a2 = 0 → 3·(7 − 1) = 18.
    let lp5 = butter(5, Band::Lowpass(40.0), 500.0).unwrap();
    assert_eq!(sosfiltfilt_padlen(&lp5), 18);
    // len == padlen is rejected, padlen + 1 accepted (scipy: len(x) > padlen).
    assert!(sosfiltfilt(&lp4, &[1.0; 15]).is_err());
    let y = sosfiltfilt(&lp4, &[1.0; 16]).unwrap();
    assert!(y.iter().all(|v| (v - 1.0).abs() < 1e-9));
}

#[test]
fn envelope_tracks_amplitude_and_normalises_to_unit_max() {
    let fs = 2048.0;
    let n = 6144;
    // 120 Hz carrier with a slow amplitude 0.5 + 0.4 sin(2π·0.5 t).
    let amp = |t: f64| 0.5 + 0.4 * (2.0 * PI * 0.5 * t).sin();
    let raw: Vec<f64> = (0..n)
        .map(|i| {
            let t = i as f64 / fs;
            amp(t) * (2.0 * PI * 120.0 * t).sin()
        })
        .collect();
    let env = envelope(&raw, fs, &EnvelopeSettings::default()).unwrap();
    // Mean of |sin| is 2/π: the envelope is ≈ (2/π)·amp in the middle of the record.
    for i in (2048..4096).step_by(256) {
        let t = i as f64 / fs;
        let want = 2.0 / PI * amp(t);
        assert!(
            (env[i] - want).abs() < 0.02,
            "t = {t}: {} vs {want}",
            env[i]
        );
    }
    let mut norm = env.clone();
    normalise(&mut norm, Normalisation::TrialMax).unwrap();
    let max = norm.iter().copied().fold(f64::MIN, f64::max);
    assert_eq!(max, 1.0);
    assert!(norm.iter().all(|v| (0.0..=1.0).contains(v)));
    // A designed-once filter gives the same result.
    let filt = EnvelopeFilter::new(fs, &EnvelopeSettings::default()).unwrap();
    assert_eq!(filt.envelope(&raw).unwrap(), env);
    assert_eq!(filt.min_len(), 16);
}

#[test]
fn mvc_normalisation_divides_and_clamps() {
    let mut env = vec![-0.1, 0.0, 0.5, 1.0, 3.0];
    normalise(&mut env, Normalisation::Mvc(2.0)).unwrap();
    assert_eq!(env, vec![0.0, 0.0, 0.25, 0.5, 1.0]);
}

#[test]
fn rectify_is_absolute_value() {
    let mut x = vec![-2.0, -0.0, 0.5, 3.0];
    rectify(&mut x);
    assert_eq!(x, vec![2.0, 0.0, 0.5, 3.0]);
}
