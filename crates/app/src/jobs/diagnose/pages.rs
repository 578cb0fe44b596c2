//! The pages of a diagnosis: its figures, and the sections of `report.html` (the crosstalk
//! correction, what lies beyond the catalogue, the parameter tables).

use super::{Closing, PLANNED};
use crate::error::{AppError, AppResult};
use crate::figures::{self, FigureSet};
use crate::output::OutDir;
use crate::Reporter;
use diagnose::Diagnosis;
use std::ops::Range;
use std::path::PathBuf;

/// The report's text: the diagnosis in words, what could not be tested, the summary, the
/// candidates and the final model's parameters.
fn diagnosis_pages(set: &mut FigureSet<'_>, d: &Diagnosis) -> AppResult {
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
        .map_err(|e| AppError::internal(e.to_string()))?;

    set.page()
        .table(
            "Parameters of the final model with their 68 % profile-likelihood intervals \
             (\"bound\": the interval reaches the parameter's bound) and, for comparison, the \
             Laplace standard error at the fit",
            &["parameter", "value", "68 % interval", "Laplace SE"],
            &parameter_rows(&d.extended),
        )
        .map_err(|e| AppError::internal(e.to_string()))?;
    Ok(())
}

/// The figures and `report.html` of a diagnosis, drawn over the samples `span` (the compared
/// samples of a recording whose torque starts after its EMG). The residual against the angle
/// is left out for a recording without a joint angle; the flexible terms are drawn when the
/// diagnosis has them. The report ends with `closing`. A figure of [`PLANNED`] this run did
/// not draw is removed from `out`.
// every figure of the report draws from its own series
#[allow(clippy::too_many_arguments)]
pub(super) fn write_figures(
    out: &OutDir,
    name: &str,
    measured_all: &[f64],
    inputs: &muscle_model::TrialInputs,
    d: &Diagnosis,
    span: Range<usize>,
    closing: &Closing,
    rep: &Reporter,
) -> AppResult<Vec<PathBuf>> {
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
    let mut set = FigureSet::new(out, &format!("surae diagnose — {name}"), rep);
    diagnosis_pages(&mut set, d)?;
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
    emg_crosstalk(set.page(), d);
    if let Some(u) = &d.unexplained {
        beyond_the_catalogue(&mut set, d, u)?;
    }
    closing.add_to(set.page());
    let written = set.finish()?;
    remove_stale(out, &written)?;
    Ok(written)
}

/// Removes the figures of [`PLANNED`] that are in `out` but were not written on this run
/// (left by an earlier run). `OutDir::prepare` refused a run with an input under one of
/// these names, so no input is removed.
fn remove_stale(out: &OutDir, written: &[PathBuf]) -> AppResult {
    if out.discards() {
        return Ok(());
    }
    for name in PLANNED.iter().filter(|n| n.ends_with(".svg")) {
        let p = out.path(name);
        if !written.contains(&p) && p.is_file() {
            std::fs::remove_file(&p).map_err(|e| {
                AppError::bad(format!(
                    "{}: cannot remove the figure of an earlier run: {e}",
                    p.display()
                ))
            })?;
        }
    }
    Ok(())
}

/// The report's section on the raw-EMG crosstalk test (nothing without a TA channel).
fn emg_crosstalk(page: &mut report::Report, d: &Diagnosis) {
    if d.emg_crosstalk.is_empty() {
        return;
    }
    let fixed: Vec<String> = d
        .emg_crosstalk
        .iter()
        .filter(|c| c.corrected)
        .map(|c| {
            format!(
                "{} carried {:.3} ± {:.3} of the TA's raw signal (z = {:.1})",
                c.channel, c.fraction, c.fraction_se, c.z
            )
        })
        .collect();
    if fixed.is_empty() {
        let z = d
            .emg_crosstalk
            .iter()
            .map(|c| c.z.abs())
            .fold(0.0, f64::max);
        let p = 10f64.powf(-diagnose::DiagnoseSettings::default().crosstalk_threshold);
        page.paragraph(format!(
            "The raw EMG shows no crosstalk from the tibialis anterior into the triceps \
             channels (largest |z| {z:.1}; a channel is corrected when p < {p:.0e})."
        ));
        return;
    }
    page.heading("EMG crosstalk");
    let worth = d.emg_correction.as_ref().map_or(String::new(), |c| {
        format!(
            " Fitted on the uncorrected envelopes, the final model's held-out RMS is {:.3} N·m; \
             on the corrected ones {:.3} N·m (−{:.1} %, held-out deviance −{:.1}).",
            c.heldout_rms_uncorrected_nm,
            c.heldout_rms_nm,
            c.heldout_rms_reduction_pct,
            c.heldout_deviance_gain
        )
    });
    page.paragraph(format!(
        "In the raw EMG, {}. Two muscles' carriers are independent, so this share is \
         crosstalk, not co-contraction; it was subtracted from the raw signal before the \
         envelopes were made, and every fit in this report used the corrected envelopes.{worth} \
         `surae identify --trial` applies the same correction before identifying.",
        fixed.join("; ")
    ));
}

/// The report's section on structure no catalogued effect explains: what it depends on (the
/// ranking of the state variables by held-out deviance gain), the causes a flexible term
/// replaced, a catalogued shape that explains it after all, and the flexible terms' shapes.
fn beyond_the_catalogue(
    set: &mut FigureSet<'_>,
    d: &Diagnosis,
    u: &diagnose::Unexplained,
) -> AppResult {
    let page = set.page();
    page.heading("Beyond the catalogue");
    let named: Vec<String> = u
        .told_variables()
        .iter()
        .map(|(v, split)| {
            let words = format!(
                "{}{}",
                v.name(),
                if *split {
                    ", differently in each direction of motion"
                } else {
                    ""
                }
            );
            match u.ranking.iter().find(|r| r.variable == *v) {
                Some(r) => format!(
                    "{words} (held-out deviance gain {:.1})",
                    r.heldout_deviance_gain
                ),
                None => words,
            }
        })
        .collect();
    match (&u.extension, named.is_empty()) {
        (Some(e), false) => {
            let fall = e.heldout_rms_reduction_pct;
            let signed = |x: f64| numerics::text::signed(x, 1);
            page.paragraph(format!(
                "The structure left in the residual depends on {}: a flexible term in {} \
                 {} the held-out RMS from {:.3} to {:.3} N·m ({} %, held-out deviance {}, \
                 ΔBIC {:.1}).",
                named.join(", then "),
                if named.len() == 1 { "it" } else { "each" },
                if fall >= 0.0 { "lowers" } else { "raises" },
                d.extended.heldout_rms_nm,
                e.heldout_rms_nm,
                signed(-fall),
                signed(-e.heldout_deviance_gain),
                e.delta_bic
            ));
        }
        // a crosstalk correction alone: its own section said what the structure depends on
        _ if u.ranking.is_empty() && d.emg_correction.is_some() => {}
        _ => {
            let best = u.ranking.first().map_or(String::new(), |r| {
                format!(
                    " The best, {}, gains {:.1} in held-out deviance: too little to tell.",
                    r.variable.name(),
                    r.heldout_deviance_gain
                )
            });
            page.paragraph(format!(
                "No state variable (angle, velocity, direction, acceleration, time, activation, \
                 activation_ta) explains the structure left in the residual.{best}"
            ));
        }
    }
    if !u.ranking.is_empty() {
        let rows: Vec<Vec<String>> = u
            .ranking
            .iter()
            .map(|r| {
                vec![
                    r.variable.name().to_string(),
                    format!("{:.1}", r.heldout_deviance_gain),
                    format!("{:.3}", r.heldout_rms_nm),
                    format!("{:.1}", r.heldout_rms_reduction_pct),
                    format!("{:.1}", r.delta_bic),
                    r.parameters.to_string(),
                ]
            })
            .collect();
        page.table(
            "A flexible term in each state variable added to the final model and \
             cross-validated on 0.5 s blocks, best held-out gain first: the fall of the \
             held-out deviance, the held-out RMS with the term and its fall against the final \
             model's, its ΔBIC and its coefficients",
            &[
                "variable",
                "held-out deviance gain",
                "held-out RMS (N·m)",
                "RMS fall (%)",
                "ΔBIC",
                "parameters",
            ],
            &rows,
        )
        .map_err(|e| AppError::internal(e.to_string()))?;
    }
    for r in &u.replaced {
        page.paragraph(format!("Not named: {}.", r.reason()));
    }
    if let Some(k) = &u.catalogued_shape {
        page.paragraph(format!(
            "The structure has the shape of {k} after all: that effect's term, added to the \
             final model, explains it as well as the flexible term in the best variable."
        ));
    }
    let Some(e) = &u.extension else {
        return Ok(());
    };
    for t in &e.terms {
        for v in &t.searched {
            page.paragraph(match v.name.as_str() {
                "change_point" => format!(
                    "The term in time steps at {:.2} {} (searched on the residual).",
                    v.value, v.unit
                ),
                "frequency" => format!(
                    "The term in time oscillates at {:.2} {} (a sinusoid in time, its frequency \
                     searched on the residual).",
                    v.value, v.unit
                ),
                "step_level" => format!(
                    "The term in {} steps at {:.3} {} (a step beside its hats, the level \
                     searched on the residual).",
                    t.variable.name(),
                    v.value,
                    v.unit
                ),
                "transition_width" => format!(
                    "The term in direction changes sign over ±{:.2} {} of joint speed \
                     (tanh(q̇/w), w searched on the residual).",
                    v.value, v.unit
                ),
                other => format!(
                    "The term in {} has {} {:.3} {} (searched on the residual).",
                    t.variable.name(),
                    other.replace('_', " "),
                    v.value,
                    v.unit
                ),
            });
        }
    }
    if !e.terms.is_empty() {
        // a term fitted in each direction of motion is drawn as two panels, named by it
        let labels: Vec<String> = e
            .terms
            .iter()
            .map(|t| match t.direction {
                None => t.variable.name().to_string(),
                Some(d) if d < 0.0 => format!("{}, plantarflexing", t.variable.name()),
                Some(_) => format!("{}, dorsiflexing", t.variable.name()),
            })
            .collect();
        let views: Vec<report::figures::FlexibleTermView<'_>> = e
            .terms
            .iter()
            .zip(&labels)
            .map(|(t, label)| report::figures::FlexibleTermView {
                variable: label,
                unit: &t.unit,
                points: &t.points,
                value_nm: &t.value_nm,
                band_nm: &t.band_nm,
            })
            .collect();
        let vars: Vec<&str> = e.variables.iter().map(|v| v.name()).collect();
        set.add(
            "flexible_terms",
            &format!(
                "The flexible term{} in {}: the torque the structure adds (N·m, centred on its \
                 mean over the trial) against the variable, with its 95 % band",
                if vars.len() == 1 { "" } else { "s" },
                vars.join(" and ")
            ),
            report::figures::flexible_terms(&views),
        )?;
    }
    Ok(())
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
