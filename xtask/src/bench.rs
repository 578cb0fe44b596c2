//! `cargo xtask bench`: the forward model and the cost on the seed fixture, then the Python
//! peer (`bench/peer/surae_peer.py`, scipy RK45) on the same trial in the same run; prints a
//! Markdown table with the ratios. The SA row runs `identify_sa::identify` end to end on the
//! trial (with `unloaded.csv` next to it when present) and divides its wall time by its
//! evaluations; the MCMC row runs `identify_mcmc::identify` with its default settings and the
//! unloaded run's noise model to R̂ < 1.01 and bulk ESS ≥ 400 (or its cap, which the row then
//! shows); the diagnosis row runs `diagnose::run` on `fixtures/electromechanical_delay`.
//! The series-geometry row times the same forward simulation with every muscle's
//! musculotendon length and moment arm given as series at the samples (the values of the
//! polynomials), against the polynomial fast path. `--model-only` prints the forward-model
//! rows alone (no identification, diagnosis or peer); `--samplers` the samplers' rows alone
//! (module `samplers`: the random walk against NUTS, with the gradient's cost).

mod long_recording;
mod samplers;
mod walk36;

use anyhow::{bail, Context, Result};
use muscle_model::{
    simulate, simulate_into, Effects, GeometrySeries, ModelParams, Muscle, Problem,
    ProblemWorkspace, SimSettings, SimStats, TrialInputs, Workspace,
};
use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::Instant;

const USAGE: &str =
    "usage: cargo xtask bench [--repeat N] [--reps M] [--trial T.csv] [--model-only]\n\
       cargo xtask bench --samplers [--sampler-iterations N]\n\
  --repeat N     Python peer simulations (median; default 5)\n\
  --reps M       Rust repetitions per row (median; default 2000)\n\
  --trial T.csv  trial (default <workspace>/fixtures/seed/trial.csv)\n\
  --model-only   the forward-model rows only (polynomial and series geometry)\n\
  --samplers     random walk against NUTS on the seed trial, fixtures/session3 and\n\
                 fixtures/walk36, with the exact gradient's cost (takes hours on 2 cores)\n\
  --sampler-iterations N  NUTS iterations per chain, half warm-up (default 2000)";

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

/// Median wall time (s) of `f` over `reps` calls after 20 warm-up calls.
fn time_it(reps: usize, mut f: impl FnMut(usize) -> Result<()>) -> Result<f64> {
    for k in 0..20 {
        f(k)?;
    }
    let mut t = Vec::with_capacity(reps);
    for k in 0..reps {
        let s = Instant::now();
        f(k)?;
        t.push(s.elapsed().as_secs_f64());
    }
    Ok(median(t))
}

/// CPU time (user + system, s) of this process from `/proc/self/stat` (Linux; 100 Hz ticks),
/// `None` elsewhere.
fn cpu_seconds() -> Option<f64> {
    let s = std::fs::read_to_string("/proc/self/stat").ok()?;
    // fields after the command name (which is in parentheses and may contain spaces)
    let rest = s.rsplit_once(')')?.1;
    let f: Vec<&str> = rest.split_whitespace().collect();
    let utime: f64 = f.get(11)?.parse().ok()?;
    let stime: f64 = f.get(12)?.parse().ok()?;
    Some((utime + stime) / 100.0)
}

/// One end-to-end `identify_sa::identify` run: (evaluations, wall s, CPU s if known).
fn sa_run(trial_path: &Path, trial: &experiment::Trial) -> Result<(u64, f64, Option<f64>)> {
    let unloaded_path = trial_path.with_file_name("unloaded.csv");
    let unloaded = if unloaded_path.exists() {
        Some(
            experiment::read_unloaded(&unloaded_path)
                .with_context(|| format!("reading {}", unloaded_path.display()))?,
        )
    } else {
        None
    };
    let prep = experiment::PreparedTrial::prepare(
        trial,
        unloaded.as_ref(),
        &Default::default(),
        &experiment::CrosstalkSettings::off(),
        &trial_path.display().to_string(),
    )?;
    let problem = prep.standard_problem()?;
    let settings = identify_sa::SaIdentifySettings::default();
    let cpu0 = cpu_seconds();
    let start = Instant::now();
    let fit = identify_sa::identify(&problem, &settings, &identify_sa::NoObserver)?;
    let wall = start.elapsed().as_secs_f64();
    let cpu = cpu_seconds().zip(cpu0).map(|(b, a)| b - a);
    eprintln!(
        "SA: {} evaluations in {wall:.2} s, torque RMS {:.3} N·m",
        fit.evaluations, fit.rms_nm
    );
    Ok((fit.evaluations, wall, cpu))
}

/// One `identify_mcmc::identify` run with the default settings (4 chains, rayon) and the noise
/// model of the unloaded run: (evaluations, wall s, CPU s if known, converged, max R̂, min ESS).
fn mcmc_run(
    trial_path: &Path,
    trial: &experiment::Trial,
) -> Result<(u64, f64, Option<f64>, bool, f64, f64)> {
    let unloaded_path = trial_path.with_file_name("unloaded.csv");
    let unloaded = experiment::read_unloaded(&unloaded_path)
        .with_context(|| format!("reading {}", unloaded_path.display()))?;
    let inputs = experiment::model_inputs(trial, &experiment::InputOptions::default())?;
    let problem = muscle_model::Problem::standard(inputs, trial.torque_nm.clone())?;
    let noise = identify_mcmc::NoiseSpec::from_unloaded(
        trial,
        &unloaded,
        identify_mcmc::NoiseKind::Ar1White,
    )?;
    timed_mcmc(
        &[identify_mcmc::SessionTrialLikelihood {
            problem: &problem,
            noise: &noise,
        }],
        "MCMC",
    )
}

/// `identify_mcmc::identify_session` with the default settings, timed: (evaluations, wall s,
/// CPU s if known, converged, max R̂, min ESS).
fn timed_mcmc(
    trials: &[identify_mcmc::SessionTrialLikelihood<'_>],
    label: &str,
) -> Result<(u64, f64, Option<f64>, bool, f64, f64)> {
    let cpu0 = cpu_seconds();
    let start = Instant::now();
    let res = identify_mcmc::identify_session(
        trials,
        &identify_mcmc::McmcIdentifySettings::default(),
        |_| std::ops::ControlFlow::Continue(()),
    )?;
    let wall = start.elapsed().as_secs_f64();
    let cpu = cpu_seconds().zip(cpu0).map(|(b, a)| b - a);
    let (r, e) = res.worst_diagnostics();
    eprintln!(
        "{label}: {} evaluations in {wall:.2} s, converged {}, max R̂ {r:.4}, min bulk ESS {e:.0}",
        res.evaluations, res.converged
    );
    Ok((res.evaluations, wall, cpu, res.converged, r, e))
}

/// One joint `identify_sa::identify_set` run on `fixtures/session3` (three trials read as
/// `surae identify --session` reads them): (evaluations, wall s, CPU s if known).
fn sa_session_run(root: &Path) -> Result<(u64, f64, Option<f64>)> {
    let manifest = root.join("fixtures/session3/session.json");
    let session = surae_app::load_session(
        &manifest,
        &Default::default(),
        None,
        &surae_app::Reporter::silent(),
    )
    .map_err(|e| anyhow::anyhow!("{e}"))?;
    let set = session.problem_set().map_err(|e| anyhow::anyhow!("{e}"))?;
    let settings = identify_sa::SaIdentifySettings::default();
    let cpu0 = cpu_seconds();
    let start = Instant::now();
    let fit = identify_sa::identify_set(&set, &settings, &identify_sa::NoObserver)?;
    let wall = start.elapsed().as_secs_f64();
    let cpu = cpu_seconds().zip(cpu0).map(|(b, a)| b - a);
    eprintln!(
        "SA, 3-trial session: {} evaluations in {wall:.2} s, torque RMS {:.3} N·m",
        fit.evaluations, fit.rms_nm
    );
    Ok((fit.evaluations, wall, cpu))
}

/// One joint `identify_mcmc::identify_session` run with the default settings on
/// `fixtures/session3`: (evaluations, wall s, CPU s if known, converged, max R̂, min ESS).
fn mcmc_session_run(root: &Path) -> Result<(u64, f64, Option<f64>, bool, f64, f64)> {
    let manifest = root.join("fixtures/session3/session.json");
    let session = surae_app::load_session(
        &manifest,
        &Default::default(),
        None,
        &surae_app::Reporter::silent(),
    )
    .map_err(|e| anyhow::anyhow!("{e}"))?;
    let (problems, noises) = session.mcmc_trials().map_err(|e| anyhow::anyhow!("{e}"))?;
    let trials: Vec<identify_mcmc::SessionTrialLikelihood<'_>> = problems
        .iter()
        .zip(&noises)
        .map(|(problem, noise)| identify_mcmc::SessionTrialLikelihood { problem, noise })
        .collect();
    timed_mcmc(&trials, "MCMC, 3-trial session")
}

/// One `diagnose::run` with the default settings on `fixtures/<name>` (trial + unloaded run):
/// (wall s, CPU s if known, named causes).
fn diagnose_run(root: &Path, name: &str) -> Result<(f64, Option<f64>, Vec<String>)> {
    let dir = root.join("fixtures").join(name);
    let trial = experiment::read_trial(dir.join("trial.csv"))
        .with_context(|| format!("reading {}", dir.join("trial.csv").display()))?;
    let unloaded = experiment::read_unloaded(dir.join("unloaded.csv"))
        .with_context(|| format!("reading {}", dir.join("unloaded.csv").display()))?;
    let cpu0 = cpu_seconds();
    let start = Instant::now();
    let d = diagnose::run(
        &trial,
        Some(&unloaded),
        &diagnose::DiagnoseSettings::default(),
        &mut diagnose::no_observer,
    )?;
    let wall = start.elapsed().as_secs_f64();
    let cpu = cpu_seconds().zip(cpu0).map(|(b, a)| b - a);
    eprintln!(
        "diagnose fixtures/{name}: causes {:?} in {wall:.2} s",
        d.causes
    );
    Ok((wall, cpu, d.causes))
}

/// `inputs` with every muscle's geometry given as series: the length polynomial and its
/// moment arm evaluated at the samples (so the simulated torque is the polynomial one, to the
/// interpolation between samples).
fn with_series_geometry(inputs: &TrialInputs, p: &ModelParams) -> Result<TrialInputs> {
    let mut out = inputs.clone();
    for m in Muscle::ALL {
        let mp = p.muscle(m);
        let series = GeometrySeries {
            lmt_m: inputs.angle().iter().map(|&q| mp.lmt(q)).collect(),
            moment_arm_m: inputs.angle().iter().map(|&q| mp.moment_arm(q)).collect(),
        };
        out = out.with_geometry(m.name(), series)?;
    }
    Ok(out)
}

/// Median time of one forward simulation of `inputs` (three parameter sets in turn, each
/// differing in every muscle, so the two-slot per-muscle cache never applies).
fn forward_time(inputs: &TrialInputs, p: &ModelParams, reps: usize) -> Result<f64> {
    let sets: Vec<ModelParams> = (0..3)
        .map(|k| {
            let mut q = *p;
            for m in &mut q.muscles {
                m.lst_m *= 1.0 + 1e-4 * k as f64;
            }
            q
        })
        .collect();
    let (e, s) = (Effects::none(), SimSettings::default());
    let mut ws = Workspace::new();
    let mut torque = vec![0.0; inputs.len()];
    time_it(reps, |k| {
        simulate_into(&mut ws, inputs, &sets[k % 3], &e, &s, &mut torque)?;
        Ok(())
    })
}

fn rms(a: &[f64], b: &[f64]) -> f64 {
    (a.iter().zip(b).map(|(x, y)| (x - y).powi(2)).sum::<f64>() / a.len() as f64).sqrt()
}

/// Runs the peer and returns its median wall time per simulation (s).
fn peer(root: &Path, trial: &Path, repeat: usize) -> Result<f64> {
    let script = root.join("bench/peer/surae_peer.py");
    let out = Command::new("python3")
        .arg(&script)
        .arg("--trial")
        .arg(trial)
        .args(["--time", "--repeat", &repeat.to_string()])
        .output()
        .context("running python3 (is it installed?)")?;
    let text =
        String::from_utf8_lossy(&out.stdout).to_string() + &String::from_utf8_lossy(&out.stderr);
    if !out.status.success() {
        if text.contains("No module named") {
            bail!(
                "the Python peer needs numpy and scipy: pip install -r bench/peer/requirements.txt\n{text}"
            );
        }
        bail!("the Python peer failed:\n{text}");
    }
    // "wall per simulation: median 0.2346 s over 3 ..."
    let v = text
        .split("median ")
        .nth(1)
        .and_then(|r| r.split_whitespace().next())
        .and_then(|x| x.parse::<f64>().ok())
        .with_context(|| format!("no median time in the peer output:\n{text}"))?;
    Ok(v)
}

/// The options of `cargo xtask bench`.
struct BenchArgs {
    /// Python peer simulations.
    repeat: usize,
    /// Rust repetitions per row.
    reps: usize,
    trial_path: PathBuf,
    model_only: bool,
    /// NUTS iterations per chain when the samplers' rows are asked for.
    samplers: Option<usize>,
}

/// Reads the options; `None` when `--help` was asked for (the usage is then printed).
fn parse_args(args: &mut impl Iterator<Item = String>, root: &Path) -> Result<Option<BenchArgs>> {
    let mut repeat = 5;
    let mut reps = 2000;
    let mut trial_path = root.join("fixtures/seed/trial.csv");
    let mut model_only = false;
    let mut samplers = None;
    let mut sampler_iterations = 2000;
    while let Some(a) = args.next() {
        match a.as_str() {
            "--model-only" => model_only = true,
            "--samplers" => samplers = Some(()),
            "--sampler-iterations" => {
                sampler_iterations = args.next().context("--sampler-iterations N")?.parse()?
            }
            "--repeat" => repeat = args.next().context("--repeat N")?.parse()?,
            "--reps" => reps = args.next().context("--reps M")?.parse()?,
            "--trial" => trial_path = args.next().context("--trial T.csv")?.into(),
            "-h" | "--help" => {
                println!("{USAGE}");
                return Ok(None);
            }
            other => bail!("unknown argument `{other}`\n{USAGE}"),
        }
    }
    if repeat == 0 || reps == 0 {
        bail!("--repeat and --reps must be positive");
    }
    Ok(Some(BenchArgs {
        repeat,
        reps,
        trial_path,
        model_only,
        samplers: samplers.map(|()| sampler_iterations),
    }))
}

/// The forward-model measurements: one simulation's time with polynomial and with series
/// geometry, and the accuracy of each.
struct ForwardRows {
    /// Median time of one simulation, polynomial geometry (s).
    t_fwd: f64,
    /// The same with the geometry as series (s).
    t_series: f64,
    /// RMS torque difference, series against polynomial geometry (N·m).
    series_err: f64,
    /// RMS torque difference, default settings against `SimSettings::tight()` (N·m).
    err: f64,
    /// Solver work of one simulation with the default settings.
    stats: SimStats,
}

/// Times the forward model on `inputs` at the nominal parameters, `reps` repetitions a row.
fn forward_rows(inputs: &TrialInputs, reps: usize) -> Result<ForwardRows> {
    let p = ModelParams::nominal();
    let e = Effects::none();
    let s = SimSettings::default();

    // accuracy of the default settings against the tight reference
    let tight = simulate(inputs, &p, &e, &SimSettings::tight())?;
    let fast = simulate(inputs, &p, &e, &s)?;
    let err = rms(&fast.torque, &tight.torque);
    let stats = fast.total_stats();

    // one forward simulation, polynomial geometry and geometry series
    let t_fwd = forward_time(inputs, &p, reps)?;
    let series_inputs = with_series_geometry(inputs, &p)?;
    let series_err = rms(&simulate(&series_inputs, &p, &e, &s)?.torque, &fast.torque);
    let t_series = forward_time(&series_inputs, &p, reps)?;
    Ok(ForwardRows {
        t_fwd,
        t_series,
        series_err,
        err,
        stats,
    })
}

/// A time in microseconds, as the table shows it.
fn us(t: f64) -> String {
    format!("{:.1} µs", t * 1e6)
}

/// `, <CPU> s CPU` when the CPU time is known.
fn cpu_note(c: Option<f64>) -> String {
    c.map_or(String::new(), |c| format!(", {c:.1} s CPU"))
}

/// The table of `--model-only`: the forward model alone, without the peer.
fn print_model_only(f: &ForwardRows, reps: usize) -> Result<()> {
    let ForwardRows {
        t_fwd,
        t_series,
        series_err,
        err,
        ..
    } = *f;
    println!("| measurement | surae (Rust, 1 thread) | relative |");
    println!("|---|---|---|");
    println!(
        "| forward simulation, seed trial (3 muscles integrated) | {} | 1 |",
        us(t_fwd)
    );
    println!(
        "| forward simulation, seed trial, geometry as series (3 muscles integrated) | {} | {:.2} |",
        us(t_series),
        t_series / t_fwd
    );
    for row in long_recording::measure(reps)?.rows(3, t_fwd) {
        println!("{row}");
    }
    println!();
    println!(
        "series vs polynomial geometry: {series_err:.2e} N·m RMS; default settings: {err:.2e} N·m RMS from SimSettings::tight(); {reps} repetitions"
    );
    Ok(())
}

/// Median times of one cost evaluation (s): every coordinate moved, and one coordinate moved.
struct CostRows {
    t_cost_full: f64,
    t_cost_sa: f64,
}

/// Times the cost of the standard problem on `inputs` and the trial's torque.
fn cost_rows(inputs: &TrialInputs, trial: &experiment::Trial, reps: usize) -> Result<CostRows> {
    // cost evaluations as an annealer makes them: one coordinate of the 9 moved at a time
    let problem = Problem::standard(inputs.clone(), trial.torque_nm.clone())?;
    let x0 = problem.base_vector();
    let mut pws = ProblemWorkspace::new();
    let mut x = x0.clone();
    let mut state = 0x2545_f491_4f6c_dd1d_u64;
    let mut next = || {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        state
    };
    let t_cost_sa = time_it(reps, |_| {
        let c = (next() % 9) as usize;
        let u = (next() >> 11) as f64 / (1u64 << 53) as f64;
        x[c] = x0[c] * (1.0 + 0.02 * (u - 0.5));
        std::hint::black_box(problem.sse_with(&x, &mut pws)?);
        Ok(())
    })?;
    // a full cost evaluation: all coordinates moved
    let t_cost_full = time_it(reps.min(500), |k| {
        for (c, xi) in x.iter_mut().enumerate() {
            *xi = x0[c] * (1.0 + 1e-4 * ((k + c) % 5) as f64);
        }
        std::hint::black_box(problem.sse_with(&x, &mut pws)?);
        Ok(())
    })?;
    Ok(CostRows {
        t_cost_full,
        t_cost_sa,
    })
}

/// The end-to-end runs, each as its `*_run` function returns it.
struct EndToEndRows {
    sa: (u64, f64, Option<f64>),
    sa_session: (u64, f64, Option<f64>),
    /// Threads available to the runs.
    threads: usize,
    mcmc: (u64, f64, Option<f64>, bool, f64, f64),
    mcmc_session: (u64, f64, Option<f64>, bool, f64, f64),
    diagnosis: (f64, Option<f64>, Vec<String>),
}

/// Runs the identifications and the diagnosis end to end, one after the other.
fn end_to_end_rows(
    root: &Path,
    trial_path: &Path,
    trial: &experiment::Trial,
) -> Result<EndToEndRows> {
    eprintln!("running identify_sa::identify (4 chains, rayon) ...");
    let sa = sa_run(trial_path, trial)?;
    eprintln!("running identify_sa::identify_set on fixtures/session3 (4 chains, rayon) ...");
    let sa_session = sa_session_run(root)?;
    let threads = std::thread::available_parallelism().map_or(1, |n| n.get());

    eprintln!("running identify_mcmc::identify (default settings, 4 chains, rayon) ...");
    let mcmc = mcmc_run(trial_path, trial)?;
    eprintln!(
        "running identify_mcmc::identify_session on fixtures/session3 (default settings) ..."
    );
    let mcmc_session = mcmc_session_run(root)?;
    eprintln!("running diagnose::run on fixtures/electromechanical_delay ...");
    let diagnosis = diagnose_run(root, "electromechanical_delay")?;
    Ok(EndToEndRows {
        sa,
        sa_session,
        threads,
        mcmc,
        mcmc_session,
        diagnosis,
    })
}

/// The rows timed against the peer (`t_peer` s per simulation): the forward model and the
/// cost evaluations.
fn print_model_rows(f: &ForwardRows, c: &CostRows, t_peer: f64) {
    let ForwardRows {
        t_fwd,
        t_series,
        series_err,
        ..
    } = *f;
    let CostRows {
        t_cost_full,
        t_cost_sa,
    } = *c;
    println!(
        "| forward simulation, seed trial (3 muscles integrated) | {} | {:.1} ms | {:.0}× |",
        us(t_fwd),
        t_peer * 1e3,
        t_peer / t_fwd
    );
    println!(
        "| forward simulation, seed trial, geometry as series (3 muscles integrated; {series_err:.1e} N·m RMS from the polynomial) | {} | {:.1} ms | {:.0}× |",
        us(t_series),
        t_peer * 1e3,
        t_peer / t_series
    );
    println!(
        "| cost evaluation, all 9 parameters moved | {} | — | {:.0}× |",
        us(t_cost_full),
        t_peer / t_cost_full
    );
    println!(
        "| cost evaluation, one random coordinate moved (annealing move) | {} | — | {:.0}× |",
        us(t_cost_sa),
        t_peer / t_cost_sa
    );
}

/// The rows of the end-to-end runs; the SA evaluation row is also timed against the peer
/// (`t_peer` s per simulation).
fn print_end_to_end_rows(r: &EndToEndRows, t_peer: f64) {
    let (sa_evals, sa_wall, sa_cpu) = r.sa;
    let (ss_evals, ss_wall, ss_cpu) = r.sa_session;
    let threads = r.threads;
    let (mc_evals, mc_wall, mc_cpu, mc_conv, mc_rhat, mc_ess) = r.mcmc;
    let (ms_evals, ms_wall, ms_cpu, ms_conv, ms_rhat, ms_ess) = r.mcmc_session;
    let (dg_wall, dg_cpu, dg_causes) = &r.diagnosis;
    let per_eval = sa_wall / sa_evals.max(1) as f64;
    println!(
        "| SA model evaluation inside `identify` (wall / evaluations; {sa_evals} evaluations in {sa_wall:.2} s on {threads} threads{}) | {} | {:.1} ms | {:.0}× |",
        sa_cpu.map_or(String::new(), |c| format!(
            "; CPU {:.1} µs per evaluation",
            c / sa_evals.max(1) as f64 * 1e6
        )),
        us(per_eval),
        t_peer * 1e3,
        t_peer / per_eval
    );
    println!(
        "| SA end to end (seed, unloaded-run correction, 4 chains + polish) | {sa_wall:.2} s wall{} | — | — |",
        cpu_note(sa_cpu)
    );
    println!(
        "| SA end to end, 3-trial session (`fixtures/session3`: knee0@30, knee90@30, knee0@60; {ss_evals} evaluations) | {ss_wall:.2} s wall{} ({:.1}× the seed's) | — | — |",
        cpu_note(ss_cpu),
        ss_wall / sa_wall
    );
    println!(
        "| MCMC to R̂ < 1.01, ESS ≥ 400 (seed trial, default settings, {mc_evals} evaluations; converged {mc_conv}, max R̂ {mc_rhat:.4}, min bulk ESS {mc_ess:.0}) | {mc_wall:.2} s wall{} | — | — |",
        cpu_note(mc_cpu)
    );
    println!(
        "| MCMC, 3-trial session (`fixtures/session3`, default settings, {ms_evals} evaluations; converged {ms_conv}, max R̂ {ms_rhat:.4}, min bulk ESS {ms_ess:.0}) | {ms_wall:.2} s wall{} ({:.1}× the seed's) | — | — |",
        cpu_note(ms_cpu),
        ms_wall / mc_wall
    );
    println!(
        "| full diagnosis (`fixtures/electromechanical_delay`, unloaded run; named {dg_causes:?}) | {dg_wall:.2} s wall{} | — | — |",
        cpu_note(*dg_cpu)
    );
}

/// `cargo xtask bench [...]`.
pub fn run(args: &mut impl Iterator<Item = String>) -> Result<bool> {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"))
        .parent()
        .context("workspace root")?
        .to_path_buf();
    let Some(BenchArgs {
        repeat,
        reps,
        trial_path,
        model_only,
        samplers,
    }) = parse_args(args, &root)?
    else {
        return Ok(true);
    };
    if let Some(iterations) = samplers {
        samplers::run(&root, iterations)?;
        return Ok(true);
    }
    let trial = experiment::read_trial(&trial_path)
        .with_context(|| format!("reading {}", trial_path.display()))?;
    let inputs = experiment::model_inputs(&trial, &Default::default())?;
    let n = inputs.len();
    eprintln!("trial {} ({n} samples)", trial_path.display());

    let forward = forward_rows(&inputs, reps)?;
    if model_only {
        print_model_only(&forward, reps)?;
        return Ok(true);
    }
    let cost = cost_rows(&inputs, &trial, reps)?;
    let runs = end_to_end_rows(&root, &trial_path, &trial)?;
    eprintln!("running surae identify --method sa --session fixtures/walk36/session.json ...");
    let walk36 = walk36::measure(&root)?;

    eprintln!("running the Python peer ({repeat} simulations) ...");
    let t_peer = peer(&root, &trial_path, repeat)?;

    println!("| measurement | surae (Rust, 1 thread) | peer (Python, scipy RK45) | ratio |");
    println!("|---|---|---|---|");
    print_model_rows(&forward, &cost, t_peer);
    print_end_to_end_rows(&runs, t_peer);
    println!("{}", walk36.row(4));
    for row in long_recording::measure(reps)?.rows(4, forward.t_fwd) {
        println!("{row}");
    }
    println!();
    println!(
        "default settings: {:.2e} N·m RMS from SimSettings::tight(); {} accepted steps, {} RHS calls (3 muscles); {} Rust repetitions, {repeat} peer simulations",
        forward.err, forward.stats.accepted, forward.stats.rhs_calls, reps
    );
    Ok(true)
}
