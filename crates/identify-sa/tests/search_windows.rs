//! A calibration whose chains search on windows of a long trial and whose best point is
//! polished on the whole trial ([`identify_set_with_search`]): on a 40 s synthetic gait-like
//! trial it recovers the truth as the search on the whole trial does, for a fraction of the
//! simulated length.

use identify_sa::{identify_set, identify_set_with_search, NoObserver, SaIdentifySettings};
use muscle_model::{
    simulate, synthetic, Effects, ModelParams, Muscle, ParamId, Problem, ProblemSet, SimSettings,
};

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
    p
}

#[test]
fn a_search_on_windows_finds_what_the_search_on_the_whole_trial_finds() {
    let fs = 100.0;
    let tr = synthetic::gait_like_trial(fs, 40.0).unwrap();
    let truth = truth();
    let measured = simulate(&tr, &truth, &Effects::none(), &SimSettings::default())
        .unwrap()
        .torque;
    let problem = Problem::new(
        tr,
        measured,
        ModelParams::nominal(),
        Effects::none(),
        ParamId::identified().to_vec(),
    )
    .unwrap();
    let set = ProblemSet::single(problem.clone());
    // four 2 s windows spread over the 40 s, each after a 0.5 s lead-in
    let windows: Vec<Problem> = [300, 1300, 2300, 3300]
        .iter()
        .map(|&s| problem.window(s..s + 200, 50).unwrap())
        .collect();
    let search = ProblemSet::new(windows).unwrap();
    let settings = SaIdentifySettings::default()
        .with_seed(5)
        .with_chains(2)
        .with_chain_evaluations(2500);
    let searched = identify_set_with_search(&set, &search, &settings, &NoObserver).unwrap();
    let whole = identify_set(&set, &settings, &NoObserver).unwrap();
    let peak = problem
        .measured()
        .iter()
        .fold(0.0f64, |m, v| m.max(v.abs()));
    println!(
        "searched on windows: RMS {:.4} N·m; on the whole trial: {:.4} N·m (peak {peak:.0})",
        searched.rms_nm, whole.rms_nm
    );
    // the result is scored on the whole trial and reaches the truth's (zero) misfit
    assert!(searched.rms_nm < 1e-3 * peak, "{}", searched.rms_nm);
    assert!(searched.rms_nm < 2.0 * whole.rms_nm.max(1e-3));
    for c in &searched.chains {
        assert!(c.search_cost.is_some());
        assert!(c.cost.is_finite());
    }
    assert!(whole.chains.iter().all(|c| c.search_cost.is_none()));
    // the tendon slack lengths, which the torque pins down (α0 and F0 of gl trade off against
    // each other at the same misfit on this trial, on the whole trial as on its windows)
    let (errors, whole_errors) = (searched.errors_pct(&truth), whole.errors_pct(&truth));
    println!("errors (%) searched on windows {errors:.2?}; on the whole trial {whole_errors:.2?}");
    for name in ["sol.lst_m", "gm.lst_m", "gl.lst_m"] {
        assert!(
            errors[name] < 0.5,
            "{name}: {:.2} % from the truth",
            errors[name]
        );
    }
}

#[test]
fn a_search_set_with_other_bounds_is_refused() {
    let tr = synthetic::gait_like_trial(100.0, 6.0).unwrap();
    let n = tr.len();
    let problem = Problem::standard(tr, vec![1.0; n]).unwrap();
    let set = ProblemSet::single(problem.clone());
    let mut bounds = problem.bounds().to_vec();
    bounds[0].1 *= 1.01;
    let other = ProblemSet::single(
        problem
            .window(0..300, 0)
            .unwrap()
            .with_bounds(bounds)
            .unwrap(),
    );
    let err = identify_set_with_search(&set, &other, &SaIdentifySettings::default(), &NoObserver)
        .unwrap_err();
    assert!(err.to_string().contains("bounds"), "{err}");
}

#[test]
fn chains_are_added_only_when_the_best_two_disagree() {
    let tr = synthetic::gait_like_trial(100.0, 8.0).unwrap();
    let measured = simulate(&tr, &truth(), &Effects::none(), &SimSettings::default())
        .unwrap()
        .torque;
    let set = ProblemSet::single(Problem::standard(tr, measured).unwrap());
    let base = SaIdentifySettings::default()
        .with_seed(9)
        .with_chains(2)
        .with_chain_evaluations(400);
    let plain = identify_set(&set, &base, &NoObserver).unwrap();
    // a strict agreement (0) adds the two extra chains after the first two, which are unchanged
    let strict = identify_set(&set, &base.with_extra_chains(2, 0.0), &NoObserver).unwrap();
    assert_eq!(strict.chains.len(), 4);
    assert_eq!(strict.chains[..2], plain.chains[..]);
    assert!(strict.sse <= plain.sse);
    // a loose one (any two chains agree) adds none
    let loose = identify_set(&set, &base.with_extra_chains(2, f64::MAX), &NoObserver).unwrap();
    assert_eq!(loose.chains.len(), 2);
    assert!(identify_set(&set, &base.with_extra_chains(2, f64::NAN), &NoObserver).is_err());
}
