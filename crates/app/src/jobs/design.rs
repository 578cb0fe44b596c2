//! `surae design`: the expected posterior sd of each identified parameter under candidate
//! protocols, from the Fisher information of the model (crate `design`, `docs/design.md`).

use crate::Reporter;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use design::{
    trial_informations, uncertainty_of, DesignNoise, DesignProtocol, DesignSettings,
    OffsetTreatment, ProtocolUncertainty,
};

use super::{load_model_config, ModelSettings};
use crate::error::{AppError, AppResult};
use crate::memory::InMemory;
use crate::output::OutDir;

/// Arguments of `surae design`.
#[derive(Debug)]
pub struct DesignJob {
    /// A candidate protocol: trials separated by commas, each `knee<deg>@<speed>` with an
    /// optional `x<cycles>` (e.g. `knee0@30,knee90@30,knee0@60`, `knee0@30x2`). Repeat the
    /// option to compare protocols.
    pub protocol: Vec<String>,
    /// An unloaded run (CSV) whose random error (AR(1) + white) replaces the synthetic
    /// dynamometer's noise.
    pub unloaded: Option<PathBuf>,
    /// The design point: a parameters JSON, an OpenSim model (`.osim`), a CEINMS subject XML or
    /// an `identify.json` (nominal parameters when omitted).
    pub params: Option<PathBuf>,
    /// With an `.osim` `--params`: the model's names of sol, gm and gl.
    pub osim_muscles: Vec<String>,
    /// Prior sd of each trial's constant torque offset left after the unloaded run's
    /// correction (N·m), integrated out; 0 treats the offset as known.
    pub offset_sd: f64,
    /// EMG realisations (synthetic EMG seeds) each trial's information is averaged over.
    pub emg_draws: usize,
    /// First EMG seed (realisation k uses seed + k).
    pub emg_seed: u64,
    /// Output folder (default `out/design`): `design.json`, `design.svg`.
    pub out: Option<PathBuf>,
    /// The unloaded run given in memory, in place of `unloaded`.
    pub unloaded_data: Option<InMemory<experiment::Unloaded>>,
    /// The design point given in memory, in place of `params`.
    pub params_data: Option<InMemory<serde_json::Value>>,
    /// Write no files: the result reaches the caller as [`crate::JobObserver::result_json`].
    pub discard_files: bool,
}

/// Runs the command.
/// The candidate protocols, with the numeric options checked.
fn checked_protocols(args: &DesignJob) -> AppResult<Vec<DesignProtocol>> {
    let protocols = args
        .protocol
        .iter()
        .map(|p| {
            p.parse::<DesignProtocol>()
                .map_err(|e| AppError::bad(format!("--{e}")))
        })
        .collect::<AppResult<Vec<_>>>()?;
    if !(args.offset_sd.is_finite() && args.offset_sd >= 0.0) {
        return Err(AppError::bad(format!(
            "--offset-sd {}: must be finite and ≥ 0",
            args.offset_sd
        )));
    }
    if !(1..=1000).contains(&args.emg_draws) {
        return Err(AppError::bad(format!(
            "--emg-draws {}: must be 1 to 1000",
            args.emg_draws
        )));
    }
    Ok(protocols)
}

/// What the design point is called: the parameters' label or file, or `nominal`.
fn params_name(args: &DesignJob) -> String {
    match (&args.params_data, &args.params) {
        (Some(d), _) => d.label.clone(),
        (None, Some(p)) => p.display().to_string(),
        (None, None) => "nominal".to_string(),
    }
}

/// The design point's parameters (fixed muscles left out: the synthetic trials have EMG for
/// the triceps only) and the files read for them.
fn design_point(
    args: &DesignJob,
    rep: &Reporter,
) -> AppResult<(muscle_model::ModelParams, Vec<PathBuf>)> {
    let model = ModelSettings {
        params: args.params.clone(),
        params_data: args.params_data.clone(),
        osim_muscles: args.osim_muscles.clone(),
        ..ModelSettings::default()
    };
    let (mut params, _, read) = load_model_config(&model)?;
    if !params.fixed.is_empty() {
        let names: Vec<&str> = params.fixed.iter().map(|f| f.name).collect();
        rep.warn(format!(
            "{}: the fixed muscles {} are left out (the design's synthetic trials have EMG for \
             sol, gm and gl only)",
            params_name(args),
            names.join(", ")
        ));
        params.fixed = Default::default();
    }
    Ok((params, read))
}

/// The dynamometer noise the design assumes, and where it comes from: the unloaded run's
/// random part, or the synthetic dynamometer's.
fn design_noise(args: &DesignJob, rep: &Reporter) -> AppResult<(DesignNoise, String)> {
    Ok(match (&args.unloaded_data, &args.unloaded) {
        (Some(d), _) => {
            d.value.validate(&d.label).map_err(AppError::bad)?;
            (noise_of_run(&d.value, &d.label)?, d.label.clone())
        }
        (None, Some(p)) => {
            let u = super::read_unloaded_any(p, rep)?;
            let name = p.display().to_string();
            (noise_of_run(&u, &name)?, name)
        }
        (None, None) => (DesignNoise::synthetic(), "synthetic".to_string()),
    })
}

pub fn run(args: DesignJob, rep: &Reporter) -> AppResult {
    let protocols = checked_protocols(&args)?;
    let (params, read) = design_point(&args, rep)?;
    let (noise, noise_source) = design_noise(&args, rep)?;
    let offset = if args.offset_sd > 0.0 {
        OffsetTreatment::Prior {
            sd_nm: args.offset_sd,
        }
    } else {
        OffsetTreatment::Known
    };
    let settings = DesignSettings {
        offset,
        emg_seed: args.emg_seed,
        emg_draws: args.emg_draws,
        ..DesignSettings::default()
    };

    let out_dir = args
        .out
        .clone()
        .unwrap_or_else(|| crate::default_out("design"));
    let mut inputs: Vec<&Path> = read.iter().map(PathBuf::as_path).collect();
    inputs.extend(args.unloaded.as_deref());
    let out = OutDir::prepare_or_discard(
        &out_dir,
        &inputs,
        &["design.json", "design.svg"],
        args.discard_files,
    )?;

    let distinct: std::collections::BTreeSet<String> = protocols
        .iter()
        .flat_map(DesignProtocol::trial_names)
        .collect();
    if rep.show() {
        rep.note(&format!(
            "design: {} protocol(s), {} distinct trial(s) × {} EMG realisation(s) …",
            protocols.len(),
            distinct.len(),
            args.emg_draws
        ));
    }
    let infos = trial_informations(&protocols, &params, &noise, &settings)
        .map_err(|e| AppError::bad(format!("design: {e}")))?;
    let mut rows = Vec::with_capacity(protocols.len());
    let mut known = Vec::with_capacity(protocols.len());
    for p in &protocols {
        let u = uncertainty_of(p, &infos, &params, offset)
            .map_err(|e| AppError::bad(format!("design: {e}")))?;
        let k = uncertainty_of(p, &infos, &params, OffsetTreatment::Known)
            .map_err(|e| AppError::bad(format!("design: {e}")))?;
        rows.push(u);
        known.push(k);
    }

    let doc = DesignReport {
        protocols: rows
            .iter()
            .zip(&known)
            .map(|(u, k)| ProtocolReport::of(u, k))
            .collect(),
        noise: DesignNoiseReport {
            source: noise_source.clone(),
            ar1_sd_nm: noise.ar1_sd_nm,
            ar1_corr_time_s: noise.ar1_corr_time_s,
            white_sd_nm: noise.white_sd_nm,
        },
        params: params_name(&args),
        offset_prior_sd_nm: args.offset_sd,
        emg: EmgDrawsReport {
            first_seed: args.emg_seed,
            draws: args.emg_draws,
        },
        jacobian: JacobianStepReport {
            rel_step: settings.jacobian.rel_step,
            rtol: settings.jacobian.sim.rtol,
        },
    };
    let text = serde_json::to_string_pretty(&doc).map_err(AppError::internal)? + "\n";
    let json_path = out.write("design.json", text.as_bytes())?;

    let names: Vec<String> = rows[0]
        .params
        .iter()
        .map(|q| short_label(&q.name))
        .collect();
    write_design_figure(&out, &rows, &names, rep)?;

    rep.print_json(&text);
    rep.say(&format!(
        "design: expected posterior sd, % of the value at the design point ({}; noise {}: AR(1) \
         {:.2} N·m, {:.3} s, white {:.2} N·m; offset prior sd {} N·m)",
        params_name(&args),
        noise_source,
        noise.ar1_sd_nm,
        noise.ar1_corr_time_s,
        noise.white_sd_nm,
        args.offset_sd
    ));
    for line in table(&rows, &names) {
        rep.say(&line);
    }
    rep.say(&format!(
        "  (* = not identifiable: sd with the bounds' prior above half the prior sd)\n  wrote {}",
        json_path.display()
    ));
    Ok(())
}

/// `design.svg`: each protocol's expected sd of every parameter (`names`), beside the prior's.
fn write_design_figure(
    out: &OutDir,
    rows: &[ProtocolUncertainty],
    names: &[String],
    rep: &Reporter,
) -> AppResult {
    let name_refs: Vec<&str> = names.iter().map(String::as_str).collect();
    let sds: Vec<Vec<f64>> = rows
        .iter()
        .map(|u| u.params.iter().map(|q| q.sd_pct).collect())
        .collect();
    let prior: Vec<f64> = rows[0].params.iter().map(|q| q.prior_sd_pct).collect();
    let series: Vec<report::figures::DesignSeries<'_>> = rows
        .iter()
        .zip(&sds)
        .map(|(u, s)| report::figures::DesignSeries {
            label: &u.protocol,
            sd_pct: s,
        })
        .collect();
    match report::figures::design_sds(&name_refs, &series, &prior) {
        Ok(svg) => {
            out.write("design.svg", svg.as_bytes())?;
        }
        Err(e) => rep.warn(format!("figure design not drawn: {e}")),
    }
    Ok(())
}

/// The random part of an unloaded run's dynamometer correction (`name` names the run in
/// errors).
fn noise_of_run(u: &experiment::Unloaded, name: &str) -> AppResult<DesignNoise> {
    let c = experiment::DynamometerCorrection::from_unloaded(u)
        .map_err(|e| AppError::bad(format!("{name}: {e}")))?;
    DesignNoise::from_correction(&c).map_err(|e| AppError::bad(format!("{name}: {e}")))
}

/// `design.json`: each candidate protocol's expected posterior sd of every parameter, and what
/// the expectation assumed.
#[derive(Debug, Clone, serde::Serialize)]
#[non_exhaustive]
pub struct DesignReport {
    /// The candidate protocols, in the order given.
    pub protocols: Vec<ProtocolReport>,
    /// The torque noise assumed.
    pub noise: DesignNoiseReport,
    /// The design point: `nominal` or the parameters file.
    pub params: String,
    /// Prior sd of each trial's torque offset (N·m).
    pub offset_prior_sd_nm: f64,
    /// The synthetic EMG realisations averaged over.
    pub emg: EmgDrawsReport,
    /// The Jacobian's finite-difference step and integration tolerance.
    pub jacobian: JacobianStepReport,
}

/// One protocol's expected uncertainty, by parameter name.
#[derive(Debug, Clone, serde::Serialize)]
#[non_exhaustive]
pub struct ProtocolReport {
    /// The protocol as given.
    pub protocol: String,
    /// Its trials.
    pub trials: Vec<String>,
    /// Expected posterior sd (% of the value), offsets integrated out.
    pub sd_pct: BTreeMap<String, f64>,
    /// The same with the parameters' priors.
    pub sd_pct_with_prior: BTreeMap<String, f64>,
    /// The priors' sd (% of the value).
    pub prior_sd_pct: BTreeMap<String, f64>,
    /// Whether the data would identify each parameter.
    pub identifiable: BTreeMap<String, bool>,
    /// Expected posterior sd with the offsets known.
    pub sd_pct_offset_known: BTreeMap<String, f64>,
}

impl ProtocolReport {
    fn of(u: &ProtocolUncertainty, known: &ProtocolUncertainty) -> Self {
        fn by_name<T>(
            u: &ProtocolUncertainty,
            f: impl Fn(&design::ParamUncertainty) -> T,
        ) -> BTreeMap<String, T> {
            u.params.iter().map(|q| (q.name.clone(), f(q))).collect()
        }
        Self {
            protocol: u.protocol.clone(),
            trials: u.trials.clone(),
            sd_pct: by_name(u, |q| q.sd_pct),
            sd_pct_with_prior: by_name(u, |q| q.sd_pct_with_prior),
            prior_sd_pct: by_name(u, |q| q.prior_sd_pct),
            identifiable: by_name(u, |q| q.identifiable),
            sd_pct_offset_known: by_name(known, |q| q.sd_pct),
        }
    }
}

/// The torque noise a design assumed.
#[derive(Debug, Clone, serde::Serialize)]
#[non_exhaustive]
pub struct DesignNoiseReport {
    /// `synthetic dynamometer` or the unloaded run.
    pub source: String,
    /// AR(1) part's sd (N·m).
    pub ar1_sd_nm: f64,
    /// AR(1) part's correlation time (s).
    pub ar1_corr_time_s: f64,
    /// White part's sd (N·m).
    pub white_sd_nm: f64,
}

/// The synthetic EMG realisations a design averaged over.
#[derive(Debug, Clone, Copy, serde::Serialize)]
#[non_exhaustive]
pub struct EmgDrawsReport {
    /// The first seed.
    pub first_seed: u64,
    /// How many.
    pub draws: usize,
}

/// The Jacobian's settings in a design.
#[derive(Debug, Clone, Copy, serde::Serialize)]
#[non_exhaustive]
pub struct JacobianStepReport {
    /// Relative finite-difference step.
    pub rel_step: f64,
    /// Relative integration tolerance.
    pub rtol: f64,
}

/// `sol LST`, `gm F0`, `gl α0`.
fn short_label(name: &str) -> String {
    let (m, f) = name.split_once('.').unwrap_or(("", name));
    let sym = match f {
        "lst_m" => "LST",
        "fom_n" => "F0",
        "alpha_deg" => "α0",
        other => other,
    };
    format!("{m} {sym}")
}

/// Two or three significant digits, as the sds are read.
fn cell(x: f64) -> String {
    if x >= 100.0 {
        format!("{x:.0}")
    } else if x >= 10.0 {
        format!("{x:.1}")
    } else {
        format!("{x:.2}")
    }
}

fn table(rows: &[ProtocolUncertainty], names: &[String]) -> Vec<String> {
    let w0 = rows
        .iter()
        .map(|u| u.protocol.chars().count())
        .max()
        .unwrap_or(8)
        .max(8);
    let mut out = Vec::new();
    let mut head = format!("  {:<w0$}", "protocol");
    for n in names {
        head.push_str(&format!(" {n:>8}"));
    }
    out.push(head);
    for u in rows {
        let mut line = format!("  {:<w0$}", u.protocol);
        for q in &u.params {
            let mark = if q.identifiable { " " } else { "*" };
            line.push_str(&format!(" {:>7}{mark}", cell(q.sd_pct)));
        }
        out.push(line);
    }
    if let Some(u) = rows.first() {
        let mut line = format!("  {:<w0$}", "prior sd");
        for q in &u.params {
            line.push_str(&format!(" {:>7} ", cell(q.prior_sd_pct)));
        }
        out.push(line);
    }
    out
}
