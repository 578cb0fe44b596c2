//! `surae validate --extensions`: the model's extensions for real recordings, each judged by
//! the error a user measures on data the calibration did not see.
//!
//! Every candidate is the session's own calibration with one thing added (a parameter set
//! free within its recording range, or the EMG normalised per trial instead of per session),
//! calibrated and scored on the same folds, with the same seed and chains, as the plain
//! calibration. Its gain on a scheme is the change of the mean held-out RMS,
//!
//! ```text
//! gain % = 100 · (RMS_plain − RMS_extended) / RMS_plain,
//! ```
//!
//! and an extension *helps* only when it lowers the held-out RMS of every scheme the session
//! forms. The best is the helping one with the lowest mean held-out RMS over the schemes; when
//! several help, they are also calibrated together (`combined`), since two extensions can
//! explain the same misfit. A calibrated value at a bound of its range is reported: the data
//! then ask for more than the range allows, and the extension may stand in for something
//! else (a compliant tendon for a delay).

use serde::Serialize;
use validate::{FitScore, FoldScheme, SchemeSummary, ValidateSettings};

use super::{session_strides, validation_trials};
use crate::error::{AppError, AppResult};
use crate::jobs::session::{load_session, LoadedSession};
use crate::jobs::ModelSettings;
use crate::Reporter;

/// One extension the study tries.
struct ExtensionCandidate {
    name: &'static str,
    description: &'static str,
    /// Parameters added to the session's free set.
    added: &'static [&'static str],
    /// The EMG normalised the other way (per trial instead of per session, or back).
    flip_emg: bool,
}

const CANDIDATES: [ExtensionCandidate; 5] = [
    ExtensionCandidate {
        name: "tendon_compliance",
        description: "the triceps' shared tendon strain at F0 (curves.e0t) calibrated",
        added: &["curves.e0t"],
        flip_emg: false,
    },
    ExtensionCandidate {
        name: "eccentric_plateau",
        description: "the eccentric force plateau (curves.flen) calibrated",
        added: &["curves.flen"],
        flip_emg: false,
    },
    ExtensionCandidate {
        name: "activation_dynamics",
        description: "the activation and deactivation time constants calibrated",
        added: &["activation.tau_act_s", "activation.tau_deact_s"],
        flip_emg: false,
    },
    ExtensionCandidate {
        name: "antagonist",
        description: "the tibialis anterior's moment against the triceps: its activation from \
                      the TA envelope times a calibrated gain (antagonist_coactivation.gain_nm)",
        added: &["antagonist_coactivation.gain_nm"],
        flip_emg: false,
    },
    ExtensionCandidate {
        name: "emg_normalisation",
        description: "the EMG normalised the other way",
        added: &[],
        flip_emg: true,
    },
];

/// What the study is run with: the plain run's job inputs.
pub(super) struct StudyInputs<'a> {
    /// The session manifest.
    pub session_path: &'a std::path::Path,
    /// The model settings of the plain run.
    pub model: &'a ModelSettings,
    /// `--free` as given.
    pub free: Option<&'a [String]>,
    /// The plain session.
    pub plain: &'a LoadedSession,
    /// The schemes validated.
    pub schemes: &'a [FoldScheme],
    /// The calibration settings of every fold.
    pub settings: &'a ValidateSettings,
    /// The plain calibration's scheme summaries.
    pub plain_schemes: &'a [SchemeSummary],
}

/// `validate.json`'s `extensions`.
#[derive(Debug, Clone, Serialize)]
#[non_exhaustive]
pub struct ExtensionStudy {
    /// Every candidate tried (or skipped, with the reason).
    pub candidates: Vec<ExtensionResult>,
    /// The helping candidates calibrated together, when more than one helps.
    pub combined: Option<ExtensionResult>,
    /// The name of the helping extension (or `combined`) with the lowest mean held-out RMS;
    /// `None` when none lowers every scheme's.
    pub best: Option<String>,
}

/// One extension held out.
#[derive(Debug, Clone, Serialize)]
#[non_exhaustive]
pub struct ExtensionResult {
    /// `tendon_compliance`, `eccentric_plateau`, `activation_dynamics`, `antagonist`,
    /// `emg_normalisation` or `combined`.
    pub name: String,
    /// What it adds.
    pub description: String,
    /// The parameters it adds to the calibrated set.
    pub free_added: Vec<String>,
    /// The EMG normalisation it runs with: `session` or `trial`.
    pub emg_normalisation: &'static str,
    /// Why it was not run (the parameters are calibrated already; the session has MVC trials).
    pub skipped: Option<String>,
    /// Per scheme: its mean held-out score beside the plain calibration's.
    pub schemes: Vec<ExtensionScheme>,
    /// It lowers the mean held-out RMS of every scheme.
    pub helps: bool,
    /// Per fold, the added parameters' calibrated values.
    pub fold_values: Vec<std::collections::BTreeMap<String, f64>>,
    /// Every held-out part: its score and whether its residual still keeps a shape.
    pub held_out: Vec<ExtensionHeldOut>,
    /// Added parameters that end at a bound of their range in some fold.
    pub at_bound: Vec<String>,
    /// Wall-clock time (s).
    pub wall_s: f64,
}

/// One held-out part of an extended calibration.
#[derive(Debug, Clone, Serialize)]
#[non_exhaustive]
pub struct ExtensionHeldOut {
    /// The fold's scheme.
    pub scheme: FoldScheme,
    /// The trial held out.
    pub trial: String,
    /// The extended calibration's score on it.
    pub model: FitScore,
    /// The held-out residual's shape test (validate's `folds[].held_out[].shape.p_value`).
    pub shape_p: f64,
    /// `shape_p < 10⁻³`: the extended model still leaves a reproducible shape.
    pub reproducible: bool,
}

/// One scheme's held-out score with the extension and without.
#[derive(Debug, Clone, Serialize)]
#[non_exhaustive]
pub struct ExtensionScheme {
    /// The scheme.
    pub scheme: FoldScheme,
    /// The extended calibration's mean held-out score.
    pub model: FitScore,
    /// The plain calibration's.
    pub plain: FitScore,
    /// `100 · (RMS_plain − RMS_extended) / RMS_plain`: positive when the extension helps.
    pub gain_pct: f64,
}

fn scope_name(s: ::session::EmgNormalisationScope) -> &'static str {
    match s {
        ::session::EmgNormalisationScope::Session => "session",
        ::session::EmgNormalisationScope::Trial => "trial",
    }
}

/// Runs every candidate (and the helping ones together) on the plain run's folds.
pub(super) fn study(inputs: &StudyInputs<'_>, rep: &Reporter) -> AppResult<ExtensionStudy> {
    let mut candidates = Vec::with_capacity(CANDIDATES.len());
    for c in &CANDIDATES {
        let progress = rep.progress(0, "extension");
        progress.message(format!("validating with {}", c.name));
        candidates.push(run_one(inputs, c.name, c.description, c.added, c.flip_emg)?);
        progress.finish();
    }
    let helping: Vec<&ExtensionResult> = candidates.iter().filter(|c| c.helps).collect();
    let combined = if helping.len() >= 2 {
        let added: Vec<&'static str> = CANDIDATES
            .iter()
            .filter(|c| helping.iter().any(|h| h.name == c.name))
            .flat_map(|c| c.added.iter().copied())
            .collect();
        let flip = CANDIDATES
            .iter()
            .any(|c| c.flip_emg && helping.iter().any(|h| h.name == c.name));
        let names: Vec<&str> = helping.iter().map(|h| h.name.as_str()).collect();
        let description = format!("together: {}", names.join(", "));
        Some(run_one(inputs, "combined", &description, &added, flip)?)
    } else {
        None
    };
    let mean_rms = |r: &ExtensionResult| {
        r.schemes.iter().map(|s| s.model.rms_nm).sum::<f64>() / r.schemes.len().max(1) as f64
    };
    let best = candidates
        .iter()
        .chain(combined.as_ref())
        .filter(|r| r.helps)
        .min_by(|a, b| mean_rms(a).total_cmp(&mean_rms(b)))
        .map(|r| r.name.clone());
    Ok(ExtensionStudy {
        candidates,
        combined,
        best,
    })
}

/// The session's calibration with `added` parameters (and the EMG normalised the other way
/// when `flip_emg`), validated on the plain run's folds.
fn run_one(
    inputs: &StudyInputs<'_>,
    name: &str,
    description: &str,
    added: &[&str],
    flip_emg: bool,
) -> AppResult<ExtensionResult> {
    let t0 = std::time::Instant::now();
    let plain_scope = inputs.plain.manifest.emg_normalisation;
    let scope = if flip_emg {
        match plain_scope {
            ::session::EmgNormalisationScope::Session => ::session::EmgNormalisationScope::Trial,
            ::session::EmgNormalisationScope::Trial => ::session::EmgNormalisationScope::Session,
        }
    } else {
        plain_scope
    };
    let description = if flip_emg && added.is_empty() {
        format!(
            "the EMG normalised per {} instead of per {}",
            scope_name(scope),
            scope_name(plain_scope)
        )
    } else {
        description.to_string()
    };
    let mut result = ExtensionResult {
        name: name.to_string(),
        description,
        free_added: added.iter().map(|s| s.to_string()).collect(),
        emg_normalisation: scope_name(scope),
        skipped: None,
        schemes: Vec::new(),
        helps: false,
        fold_values: Vec::new(),
        held_out: Vec::new(),
        at_bound: Vec::new(),
        wall_s: 0.0,
    };
    let plain_names: Vec<String> = inputs.plain.free.iter().map(|p| p.name()).collect();
    if let Some(a) = added.iter().find(|a| plain_names.iter().any(|n| n == *a)) {
        result.skipped = Some(format!("{a} is calibrated already"));
        return Ok(result);
    }
    if added.contains(&ANTAGONIST_GAIN) {
        if let Some(why) = no_antagonist_envelope(inputs.plain) {
            result.skipped = Some(why);
            return Ok(result);
        }
    }
    if flip_emg && !inputs.plain.manifest.mvc.is_empty() {
        result.skipped = Some("the session's EMG is normalised by its MVC trials".into());
        return Ok(result);
    }
    // added to the free set as given: `+name` keeps the default set and its bounds, a plain
    // `--free` list takes the names plainly
    let free: Vec<String> = match inputs.free {
        Some(f) if !f.iter().all(|n| n.starts_with('+')) => f
            .iter()
            .cloned()
            .chain(added.iter().map(|a| a.to_string()))
            .collect(),
        given => given
            .unwrap_or_default()
            .iter()
            .cloned()
            .chain(added.iter().map(|a| format!("+{a}")))
            .collect(),
    };
    let model = ModelSettings {
        emg_normalisation: Some(scope),
        ..inputs.model.clone()
    };
    // the plain run has said what the session's files warn of
    let session = load_session(
        inputs.session_path,
        &model,
        (!free.is_empty()).then_some(free.as_slice()),
        &Reporter::silent(),
    )?;
    let strides = session_strides(&session)?;
    let trials = validation_trials(&session, &strides);
    let v = validate::validate(&trials, inputs.schemes, &[], inputs.settings)
        .map_err(|e| AppError::bad(format!("{}: {e}", inputs.session_path.display())))?;
    result.schemes = v
        .schemes
        .iter()
        .zip(inputs.plain_schemes)
        .map(|(e, p)| ExtensionScheme {
            scheme: e.scheme,
            model: e.model,
            plain: p.model,
            gain_pct: 100.0 * (p.model.rms_nm - e.model.rms_nm) / p.model.rms_nm,
        })
        .collect();
    result.helps = !result.schemes.is_empty() && result.schemes.iter().all(|s| s.gain_pct > 0.0);
    let problem = &session.trials[0].problem;
    for f in &v.folds {
        let values: std::collections::BTreeMap<String, f64> = added
            .iter()
            .filter_map(|a| f.params.get(*a).map(|v| (a.to_string(), *v)))
            .collect();
        for (a, x) in &values {
            let Some(i) = problem.names().iter().position(|n| n == a) else {
                continue;
            };
            let (lo, hi) = problem.bounds()[i];
            let near = 1e-3 * (hi - lo);
            if (x - lo < near || hi - x < near) && !result.at_bound.contains(a) {
                result.at_bound.push(a.clone());
            }
        }
        result.fold_values.push(values);
        for h in &f.held_out {
            result.held_out.push(ExtensionHeldOut {
                scheme: f.scheme,
                trial: h.trial.clone(),
                model: h.model,
                shape_p: h.shape.p_value,
                reproducible: h.shape.reproducible,
            });
        }
    }
    result.wall_s = t0.elapsed().as_secs_f64();
    Ok(result)
}

/// The antagonist's parameter.
const ANTAGONIST_GAIN: &str = "antagonist_coactivation.gain_nm";

/// Why the antagonist cannot be added to `session`: a trial without the TA's envelope, or
/// whose TA is a muscle of the model already (a CEINMS folder drives `tibant_r` with the
/// subject file's parameters, so a second TA term would count it twice).
fn no_antagonist_envelope(session: &LoadedSession) -> Option<String> {
    session.trials.iter().find_map(|t| {
        let inputs = t.problem.inputs();
        if inputs.geometry("tibant_r").is_some() {
            Some(format!(
                "trial {}: the tibialis anterior is a muscle of the model already (tibant_r, \
                 with the subject file's parameters)",
                t.name
            ))
        } else if inputs.envelope_ta().is_none() {
            Some(format!("trial {} has no TA envelope (emg_ta)", t.name))
        } else {
            None
        }
    })
}

/// The study's summary lines.
pub(super) fn summary_lines(s: &ExtensionStudy) -> Vec<String> {
    let mut lines = vec!["  extensions, held out against the plain calibration:".to_string()];
    for r in s.candidates.iter().chain(s.combined.as_ref()) {
        if let Some(why) = &r.skipped {
            lines.push(format!("    {:20} not run: {why}", r.name));
            continue;
        }
        let schemes: Vec<String> = r
            .schemes
            .iter()
            .map(|x| {
                format!(
                    "{} {:.2} N·m / R² {:.3} ({:+.1} %)",
                    x.scheme.name(),
                    x.model.rms_nm,
                    x.model.r2,
                    -x.gain_pct
                )
            })
            .collect();
        let mut l = format!("    {:20} {}", r.name, schemes.join("; "));
        if !r.at_bound.is_empty() {
            l.push_str(&format!("; at a bound: {}", r.at_bound.join(", ")));
        }
        let shaped = r.held_out.iter().filter(|h| h.reproducible).count();
        l.push_str(&format!(
            "; {shaped} of {} held-out parts keep a shape",
            r.held_out.len()
        ));
        lines.push(l);
    }
    lines.push(match &s.best {
        Some(b) => format!("    best: {b}"),
        None => "    best: none lowers the held-out RMS of every scheme".to_string(),
    });
    lines
}
