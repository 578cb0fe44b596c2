//! Whole-trial behaviour: isometric steps (dissertation Fig. 5), concentric < isometric <
//! eccentric, invariants, accuracy vs a tight run, the initial equilibrium.

#![allow(clippy::needless_range_loop)] // index-parallel arrays read clearer in tests

mod common;

use common::{idx, max_diff, random_identified, rms_diff};
use muscle_model::activation::ManalBuchanan;
use muscle_model::musculotendon::{IX_FT, IX_LM, IX_LMT};
use muscle_model::{
    simulate, synthetic, Effects, Formulation, ModelParams, Muscle, MuscleUnit, ParamId,
    SimSettings, TrialInputs,
};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

const FS: f64 = 2048.0;

fn mean(v: &[f64]) -> f64 {
    v.iter().sum::<f64>() / v.len() as f64
}

#[test]
fn isometric_steps_at_50_and_100_percent_excitation() {
    let p = ModelParams::nominal();
    let e = Effects::none();
    let s = SimSettings::default();
    let onset = 0.1;
    let run = |level: f64| {
        let tr = synthetic::isometric_trial(FS, 1.5, 0.0, level, onset).unwrap();
        simulate(&tr, &p, &e, &s).unwrap().torque
    };
    let t100 = run(1.0);
    let t50 = run(0.5);
    let rest = t100[idx(FS, onset) - 1];
    assert!((rest - t50[idx(FS, onset) - 1]).abs() < 1e-4);
    let n = t100.len();
    let last = idx(FS, 0.2);
    let steady100 = mean(&t100[n - last..]);
    let steady50 = mean(&t50[n - last..]);
    // steady: the last 0.2 s varies by less than 0.1 %
    for (t, st) in [(&t100, steady100), (&t50, steady50)] {
        let spread = t[n - last..]
            .iter()
            .map(|x| (x - st).abs())
            .fold(0.0, f64::max);
        assert!(spread < 1e-3 * st, "not steady: spread {spread} of {st}");
    }
    // 100 % gives a realistic maximal isometric plantarflexion torque at 0°
    assert!(steady100 > 150.0 && steady100 < 300.0, "τ100 = {steady100}");
    // 50 % gives more than half the active torque (Manal–Buchanan: â(0.5) = 0.576)
    let ratio = (steady50 - rest) / (steady100 - rest);
    let a_half = ManalBuchanan::new(0.08).apply(0.5);
    println!(
        "rest {rest:.3} τ50 {steady50:.3} τ100 {steady100:.3} ratio {ratio:.4} â(0.5) {a_half:.4}"
    );
    assert!(ratio > 0.5, "ratio {ratio}");
    assert!(
        (ratio - a_half).abs() < 0.01,
        "ratio {ratio} vs â(0.5) {a_half}"
    );
    // rise time (onset to 90 % of the increase): activation (15 ms) + tendon compliance
    let rise = |t: &[f64], st: f64| {
        let target = rest + 0.9 * (st - rest);
        let k = t.iter().position(|&x| x >= target).unwrap();
        k as f64 / FS - onset
    };
    let r100 = rise(&t100, steady100);
    let r50 = rise(&t50, steady50);
    println!("rise 100 % {r100:.4} s, 50 % {r50:.4} s");
    assert!(r100 > 0.02 && r100 < 0.25, "rise 100 % {r100}");
    assert!(r50 > 0.02 && r50 < 0.3, "rise 50 % {r50}");
    // torque never overshoots the steady value by more than 1 %
    assert!(t100.iter().cloned().fold(f64::MIN, f64::max) < 1.01 * steady100);
}

#[test]
fn concentric_below_isometric_below_eccentric() {
    let p = ModelParams::nominal();
    let e = Effects::none();
    let s = SimSettings::default();
    for &angle in &[-10.0, 0.0, 10.0] {
        for &level in &[0.5, 1.0] {
            let at = |speed: f64| {
                let tr = synthetic::constant_velocity_trial(FS, 1.0, angle, speed, level).unwrap();
                let out = simulate(&tr, &p, &e, &s).unwrap();
                out.torque[idx(FS, 0.5)]
            };
            let conc = at(-30.0);
            let iso = at(0.0);
            let ecc = at(30.0);
            println!("angle {angle} level {level}: conc {conc:.2} iso {iso:.2} ecc {ecc:.2}");
            assert!(conc < iso && iso < ecc, "{conc} {iso} {ecc}");
            assert!(
                conc / iso > 0.7 && conc / iso < 0.97,
                "conc/iso {}",
                conc / iso
            );
            assert!(ecc / iso > 1.03 && ecc / iso < 1.3, "ecc/iso {}", ecc / iso);
        }
    }
}

/// The four-state integration (where the invariants are not built in).
fn four_state(s: SimSettings) -> SimSettings {
    SimSettings {
        formulation: Formulation::FourState,
        ..s
    }
}

fn check_invariants(settings: SimSettings, tol_ft: f64, tol_lmt: f64, params: &ModelParams) {
    let settings = four_state(settings);
    let tr = synthetic::seed_like_trial(FS).unwrap();
    let e = Effects::none();
    let out = simulate(&tr, params, &e, &settings.with_states()).unwrap();
    for m in Muscle::ALL {
        let unit = MuscleUnit::new(params, m, &e);
        let st = out.states_of(m).unwrap();
        let mut worst_ft = 0.0_f64;
        let mut worst_lmt = 0.0_f64;
        for (i, y) in st.iter().enumerate() {
            let ft = unit.detail(y).tendon_force_from_lengths;
            worst_ft = worst_ft.max((ft - y[IX_FT]).abs());
            worst_lmt = worst_lmt.max((y[IX_LMT] - unit.lmt(tr.angle()[i])).abs());
            // torque is F̃T·F0·r(q)
            let tq = y[IX_FT] * unit.f0 * unit.moment_arm(tr.angle()[i]);
            assert!((tq - out.torque_of(m)[i]).abs() < 1e-9);
        }
        println!("{m}: max |F̃T − fT(ε)| = {worst_ft:e}, max |LMT − LMT(q)| = {worst_lmt:e} m");
        assert!(worst_ft < tol_ft, "{m}: {worst_ft}");
        assert!(worst_lmt < tol_lmt, "{m}: {worst_lmt}");
        // r(q) = dLMT/dq along the trajectory: LMT increments over the sweeps vs r·Δq
        let q = tr.angle();
        let mut checked = 0;
        for i in 1..st.len() - 1 {
            let dq = q[i + 1] - q[i - 1];
            if dq.abs() > 1e-4 {
                let dl = st[i + 1][IX_LMT] - st[i - 1][IX_LMT];
                let r = unit.moment_arm(q[i]);
                assert!(
                    (dl / dq - r).abs() < 0.02 * r,
                    "{m} sample {i}: {} vs {r}",
                    dl / dq
                );
                checked += 1;
            }
        }
        assert!(checked > 3000, "only {checked} moving samples");
    }
}

#[test]
fn invariants_hold_along_a_trial_with_tight_tolerances() {
    let settings = SimSettings {
        rtol: 1e-8,
        atol: 1e-10,
        ..SimSettings::default()
    };
    check_invariants(settings, 1e-6, 1e-6, &ModelParams::nominal());
    let mut rng = ChaCha8Rng::seed_from_u64(7);
    check_invariants(settings, 1e-6, 1e-6, &random_identified(&mut rng, 1.0));
}

#[test]
fn invariants_hold_along_a_trial_with_default_tolerances() {
    // the drift is integration error, O(rtol): 1.7e-5 and 1.3e-6 m measured at the defaults
    check_invariants(SimSettings::default(), 1e-4, 1e-5, &ModelParams::nominal());
}

#[test]
fn initial_state_is_static_equilibrium() {
    let p = ModelParams::nominal();
    let e = Effects::none();
    for m in Muscle::ALL {
        let unit = MuscleUnit::new(&p, m, &e);
        for &u in &[0.0, 0.02, 0.3, 0.5, 1.0] {
            for &qd in &[-20.0, 0.0, 15.0] {
                let q = f64::to_radians(qd);
                let y = unit.equilibrium_state(u, q);
                let v = unit.fibre_velocity(&y);
                assert!(v.abs() < 1e-9, "{m} u {u} q {qd}: vM = {v}");
                assert_eq!(y[IX_LMT], unit.lmt(q));
                assert_eq!(y[0], u);
                assert!((unit.detail(&y).tendon_force_from_lengths - y[IX_FT]).abs() < 1e-15);
                assert!(y[IX_LM] > unit.lm_min);
            }
        }
    }
}

#[test]
fn default_settings_agree_with_a_tight_run() {
    let tr = synthetic::seed_like_trial(FS).unwrap();
    let e = Effects::none();
    let mut rng = ChaCha8Rng::seed_from_u64(11);
    let mut sets = vec![ModelParams::nominal()];
    for _ in 0..5 {
        sets.push(random_identified(&mut rng, 1.0));
    }
    for p in &sets {
        let a = simulate(&tr, p, &e, &SimSettings::default()).unwrap();
        // tight runs of both formulations of the same ODE
        let b = simulate(&tr, p, &e, &SimSettings::tight()).unwrap();
        let c = simulate(&tr, p, &e, &four_state(SimSettings::tight())).unwrap();
        let d = simulate(&tr, p, &e, &four_state(SimSettings::default())).unwrap();
        let rms = rms_diff(&a.torque, &b.torque);
        let mx = max_diff(&a.torque, &b.torque);
        let rms4 = rms_diff(&a.torque, &c.torque);
        let rms44 = rms_diff(&d.torque, &c.torque);
        println!(
            "default vs tight: RMS {rms:.2e} N·m, max {mx:.2e} N·m ({} vs {} RHS calls); vs four-state tight {rms4:.2e}; four-state default vs tight {rms44:.2e}",
            a.total_stats().rhs_calls,
            b.total_stats().rhs_calls
        );
        assert!(rms <= 0.01, "RMS {rms}");
        assert!(rms4 <= 0.01, "RMS vs four-state {rms4}");
        assert!(rms44 <= 0.01, "four-state RMS {rms44}");
        // the two formulations solve the same ODE
        assert!(rms_diff(&b.torque, &c.torque) < 1e-4);
    }
}

#[test]
fn soleus_slack_length_plus_five_percent_integrates() {
    // the dissertation's solver diverged above +2.8 % soleus LST
    let tr = synthetic::seed_like_trial(FS).unwrap();
    let e = Effects::none();
    let nominal = simulate(&tr, &ModelParams::nominal(), &e, &SimSettings::default()).unwrap();
    for &pct in &[2.8, 5.0, 10.0] {
        let mut p = ModelParams::nominal();
        p.muscle_mut(Muscle::Sol).lst_m *= 1.0 + pct / 100.0;
        let out = simulate(&tr, &p, &e, &SimSettings::default()).unwrap();
        assert!(out.torque.iter().all(|t| t.is_finite()));
        // a longer tendon slack length lowers the soleus torque
        let sol_nom: f64 = nominal.torque_of(Muscle::Sol).iter().sum();
        let sol: f64 = out.torque_of(Muscle::Sol).iter().sum();
        assert!(sol < sol_nom, "+{pct} %: {sol} vs {sol_nom}");
        // and agrees with a tight run
        let tight = simulate(&tr, &p, &e, &SimSettings::tight()).unwrap();
        assert!(rms_diff(&out.torque, &tight.torque) < 0.01);
    }
    // all three LST at +5 % together
    let mut p = ModelParams::nominal();
    for m in Muscle::ALL {
        p.muscle_mut(m).lst_m *= 1.05;
    }
    assert!(simulate(&tr, &p, &e, &SimSettings::default()).is_ok());
}

#[test]
fn outputs_have_one_value_per_sample() {
    let tr = synthetic::seed_like_trial(512.0).unwrap();
    let out = simulate(
        &tr,
        &ModelParams::nominal(),
        &Effects::none(),
        &SimSettings::default(),
    )
    .unwrap();
    assert_eq!(out.time.len(), tr.len());
    assert_eq!(out.torque.len(), tr.len());
    assert!(out.muscles.iter().all(|m| m.states.is_none()));
    for i in 0..tr.len() {
        let s = out.muscles[0].torque[i] + out.muscles[1].torque[i] + out.muscles[2].torque[i];
        assert_eq!(out.torque[i], s);
    }
    assert!((out.time[1] - 1.0 / 512.0).abs() < 1e-15);
    // identified parameter names, as every output spells them
    let names: Vec<String> = ParamId::identified().iter().map(|p| p.name()).collect();
    assert_eq!(names[0], "sol.lst_m");
    assert_eq!(names[4], "gm.fom_n");
    assert_eq!(names[8], "gl.alpha_deg");
}

#[test]
fn slack_tendon_drives_the_fibre_to_its_floor_without_failure() {
    // soleus LST +20 %: LST = 0.30 m > LMT(q) for most of the trial, so the tendon is slack
    // and the active fibre shortens until the fibre-length floor stops it
    let tr = synthetic::seed_like_trial(FS).unwrap();
    let mut p = ModelParams::nominal();
    p.muscle_mut(Muscle::Sol).lst_m = 0.30;
    let e = Effects::none();
    let out = simulate(&tr, &p, &e, &SimSettings::default().with_states()).unwrap();
    let unit = MuscleUnit::new(&p, Muscle::Sol, &e);
    let st = out.states_of(Muscle::Sol).unwrap();
    let min_lm = st.iter().map(|y| y[IX_LM]).fold(f64::MAX, f64::min);
    println!("floor {:.5} m, min LM {min_lm:.5} m", unit.lm_min);
    assert!(
        min_lm > unit.lm_min - 1e-6,
        "fibre went below its floor: {min_lm}"
    );
    assert!(min_lm < unit.lm_min + 1e-3, "floor never reached: {min_lm}");
    assert!(out.torque.iter().all(|t| t.is_finite()));
    // the slack soleus carries (almost) no force
    assert!(out.torque_of(Muscle::Sol).iter().all(|t| *t < 5.0));
}

#[test]
fn quantised_angle_stays_cheap_and_accurate() {
    // a recorded angle quantised to 0.01° (e.g. a CSV with 2 decimals): q̇ from differences is
    // a spike train; the default (reduced) formulation does not need q̇
    let tr = synthetic::seed_like_trial(FS).unwrap();
    let angle: Vec<f64> = tr
        .angle()
        .iter()
        .map(|q| ((q.to_degrees() / 0.01).round() * 0.01).to_radians())
        .collect();
    let env = Muscle::ALL.map(|m| tr.envelope(m).to_vec());
    let tq = TrialInputs::new(FS, 0.0, angle, env, None).unwrap();
    let p = ModelParams::nominal();
    let e = Effects::none();
    let a = simulate(&tq, &p, &e, &SimSettings::default()).unwrap();
    let b = simulate(&tq, &p, &e, &SimSettings::tight()).unwrap();
    let clean = simulate(&tr, &p, &e, &SimSettings::default()).unwrap();
    let rms = rms_diff(&a.torque, &b.torque);
    let calls = a.total_stats().rhs_calls;
    println!(
        "quantised 0.01°: default vs tight RMS {rms:.2e} N·m, {calls} RHS calls (clean {}); vs clean angle RMS {:.3} N·m",
        clean.total_stats().rhs_calls,
        rms_diff(&a.torque, &clean.torque)
    );
    assert!(rms <= 0.02, "{rms}");
    assert!(calls < 2 * clean.total_stats().rhs_calls, "{calls}");
}
