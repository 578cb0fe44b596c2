//! Identification of sol, gm and gl on a synthetic trial whose torque includes a tibialis
//! anterior (a fixed muscle with its own envelope): with the TA in the model the annealer
//! recovers the triceps parameters; without it the fit absorbs the TA's torque into them.

use identify_sa::{identify, NoObserver, SaIdentifySettings};
use muscle_model::{
    simulate, synthetic, Effects, ModelParams, Muscle, MuscleParams, ParamId, Problem, SimSettings,
    TrialInputs,
};

/// The seed-like trial at 1024 Hz with a TA envelope bursting to 0.6 in the middle of the
/// sweeps (co-contraction) over a 0.05 rest.
fn trial() -> TrialInputs {
    let tr = synthetic::seed_like_trial(1024.0).unwrap();
    let st = synthetic::seed_times();
    let mid = 0.5 * (st.concentric_start + st.eccentric_end);
    let ta: Vec<f64> = tr
        .times()
        .iter()
        .map(|&t| 0.05 + 0.55 * (-((t - mid) / 0.4).powi(2)).exp())
        .collect();
    tr.with_envelope("ta", ta).unwrap()
}

fn with_ta(mut p: ModelParams) -> ModelParams {
    p.fixed.insert("ta", MuscleParams::nominal_ta()).unwrap();
    p
}

/// A truth inside the default bounds (LST ±5 %, F0 and α0 ±20 % of nominal).
fn truth() -> ModelParams {
    let mut p = ModelParams::nominal();
    for (m, lst, f0, alpha) in [
        (Muscle::Sol, 1.02, 0.90, 1.10),
        (Muscle::Gm, 0.98, 1.12, 0.92),
        (Muscle::Gl, 1.01, 0.95, 1.05),
    ] {
        let mp = p.muscle_mut(m);
        mp.lst_m *= lst;
        mp.fom_n *= f0;
        mp.alpha_deg *= alpha;
    }
    with_ta(p)
}

#[test]
fn sa_recovers_the_triceps_with_a_fixed_tibialis_anterior_in_the_model() {
    let tr = trial();
    let truth = truth();
    let measured = simulate(&tr, &truth, &Effects::none(), &SimSettings::default())
        .unwrap()
        .torque;
    let ta_torque = simulate(&tr, &truth, &Effects::none(), &SimSettings::default())
        .unwrap()
        .muscle_named("ta")
        .unwrap()
        .torque
        .iter()
        .cloned()
        .fold(0.0, f64::min);
    println!("TA torque peak {ta_torque:.1} N·m");
    assert!(ta_torque < -20.0);
    let settings = SaIdentifySettings::default().with_seed(23);
    let fit = |base: ModelParams| {
        let problem = Problem::new(
            tr.clone(),
            measured.clone(),
            base,
            Effects::none(),
            ParamId::identified().to_vec(),
        )
        .unwrap();
        identify(&problem, &settings, &NoObserver).unwrap()
    };

    let id = fit(with_ta(ModelParams::nominal()));
    let errors = id.errors_pct(&truth);
    println!(
        "with the TA: RMS {:.4} N·m, {} evaluations, {:.1} s",
        id.rms_nm, id.evaluations, id.wall_s
    );
    for (k, v) in &errors {
        println!("  {k:16} error {v:7.3} %");
    }
    assert!(id.rms_nm < 0.05, "RMS {}", id.rms_nm);
    for m in ["sol", "gm", "gl"] {
        let lst = errors[&format!("{m}.lst_m")];
        let f0 = errors[&format!("{m}.fom_n")];
        let alpha = errors[&format!("{m}.alpha_deg")];
        assert!(
            lst < 0.5 && f0 < 1.0 && alpha < 2.0,
            "{m}: LST {lst} %, F0 {f0} %, α0 {alpha} %"
        );
    }

    // the same trial fitted by a triceps-only model: the TA's torque is left unexplained
    let without = fit(ModelParams::nominal());
    println!("without the TA: RMS {:.3} N·m", without.rms_nm);
    assert!(
        without.rms_nm > 20.0 * id.rms_nm.max(0.01),
        "{}",
        without.rms_nm
    );
}
