//! Identification on `fixtures/seed` and on random truths (release mode; about a minute on
//! two cores).
//!
//! The noise floor is compared like with like: `rms_nm` is the RMS of (corrected measured
//! torque − fitted model), i.e. of (raw measured − fitted model − subtracted dynamometer
//! error); the floor is the RMS of (corrected measured torque − true model), the true model
//! being the truth's parameters simulated on the same inputs with the same settings. The
//! acceptance's wording (floor = RMS of raw measured − true model) is checked too. The raw
//! RMS of the model alone is printed, not asserted: with a 1.5 N·m offset left in the raw
//! torque it moves by `2·|offset|·bias` for any constant bias the fit absorbs from the offset
//! estimate's own error (±0.1 N·m), i.e. by several per cent either way.

use std::path::PathBuf;

use experiment::{
    random_params, read_trial, read_unloaded, synthesize, CrosstalkSettings, InputOptions,
    PreparedTrial, Protocol, SynthConfig, Trial, Unloaded,
};
use identify_sa::{identify, NoObserver, SaIdentifySettings};
use muscle_model::{ModelParams, Problem};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

fn fixture(name: &str) -> PathBuf {
    fixture_in("seed", name)
}

fn fixture_in(folder: &str, name: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../../fixtures")
        .join(folder)
        .join(name)
}

struct Checked {
    ratio: f64,
    acceptance_ratio: f64,
    errors: std::collections::BTreeMap<String, f64>,
    wall_s: f64,
    evaluations: u64,
}

/// The trial prepared as the identification prepares it, without the crosstalk test (the
/// synthetic trials carry none), and its standard problem.
fn prepare(trial: &Trial, unloaded: Option<&Unloaded>) -> (PreparedTrial, Problem) {
    let prep = PreparedTrial::prepare(
        trial,
        unloaded,
        &InputOptions::default(),
        &CrosstalkSettings::off(),
        "trial.csv",
    )
    .unwrap();
    let problem = prep.standard_problem().unwrap();
    (prep, problem)
}

/// RMS of the raw torque − model(x) (N·m): the fit judged against the torque as measured.
fn raw_rms_nm(prep: &PreparedTrial, problem: &Problem, x: &[f64]) -> f64 {
    numerics::rms_diff(&problem.predict(x).unwrap(), prep.raw_torque())
}

fn fit_and_check(
    (prep, problem): &(PreparedTrial, Problem),
    truth: &ModelParams,
    label: &str,
) -> Checked {
    let id = identify(problem, &SaIdentifySettings::default(), &NoObserver).unwrap();
    let truth_x = problem.vector_from(truth, &muscle_model::Effects::none());
    let floor = problem.rms(&truth_x).unwrap();
    let raw_floor = raw_rms_nm(prep, problem, &truth_x);
    let raw_fit = raw_rms_nm(prep, problem, &id.x);
    let errors = id.errors_pct(truth);
    println!(
        "{label}: rms {:.4} N·m, floor {:.4} (ratio {:.4}); raw model-only {:.4} vs {:.4} (ratio {:.4}); \
         subtracted RMS {:.3}; {} evaluations, {:.1} s wall, chains {:?}",
        id.rms_nm,
        floor,
        id.rms_nm / floor,
        raw_fit,
        raw_floor,
        raw_fit / raw_floor,
        prep.subtracted_rms_nm(),
        id.evaluations,
        id.wall_s,
        id.chains.iter().map(|c| (c.cost / problem.inputs().len() as f64).sqrt()).collect::<Vec<_>>()
    );
    for (k, v) in &errors {
        println!("  {k:16} {:12.6} error {v:6.2} %", id.params[k]);
    }
    assert_eq!(id.params.len(), 9);
    assert!(problem.in_bounds(&id.x));
    Checked {
        ratio: id.rms_nm / floor,
        acceptance_ratio: id.rms_nm / raw_floor,
        errors,
        wall_s: id.wall_s,
        evaluations: id.evaluations,
    }
}

#[test]
fn seed_fixture_reaches_the_noise_floor_and_recovers_soleus_lst() {
    let trial = read_trial(fixture("trial.csv")).unwrap();
    let unloaded = read_unloaded(fixture("unloaded.csv")).unwrap();
    let truth_json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(fixture("truth.json")).unwrap()).unwrap();
    let truth = ModelParams::from_json_str(&truth_json["params"].to_string()).unwrap();
    let prep = prepare(&trial, Some(&unloaded));
    assert!(prep.0.systematic().is_some());
    assert_eq!(prep.0.events().unwrap().reversals.len(), 1);
    let c = fit_and_check(&prep, &truth, "fixtures/seed");
    assert!(c.ratio <= 1.02, "fitted RMS / noise floor = {}", c.ratio);
    assert!(
        c.acceptance_ratio <= 1.02,
        "vs raw floor: {}",
        c.acceptance_ratio
    );
    assert!(
        c.errors["sol.lst_m"] < 1.0,
        "soleus LST error {} %",
        c.errors["sol.lst_m"]
    );
    assert!(c.evaluations > 1000);
    assert!(c.wall_s > 0.0);
}

/// `fixtures/offnominal`: every identified parameter 2–12 % off nominal (the first chain
/// starts at nominal, so on `fixtures/seed` a chain that never moved would look perfect).
///
/// Measured (errors against the truth, and of the nominal start): LST sol 0.28 % (2.91 %),
/// gm 0.10 % (3.09 %), gl 0.29 % (1.96 %); F0 sol 7.84 % (13.64 %), gm 8.62 % (9.09 %),
/// gl 7.78 % (11.11 %); α0 sol 9.09 % (9.09 %), gm 36.4 % (13.6 %), gl 7.14 % (10.71 %),
/// the three α0 on their upper bound; fitted RMS 1.186 N·m against a noise floor of
/// 1.363 N·m (ratio 0.870). The three tendon slack lengths are recovered; F0 and α0 are
/// not: a fit with every α0 on its bound matches the noisy torque better than the truth
/// does, so nothing is asserted of them here (the MCMC test of the same fixture reports how
/// wide their posteriors are).
#[test]
fn off_nominal_fixture_recovers_the_tendon_slack_lengths() {
    let trial = read_trial(fixture_in("offnominal", "trial.csv")).unwrap();
    let unloaded = read_unloaded(fixture_in("offnominal", "unloaded.csv")).unwrap();
    let truth_json: serde_json::Value = serde_json::from_str(
        &std::fs::read_to_string(fixture_in("offnominal", "truth.json")).unwrap(),
    )
    .unwrap();
    let truth = ModelParams::from_json_str(&truth_json["params"].to_string()).unwrap();
    let prep = prepare(&trial, Some(&unloaded));
    let c = fit_and_check(&prep, &truth, "fixtures/offnominal");
    // the same fit-quality acceptance as the seed fixture
    assert!(c.ratio <= 1.02, "fitted RMS / noise floor = {}", c.ratio);
    assert!(
        c.acceptance_ratio <= 1.02,
        "vs raw floor: {}",
        c.acceptance_ratio
    );
    // soleus: the seed fixture's 1 %; gastrocnemii: about 3–5 times the errors measured,
    // all well under the 2–3 % of the nominal start
    for (name, tol) in [("sol.lst_m", 1.0), ("gm.lst_m", 0.5), ("gl.lst_m", 1.0)] {
        assert!(
            c.errors[name] <= tol,
            "{name} error {} % (tolerance {tol} %)",
            c.errors[name]
        );
    }
}

#[test]
fn random_truths_meet_the_acceptance() {
    for seed in [101u64, 202] {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let truth = random_params(&mut rng, &ModelParams::nominal());
        let syn = synthesize(&SynthConfig::new(Protocol::Seed, seed).with_params(truth)).unwrap();
        let prep = prepare(&syn.trial, Some(&syn.unloaded));
        let c = fit_and_check(&prep, &truth, &format!("random truth {seed}"));
        assert!(c.ratio <= 1.02, "seed {seed}: ratio {}", c.ratio);
        assert!(
            c.acceptance_ratio <= 1.02,
            "seed {seed}: vs raw floor {}",
            c.acceptance_ratio
        );
        assert!(
            c.errors["sol.lst_m"] <= 1.5,
            "seed {seed}: soleus LST error {} %",
            c.errors["sol.lst_m"]
        );
    }
}

#[test]
fn identification_is_deterministic_and_thread_count_independent() {
    // Small budget: the point is reproducibility, not accuracy.
    let trial = read_trial(fixture("trial.csv")).unwrap();
    let (prep, problem) = prepare(&trial, None);
    let s = SaIdentifySettings::default()
        .with_chain_evaluations(600)
        .with_chains(3);
    let one = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .unwrap()
        .install(|| identify(&problem, &s, &NoObserver).unwrap());
    let two = rayon::ThreadPoolBuilder::new()
        .num_threads(2)
        .build()
        .unwrap()
        .install(|| identify(&problem, &s, &NoObserver).unwrap());
    assert_eq!(one.x, two.x);
    assert_eq!(one.sse, two.sse);
    assert_eq!(one.evaluations, two.evaluations);
    assert_eq!(one.chains.len(), 3);
    // Without the unloaded run nothing is subtracted.
    assert!(prep.systematic().is_none());
    assert_eq!(prep.subtracted_rms_nm(), 0.0);
}
