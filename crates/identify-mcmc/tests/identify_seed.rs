//! The acceptance scenario on the bundled seed fixture (`fixtures/seed`, nominal truth, SPEC
//! noise, unloaded run): convergence, accuracy, intervals and identifiability flags.

use std::ops::ControlFlow;
use std::path::Path;

use identify_mcmc::{identify, IdentifySettings, NoiseKind, NoiseSpec};
use muscle_model::{Effects, ModelParams, ParamId, Problem};

#[test]
fn seed_fixture_converges_and_flags_identifiability() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../fixtures/seed");
    let trial = experiment::read_trial(dir.join("trial.csv")).unwrap();
    let unloaded = experiment::read_unloaded(dir.join("unloaded.csv")).unwrap();
    let truth_json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("truth.json")).unwrap()).unwrap();
    let truth = ModelParams::from_json_str(&truth_json["params"].to_string()).unwrap();
    let inputs = experiment::model_inputs(&trial, &experiment::InputOptions::default()).unwrap();
    let problem = Problem::standard(inputs, trial.torque_nm.clone()).unwrap();
    let noise = NoiseSpec::from_unloaded(&trial, &unloaded, NoiseKind::Ar1White).unwrap();
    let res = identify(&problem, &noise, &IdentifySettings::default(), |_| {
        ControlFlow::Continue(())
    })
    .unwrap();
    assert!(res.converged, "stopped by {:?}", res.stop);
    for p in &res.posterior {
        assert!(
            p.rhat <= 1.01 && p.ess_bulk >= 400.0,
            "{}: R̂ {} ESS {}",
            p.name,
            p.rhat,
            p.ess_bulk
        );
    }
    let tv: Vec<f64> = ParamId::identified()
        .iter()
        .map(|id| id.get(&truth, &Effects::none()))
        .collect();
    let covered = res
        .posterior
        .iter()
        .zip(&tv)
        .filter(|(p, t)| p.covers(**t))
        .count();
    assert!(
        covered >= 6,
        "only {covered}/9 truths inside the 90% intervals"
    );
    let sol_lst = res.get("sol.lst_m").unwrap();
    let err = (sol_lst.mean - tv[0]).abs() / tv[0];
    assert!(err <= 0.015, "sol LST error {:.3}%", 100.0 * err);
    assert!(sol_lst.identifiable);
    assert!(!res.get("gl.alpha_deg").unwrap().identifiable);
    assert!(
        res.max_abs_z < 0.9 * res.z_half_width,
        "max |z| {}",
        res.max_abs_z
    );
    // The chains CSV: header plus one row per kept draw.
    let mut csv = Vec::new();
    res.write_chains_csv(&mut csv).unwrap();
    let text = String::from_utf8(csv).unwrap();
    let mut lines = text.lines();
    assert_eq!(
        lines.next().unwrap(),
        "chain,iteration,sol.lst_m,sol.fom_n,sol.alpha_deg,gm.lst_m,gm.fom_n,gm.alpha_deg,gl.lst_m,gl.fom_n,gl.alpha_deg,log_density"
    );
    let rows: usize = res.run.log_density.iter().map(Vec::len).sum();
    assert_eq!(lines.count(), rows);
}
