//! The acceptance scenario on the bundled seed fixture (`fixtures/seed`, nominal truth, nominal
//! dynamometer error, unloaded run): convergence, accuracy, intervals and identifiability flags; and the
//! same identification on `fixtures/offnominal`, whose truth is away from the nominal
//! parameters the first mode search and chain start from.

use std::ops::ControlFlow;
use std::path::Path;

use identify_mcmc::{identify, McmcIdentification, McmcIdentifySettings, NoiseKind, NoiseSpec};
use muscle_model::{Effects, ModelParams, ParamId, Problem};

/// Identifies the fixture in `fixtures/<folder>` with the default settings; returns the
/// result and the true values of the 9 identified parameters.
fn identify_fixture(folder: &str) -> (McmcIdentification, Vec<f64>) {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../fixtures")
        .join(folder);
    let trial = experiment::read_trial(dir.join("trial.csv")).unwrap();
    let unloaded = experiment::read_unloaded(dir.join("unloaded.csv")).unwrap();
    let truth_json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("truth.json")).unwrap()).unwrap();
    let truth = ModelParams::from_json_str(&truth_json["params"].to_string()).unwrap();
    let inputs = experiment::model_inputs(&trial, &experiment::InputOptions::default()).unwrap();
    let problem = Problem::standard(inputs, trial.torque_nm.clone()).unwrap();
    let noise = NoiseSpec::from_unloaded(&trial, &unloaded, NoiseKind::Ar1White).unwrap();
    let res = identify(&problem, &noise, &McmcIdentifySettings::default(), |_| {
        ControlFlow::Continue(())
    })
    .unwrap();
    let tv = ParamId::identified()
        .iter()
        .map(|id| id.get(&truth, &Effects::none()))
        .collect();
    (res, tv)
}

#[test]
fn seed_fixture_converges_and_flags_identifiability() {
    let (res, tv) = identify_fixture("seed");
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

/// `fixtures/offnominal`: every identified parameter 2–12 % off nominal (the first mode
/// search and chain start at nominal, so on `fixtures/seed` a sampler that never moved
/// would look perfect).
///
/// Measured (error of the posterior mean against the truth, of the nominal start, whether
/// the 90 % interval covers the truth, the identifiability flag):
///
/// | | error | nominal | covers | identifiable |
/// |---|---|---|---|---|
/// | sol LST | 0.10 % | 2.91 % | yes | yes |
/// | sol F0 | 6.85 % | 13.64 % | no (3123 vs [3161, 3497] N) | yes |
/// | sol α0 | 5.92 % | 9.09 % | no (27.50 vs [27.58, 29.95]°) | yes |
/// | gm LST | 0.50 % | 3.09 % | yes | yes |
/// | gm F0 | 12.37 % | 9.09 % | no (1714 vs [1335, 1677] N) | no |
/// | gm α0 | 21.0 % | 13.6 % | yes | no |
/// | gl LST | 2.31 % | 1.96 % | yes | no |
/// | gl F0 | 5.58 % | 11.11 % | yes | no |
/// | gl α0 | 10.0 % | 10.7 % | yes | no |
///
/// Asserted: what the seed fixture's test claims (convergence, R̂ and ESS, at least 6 of 9
/// truths covered, the mode inside the box), the identifiable parameters moved towards the
/// truth from the nominal start, the two identifiable tendon slack lengths within about
/// three to five times their measured error, and for the parameters flagged as barely
/// constrained only the flag and, where it holds, the coverage.
#[test]
fn off_nominal_fixture_recovers_the_truth() {
    let (res, tv) = identify_fixture("offnominal");
    let nominal = ModelParams::nominal();
    println!(
        "fixtures/offnominal: converged {}, max |z| {:.3} (half-width {:.3})",
        res.converged, res.max_abs_z, res.z_half_width
    );
    let mut covered = 0;
    for ((p, t), id) in res.posterior.iter().zip(&tv).zip(ParamId::identified()) {
        let n = id.get(&nominal, &Effects::none());
        let (err, err_nominal) = ((p.mean - t).abs() / t, (n - t).abs() / t);
        println!(
            "  {:16} truth {:10.5} mean {:10.5} error {:6.2} % (nominal {:6.2} %), 90 % [{:.5}, {:.5}] covers {} identifiable {} R̂ {:.4} ESS {:.0}",
            p.name, t, p.mean, 100.0 * err, 100.0 * err_nominal,
            p.q05, p.q95, p.covers(*t), p.identifiable, p.rhat, p.ess_bulk
        );
        assert!(
            p.rhat <= 1.01 && p.ess_bulk >= 400.0,
            "{}: R̂ {} ESS {}",
            p.name,
            p.rhat,
            p.ess_bulk
        );
        if p.identifiable {
            assert!(
                err < err_nominal,
                "{}: error {:.2} % not below the nominal start's {:.2} %",
                p.name,
                100.0 * err,
                100.0 * err_nominal
            );
        }
        covered += usize::from(p.covers(*t));
    }
    assert!(res.converged, "stopped by {:?}", res.stop);
    assert!(
        covered >= 6,
        "only {covered}/9 truths inside the 90% intervals"
    );
    for (name, tol) in [("sol.lst_m", 0.005), ("gm.lst_m", 0.015)] {
        let p = res.get(name).unwrap();
        let t = tv[res.posterior.iter().position(|q| q.name == name).unwrap()];
        assert!(p.identifiable, "{name} flagged as barely constrained");
        assert!(
            p.covers(t),
            "{name}: truth {t} outside [{}, {}]",
            p.q05,
            p.q95
        );
        let err = (p.mean - t).abs() / t;
        assert!(
            err <= tol,
            "{name} error {:.3} % (tolerance {} %)",
            100.0 * err,
            100.0 * tol
        );
    }
    for name in [
        "gm.fom_n",
        "gm.alpha_deg",
        "gl.lst_m",
        "gl.fom_n",
        "gl.alpha_deg",
    ] {
        assert!(
            !res.get(name).unwrap().identifiable,
            "{name} is flagged identifiable"
        );
    }
    for name in ["gm.alpha_deg", "gl.lst_m", "gl.fom_n", "gl.alpha_deg"] {
        let p = res.get(name).unwrap();
        let t = tv[res.posterior.iter().position(|q| q.name == name).unwrap()];
        assert!(
            p.covers(t),
            "{name}: truth {t} outside [{}, {}]",
            p.q05,
            p.q95
        );
    }
    assert!(
        res.max_abs_z < 0.9 * res.z_half_width,
        "max |z| {}",
        res.max_abs_z
    );
}
