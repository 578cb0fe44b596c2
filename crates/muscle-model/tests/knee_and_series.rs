//! The knee term and geometry series: the knee-extended polynomial model is unchanged, series
//! sampled from the polynomial reproduce it, and knee-flexed trials agree with an independent
//! implementation of the four-state equations (`common::spec_model`).

mod common;

use common::spec_model::{spec_torque, SpecMuscle};
use common::{max_diff, rms_diff};
use muscle_model::{
    simulate, synthetic, Effects, Formulation, GeometrySeries, ModelParams, Muscle, SimSettings,
    TrialInputs,
};

const FS: f64 = 2048.0;

fn settings(f: Formulation) -> SimSettings {
    SimSettings {
        formulation: f,
        ..SimSettings::default()
    }
}

const FORMULATIONS: [Formulation; 3] = [
    Formulation::Fast,
    Formulation::Reduced,
    Formulation::FourState,
];

/// The seed-like trial's torque at nominal parameters without effects, knee extended and
/// polynomial geometry, per formulation: its sum over the 6828 samples and its value at
/// samples 0, 975, …, 6827 (every seventh of the trial). These pin the model's arithmetic:
/// the knee term, series and fixed muscles leave a model without them exactly as it is.
const PINNED: [(Formulation, f64, [f64; 8]); 3] = [
    (
        Formulation::Fast,
        1171903.0620486399,
        [
            13.714620982599765,
            205.0215777497616,
            178.09570169175112,
            145.83180213952025,
            180.94400499628676,
            238.33612449548843,
            250.90777392539226,
            21.967331634326086,
        ],
    ),
    (
        Formulation::Reduced,
        1171906.4417219108,
        [
            13.714620982599671,
            205.02160551576685,
            178.0957003491087,
            145.83171007515404,
            180.94491394108465,
            238.3358309392065,
            250.90777745711253,
            21.966939075658072,
        ],
    ),
    (
        Formulation::FourState,
        1171892.212383021,
        [
            13.714620982599671,
            205.02182940015754,
            178.0951107972378,
            145.83117661819264,
            180.94065583254627,
            238.33309537869695,
            250.90628957740083,
            21.967175770408417,
        ],
    ),
];

#[test]
fn knee_extended_polynomial_torque_is_pinned_and_a_zero_knee_series_changes_nothing() {
    let tr = synthetic::seed_like_trial(FS).unwrap();
    assert_eq!(tr.len(), 6828);
    let zero_knee = tr.clone().with_knee_angle(vec![0.0; tr.len()]).unwrap();
    let p = ModelParams::nominal();
    for (f, sum, values) in PINNED {
        let out = simulate(&tr, &p, &Effects::none(), &settings(f)).unwrap();
        let got_sum: f64 = out.torque.iter().sum();
        assert!(
            (got_sum - sum).abs() < 1e-9 * tr.len() as f64,
            "{f:?}: sum {got_sum} vs {sum}"
        );
        for (k, v) in values.into_iter().enumerate() {
            let i = k * (tr.len() - 1) / 7;
            assert!(
                (out.torque[i] - v).abs() < 1e-9,
                "{f:?} sample {i}: {} vs {v}",
                out.torque[i]
            );
        }
        // a knee angle of 0 everywhere is the knee-extended model, bit for bit
        let zero = simulate(&zero_knee, &p, &Effects::none(), &settings(f)).unwrap();
        assert_eq!(zero.torque, out.torque, "{f:?}");
    }
}

/// The trial's musculotendon lengths and moment arms sampled from the polynomials at 250 Hz
/// (from the analytic seed angle), then resampled linearly to the trial's grid, as a reader
/// of OpenSim or CEINMS files does.
fn series_from_polynomial(tr: &TrialInputs, p: &ModelParams, m: Muscle) -> GeometrySeries {
    let c = p.muscle(m).lmt_poly_m;
    let duration = tr.times()[tr.len() - 1] - tr.t0();
    let coarse = (duration * 250.0).ceil() as usize + 1;
    let q: Vec<f64> = (0..coarse)
        .map(|k| synthetic::seed_angle_deg_at(tr.t0() + k as f64 / 250.0).to_radians())
        .collect();
    let lmt: Vec<f64> = q
        .iter()
        .map(|&q| c[0] + q * (c[1] + q * (c[2] + q * c[3])))
        .collect();
    let arm: Vec<f64> = q
        .iter()
        .map(|&q| c[1] + q * (2.0 * c[2] + 3.0 * c[3] * q))
        .collect();
    let resample = |v: &[f64]| -> Vec<f64> {
        tr.times()
            .iter()
            .map(|&t| {
                let x = (t - tr.t0()) * 250.0;
                let i = (x.floor() as usize).min(coarse - 2);
                let s = x - i as f64;
                v[i] + s * (v[i + 1] - v[i])
            })
            .collect()
    };
    GeometrySeries {
        lmt_m: resample(&lmt),
        moment_arm_m: resample(&arm),
    }
}

#[test]
fn series_sampled_from_the_polynomial_at_250_hz_reproduce_its_torque() {
    let tr = synthetic::seed_like_trial(FS).unwrap();
    let p = ModelParams::nominal();
    let mut with_series = tr.clone();
    for m in Muscle::ALL {
        with_series = with_series
            .with_geometry(m.name(), series_from_polynomial(&tr, &p, m))
            .unwrap();
    }
    for f in FORMULATIONS {
        let poly = simulate(&tr, &p, &Effects::none(), &settings(f)).unwrap();
        let series = simulate(&with_series, &p, &Effects::none(), &settings(f)).unwrap();
        let rms = rms_diff(&poly.torque, &series.torque);
        let mx = max_diff(&poly.torque, &series.torque);
        println!("{f:?}: series vs polynomial RMS {rms:.2e} N·m, max {mx:.2e} N·m");
        assert!(rms < 0.05, "{f:?}: RMS {rms}");
        // the series are used: they differ from the polynomial by the 250 Hz sampling
        assert!(rms > 0.0, "{f:?}");
    }
}

fn spec_muscles(p: &ModelParams) -> Vec<SpecMuscle> {
    Muscle::ALL
        .iter()
        .map(|&m| {
            let mp = p.muscle(m);
            SpecMuscle {
                f0: mp.fom_n,
                lom: mp.lom_m,
                lst: mp.lst_m,
                alpha0_deg: mp.alpha_deg,
                poly: mp.lmt_poly_m,
                knee_arm: mp.knee_moment_arm_m,
            }
        })
        .collect()
}

/// A knee at 90° throughout, and a knee moving between 10° and 80° during the trial.
fn knee_cases(n: usize) -> [(&'static str, Vec<f64>); 2] {
    let moving = (0..n)
        .map(|i| {
            let t = i as f64 / FS;
            (45.0 - 35.0 * (std::f64::consts::PI * 0.6 * t).cos()).to_radians()
        })
        .collect();
    [
        ("knee 90°", vec![90f64.to_radians(); n]),
        ("knee 10°–80°", moving),
    ]
}

#[test]
fn knee_flexed_trials_agree_with_an_independent_implementation() {
    let tr = synthetic::seed_like_trial(FS).unwrap();
    let p = ModelParams::nominal();
    let extended = simulate(&tr, &p, &Effects::none(), &SimSettings::default()).unwrap();
    let sm = spec_muscles(&p);
    for (label, knee) in knee_cases(tr.len()) {
        let flexed = tr.clone().with_knee_angle(knee.clone()).unwrap();
        let muscles: Vec<(SpecMuscle, &[f64])> = Muscle::ALL
            .iter()
            .map(|&m| (sm[m.index()], tr.envelope(m)))
            .collect();
        let reference = spec_torque(&muscles, tr.angle(), &knee, FS, 8);
        for f in [Formulation::Fast, Formulation::FourState] {
            let out = simulate(&flexed, &p, &Effects::none(), &settings(f)).unwrap();
            let rms = rms_diff(&out.torque, &reference);
            println!("{label}, {f:?}: RMS vs independent RK4 {rms:.2e} N·m");
            assert!(rms < 0.5, "{label} {f:?}: RMS {rms}");
        }
        // the knee term is in effect: flexion slackens the gastrocnemii, not the soleus
        let out = simulate(&flexed, &p, &Effects::none(), &SimSettings::default()).unwrap();
        let mean = |v: &[f64]| v.iter().sum::<f64>() / v.len() as f64;
        let gm = mean(out.torque_of(Muscle::Gm)) / mean(extended.torque_of(Muscle::Gm));
        println!("{label}: gm torque {gm:.3} of knee extended");
        assert!(gm < 0.8, "{label}: gm {gm}");
        assert_eq!(
            out.torque_of(Muscle::Sol),
            extended.torque_of(Muscle::Sol),
            "{label}"
        );
    }
}
