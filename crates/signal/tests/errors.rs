//! Every error path returns a structured `SignalError` instead of panicking.

use signal::{
    butter, envelope, normalise, sosfilt, sosfilt_inplace, sosfilt_into, sosfiltfilt,
    sosfiltfilt_into, Band, EnvelopeFilter, EnvelopeSettings, Normalisation, SignalError, Sos,
};

fn lp() -> Sos {
    butter(4, Band::Lowpass(2.0), 2048.0).unwrap()
}

#[test]
fn order_zero_is_rejected() {
    assert_eq!(
        butter(0, Band::Lowpass(10.0), 1000.0),
        Err(SignalError::InvalidOrder { order: 0 })
    );
}

#[test]
fn cutoffs_outside_zero_nyquist_are_rejected() {
    for f in [0.0, -5.0, 500.0, 600.0, f64::NAN, f64::INFINITY] {
        for band in [Band::Lowpass(f), Band::Highpass(f)] {
            match butter(2, band, 1000.0) {
                Err(SignalError::CutoffOutOfRange {
                    cutoff_hz,
                    nyquist_hz,
                }) => {
                    assert!(cutoff_hz == f || (f.is_nan() && cutoff_hz.is_nan()));
                    assert_eq!(nyquist_hz, 500.0);
                }
                other => panic!("{band:?}: expected CutoffOutOfRange, got {other:?}"),
            }
        }
    }
    assert!(matches!(
        butter(2, Band::Bandpass(10.0, 500.0), 1000.0),
        Err(SignalError::CutoffOutOfRange { cutoff_hz, .. }) if cutoff_hz == 500.0
    ));
    assert!(matches!(
        butter(2, Band::Bandstop(0.0, 100.0), 1000.0),
        Err(SignalError::CutoffOutOfRange { cutoff_hz, .. }) if cutoff_hz == 0.0
    ));
}

#[test]
fn band_edges_must_increase() {
    for (lo, hi) in [(350.0, 10.0), (50.0, 50.0)] {
        assert_eq!(
            butter(2, Band::Bandpass(lo, hi), 2048.0),
            Err(SignalError::BandEdgesOutOfOrder {
                low_hz: lo,
                high_hz: hi
            })
        );
        assert!(matches!(
            butter(2, Band::Bandstop(lo, hi), 2048.0),
            Err(SignalError::BandEdgesOutOfOrder { .. })
        ));
    }
}

#[test]
fn bad_sampling_rate_is_rejected() {
    for fs in [0.0, -1.0, f64::NAN, f64::INFINITY] {
        assert!(matches!(
            butter(2, Band::Lowpass(1.0), fs),
            Err(SignalError::InvalidSamplingRate { .. })
        ));
    }
}

#[test]
fn signal_not_longer_than_padlen_is_rejected() {
    let sos = lp();
    for len in [0, 1, 15] {
        assert_eq!(
            sosfiltfilt(&sos, &vec![1.0; len]),
            Err(SignalError::SignalTooShort { len, padlen: 15 })
        );
    }
    // The envelope needs more than the band-pass and low-pass pad lengths (both 15).
    assert_eq!(
        envelope(&[0.5; 15], 2048.0, &EnvelopeSettings::default()),
        Err(SignalError::SignalTooShort {
            len: 15,
            padlen: 15
        })
    );
}

#[test]
fn non_finite_samples_are_reported_with_their_index() {
    let sos = lp();
    let mut x = vec![0.0; 100];
    x[42] = f64::NAN;
    let expect = |r: Result<Vec<f64>, SignalError>| match r {
        Err(SignalError::NonFiniteSample { index, value }) => {
            assert_eq!(index, 42);
            assert!(value.is_nan());
        }
        other => panic!("expected NonFiniteSample, got {other:?}"),
    };
    expect(sosfilt(&sos, &x));
    expect(sosfiltfilt(&sos, &x));
    expect(envelope(&x, 2048.0, &EnvelopeSettings::default()));
    x[42] = 0.0;
    x[7] = f64::NEG_INFINITY;
    assert_eq!(
        sosfilt_inplace(&sos, &mut x, &mut [[0.0; 2]; 2]),
        Err(SignalError::NonFiniteSample {
            index: 7,
            value: f64::NEG_INFINITY
        })
    );
    let mut env = vec![0.1, f64::INFINITY];
    assert!(matches!(
        normalise(&mut env, Normalisation::TrialMax),
        Err(SignalError::NonFiniteSample { index: 1, .. })
    ));
}

#[test]
fn invalid_mvc_is_rejected() {
    for mvc in [0.0, -1.0, f64::NAN, f64::INFINITY] {
        let mut env = vec![0.1, 0.2];
        match normalise(&mut env, Normalisation::Mvc(mvc)) {
            Err(SignalError::InvalidMvc { mvc: got }) => {
                assert!(got == mvc || (mvc.is_nan() && got.is_nan()))
            }
            other => panic!("expected InvalidMvc, got {other:?}"),
        }
        assert_eq!(env, vec![0.1, 0.2], "input untouched on error");
    }
}

#[test]
fn all_zero_or_empty_channel_cannot_be_normalised_by_its_max() {
    let mut zero = vec![0.0; 10];
    assert_eq!(
        normalise(&mut zero, Normalisation::TrialMax),
        Err(SignalError::NonPositiveMaximum { max: 0.0, len: 10 })
    );
    let mut empty: Vec<f64> = vec![];
    assert!(matches!(
        normalise(&mut empty, Normalisation::TrialMax),
        Err(SignalError::NonPositiveMaximum { len: 0, .. })
    ));
    // An all-zero raw channel gives an all-zero envelope, hence the same error.
    let mut env = envelope(&[0.0; 200], 2048.0, &EnvelopeSettings::default()).unwrap();
    assert!(env.iter().all(|v| *v == 0.0));
    assert!(matches!(
        normalise(&mut env, Normalisation::TrialMax),
        Err(SignalError::NonPositiveMaximum { .. })
    ));
}

#[test]
fn invalid_sections_and_buffer_sizes_are_rejected() {
    assert_eq!(Sos::new(vec![]), Err(SignalError::EmptySos));
    assert!(matches!(
        Sos::new(vec![[1.0, 0.0, 0.0, 2.0, 0.0, 0.0]]),
        Err(SignalError::InvalidSection { index: 0, .. })
    ));
    assert!(matches!(
        Sos::new(vec![
            [1.0, 0.0, 0.0, 1.0, 0.0, 0.0],
            [f64::NAN, 0.0, 0.0, 1.0, 0.0, 0.0]
        ]),
        Err(SignalError::InvalidSection { index: 1, .. })
    ));
    let sos = lp();
    let x = vec![1.0; 50];
    let mut y = vec![0.0; 49];
    assert_eq!(
        sosfilt_into(&sos, &x, &mut [[0.0; 2]; 2], &mut y),
        Err(SignalError::LengthMismatch {
            what: "output buffer",
            expected: 50,
            got: 49
        })
    );
    assert!(matches!(
        sosfilt_into(&sos, &x, &mut [[0.0; 2]; 3], &mut vec![0.0; 50]),
        Err(SignalError::LengthMismatch {
            expected: 2,
            got: 3,
            ..
        })
    ));
    assert!(matches!(
        sosfiltfilt_into(&sos, &x, &mut y, &mut Vec::new()),
        Err(SignalError::LengthMismatch { .. })
    ));
    let filt = EnvelopeFilter::new(2048.0, &EnvelopeSettings::default()).unwrap();
    assert!(matches!(
        filt.envelope_into(&x, &mut y, &mut Vec::new()),
        Err(SignalError::LengthMismatch { .. })
    ));
}

#[test]
fn envelope_settings_errors_propagate() {
    let bad = EnvelopeSettings {
        lowpass_order: 0,
        ..EnvelopeSettings::default()
    };
    assert_eq!(
        envelope(&[0.0; 100], 2048.0, &bad),
        Err(SignalError::InvalidOrder { order: 0 })
    );
    // 350 Hz is above Nyquist at fs = 500 Hz.
    assert!(matches!(
        envelope(&[0.0; 100], 500.0, &EnvelopeSettings::default()),
        Err(SignalError::CutoffOutOfRange { cutoff_hz, nyquist_hz })
            if cutoff_hz == 350.0 && nyquist_hz == 250.0
    ));
}

#[test]
fn errors_display_their_fields() {
    let e = SignalError::NonFiniteSample {
        index: 3,
        value: f64::NAN,
    };
    assert_eq!(e.to_string(), "sample 3 is not finite (NaN)");
    let e = SignalError::SignalTooShort {
        len: 10,
        padlen: 15,
    };
    assert!(e.to_string().contains("padlen = 15"));
}
