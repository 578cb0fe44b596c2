//! Models with fixed muscles besides sol, gm and gl: a tibialis anterior driven by its own
//! envelope pulls the other way, its torque adds to the joint torque in every formulation and
//! in the identification problem (where it is integrated once), and missing inputs are
//! errors naming the muscle.

mod common;

use common::rms_diff;
use common::spec_model::{spec_torque, SpecMuscle};
use muscle_model::musculotendon::IX_FT;
use muscle_model::{
    simulate, simulate_into, synthetic, Effects, Formulation, GeometrySeries, ModelError,
    ModelParams, Muscle, MuscleParams, ParamId, Problem, ProblemWorkspace, SimSettings,
    TrialInputs, Workspace,
};

const FS: f64 = 1024.0;

fn with_ta() -> ModelParams {
    let mut p = ModelParams::nominal();
    p.fixed.insert("ta", MuscleParams::nominal_ta()).unwrap();
    p
}

/// The seed-like trial with a TA envelope that bursts to 0.6 in the middle of each sweep
/// (co-contraction) over a 0.05 rest.
fn trial_with_ta_burst() -> TrialInputs {
    let tr = synthetic::seed_like_trial(FS).unwrap();
    let st = synthetic::seed_times();
    let mid = 0.5 * (st.concentric_start + st.eccentric_end);
    let ta: Vec<f64> = tr
        .times()
        .iter()
        .map(|&t| 0.05 + 0.55 * (-((t - mid) / 0.4).powi(2)).exp())
        .collect();
    tr.with_envelope("ta", ta).unwrap()
}

fn settings(f: Formulation) -> SimSettings {
    SimSettings {
        formulation: f,
        ..SimSettings::default()
    }
}

#[test]
fn a_tibialis_anterior_pulls_against_the_triceps_in_every_formulation() {
    let tr = trial_with_ta_burst();
    let p = with_ta();
    let e = Effects::none();
    for f in [
        Formulation::Fast,
        Formulation::Reduced,
        Formulation::FourState,
    ] {
        let s = settings(f).with_states();
        let out = simulate(&tr, &p, &e, &s).unwrap();
        let names: Vec<&str> = out.muscles.iter().map(|m| m.name).collect();
        assert_eq!(names, ["sol", "gm", "gl", "ta"], "{f:?}");
        let ta = out.muscle_named("ta").unwrap();
        let states = ta.states.as_ref().unwrap();
        let mut active = 0;
        for (i, (&tq, y)) in ta.torque.iter().zip(states).enumerate() {
            if y[IX_FT] > 0.0 {
                active += 1;
                assert!(
                    tq < 0.0,
                    "{f:?} sample {i}: TA torque {tq} with force {}",
                    y[IX_FT]
                );
            } else {
                assert_eq!(tq, 0.0, "{f:?} sample {i}");
            }
        }
        let peak = ta.torque.iter().cloned().fold(0.0, f64::min);
        println!("{f:?}: TA torque peak {peak:.2} N·m, force at {active} samples");
        assert!(peak < -20.0, "{f:?}: TA peak {peak}");
        assert!(active > tr.len() / 2, "{f:?}: {active}");
        // the joint torque is the triceps model's plus the TA's
        let triceps = simulate(&tr, &ModelParams::nominal(), &e, &settings(f)).unwrap();
        for i in 0..tr.len() {
            let want = triceps.torque[i] + ta.torque[i];
            assert!((out.torque[i] - want).abs() < 1e-9, "{f:?} sample {i}");
        }
        for m in Muscle::ALL {
            assert_eq!(out.torque_of(m), triceps.torque_of(m), "{f:?} {m}");
        }
        // the workspace path gives the same joint torque and names every muscle
        let mut ws = Workspace::new();
        let mut into = vec![0.0; tr.len()];
        simulate_into(&mut ws, &tr, &p, &e, &settings(f), &mut into).unwrap();
        assert!(rms_diff(&into, &out.torque) < 1e-9, "{f:?}");
        let tm = ws.torque_muscle();
        assert_eq!(tm.len(), 4);
        assert_eq!(tm[3].name, "ta");
        assert_eq!(tm[3].torque, ta.torque, "{f:?}");
    }
}

#[test]
fn the_tibialis_anterior_agrees_with_an_independent_implementation() {
    let tr = trial_with_ta_burst();
    let p = with_ta();
    let ta = MuscleParams::nominal_ta();
    let spec = SpecMuscle {
        f0: ta.fom_n,
        lom: ta.lom_m,
        lst: ta.lst_m,
        alpha0_deg: ta.alpha_deg,
        poly: ta.lmt_poly_m,
        knee_arm: 0.0,
    };
    let env = tr.envelope_named("ta").unwrap();
    let reference = spec_torque(&[(spec, env)], tr.angle(), &vec![0.0; tr.len()], FS, 8);
    let out = simulate(&tr, &p, &Effects::none(), &SimSettings::default()).unwrap();
    let rms = rms_diff(&out.muscle_named("ta").unwrap().torque, &reference);
    println!("TA vs independent RK4: RMS {rms:.2e} N·m");
    assert!(rms < 0.05, "RMS {rms}");
}

#[test]
fn the_identification_problem_integrates_a_fixed_muscle_once() {
    let tr = trial_with_ta_burst();
    let truth = with_ta();
    let measured = simulate(&tr, &truth, &Effects::none(), &SimSettings::default())
        .unwrap()
        .torque;
    let problem = Problem::new(
        tr.clone(),
        measured.clone(),
        with_ta(),
        Effects::none(),
        ParamId::identified().to_vec(),
    )
    .unwrap();
    let mut ws = ProblemWorkspace::new();
    let x0 = problem.base_vector();
    // the truth is the base: zero cost there
    assert!(problem.sse_with(&x0, &mut ws).unwrap() < 1e-12);
    // a model without the TA misses its torque
    let triceps_only = Problem::new(
        tr,
        measured,
        ModelParams::nominal(),
        Effects::none(),
        ParamId::identified().to_vec(),
    )
    .unwrap();
    let missing = triceps_only.rms(&x0).unwrap();
    println!("RMS without the TA: {missing:.2} N·m");
    assert!(missing > 5.0, "{missing}");
    // annealing-style moves of the identified parameters: the cost follows, and the TA
    // (like any muscle whose inputs did not change) is taken from the workspace
    let mut last = 0.0;
    for k in 0..12 {
        let mut x = x0.clone();
        let i = k % x.len();
        x[i] *= 1.0 + 0.01 * (k as f64 + 1.0);
        let (lo, hi) = problem.bounds()[i];
        x[i] = x[i].clamp(lo, hi);
        let sse = problem.sse_with(&x, &mut ws).unwrap();
        assert!(
            sse > 0.0 && sse.is_finite() && sse != last,
            "move {k}: {sse}"
        );
        last = sse;
        let fresh = problem.sse(&x).unwrap();
        assert!(
            (sse - fresh).abs() <= 1e-9 * fresh,
            "move {k}: {sse} vs {fresh}"
        );
    }
}

#[test]
fn a_fixed_muscle_is_integrated_once_per_trial_and_parameters() {
    let tr = trial_with_ta_burst();
    let mut p = with_ta();
    let e = Effects::none();
    let s = SimSettings::default();
    let mut ws = Workspace::new();
    let mut out = vec![0.0; tr.len()];
    simulate_into(&mut ws, &tr, &p, &e, &s, &mut out).unwrap();
    assert_eq!(ws.cache_counts(), (0, 4));
    // a move of the soleus integrates the soleus only
    p.muscle_mut(Muscle::Sol).lst_m *= 1.01;
    simulate_into(&mut ws, &tr, &p, &e, &s, &mut out).unwrap();
    assert_eq!(ws.cache_counts(), (3, 5));
    // a move of the activation changes every muscle, the TA too
    p.activation.tau_act_s = 0.02;
    simulate_into(&mut ws, &tr, &p, &e, &s, &mut out).unwrap();
    assert_eq!(ws.cache_counts(), (3, 9));
}

#[test]
fn missing_or_wrong_inputs_of_a_muscle_are_errors_naming_it() {
    let p = with_ta();
    let e = Effects::none();
    let s = SimSettings::default();
    // the seed-like trial has a `ta` envelope; a fixed `perlong` needs its own
    let tr = synthetic::seed_like_trial(512.0).unwrap();
    let mut q = p;
    q.fixed
        .insert("perlong", MuscleParams::nominal_ta())
        .unwrap();
    let err = simulate(&tr, &q, &e, &s).unwrap_err();
    let msg = err.to_string();
    println!("{msg}");
    assert!(matches!(err, ModelError::InvalidInput { .. }), "{err:?}");
    assert!(
        msg.contains("`perlong`") && msg.contains("emg_perlong"),
        "{msg}"
    );
    let mut ws = Workspace::new();
    let mut out = vec![0.0; tr.len()];
    let err = simulate_into(&mut ws, &tr, &q, &e, &s, &mut out).unwrap_err();
    assert!(err.to_string().contains("`perlong`"), "{err}");

    // a fixed muscle without a length polynomial needs the trial's series
    let series_only = ModelParams::nominal()
        .merged_json_str(
            r#"{"muscles": {"perbrev": {"fom_n": 435, "lom_m": 0.05, "lst_m": 0.161,
                "alpha_deg": 5}}}"#,
        )
        .unwrap();
    assert!(series_only
        .fixed
        .get("perbrev")
        .unwrap()
        .params
        .geometry_from_trial());
    let env = vec![0.1; tr.len()];
    let tr2 = tr.clone().with_envelope("perbrev", env).unwrap();
    for f in [Formulation::Fast, Formulation::FourState] {
        let err = simulate(&tr2, &series_only, &e, &settings(f)).unwrap_err();
        let msg = err.to_string();
        println!("{msg}");
        assert!(msg.contains("`perbrev`") && msg.contains("series"), "{msg}");
    }
    // with the series it simulates, a plantarflexor with a positive moment arm
    let n = tr.len();
    let series = GeometrySeries {
        lmt_m: tr.angle().iter().map(|q| 0.215 + 0.02 * q).collect(),
        moment_arm_m: vec![0.02; n],
    };
    let tr3 = tr2.with_geometry("perbrev", series.clone()).unwrap();
    let out = simulate(&tr3, &series_only, &e, &s).unwrap();
    let pb = out.muscle_named("perbrev").unwrap();
    assert!(pb.torque.iter().all(|&t| t >= 0.0));
    assert!(pb.torque.iter().any(|&t| t > 0.5));

    // series and envelopes of the wrong length
    let short = GeometrySeries {
        lmt_m: series.lmt_m[..n - 1].to_vec(),
        moment_arm_m: series.moment_arm_m.clone(),
    };
    let err = tr.clone().with_geometry("perbrev", short).unwrap_err();
    assert!(
        matches!(err, ModelError::Length { expected, got, .. } if expected == n && got == n - 1),
        "{err:?}"
    );
    assert!(err.to_string().contains("perbrev"), "{err}");
    let err = tr
        .clone()
        .with_envelope("perbrev", vec![0.1; n + 3])
        .unwrap_err();
    assert!(err.to_string().contains("perbrev"), "{err}");
    // an envelope named after an identified muscle replaces that muscle's
    let quiet = tr.clone().with_envelope("gm", vec![0.0; n]).unwrap();
    assert_eq!(quiet.envelope(Muscle::Gm), &vec![0.0; n][..]);
    assert_eq!(quiet.envelope_named("gm"), Some(&vec![0.0; n][..]));
    let err = tr.with_knee_angle(vec![0.0; 2]).unwrap_err();
    assert!(matches!(err, ModelError::Length { .. }), "{err:?}");
}

#[test]
fn envelopes_scaled_to_their_own_peaks_each_reach_one_and_keep_their_shape() {
    let half: Vec<f64> = (0..200).map(|i| 0.5 * (i as f64 / 199.0)).collect();
    let tr = TrialInputs::new(
        FS,
        0.0,
        vec![0.1; 200],
        [
            half.clone(),
            vec![0.0; 200],
            half.iter().map(|x| 0.4 * x).collect(),
        ],
        Some(half.iter().map(|x| 0.2 + x).collect()),
    )
    .unwrap()
    .with_envelope("perlong_r", half.iter().map(|x| 1.6 * x).collect())
    .unwrap();
    let (scaled, peaks) = tr.clone().scaled_to_own_peaks();
    let peak = |n: &str| peaks.iter().find(|(k, _)| k == n).unwrap().1;
    assert_eq!(peaks.len(), 5);
    assert!((peak("sol") - 0.5).abs() < 1e-15);
    assert_eq!(peak("gm"), 0.0);
    assert!((peak("gl") - 0.2).abs() < 1e-15);
    assert!((peak("ta") - 0.7).abs() < 1e-15);
    assert!((peak("perlong_r") - 0.8).abs() < 1e-15);
    for name in ["sol", "gl", "ta", "perlong_r"] {
        let (a, b) = (
            tr.envelope_named(name).unwrap(),
            scaled.envelope_named(name).unwrap(),
        );
        let top = b.iter().copied().fold(0.0, f64::max);
        assert!((top - 1.0).abs() < 1e-15, "{name}: {top}");
        for (x, y) in a.iter().zip(b) {
            assert!((y * peak(name) - x).abs() < 1e-15, "{name}");
        }
    }
    // the all-zero gastrocnemius stays zero, not NaN
    assert!(scaled.envelope(Muscle::Gm).iter().all(|&x| x == 0.0));
    // new inputs, so no memo of the old envelopes is reused
    let p = ModelParams::nominal();
    let e = Effects::none();
    let s = SimSettings::default();
    let (t0, t1) = (
        simulate(&tr, &p, &e, &s).unwrap().torque,
        simulate(&scaled, &p, &e, &s).unwrap().torque,
    );
    assert!(t1[150] > t0[150] + 1.0, "{} {}", t0[150], t1[150]);
}
