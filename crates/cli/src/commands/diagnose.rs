//! `surae diagnose`: what the baseline model gets wrong, which catalogued
//! effect explains it, and what the extension buys out of sample; with `--session`, the
//! session's trials jointly and every trial on its own (`session_run`).

use super::{load_trial, load_unloaded, trial_inputs, ModelArgs};
use crate::error::{CmdResult, Failure};
use crate::figures::{self, FigureSet};
use crate::output::OutDir;
use crate::progress::ProgressDisplay;
use diagnose::{DiagnoseSettings, Diagnosis};
use std::ops::Range;
use std::path::{Path, PathBuf};

mod session_run;

/// Files `surae diagnose` writes.
const PLANNED: &[&str] = &[
    "diagnosis.json",
    "torque_fit.svg",
    "residual_vs_angle.svg",
    "residual_vs_time.svg",
    "fit_comparison.svg",
    "candidates.svg",
    "report.html",
];

/// Arguments of `surae diagnose`.
#[derive(clap::Args, Debug)]
pub struct DiagnoseArgs {
    /// Trial: a trial CSV, a recording map (`.json`) of a lab's files, or a CEINMS trial folder (a session of one) (docs/formats.md);
    /// the bundled seed trial (and its unloaded run) when omitted.
    #[arg(long, conflicts_with = "session")]
    pub trial: Option<PathBuf>,
    /// Unloaded run CSV: its cycle-locked error is removed from the measured
    /// torque and its noise sets the likelihood. Strongly recommended.
    #[arg(long, conflicts_with = "session")]
    pub unloaded: Option<PathBuf>,
    /// Session manifest (docs/formats.md): the trials diagnosed jointly (shared muscle
    /// parameters and subject effects, per-trial offset and gravity, held-out gain by leaving
    /// one trial out) into `DIR/diagnosis_session.json`, and every trial on its own with the
    /// session's parameters into `--out DIR/<trial>/`.
    #[arg(long)]
    pub session: Option<PathBuf>,
    /// With `--session`: parameters replacing the session's (parameters JSON, `.osim`, CEINMS
    /// subject XML), or an `identify.json` whose identified values are set over them.
    #[arg(long, requires = "session")]
    pub params: Option<PathBuf>,
    /// Seed (the diagnosis itself is deterministic; kept for scripts that pass one).
    #[arg(long, default_value_t = 42)]
    pub seed: u64,
    /// The EMG columns are already normalised envelopes in [0, 1].
    #[arg(long)]
    pub emg_is_envelope: bool,
    #[command(flatten)]
    pub knee: super::KneeArgs,
    /// Output folder (default `out/diagnose`).
    #[arg(long)]
    pub out: Option<PathBuf>,
    #[command(flatten)]
    pub report: super::ReportArgs,
}

/// Runs the command.
pub fn run(args: DiagnoseArgs) -> CmdResult {
    if let Some(session) = &args.session {
        if args.knee.knee_angle_deg.is_some() {
            return Err(Failure::bad(
                "--knee-angle-deg: with --session, each trial's knee angle is in the manifest",
            ));
        }
        return session_run::run(&args, session);
    }
    if let Some(folder) = args.trial.as_deref().filter(|p| p.is_dir()) {
        if args.unloaded.is_some() || args.knee.knee_angle_deg.is_some() {
            return Err(Failure::bad(format!(
                "{}: a CEINMS trial folder has no unloaded run or knee angle (its lengths and \
                 moment arms hold the knee's); --unloaded and --knee-angle-deg do not apply",
                folder.display()
            )));
        }
        return session_run::run(&args, folder);
    }
    let loaded = load_trial(args.trial.as_deref())?;
    let unloaded = load_unloaded(args.unloaded.as_deref(), args.trial.is_some())?;
    if let Some((u, name)) = &unloaded {
        super::check_unloaded(&loaded.trial, &loaded.name, u, name)?;
    }
    let emg_is_envelope = args.emg_is_envelope || loaded.emg_is_envelope;
    let model_args = ModelArgs {
        emg_is_envelope,
        knee: args.knee,
        ..ModelArgs::default()
    };
    // validates the inputs with messages that name the file
    let inputs = trial_inputs(&loaded, &model_args)?;
    let mut inputs_read: Vec<&Path> = loaded.path.iter().map(|p| p.as_path()).collect();
    inputs_read.extend(loaded.data_files.iter().map(|p| p.as_path()));
    if let Some(p) = &args.unloaded {
        inputs_read.push(p.as_path());
    }
    let out_dir = args
        .out
        .clone()
        .unwrap_or_else(|| crate::default_out("diagnose"));
    let out = OutDir::prepare(&out_dir, &inputs_read, PLANNED)?;

    let settings = DiagnoseSettings {
        input_options: args.knee.input_options(emg_is_envelope),
        ..DiagnoseSettings::default()
    };
    let show = args.report.show();
    let progress = ProgressDisplay::new(show, 0, "diag");
    let mut observer = |p: &diagnose::DiagnosisProgress| {
        progress.message(format!("{} ({} simulations)", p.message, p.evaluations));
        progress.flow()
    };
    let d = diagnose::run(
        &loaded.trial,
        unloaded.as_ref().map(|(u, _)| u),
        &settings,
        &mut observer,
    )
    .map_err(|e| {
        if progress.stop_requested() {
            return Failure::Interrupted;
        }
        let names = match &unloaded {
            Some((_, n)) => format!("{} / {n}", loaded.name),
            None => loaded.name.clone(),
        };
        Failure::bad(format!("{names}: {e}"))
    })?;
    progress.finish();

    // the correction subtracted, in the same form `identify` reports it; its AR(1)
    // correlation time is per sample of the recording the noise was fitted on
    let fitted_on = match &unloaded {
        Some((u, _)) => u.sample_rate_hz(),
        None => loaded.trial.sample_rate_hz(),
    };
    let unloaded_name = unloaded.as_ref().map(|(_, n)| n.as_str());
    let checks = super::inspect::trial_checks(&loaded);
    let text = diagnosis_json(
        &d,
        &loaded.name,
        unloaded_name,
        fitted_on,
        None,
        Some(&checks),
    )?;
    let path = out.write("diagnosis.json", text.as_bytes())?;
    let files = write_figures(
        &out,
        &loaded.name,
        &loaded.trial.torque_nm,
        &inputs,
        &d,
        0..inputs.len(),
    )?;

    args.report.print_json(&text);
    if show {
        let say = |s: &str| args.report.say(s);
        say(&format!("diagnose: {}", loaded.name));
        if unloaded.is_none() {
            say("  (no unloaded run: the dynamometer's own error cannot be told from a torque offset)");
        }
        for l in d.summary_lines() {
            say(&l);
        }
        for l in super::inspect::check_lines(&checks) {
            say(&l);
        }
        say(&format!(
            "wrote {} and {} figure/report files in {}",
            path.display(),
            files.len(),
            out_dir.display()
        ));
    }
    Ok(())
}

/// `diagnosis.json`: the diagnosis with the trial's name, its unloaded run's (or `null`), the
/// dynamometer correction subtracted (its AR(1) correlation time per sample of a recording
/// at `fitted_on_hz`), for a session's trial where it was read from, and the recording checks.
fn diagnosis_json(
    d: &Diagnosis,
    name: &str,
    unloaded: Option<&str>,
    fitted_on_hz: f64,
    source: Option<&str>,
    checks: Option<&recording::checks::TrialChecks>,
) -> CmdResult<String> {
    let mut doc = d.to_json_value();
    if let Some(obj) = doc.as_object_mut() {
        if let Some(c) = checks {
            obj.insert("checks".into(), serde_json::json!(c));
        }
        obj.insert("trial".into(), serde_json::json!(name));
        if let Some(src) = source {
            obj.insert("source".into(), serde_json::json!(src));
        }
        obj.insert("unloaded".into(), serde_json::json!(unloaded));
        obj.insert(
            "dynamometer".into(),
            serde_json::json!(d.noise.dynamometer(1.0 / fitted_on_hz)),
        );
    }
    Ok(serde_json::to_string_pretty(&doc).map_err(Failure::internal)? + "\n")
}

/// The figures and `report.html` of a diagnosis, drawn over the samples `span` (the compared
/// samples of a recording whose torque starts after its EMG). The residual against the angle
/// is left out for a recording without a joint angle.
fn write_figures(
    out: &OutDir,
    name: &str,
    measured_all: &[f64],
    inputs: &muscle_model::TrialInputs,
    d: &Diagnosis,
    span: Range<usize>,
) -> CmdResult<Vec<PathBuf>> {
    let s = &d.residual_analysis.series;
    let time = &s.time_s[span.clone()];
    let measured = &measured_all[span.clone()];
    let baseline_residual = &s.baseline_residual_nm[span.clone()];
    let extended_residual = &s.extended_residual_nm[span.clone()];
    // predictions of the measured torque: measured − residual (model + the
    // dynamometer's cycle-locked error)
    let baseline: Vec<f64> = measured
        .iter()
        .zip(baseline_residual)
        .map(|(m, r)| m - r)
        .collect();
    let extended: Vec<f64> = measured
        .iter()
        .zip(extended_residual)
        .map(|(m, r)| m - r)
        .collect();
    let mut set = FigureSet::new(out, &format!("surae diagnose — {name}"));
    let causes: Vec<&str> = d.causes.iter().map(|c| c.as_str()).collect();
    let mut effect_labels: Vec<(String, f64)> = Vec::new();
    if let Some(effects) = &d.extended.effects {
        for (effect, params) in effects {
            for (p, v) in params {
                effect_labels.push((format!("{effect}: {p}"), *v));
            }
        }
    }
    let effect_values: Vec<(&str, f64)> = effect_labels
        .iter()
        .map(|(l, v)| (l.as_str(), *v))
        .collect();
    let ties: Vec<(&str, &str)> = d
        .near_ties
        .iter()
        .map(|t| (t.cause.as_str(), t.alternative.as_str()))
        .collect();
    let story = report::diagnosis_in_words(&report::DiagnosisSummary {
        adequate: d.causes.is_empty() && !d.unexplained_structure,
        causes: &causes,
        unexplained_structure: d.unexplained_structure,
        baseline_rms_nm: d.baseline.rms_nm,
        baseline_heldout_rms_nm: d.baseline.heldout_rms_nm,
        extended_heldout_rms_nm: (!d.causes.is_empty()).then_some(d.extended.heldout_rms_nm),
        heldout_rms_reduction_pct: d.gain.heldout_rms_reduction_pct,
        delta_bic: -d.gain.delta_bic,
        effect_values: &effect_values,
        near_ties: &ties,
    });
    for p in story {
        set.page().paragraph(p);
    }
    if !d.not_testable.is_empty() {
        let names: Vec<&str> = d.not_testable.iter().map(|t| t.effect.as_str()).collect();
        set.page().paragraph(format!(
            "Not tested: {} ({}).",
            names.join(", "),
            d.not_testable[0].reason
        ));
    }
    set.page().preformatted(d.summary_lines().join("\n"));
    let rows: Vec<Vec<String>> = d
        .candidates
        .iter()
        .map(|c| {
            vec![
                c.effect.clone(),
                format!("{:.1}", c.evidence),
                c.heldout_rms_nm.map_or("–".into(), |v| format!("{v:.3}")),
                c.delta_bic.map_or("–".into(), |v| format!("{v:.1}")),
                c.detection_limit_text().unwrap_or_else(|| "–".into()),
                if c.accepted {
                    "named".into()
                } else if let Some(t) = d.near_ties.iter().find(|t| t.alternative == c.effect) {
                    format!("near tie with {}", t.cause)
                } else if c.confounded {
                    "confounded".into()
                } else {
                    String::new()
                },
            ]
        })
        .collect();
    set.page()
        .table(
            "Candidate effects (score-test evidence, refit held-out RMS and ΔBIC) and, for \
             those not named, the size this trial would reveal in 95 % of such trials: a \
             smaller effect could be present and missed",
            &[
                "effect",
                "evidence",
                "held-out RMS (N·m)",
                "ΔBIC",
                "could be missed below",
                "",
            ],
            &rows,
        )
        .map_err(|e| Failure::internal(e.to_string()))?;

    set.page()
        .table(
            "Parameters of the final model with their 68 % profile-likelihood intervals \
             (\"bound\": the interval reaches the parameter's bound) and, for comparison, the \
             Laplace standard error at the fit",
            &["parameter", "value", "68 % interval", "Laplace SE"],
            &parameter_rows(&d.extended),
        )
        .map_err(|e| Failure::internal(e.to_string()))?;

    let angle = &s.angle_deg[span.clone()];
    let env: Vec<(&str, &[f64])> = figures::envelopes(inputs)
        .into_iter()
        .map(|(m, e)| (m, &e[span.clone()]))
        .collect();
    let phase_names: Vec<&str> = diagnose::segment::PhaseLabel::ALL
        .iter()
        .map(|p| p.name())
        .collect();
    let phase: Vec<usize> = s.phase[span.clone()]
        .iter()
        .map(|p| {
            diagnose::segment::PhaseLabel::ALL
                .iter()
                .position(|q| q == p)
                .unwrap_or(0)
        })
        .collect();
    set.add(
        "torque_fit",
        "Measured torque with the baseline and extended models, ankle angle and EMG envelopes",
        report::figures::torque_fit(
            time,
            measured,
            &[("baseline", &baseline), ("extended", &extended)],
            angle,
            &env,
        ),
    )?;
    if d.not_testable.is_empty() {
        set.add(
            "residual_vs_angle",
            "Baseline residual against ankle angle, coloured by phase",
            report::figures::residual_vs_angle(angle, baseline_residual, &phase, &phase_names),
        )?;
    }
    set.add(
        "residual_vs_time",
        "Residual of the baseline and the extended model against time",
        report::figures::residual_vs_time(
            time,
            &[
                ("baseline", baseline_residual),
                ("extended", extended_residual),
            ],
        ),
    )?;
    set.add(
        "fit_comparison",
        "Baseline against extended fit",
        report::figures::fit_comparison(time, measured, &baseline, &extended),
    )?;
    let candidates: Vec<report::figures::Candidate<'_>> = d
        .candidates
        .iter()
        .map(|c| report::figures::Candidate {
            name: &c.effect,
            evidence: c.evidence,
            heldout_rms_nm: c.heldout_rms_nm,
            selected: c.accepted,
        })
        .collect();
    set.add(
        "candidates",
        "Candidate effects ranked by evidence (named causes highlighted)",
        report::figures::candidate_ranking(&candidates, Some(d.baseline.heldout_rms_nm)),
    )?;
    set.finish()
}

/// One row per parameter of `m` (muscle parameters, then effect parameters as
/// `effect.parameter`): value, 68 % profile interval, Laplace standard error.
fn parameter_rows(m: &diagnose::ModelReport) -> Vec<Vec<String>> {
    let row = |name: String, v: f64, iv: Option<&diagnose::ParamInterval>| {
        let end = |x: f64, b: bool| {
            if b {
                format!("{x:.4} (bound)")
            } else {
                format!("{x:.4}")
            }
        };
        vec![
            name,
            format!("{v:.4}"),
            iv.map_or("–".into(), |iv| {
                format!(
                    "{} … {}",
                    end(iv.lower, iv.lower_at_bound),
                    end(iv.upper, iv.upper_at_bound)
                )
            }),
            iv.map_or("–".into(), |iv| format!("{:.4}", iv.laplace_se)),
        ]
    };
    let mut rows: Vec<Vec<String>> = m
        .params
        .iter()
        .map(|(k, v)| {
            row(
                k.clone(),
                *v,
                m.param_interval.as_ref().and_then(|i| i.get(k)),
            )
        })
        .collect();
    for (effect, vals) in m.effects.iter().flatten() {
        for (p, v) in vals {
            let iv = m
                .effect_interval
                .as_ref()
                .and_then(|i| i.get(effect))
                .and_then(|i| i.get(p));
            rows.push(row(format!("{effect}.{p}"), *v, iv));
        }
    }
    rows
}
