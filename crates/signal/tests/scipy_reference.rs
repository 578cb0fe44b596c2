//! Agreement with scipy 1.17.1 outputs in `tests/data/scipy_reference.json`.

use serde_json::Value;
use signal::{
    butter, envelope, normalise, sosfilt, sosfiltfilt, Band, EnvelopeSettings, Normalisation,
};

const REL_TOL: f64 = 1e-10;

fn reference() -> Value {
    let text = include_str!("data/scipy_reference.json");
    serde_json::from_str(text).expect("reference JSON parses")
}

fn vec_f64(v: &Value) -> Vec<f64> {
    v.as_array()
        .expect("array")
        .iter()
        .map(|x| x.as_f64().expect("number"))
        .collect()
}

/// max |got − want| / max |want|
fn rel_err(got: &[f64], want: &[f64]) -> f64 {
    assert_eq!(got.len(), want.len(), "length mismatch");
    let scale = want.iter().fold(0.0_f64, |m, v| m.max(v.abs()));
    assert!(scale > 0.0);
    let err = got
        .iter()
        .zip(want)
        .fold(0.0_f64, |m, (a, b)| m.max((a - b).abs()));
    err / scale
}

fn band_of(filter: &Value) -> Band {
    let cut = vec_f64(&filter["cutoff"]);
    match filter["btype"].as_str().expect("btype") {
        "lowpass" => Band::Lowpass(cut[0]),
        "highpass" => Band::Highpass(cut[0]),
        "bandpass" => Band::Bandpass(cut[0], cut[1]),
        "bandstop" => Band::Bandstop(cut[0], cut[1]),
        other => panic!("unknown btype {other}"),
    }
}

fn filters(r: &Value) -> &Vec<Value> {
    let f = r["filters"].as_array().expect("filters");
    assert!(f.len() >= 6, "expected all reference filters");
    f
}

#[test]
fn sos_coefficients_match_scipy_butter() {
    let r = reference();
    for f in filters(&r) {
        let name = f["name"].as_str().unwrap();
        let order = f["order"].as_u64().unwrap() as usize;
        let fs = f["fs"].as_f64().unwrap();
        let sos = butter(order, band_of(f), fs).unwrap();
        let want: Vec<Vec<f64>> = f["sos"].as_array().unwrap().iter().map(vec_f64).collect();
        assert_eq!(sos.len(), want.len(), "{name}: number of sections");
        let mut worst = 0.0_f64;
        for (i, (got, w)) in sos.sections().iter().zip(&want).enumerate() {
            // numerator relative to the row's largest |b|, denominator to its largest |a|
            for (range, label) in [(0..3, "b"), (3..6, "a")] {
                let scale = w[range.clone()].iter().fold(0.0_f64, |m, v| m.max(v.abs()));
                for j in range {
                    let e = (got[j] - w[j]).abs() / scale;
                    worst = worst.max(e);
                    assert!(
                        e <= 1e-12,
                        "{name}: sos[{i}][{j}] ({label}) = {} vs scipy {} (rel {e:e})",
                        got[j],
                        w[j]
                    );
                }
            }
        }
        println!("{name}: worst relative coefficient error {worst:.3e}");
    }
}

#[test]
fn sosfilt_matches_scipy() {
    let r = reference();
    let x = vec_f64(&r["input"]["x"]);
    let mut tested = 0;
    for f in filters(&r) {
        if f.get("sosfilt").is_none() {
            continue;
        }
        let name = f["name"].as_str().unwrap();
        let sos = butter(
            f["order"].as_u64().unwrap() as usize,
            band_of(f),
            f["fs"].as_f64().unwrap(),
        )
        .unwrap();
        let y = sosfilt(&sos, &x).unwrap();
        let e = rel_err(&y, &vec_f64(&f["sosfilt"]));
        println!("{name}: sosfilt rel err {e:.3e}");
        assert!(e <= REL_TOL, "{name}: sosfilt rel err {e:e}");
        tested += 1;
    }
    assert_eq!(tested, 4);
}

#[test]
fn sosfiltfilt_matches_scipy() {
    let r = reference();
    let x = vec_f64(&r["input"]["x"]);
    let mut tested = 0;
    for f in filters(&r) {
        if f.get("sosfiltfilt").is_none() {
            continue;
        }
        let name = f["name"].as_str().unwrap();
        let sos = butter(
            f["order"].as_u64().unwrap() as usize,
            band_of(f),
            f["fs"].as_f64().unwrap(),
        )
        .unwrap();
        let y = sosfiltfilt(&sos, &x).unwrap();
        let e = rel_err(&y, &vec_f64(&f["sosfiltfilt"]));
        println!("{name}: sosfiltfilt rel err {e:.3e}");
        assert!(e <= REL_TOL, "{name}: sosfiltfilt rel err {e:e}");
        tested += 1;
    }
    assert_eq!(tested, 4);
}

#[test]
fn envelope_pipeline_matches_scipy() {
    let r = reference();
    let e = &r["envelope"];
    let fs = e["fs"].as_f64().unwrap();
    let raw = vec_f64(&e["raw"]);
    let mut env = envelope(&raw, fs, &EnvelopeSettings::default()).unwrap();
    let err_env = rel_err(&env, &vec_f64(&e["envelope"]));
    println!("envelope rel err {err_env:.3e}");
    assert!(err_env <= REL_TOL, "envelope rel err {err_env:e}");
    normalise(&mut env, Normalisation::TrialMax).unwrap();
    let err_norm = rel_err(&env, &vec_f64(&e["normalized"]));
    println!("normalized rel err {err_norm:.3e}");
    assert!(err_norm <= REL_TOL, "normalized rel err {err_norm:e}");
}
