//! The exact torque Jacobian (forward sensitivities) against difference columns of very tight
//! simulations, at the default settings against the tight reference, and its refusals.

mod common;

use muscle_model::{
    exact_derivative_available, Effects, Formulation, ModelError, ModelParams, ParamId, Problem,
    ProblemWorkspace, SimSettings, TrialInputs,
};
use numerics::rms;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

fn seed_inputs() -> TrialInputs {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../../fixtures/seed/trial.csv");
    let trial = experiment::read_trial(path).unwrap();
    experiment::model_inputs(&trial, &Default::default()).unwrap()
}

fn fast(rtol: f64) -> SimSettings {
    SimSettings {
        rtol,
        atol: rtol * 1e-2,
        max_steps: 10_000_000,
        ..SimSettings::default()
    }
}

fn ids(names: &[&str]) -> Vec<ParamId> {
    names.iter().map(|n| ParamId::parse(n).unwrap()).collect()
}

/// The central difference of `problem`'s prediction in parameter `j` at `x`, step `h`.
fn central_column(problem: &Problem, x: &[f64], j: usize, h: f64) -> Vec<f64> {
    let (mut a, mut b) = (x.to_vec(), x.to_vec());
    a[j] += h;
    b[j] -= h;
    let (ta, tb) = (problem.predict(&a).unwrap(), problem.predict(&b).unwrap());
    ta.iter()
        .zip(&tb)
        .map(|(p, q)| (p - q) / (2.0 * h))
        .collect()
}

/// Richardson extrapolation of central differences of `problem`'s prediction in parameter `j`
/// at `x`, steps `h` and `2h`.
fn reference_column(problem: &Problem, x: &[f64], j: usize, h: f64) -> Vec<f64> {
    let (d1, d2) = (
        central_column(problem, x, j, h),
        central_column(problem, x, j, 2.0 * h),
    );
    d1.iter()
        .zip(&d2)
        .map(|(a, b)| (4.0 * a - b) / 3.0)
        .collect()
}

/// RMS of `a − b` relative to the RMS of `b`.
fn relative(a: &[f64], b: &[f64]) -> f64 {
    let d: Vec<f64> = a.iter().zip(b).map(|(p, q)| p - q).collect();
    rms(&d) / rms(b)
}

#[test]
fn exact_columns_converge_and_agree_with_differences_of_very_tight_simulations() {
    // Two checks at random points of the bounds box. (1) The exact columns at rtol 1e-11 and
    // 1e-13 agree to 1e-6 (relative RMS): the sensitivities converge with the tolerance.
    // (2) Against Richardson-extrapolated central differences of simulations at rtol 1e-13,
    // step 1e-5 of each value: the explicit columns (F0, the joint-level terms) to 1e-9; the
    // fibre's columns to 1e-4, which is the differences' own error, not the derivative's
    // (the curves' kinks at ṽ = 0 and at the end of the tendon's toe smear a difference over
    // the samples that straddle them, the more the larger the step, and the integration's
    // rounding takes over at smaller steps: `cargo run --release -p muscle-model --example
    // exact_jacobian` shows the agreement following the step, 1e-6 to 6e-4).
    let inputs = seed_inputs();
    let n = inputs.len();
    let free = ids(&[
        "sol.lst_m",
        "sol.fom_n",
        "gm.alpha_deg",
        "gl.lst_m",
        "gl.alpha_deg",
        "curves.e0t",
        "curves.flen",
        "sol.lom_m",
        "gm.vmax_lom_per_s",
        "gravity.moment_nm",
        "gravity.phase_deg",
        "passive_joint_torque.stiffness_per_rad",
    ]);
    let explicit = |id: &ParamId| {
        id.name().ends_with("fom_n")
            || id.name().starts_with("gravity")
            || id.name().starts_with("passive")
    };
    let mut p = ModelParams::nominal();
    let mut e = Effects::none();
    ParamId::parse("passive_joint_torque.scale_nm")
        .unwrap()
        .set(&mut p, &mut e, 2.0);
    let at = |rtol: f64| {
        Problem::new(inputs.clone(), vec![0.0; n], p, e, free.clone())
            .unwrap()
            .with_settings(fast(rtol))
    };
    let (problem, looser) = (at(1e-13), at(1e-11));
    let mut rng = ChaCha8Rng::seed_from_u64(41);
    let bounds = problem.bounds().to_vec();
    let mut ws = ProblemWorkspace::new();
    let (mut jac, mut jac_loose) = (Vec::new(), Vec::new());
    for point in 0..2 {
        let x: Vec<f64> = bounds
            .iter()
            .map(|&(lo, hi)| rng.random_range(lo..=hi))
            .collect();
        looser.jacobian_with(&x, &mut ws, &mut jac_loose).unwrap();
        problem.jacobian_with(&x, &mut ws, &mut jac).unwrap();
        assert_eq!(jac.len(), n * free.len());
        // the prediction that comes with it is the problem's
        assert_eq!(ws.prediction(), &problem.predict(&x).unwrap()[..]);
        for (j, id) in free.iter().enumerate() {
            let got = &jac[j * n..(j + 1) * n];
            let converged = relative(&jac_loose[j * n..(j + 1) * n], got);
            assert!(
                converged < 1e-6,
                "point {point} {id}: rtol 1e-11 against 1e-13 {converged:.2e}"
            );
            let h = 1e-5 * x[j].abs().max(1e-2);
            let reference = reference_column(&problem, &x, j, h);
            assert!(rms(&reference) > 0.0, "{id}: no influence");
            let rel = relative(got, &reference);
            let limit = if explicit(id) { 1e-9 } else { 1e-4 };
            assert!(
                rel < limit,
                "point {point} {id}: against differences {rel:.2e}"
            );
        }
    }
}

#[test]
fn at_the_default_settings_the_alpha_columns_are_within_a_thousandth_of_the_reference() {
    // the jitter study's points (docs/model.md, "Integration jitter"): nominal and random
    // points of the bounds box from ChaCha8 seed 2016, where a difference column of the
    // default settings is 1–56 % off
    let inputs = seed_inputs();
    let n = inputs.len();
    let free = ParamId::identified().to_vec();
    let at = |s: SimSettings| {
        Problem::new(
            inputs.clone(),
            vec![0.0; n],
            ModelParams::nominal(),
            Effects::none(),
            free.clone(),
        )
        .unwrap()
        .with_settings(s)
    };
    let (default, reference) = (at(SimSettings::default()), at(fast(1e-12)));
    let bounds = default.bounds().to_vec();
    let mut rng = ChaCha8Rng::seed_from_u64(2016);
    let mut points = vec![default.base_vector()];
    for _ in 0..2 {
        points.push(
            bounds
                .iter()
                .map(|&(lo, hi)| rng.random_range(lo..=hi))
                .collect(),
        );
    }
    let mut ws = ProblemWorkspace::new();
    let (mut jd, mut jr) = (Vec::new(), Vec::new());
    for x in &points {
        default.jacobian_with(x, &mut ws, &mut jd).unwrap();
        reference.jacobian_with(x, &mut ws, &mut jr).unwrap();
        for (j, id) in free.iter().enumerate() {
            let rel = relative(&jd[j * n..(j + 1) * n], &jr[j * n..(j + 1) * n]);
            assert!(rel < 1e-3, "{id}: {rel:.2e}");
        }
    }
}

#[test]
fn a_trial_that_starts_at_rest_with_a_slack_tendon_has_its_derivatives() {
    // fixtures/session3/knee0_30 starts with no activation and gm's tendon just slack, where
    // the equilibrium residual is flat: the initial fibre length is the slack length
    let path = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../fixtures/session3/knee0_30.csv"
    );
    let trial = experiment::read_trial(path).unwrap();
    let inputs = experiment::model_inputs(&trial, &Default::default()).unwrap();
    let n = inputs.len();
    let problem = Problem::standard(inputs, trial.torque_nm.clone())
        .unwrap()
        .with_settings(fast(1e-12));
    let x = problem.base_vector();
    let mut jac = Vec::new();
    problem
        .jacobian_with(&x, &mut ProblemWorkspace::new(), &mut jac)
        .unwrap();
    for (j, id) in problem.free().iter().enumerate() {
        let reference = reference_column(&problem, &x, j, 1e-5 * x[j]);
        let rel = relative(&jac[j * n..(j + 1) * n], &reference);
        assert!(rel < 1e-3, "{id}: {rel:.2e}");
    }
}

#[test]
fn parameters_of_the_activation_are_refused_by_name() {
    let s = SimSettings::default();
    let e = Effects::none();
    let with = |name: &str| {
        let (mut p, mut e) = (ModelParams::nominal(), Effects::none());
        let id = ParamId::parse(name).unwrap();
        let v = id.get(&p, &e).max(0.1);
        id.set(&mut p, &mut e, v);
        e
    };
    for (name, effects, word) in [
        ("activation.tau_act_s", e, "activation"),
        ("fatigue.rate_per_s", e, "fatigue"),
        (
            "electromechanical_delay.delay_ms",
            with("fatigue.rate_per_s"),
            "fatigue",
        ),
        ("activation.shape_a", with("fatigue.rate_per_s"), "fatigue"),
        (
            "electromechanical_delay.delay_ms",
            with("antagonist_coactivation.gain_nm"),
            "antagonist",
        ),
    ] {
        let err = exact_derivative_available(&ids(&[name]), &effects, &s).unwrap_err();
        let msg = err.to_string();
        assert!(matches!(err, ModelError::NoExactDerivative { .. }), "{msg}");
        assert!(msg.contains(name) && msg.contains(word), "{msg}");
    }
    let drive = ids(&["activation.shape_a", "electromechanical_delay.delay_ms"]);
    assert!(exact_derivative_available(&drive, &e, &s).is_ok());
    let four = SimSettings {
        formulation: Formulation::FourState,
        ..s
    };
    let err = exact_derivative_available(&ids(&["sol.lst_m"]), &e, &four).unwrap_err();
    assert!(err.to_string().contains("fast formulation"), "{err}");
    assert!(exact_derivative_available(&ParamId::identified(), &e, &s).is_ok());
}

#[test]
fn flen_under_the_eccentric_effect_has_no_influence_and_the_effect_s_has() {
    let inputs = seed_inputs();
    let n = inputs.len();
    let mut p = ModelParams::nominal();
    let mut e = Effects::none();
    ParamId::parse("eccentric_enhancement.flen")
        .unwrap()
        .set(&mut p, &mut e, 1.6);
    let free = ids(&["curves.flen", "eccentric_enhancement.flen"]);
    let problem = Problem::new(inputs, vec![0.0; n], p, e, free).unwrap();
    let mut jac = Vec::new();
    problem
        .jacobian_with(
            &problem.base_vector(),
            &mut ProblemWorkspace::new(),
            &mut jac,
        )
        .unwrap();
    assert!(jac[..n].iter().all(|v| *v == 0.0));
    assert!(rms(&jac[n..]) > 1.0, "{}", rms(&jac[n..]));
}

#[test]
fn the_activation_shape_and_the_delay_have_exact_columns_on_high_and_low_rate_trials() {
    // The shape A and the delay move the tabulated activation, not a fibre constant: their
    // columns against Richardson differences of simulations at rtol 1e-13 at random points of
    // the bounds box (A > 0, d > 0), on the 2048 Hz seed trial and on a 100 Hz gait-like trial
    // (a low-rate trial: the tables sit on a finer grid than the samples and the envelope is a
    // monotone cubic), with a muscle column beside them.
    let gait = muscle_model::synthetic::gait_like_trial(100.0, 3.0).unwrap();
    for (trial, inputs) in [("seed", seed_inputs()), ("gait", gait)] {
        let n = inputs.len();
        let free = ids(&[
            "activation.shape_a",
            "electromechanical_delay.delay_ms",
            "gm.lst_m",
        ]);
        let (mut p, mut e) = (ModelParams::nominal(), Effects::none());
        ParamId::parse("electromechanical_delay.delay_ms")
            .unwrap()
            .set(&mut p, &mut e, 40.0);
        let at = |rtol: f64| {
            Problem::new(inputs.clone(), vec![0.0; n], p, e, free.clone())
                .unwrap()
                .with_settings(fast(rtol))
        };
        let (problem, looser) = (at(1e-13), at(1e-11));
        let bounds = problem.bounds().to_vec();
        let mut rng = ChaCha8Rng::seed_from_u64(43);
        let mut ws = ProblemWorkspace::new();
        let (mut jac, mut jac_loose) = (Vec::new(), Vec::new());
        for point in 0..2 {
            let x: Vec<f64> = bounds
                .iter()
                .map(|&(lo, hi)| rng.random_range(lo + 0.05 * (hi - lo)..=hi))
                .collect();
            problem.jacobian_with(&x, &mut ws, &mut jac).unwrap();
            looser.jacobian_with(&x, &mut ws, &mut jac_loose).unwrap();
            for (j, id) in free.iter().enumerate() {
                let got = &jac[j * n..(j + 1) * n];
                let converged = relative(&jac_loose[j * n..(j + 1) * n], got);
                assert!(
                    converged < 1e-6,
                    "{trial} point {point} {id}: rtol 1e-11 against 1e-13 {converged:.2e}"
                );
                let reference = reference_column(&problem, &x, j, 1e-5 * x[j].abs());
                assert!(rms(&reference) > 0.0, "{trial} {id}: no influence");
                let rel = relative(got, &reference);
                assert!(
                    rel < 1e-4,
                    "{trial} point {point} {id} = {}: against differences {rel:.2e}",
                    x[j]
                );
            }
        }
    }
}

#[test]
fn a_gastrocnemius_held_at_its_floor_on_a_knee_flexed_trial_has_its_derivatives() {
    // With the knee at 90° the gastrocnemii of this subject (the session-coverage study's
    // subject 2) shorten to their floor, where the velocity is held at zero; the sensitivity
    // jumps there to the floor's derivative. Without the jump the LST columns kept a spike where
    // the tendon tightens again, 1.4 % of the column's RMS at every difference step from 4e-3
    // of the bound width down to 6e-5; with it the columns and the differences meet as the step
    // shrinks (kinks are smeared over the step, so no extrapolation).
    let mut rng = ChaCha8Rng::seed_from_u64(2);
    let truth = experiment::random_params(&mut rng, &ModelParams::nominal());
    let configs: Vec<experiment::SynthConfig> = ["knee0@30", "knee90@30", "knee0@60"]
        .iter()
        .enumerate()
        .map(|(k, p)| {
            experiment::SynthConfig::for_protocol(p.parse().unwrap(), 2000 + k as u64)
                .with_params(truth)
        })
        .collect();
    let syn = experiment::synth_session::synthesize_session_configs(&configs).unwrap();
    let inputs = syn[1].inputs.clone();
    let n = inputs.len();
    let settings = SimSettings {
        formulation: Formulation::Fast,
        ..SimSettings::tight()
    };
    let free = ids(&["gm.lst_m", "gl.lst_m"]);
    let problem = Problem::new(inputs, vec![0.0; n], truth, Effects::none(), free.clone())
        .unwrap()
        .with_settings(settings);
    let x = problem.base_vector();
    let mut jac = Vec::new();
    problem
        .jacobian_with(&x, &mut ProblemWorkspace::new(), &mut jac)
        .unwrap();
    for (j, id) in free.iter().enumerate() {
        let central = |h: f64| central_column(&problem, &x, j, h);
        let exact = &jac[j * n..(j + 1) * n];
        // the bound width of an LST is a tenth of it
        let coarse = relative(exact, &central(4e-3 * 0.1 * x[j]));
        let fine = relative(exact, &central(1.5625e-5 * 0.1 * x[j]));
        assert!(
            coarse > 5e-3,
            "{id}: the trial does not reach the floor ({coarse:.2e})"
        );
        assert!(
            fine < 1e-3,
            "{id}: {fine:.2e} at the finest step ({coarse:.2e} at 4e-3)"
        );
    }
}
