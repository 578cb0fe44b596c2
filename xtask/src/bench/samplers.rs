//! `cargo xtask bench --samplers`: the random walk against NUTS on the seed trial,
//! `fixtures/session3` and the real recording `fixtures/walk36` (its recording defaults: 11
//! parameters with the activation's shape and a delay), each with the same trials, noise models
//! and convergence targets as `surae identify --method mcmc|nuts`. Per problem: what one exact
//! Jacobian costs against one simulation of the first trial (median of 5), and per sampler the
//! wall time, the model evaluations (NUTS: gradients, each a simulation and its Jacobian),
//! evaluations per effective draw of the slowest parameter and the worst R̂.
//!
//! `--sampler-iterations N` gives NUTS N iterations per chain (half warm-up; default 2 000, as
//! the command line's); the random walk runs to its targets as the command line's does.

use anyhow::{Context, Result};
use identify_mcmc::{
    McmcIdentification, McmcIdentifySettings, NutsSettings, SessionTrialLikelihood,
};
use muscle_model::{Problem, ProblemWorkspace};
use std::path::Path;
use std::time::Instant;

/// One problem's measurements.
struct SamplerRows {
    label: String,
    params: usize,
    t_sim: f64,
    t_jac: f64,
    walk: Outcome,
    nuts: Outcome,
}

/// One sampler's run.
struct Outcome {
    wall: f64,
    evaluations: u64,
    min_ess: f64,
    max_rhat: f64,
    leapfrog: Option<f64>,
}

impl Outcome {
    fn of(m: &McmcIdentification, wall: f64) -> Self {
        let (max_rhat, min_ess) = m.worst_diagnostics();
        Outcome {
            wall,
            evaluations: m.evaluations,
            min_ess,
            max_rhat,
            leapfrog: m.nuts.as_ref().map(|n| n.mean_leapfrog),
        }
    }

    fn cells(&self) -> String {
        format!(
            "{:.1} s | {} | {:.0} | {:.0} | {:.4}{}",
            self.wall,
            self.evaluations,
            self.min_ess,
            self.evaluations as f64 / self.min_ess,
            self.max_rhat,
            self.leapfrog.map_or(String::new(), |l| format!(
                " ({l:.1} leapfrog steps per draw)"
            ))
        )
    }
}

/// Median time (s) of five calls of `f`, after one.
fn median_of_five(mut f: impl FnMut() -> Result<()>) -> Result<f64> {
    f()?;
    let mut t = Vec::with_capacity(5);
    for _ in 0..5 {
        let s = Instant::now();
        f()?;
        t.push(s.elapsed().as_secs_f64());
    }
    Ok(super::median(t))
}

/// Times a gradient against a simulation on `trials[0]`, then runs both samplers.
fn measure(
    label: &str,
    trials: &[SessionTrialLikelihood<'_>],
    nuts: &NutsSettings,
) -> Result<SamplerRows> {
    let problem: &Problem = trials[0].problem;
    let x = problem.base_vector();
    let mut ws = ProblemWorkspace::new();
    let mut out = vec![0.0; problem.measured().len()];
    let mut jac = Vec::new();
    let t_sim = median_of_five(|| Ok(problem.predict_with(&x, &mut ws, &mut out)?))?;
    let t_jac = median_of_five(|| Ok(problem.jacobian_with(&x, &mut ws, &mut jac)?))?;
    let settings = McmcIdentifySettings::default();
    eprintln!("{label}: random walk ...");
    let start = Instant::now();
    let rw =
        identify_mcmc::identify_session(
            trials,
            &settings,
            |_| std::ops::ControlFlow::Continue(()),
        )?;
    let walk = Outcome::of(&rw, start.elapsed().as_secs_f64());
    eprintln!("{label}: NUTS ...");
    let start = Instant::now();
    let nu = identify_mcmc::identify_session_nuts(trials, &settings, nuts)?;
    let nuts = Outcome::of(&nu, start.elapsed().as_secs_f64());
    Ok(SamplerRows {
        label: label.to_string(),
        params: problem.dim(),
        t_sim,
        t_jac,
        walk,
        nuts,
    })
}

/// A session's trials and noise models as `surae identify --session` builds them.
fn session_rows(
    root: &Path,
    manifest: &str,
    label: &str,
    nuts: &NutsSettings,
) -> Result<SamplerRows> {
    let session = surae_app::load_session(
        &root.join(manifest),
        &Default::default(),
        None,
        &surae_app::Reporter::silent(),
    )
    .map_err(|e| anyhow::anyhow!("{e}"))?;
    let (problems, noises) = session.mcmc_trials().map_err(|e| anyhow::anyhow!("{e}"))?;
    let trials: Vec<SessionTrialLikelihood<'_>> = problems
        .iter()
        .zip(&noises)
        .map(|(problem, noise)| SessionTrialLikelihood { problem, noise })
        .collect();
    measure(label, &trials, nuts)
}

/// Runs the three problems and prints the table.
pub(super) fn run(root: &Path, iterations: usize) -> Result<()> {
    let nuts = NutsSettings {
        seed: 7,
        dense_metric: true,
        warmup: iterations / 2,
        draws: iterations - iterations / 2,
        ..NutsSettings::default()
    };
    nuts.validate()?;
    let dir = root.join("fixtures/seed");
    let trial = experiment::read_trial(dir.join("trial.csv")).context("fixtures/seed/trial.csv")?;
    let unloaded = experiment::read_unloaded(dir.join("unloaded.csv"))
        .context("fixtures/seed/unloaded.csv")?;
    let inputs = experiment::model_inputs(&trial, &Default::default())?;
    let problem = Problem::standard(inputs, trial.torque_nm.clone())?;
    let noise = identify_mcmc::NoiseSpec::from_unloaded(
        &trial,
        &unloaded,
        identify_mcmc::NoiseKind::Ar1White,
    )?;
    let rows = [
        measure(
            "seed trial",
            &[SessionTrialLikelihood {
                problem: &problem,
                noise: &noise,
            }],
            &nuts,
        )?,
        session_rows(
            root,
            "fixtures/session3/session.json",
            "fixtures/session3 (3 trials)",
            &nuts,
        )?,
        session_rows(
            root,
            "fixtures/walk36/session.json",
            "fixtures/walk36 (61 s of walking, recording defaults)",
            &nuts,
        )?,
    ];
    println!(
        "| problem | parameters | simulation | exact Jacobian | sampler | wall | evaluations | min bulk ESS | evaluations per effective draw | max R̂ |"
    );
    println!("|---|---|---|---|---|---|---|---|---|---|");
    for r in &rows {
        let lead = format!(
            "| {} | {} | {:.2} ms | {:.2} ms ({:.1} simulations) |",
            r.label,
            r.params,
            1e3 * r.t_sim,
            1e3 * r.t_jac,
            r.t_jac / r.t_sim
        );
        println!("{lead} random walk | {} |", r.walk.cells());
        println!(
            "{lead} NUTS ({iterations} iterations per chain) | {} |",
            r.nuts.cells()
        );
    }
    Ok(())
}
