//! `surae identify`: fit LST, F0 and α0 of the three muscles (docs/results.md), and with
//! `--with` the parameters of catalogued effects, by simulated annealing or MCMC; then test
//! the identified model for structure left in its residual (`"adequacy"`).

mod exports;
mod extended;
mod mcmc;
mod reports;
mod session_fit;

pub use reports::{
    AdequacyReport, CorrelationMatrixReport, CorrelationReport, IdentifyReport, McmcReport,
    McmcTrialReport, NoiseCorrectionReport, NoiseUseReport, NutsReport, PosteriorReport,
    SaChainsReport, SessionAdequacyReport, SessionContextReport, SessionIdentifyReport,
    SessionSaChainsReport, SessionTrialReport,
};

use super::{load_model_config, LoadedTrial, ModelSettings};
use crate::error::{AppError, AppResult};
use crate::figures::{self, FigureSet};
use crate::memory::InMemory;
use crate::output::OutDir;
use crate::Reporter;
use muscle_model::{EffectKind, Effects, ModelParams, ParamId, Problem};
use serde_json::Value;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// Identification method.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Method {
    /// Simulated annealing (eq. 13 acceptance) with a Levenberg–Marquardt polish.
    Sa,
    /// Metropolis–Hastings chains with an AR(1) noise likelihood.
    Mcmc,
    /// The No-U-Turn sampler on the same likelihood, along its exact gradient.
    Nuts,
}

impl Method {
    fn name(self) -> &'static str {
        match self {
            Method::Sa => "sa",
            Method::Mcmc => "mcmc",
            Method::Nuts => "nuts",
        }
    }

    /// A posterior sampler (`mcmc` or `nuts`).
    pub(super) fn samples(self) -> bool {
        matches!(self, Method::Mcmc | Method::Nuts)
    }
}

/// Files `surae identify` may write.
const PLANNED: &[&str] = &[
    "identify.json",
    "chains.csv",
    "chains",
    "identified.osim",
    "torque_fit.svg",
    "residual_vs_time.svg",
    "residual_vs_angle.svg",
    "traces.svg",
    "rhat.svg",
    "histograms.svg",
    "corner.svg",
    "report.html",
];

/// Arguments of `surae identify`.
#[derive(Debug)]
pub struct IdentifyJob {
    /// `sa` (simulated annealing) or `mcmc` (Metropolis–Hastings).
    pub method: Method,
    /// Trial: a trial CSV, a recording map (`.json`) of a lab's files, or a CEINMS trial folder (a session of one) (docs/formats.md);
    /// the bundled seed trial (and its unloaded run) when omitted.
    pub trial: Option<PathBuf>,
    /// Session manifest (docs/formats.md): several trials of one subject identified together,
    /// with the session's parameters and free parameters.
    pub session: Option<PathBuf>,
    /// The parameters to identify, comma-separated (e.g.
    /// `sol.lst_m,sol.fom_n,activation.shape_a,electromechanical_delay.delay_ms`); default LST,
    /// F0 and α0 of sol, gm and gl. With --session only.
    pub free: Option<Vec<String>>,
    /// Catalogued effects whose parameters are identified with the muscles', comma-separated
    /// (e.g. `electromechanical_delay,passive_joint_torque`): torque_offset,
    /// passive_joint_torque, gravity, electromechanical_delay, fatigue,
    /// antagonist_coactivation, eccentric_enhancement, viscous_damping, inertia (parameters and
    /// ranges in docs/results.md, "Effects identified with the muscles"). Each starts at its
    /// value in --effects, or at its null value, and has a uniform prior on its range. With
    /// --session its parameters join the free ones, shared by the trials (a per-trial effect,
    /// torque_offset or gravity, is refused in a session of several trials).
    pub with_effects: Option<Vec<String>>,
    /// SA only: number of annealing chains (starts); chain 0 starts from the base values, the
    /// others from random points. Default 4.
    pub chains: Option<u32>,
    /// Unloaded run CSV (`time_s, ankle_angle_deg, torque_nm`): its cycle-locked
    /// error is removed from the measured torque and its noise sets the likelihood.
    pub unloaded: Option<PathBuf>,
    /// Seed of every random choice (results do not depend on the thread count).
    pub seed: u64,
    /// True parameters (a parameters JSON, docs/formats.md, or a fixture's `truth.json`):
    /// adds `errors_pct`. The bundled trial's truth is used when no `--trial` is given.
    pub truth: Option<PathBuf>,
    /// MCMC only: cap on the iterations per chain (warm-up and sampling). A
    /// run that reaches it before R̂ < 1.01 and bulk ESS ≥ 400 reports
    /// `"converged": false`. Default: the sampler's documented cap.
    pub max_iterations: Option<usize>,
    pub model: ModelSettings,
    /// Output folder (default `out/identify`).
    pub out: Option<PathBuf>,
    /// The trial given in memory, in place of `trial`.
    pub trial_data: Option<InMemory<experiment::Trial>>,
    /// The unloaded run given in memory, in place of `unloaded`.
    pub unloaded_data: Option<InMemory<experiment::Unloaded>>,
    /// The truth given in memory, in place of `truth`.
    pub truth_data: Option<InMemory<Value>>,
    /// Write no files: the result reaches the caller as [`crate::JobObserver::result_json`].
    pub discard_files: bool,
}

/// Reads a truth file with its effects: a parameters JSON (no effect), or an object with a
/// `params` member and, as a fixture's `truth.json` has, an `effects` member.
pub fn read_truth_model(path: &Path, text: &str) -> AppResult<(ModelParams, Effects)> {
    let v: Value = serde_json::from_str(text).map_err(|e| {
        AppError::bad(format!(
            "{}:{}:{}: invalid JSON: {e}",
            path.display(),
            e.line(),
            e.column()
        ))
    })?;
    truth_of_json(&v, &path.display().to_string())
}

/// A truth object named `name` in errors: parameters, or `params` with `effects`.
pub fn truth_of_json(v: &Value, name: &str) -> AppResult<(ModelParams, Effects)> {
    let (params, effects) = match v.get("params") {
        Some(p) => (p, v.get("effects")),
        None => (v, None),
    };
    let effects = match effects {
        Some(e) => {
            Effects::from_json(e).map_err(|e| AppError::bad(format!("{name}: effects: {e}")))?
        }
        None => Effects::none(),
    };
    let params = ModelParams::nominal()
        .merged_json(params)
        .map_err(|e| AppError::bad(format!("{name}: {e}")))?;
    Ok((params, effects))
}

/// Everything both methods need.
pub struct Prepared {
    /// The trial.
    pub loaded: LoadedTrial,
    /// The identification problem (measured torque corrected by the unloaded run).
    pub problem: Problem,
    /// The trial prepared once: crosstalk decision, model inputs, dynamometer correction and
    /// the torque as measured and as corrected.
    pub prepared: experiment::PreparedTrial,
    /// How the unloaded run was used, for the JSON.
    pub noise: NoiseUseReport,
    /// The dynamometer correction subtracted (`"dynamometer"` in the JSON; `null` without an
    /// unloaded run, when nothing is subtracted).
    pub dynamometer: Option<experiment::DynamometerReport>,
    /// True parameters and effects, if known.
    pub truth: Option<(ModelParams, Effects)>,
    /// Files read (never overwritten).
    pub inputs: Vec<PathBuf>,
    /// The effects `--with` added to the identified parameters.
    pub with: Vec<EffectKind>,
}

/// Loads the trial, unloaded run and truth and builds the problem: the 9 muscle parameters and
/// the parameters of the effects `with` (switched on at their null values unless `--effects`
/// gives them).
pub fn prepare(args: &IdentifyJob, with: &[EffectKind], rep: &Reporter) -> AppResult<Prepared> {
    let model = &args.model;
    let (params, effects, mut inputs_read) = load_model_config(model)?;
    let (mut loaded, unloaded) = super::load_trial_pair(
        (args.trial.as_deref(), args.trial_data.as_ref()),
        (args.unloaded.as_deref(), args.unloaded_data.as_ref()),
        rep,
    )?;
    let truth = match (&args.truth_data, &args.truth) {
        (Some(d), _) => Some(truth_of_json(&d.value, &d.label)?),
        (None, Some(p)) => {
            let text = super::read_text(p)?;
            inputs_read.push(p.to_path_buf());
            Some(read_truth_model(p, &text)?)
        }
        (None, None) if loaded.bundled => Some(
            read_truth_model(
                Path::new(crate::bundled::SEED_TRUTH_NAME),
                crate::bundled::SEED_TRUTH,
            )
            .map_err(|e| AppError::internal(e.to_string()))?,
        ),
        (None, None) => None,
    };
    if let Some(p) = &loaded.path {
        inputs_read.push(p.clone());
    }
    inputs_read.extend(loaded.data_files.iter().cloned());
    let opts = model
        .knee
        .input_options(model.emg_is_envelope || loaded.emg_is_envelope);
    // the TA's crosstalk is removed from the raw triceps EMG as `surae diagnose` removes it
    let prepared = super::prepare_trial(
        &loaded,
        unloaded.as_ref().map(|(u, n)| (u, n.as_str())),
        model,
        &extended::settings(opts).crosstalk_settings(),
    )?;
    if prepared.uncorrected_inputs.is_some() {
        loaded.trial = prepared.trial.clone();
    }
    let unloaded_name = unloaded.as_ref().map(|(_, n)| n.clone());
    let noise = match prepared.correction() {
        Some(c) => NoiseUseReport {
            unloaded: unloaded_name,
            correction: Some(NoiseCorrectionReport {
                offset_nm: c.offset_nm,
                sigma_nm: c.random.marginal_sd(),
                lag1_autocorrelation: c.random.autocorrelation(1),
                ar1_phi: c.random.phi,
                subtracted_rms_nm: prepared.subtracted_rms_nm(),
            }),
        },
        None => NoiseUseReport {
            unloaded: None,
            correction: None,
        },
    };
    let dynamometer = prepared.correction().map(|c| c.report());
    let problem = Problem::new(
        prepared.inputs.clone(),
        prepared.measured().to_vec(),
        params,
        extended::with_effects(effects, with),
        extended::with_free(ParamId::identified().to_vec(), with),
    )
    .map_err(|e| AppError::bad(format!("{}: {e}", loaded.name)))?;
    if !with.is_empty() {
        // an effect the trial cannot carry (antagonist_coactivation without emg_ta) is refused
        // before anything is written
        problem
            .predict(&problem.base_vector())
            .map_err(|e| AppError::bad(format!("{}: --with: {e}", loaded.name)))?;
    }
    Ok(Prepared {
        loaded,
        problem,
        prepared,
        noise,
        dynamometer,
        truth,
        inputs: inputs_read,
        with: with.to_vec(),
    })
}

/// `100·|estimate − truth|/|truth|` of every parameter whose true value is known and not 0 (an
/// effect's parameter at a null value of 0 has no relative error).
pub(super) fn errors_pct(
    params: &BTreeMap<String, f64>,
    truth: &(ModelParams, Effects),
) -> BTreeMap<String, f64> {
    params
        .iter()
        .filter_map(|(name, v)| {
            let id = ParamId::parse(name).ok()?;
            let t = id.get(&truth.0, &truth.1);
            (t != 0.0).then(|| (name.clone(), 100.0 * (v - t).abs() / t.abs()))
        })
        .collect()
}

/// Runs the command.
pub fn run(args: IdentifyJob, rep: &Reporter) -> AppResult {
    let with = extended::parse_with(args.with_effects.as_deref())?;
    if args.max_iterations.is_some() && !args.method.samples() {
        return Err(AppError::bad(
            "--max-iterations applies to --method mcmc and nuts only",
        ));
    }
    if let Some(c) = args.chains {
        if args.method != Method::Sa {
            return Err(AppError::bad("--chains applies to --method sa only"));
        }
        if c == 0 {
            return Err(AppError::bad("--chains: at least 1"));
        }
    }
    if let Some(session) = &args.session {
        if args.unloaded.is_some() {
            return Err(AppError::bad(
                "--session: each trial's unloaded run is named in the manifest; --unloaded \
                 applies to --trial",
            ));
        }
        return session_fit::run(&args, session, &with, rep);
    }
    if let Some(folder) = args.trial.as_deref().filter(|p| p.is_dir()) {
        if args.unloaded.is_some() {
            return Err(AppError::bad(format!(
                "{}: a CEINMS trial folder has no unloaded run (its moment comes from inverse \
                 dynamics); --unloaded does not apply",
                folder.display()
            )));
        }
        return session_fit::run(&args, folder, &with, rep);
    }
    let prep = prepare(&args, &with, rep)?;
    let out_dir = args
        .out
        .clone()
        .unwrap_or_else(|| crate::default_out("identify"));
    let input_refs: Vec<&Path> = prep.inputs.iter().map(|p| p.as_path()).collect();
    let out = OutDir::prepare_or_discard(&out_dir, &input_refs, PLANNED, args.discard_files)?;
    let show = rep.show();
    let Outcome {
        estimate,
        lines,
        prediction,
        mcmc,
    } = match args.method {
        Method::Sa => run_sa(&prep, args.seed, args.chains, rep)?,
        Method::Mcmc | Method::Nuts => {
            mcmc::run_mcmc(&prep, args.method, args.seed, args.max_iterations, rep)?
        }
    };

    let (report, point_params, adequacy_lines) = identify_report(&prep, estimate, args.seed)?;
    let text = serde_json::to_string_pretty(&report).map_err(AppError::internal)? + "\n";
    let path = out.write("identify.json", text.as_bytes())?;
    let mut files = Vec::new();
    if let Some(m) = &mcmc {
        let mut csv = Vec::new();
        m.write_chains_csv(&mut csv).map_err(AppError::internal)?;
        files.push(out.write("chains.csv", &csv)?);
    }
    // files for ArviZ and OpenSim, reported on a line of their own
    let chain_files = match &mcmc {
        Some(m) => exports::write_chains(&out, m, args.seed, &prep.loaded.name)?,
        None => Vec::new(),
    };
    let osim = exports::write_identified_osim(&out, &args.model, &point_params)?;
    files.extend(write_figures(
        &out,
        &prep,
        &report,
        &prediction,
        args.method,
        mcmc.as_ref(),
        rep,
    )?);

    rep.print_json(&text);
    if show {
        let say = |s: &str| rep.say(s);
        for l in &lines {
            say(l);
        }
        for l in super::inspect::check_lines(&report.checks) {
            say(&l);
        }
        if let Some(e) = &report.errors_pct {
            say("errors vs truth (%):");
            for m in ["sol", "gm", "gl"] {
                let get = |f: &str| e.get(&format!("{m}.{f}")).copied().unwrap_or(f64::NAN);
                say(&format!(
                    "  {m:<4} LST {:6.2}   F0 {:6.2}   α0 {:6.2}",
                    get("lst_m"),
                    get("fom_n"),
                    get("alpha_deg")
                ));
            }
            for (name, err) in e {
                if ParamId::parse(name).is_ok_and(|id| id.muscle().is_none()) {
                    say(&format!("  {name:<32} {err:6.2}"));
                }
            }
        }
        if let Some(l) = diagnose::crosstalk_summary_line(&prep.prepared.crosstalk, None) {
            say(&l);
        }
        for l in &adequacy_lines {
            say(l);
        }
        say(&format!(
            "wrote {} and {} figures/report files in {}",
            path.display(),
            files.len(),
            out_dir.display()
        ));
        if !chain_files.is_empty() {
            say(&format!(
                "wrote {} chains in CmdStan's CSV layout in {} (arviz.from_cmdstan)",
                chain_files.len(),
                out.path("chains").display()
            ));
        }
        if let Some(p) = &osim {
            say(&format!(
                "wrote {} (the model with the identified F0, LST and α0)",
                p.display()
            ));
        }
    }
    Ok(())
}

/// `identify.json` of a trial from the method's estimate: the estimate with the structure
/// test of the identified model's residual, the recording's checks and, with a truth, the
/// errors; also the identified parameters and the summary's lines on the test.
fn identify_report(
    prep: &Prepared,
    estimate: Estimate,
    seed: u64,
) -> AppResult<(IdentifyReport, ModelParams, Vec<String>)> {
    // does the identified model leave structure in its residual?
    let (point_params, point_effects) = extended::identified_point(
        prep.problem.base_params(),
        prep.problem.base_effects(),
        &estimate.params,
    )?;
    let adequacy = diagnose::adequacy(
        &prep.prepared,
        &point_params,
        &point_effects,
        prep.problem.free(),
        &extended::settings(prep.prepared.options),
    )
    .map_err(|e| e.to_string());
    let adequacy_lines = extended::adequacy_lines(&adequacy, None);
    let checks = super::inspect::trial_checks(&prep.loaded, prep.prepared.options.emg_is_envelope);
    let errors_pct = prep.truth.as_ref().map(|t| errors_pct(&estimate.params, t));
    let report = IdentifyReport {
        method: estimate.method.name(),
        params: estimate.params,
        rms_nm: estimate.rms_nm,
        rms_raw_nm: estimate.rms_raw_nm,
        evaluations: estimate.evaluations,
        wall_s: estimate.wall_s,
        sa: estimate.sa,
        mcmc: estimate.mcmc,
        with: prep.with.iter().map(|k| k.name()).collect(),
        effects: (!point_effects.enabled().is_empty()).then(|| point_effects.to_json_value()),
        adequacy: AdequacyReport::of(&adequacy),
        emg_crosstalk: prep.prepared.crosstalk.clone(),
        trial: prep.loaded.name.clone(),
        seed,
        noise: prep.noise.clone(),
        dynamometer: prep.dynamometer,
        checks,
        errors_pct,
    };
    Ok((report, point_params, adequacy_lines))
}

/// What a method estimated: the fields of `identify.json` that depend on the method.
pub(super) struct Estimate {
    pub(super) method: Method,
    pub(super) params: BTreeMap<String, f64>,
    pub(super) rms_nm: f64,
    pub(super) rms_raw_nm: f64,
    pub(super) evaluations: u64,
    pub(super) wall_s: f64,
    pub(super) sa: Option<SaChainsReport>,
    pub(super) mcmc: Option<McmcReport>,
}

/// What a method returns to the command.
struct Outcome {
    /// The method's part of `identify.json`.
    estimate: Estimate,
    /// Summary lines.
    lines: Vec<String>,
    /// Model torque at the estimate (on the corrected torque's scale).
    prediction: Vec<f64>,
    /// The MCMC result, for chains and figures.
    mcmc: Option<identify_mcmc::McmcIdentification>,
}

fn run_sa(prep: &Prepared, seed: u64, chains: Option<u32>, rep: &Reporter) -> AppResult<Outcome> {
    let mut settings = identify_sa::SaIdentifySettings::default().with_seed(seed);
    if let Some(c) = chains {
        settings = settings.with_chains(c);
    }
    let total = u64::from(settings.chains) * settings.annealer.max_evaluations;
    let progress = rep.progress(total, "SA");
    let observer = |ev: &identify_sa::IdentifyEvent| {
        progress.on_sa_event(ev);
        progress.flow()
    };
    let fit = identify_sa::identify(&prep.problem, &settings, &observer)
        .map_err(|e| AppError::bad(format!("{}: identification failed: {e}", prep.loaded.name)))?;
    progress.finish();
    if progress.stop_requested() {
        return Err(AppError::Interrupted);
    }
    let prediction = prep
        .problem
        .predict(&fit.x)
        .map_err(|e| AppError::internal(format!("simulation of the fit failed: {e}")))?;
    let rms_raw = numerics::rms_diff(prep.prepared.raw_torque(), &prediction);
    let estimate = Estimate {
        method: Method::Sa,
        params: fit.params.iter().map(|(k, v)| (k.clone(), *v)).collect(),
        rms_nm: fit.rms_nm,
        rms_raw_nm: rms_raw,
        evaluations: fit.evaluations,
        wall_s: fit.wall_s,
        sa: Some(SaChainsReport {
            chains: fit.chains.len(),
            best_chain: fit.best_chain,
            chain_costs: fit.chains.iter().map(|c| c.cost).collect(),
        }),
        mcmc: None,
    };
    let mut lines = vec![format!(
        "identify (sa): {} — {} evaluations in {:.1} s ({:.1} µs per evaluation)",
        prep.loaded.name,
        fit.evaluations,
        fit.wall_s,
        1e6 * fit.wall_s / fit.evaluations.max(1) as f64
    )];
    // the correction is named only when a dynamometer's unloaded run gave one
    lines.push(if prep.dynamometer.is_some() {
        format!(
            "  torque RMS {:.2} N·m after removing the dynamometer's cycle-locked error ({:.2} N·m against the raw torque)",
            fit.rms_nm, rms_raw
        )
    } else {
        format!("  torque RMS {:.2} N·m", fit.rms_nm)
    });
    let width = prep
        .problem
        .names()
        .iter()
        .map(|n| n.len())
        .max()
        .unwrap_or(0)
        .max(16);
    lines.push(format!(
        "  {:<width$} {:>12}    bounds",
        "parameter", "estimate"
    ));
    for (i, id) in prep.problem.free().iter().enumerate() {
        let (lo, hi) = prep.problem.bounds()[i];
        let v = fit.x[i];
        let at_bound = (v - lo).abs() <= 1e-9 * (hi - lo) || (hi - v).abs() <= 1e-9 * (hi - lo);
        lines.push(format!(
            "  {:<width$} {v:>12.5}    [{lo:.5}, {hi:.5}]{}",
            id.name(),
            if at_bound { "  at bound" } else { "" }
        ));
    }
    Ok(Outcome {
        estimate,
        lines,
        prediction,
        mcmc: None,
    })
}

/// The fit figures and `report.html` of an identification.
fn write_figures(
    out: &OutDir,
    prep: &Prepared,
    report: &IdentifyReport,
    prediction: &[f64],
    method: Method,
    mcmc: Option<&identify_mcmc::McmcIdentification>,
    rep: &Reporter,
) -> AppResult<Vec<PathBuf>> {
    let inputs = prep.problem.inputs();
    let measured = prep.problem.measured();
    let time = inputs.times();
    let angle = figures::angle_deg(inputs);
    let residual: Vec<f64> = measured
        .iter()
        .zip(prediction)
        .map(|(m, p)| m - p)
        .collect();
    let mut set = FigureSet::new(
        out,
        &format!("surae identify ({}) — {}", method.name(), prep.loaded.name),
        rep,
    );
    set.page().paragraph(format!(
        "Identification of tendon slack length (LST), maximum isometric force (F0) and \
         pennation angle (α0) of soleus, gastrocnemius medialis and lateralis{} by {}. \
         The measured torque is shown after removing the dynamometer's cycle-locked error \
         estimated from the unloaded run (when one was given).",
        if prep.with.is_empty() {
            String::new()
        } else {
            format!(
                ", with the parameters of {}",
                prep.with
                    .iter()
                    .map(|k| k.name())
                    .collect::<Vec<_>>()
                    .join(", ")
            )
        },
        match method {
            Method::Sa => "simulated annealing with a Levenberg–Marquardt polish",
            Method::Mcmc => "Metropolis–Hastings sampling",
            Method::Nuts => "No-U-Turn sampling along the exact gradient",
        }
    ));
    let nominal = ModelParams::nominal();
    let none = muscle_model::Effects::none();
    let truth = prep
        .truth
        .as_ref()
        .map(|t| extended::truth_values(prep.problem.free(), t));
    let mut rows = Vec::new();
    for (i, id) in prep.problem.free().iter().enumerate() {
        let name = id.name();
        let v = report.params.get(&name).copied().unwrap_or(f64::NAN);
        let (lo, hi) = prep.problem.bounds()[i];
        let mut row = vec![
            report::param_label(&name),
            report::format_sig(v, 5),
            report::format_sig(id.get(&nominal, &none), 5),
            format!(
                "[{}, {}]",
                report::format_sig(lo, 4),
                report::format_sig(hi, 4)
            ),
        ];
        if let Some(t) = &truth {
            row.push(report::format_sig(t[i], 5));
            row.push(
                report
                    .errors_pct
                    .as_ref()
                    .and_then(|e| e.get(&name))
                    .map_or("–".into(), |e| format!("{e:.2}")),
            );
        }
        rows.push(row);
    }
    let mut headers = vec!["parameter", "estimate", "nominal", "bounds"];
    if prep.truth.is_some() {
        headers.extend(["truth", "error (%)"]);
    }
    set.page()
        .table("Identified parameters", &headers, &rows)
        .map_err(|e| AppError::internal(e.to_string()))?;
    set.page().key_values(
        "Fit",
        &[
            ("torque RMS (N·m)", format!("{:.3}", report.rms_nm)),
            ("model evaluations", report.evaluations.to_string()),
            ("wall time (s)", format!("{:.2}", report.wall_s)),
            (
                "residual structure p",
                report
                    .adequacy
                    .structure_p()
                    .map_or("not tested".into(), |p| format!("{p:.3e}")),
            ),
        ],
    );
    if let Some(w) = report.adequacy.warning() {
        set.page().paragraph(format!("Warning: {w}."));
    }
    let env = figures::envelopes(inputs);
    set.add(
        "torque_fit",
        "Measured (corrected) and fitted torque, ankle angle and EMG envelopes",
        report::figures::torque_fit(time, measured, &[("fit", prediction)], &angle, &env),
    )?;
    set.add(
        "residual_vs_time",
        "Residual (measured − model) against time",
        report::figures::residual_vs_time(time, &[("fit", &residual)]),
    )?;
    set.add(
        "residual_vs_angle",
        "Residual against ankle angle, coloured by phase",
        report::figures::residual_vs_angle(
            &angle,
            &residual,
            &figures::phases(inputs),
            &figures::PHASE_NAMES,
        ),
    )?;
    if let Some(m) = mcmc {
        mcmc::mcmc_figures(&mut set, prep, m)?;
    }
    set.finish()
}
