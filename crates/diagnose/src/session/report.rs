//! The diagnosis of a session: the `diagnosis_session.json` shape (docs/diagnosis.md,
//! "Sessions") and its terminal summary.

use std::collections::BTreeMap;

use muscle_model::EffectKind;
use serde::Serialize;

use super::scope::{effect_scope, EffectScope};
use crate::{Diagnosis, Verdict};

/// A cause named over a session.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct SessionCause {
    /// Effect name.
    pub effect: String,
    /// `subject` (one value shared by every trial) or `trial` (one value per trial).
    pub scope: EffectScope,
    /// The shared values by parameter name (scope `subject`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub values: Option<BTreeMap<String, f64>>,
    /// By trial name, the values of each trial the effect is named for (scope `trial`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub per_trial: Option<BTreeMap<String, BTreeMap<String, f64>>>,
}

/// How the session's held-out errors were obtained.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
#[non_exhaustive]
pub enum HeldoutScheme {
    /// Each trial predicted by the model fitted on the others.
    LeaveOneTrialOut,
    /// One trial: its own cycle-wise (or block-wise) cross-validation.
    WithinTrial,
}

/// One trial's held-out RMS under the baseline and the final model.
#[derive(Clone, Debug, PartialEq, Serialize)]
#[non_exhaustive]
pub struct TrialHeldout {
    /// Trial name.
    pub name: String,
    /// Held-out RMS of the baseline (N·m).
    pub baseline_rms_nm: f64,
    /// Held-out RMS of the final model (N·m).
    pub extended_rms_nm: f64,
}

/// The session's held-out comparison of the final model with the baseline.
#[derive(Clone, Debug, PartialEq, Serialize)]
#[non_exhaustive]
pub struct SessionHeldout {
    /// `leave_one_trial_out` or `within_trial`.
    pub scheme: HeldoutScheme,
    /// Held-out RMS of the baseline, pooled over the trials (N·m).
    pub baseline_rms_nm: f64,
    /// Held-out RMS of the final model (N·m).
    pub extended_rms_nm: f64,
    /// `100·(1 − extended/baseline)`.
    pub rms_reduction_pct: f64,
    /// Fall of the held-out deviance `Σ ν²/S` (χ² units; positive favours the final model).
    pub deviance_reduction: f64,
    /// Per trial.
    pub per_trial: Vec<TrialHeldout>,
}

/// One trial's in-sample fit by the session's joint baseline and final model.
#[derive(Clone, Debug, PartialEq, Serialize)]
#[non_exhaustive]
pub struct SessionTrialFit {
    /// Trial name.
    pub name: String,
    /// In-sample RMS of the baseline on this trial (N·m).
    pub baseline_rms_nm: f64,
    /// In-sample RMS of the final model (N·m).
    pub extended_rms_nm: f64,
    /// p-value of the structure tests on this trial's final residual.
    pub structure_p_value: f64,
}

/// A candidate term of the session's selection.
#[derive(Clone, Debug, PartialEq, Serialize)]
#[non_exhaustive]
pub struct SessionCandidate {
    /// Effect name.
    pub effect: String,
    /// Its scope.
    pub scope: EffectScope,
    /// The trial of a term of scope `trial`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub trial: Option<String>,
    /// Score-test evidence `LM − p ln n` at the round it was last scored.
    pub evidence: f64,
    /// Score statistic.
    pub score_lm: f64,
    /// Cosine between its fitted signature and the span of the model's parameters.
    pub cos_to_model: f64,
    /// Round it was last scored in (0 = against the baseline).
    pub round: usize,
    /// `BIC(with) − BIC(without)` of its refit (null if not refitted).
    pub delta_bic: Option<f64>,
    /// Held-out RMS of its refit (null if not refitted).
    pub heldout_rms_nm: Option<f64>,
    /// Fall of the held-out deviance with it added (null if not refitted).
    pub heldout_dev_gain: Option<f64>,
    /// Named.
    pub accepted: bool,
}

/// The diagnosis of a session (serialises to the session part of `diagnosis_session.json`).
#[derive(Clone, Debug, PartialEq, Serialize)]
#[non_exhaustive]
pub struct SessionDiagnosis {
    /// `adequate` or `deficient`.
    pub verdict: Verdict,
    /// Named causes in order of selection, each once.
    pub causes: Vec<SessionCause>,
    /// Some trial's final residual keeps structure no catalogued effect explains.
    pub unexplained_structure: bool,
    /// Bonferroni p-value of the structure tests over the trials.
    pub structure_p_value: f64,
    /// Held-out comparison of the final model with the baseline.
    pub heldout: SessionHeldout,
    /// `BIC_ext − BIC_base` of the joint fits (negative favours the final model).
    pub delta_bic: f64,
    /// The shared muscle parameters of the baseline.
    pub baseline_params: BTreeMap<String, f64>,
    /// The shared muscle parameters of the final model.
    pub extended_params: BTreeMap<String, f64>,
    /// Per trial, the in-sample fit of the joint models.
    pub trial_fits: Vec<SessionTrialFit>,
    /// Every term scored, best evidence first.
    pub candidates: Vec<SessionCandidate>,
    /// Model simulations of the joint diagnosis.
    pub evaluations: usize,
    /// Wall time of the joint diagnosis (s).
    pub wall_s: f64,
    /// Every trial's held-out residual tested for a reproducible shape
    /// ([`SessionDiagnosis::judge_held_out_shape`]; a session with a trial without an unloaded
    /// run).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub held_out_shape: Option<crate::SessionHeldOutShape>,
    /// Per trial, how the parameters given to `diagnose --session --params` predict it as they
    /// are ([`SessionDiagnosis::judge_given_params`]; empty without `--params`).
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub given_params: Vec<crate::TrialGivenParamsFit>,
}

/// `100·(1 − after/before)`.
pub(crate) fn reduction_pct(before: f64, after: f64) -> f64 {
    100.0 * (1.0 - after / before)
}

impl SessionDiagnosis {
    /// The session of one trial: its own diagnosis, the causes given their scope, the held-out
    /// errors of its own cross-validation.
    #[must_use]
    pub fn of_one_trial(name: &str, d: &Diagnosis) -> Self {
        let values = |effect: &str| {
            d.extended
                .effects
                .as_ref()
                .and_then(|e| e.get(effect))
                .cloned()
                .unwrap_or_default()
        };
        let causes = d
            .causes
            .iter()
            .map(|c| {
                let scope = EffectKind::from_name(c).map_or(EffectScope::Subject, effect_scope);
                let v = values(c);
                SessionCause {
                    effect: c.clone(),
                    scope,
                    values: (scope == EffectScope::Subject).then(|| v.clone()),
                    per_trial: (scope == EffectScope::Trial)
                        .then(|| BTreeMap::from([(name.to_string(), v)])),
                }
            })
            .collect();
        let candidates = d
            .candidates
            .iter()
            .map(|c| {
                let scope =
                    EffectKind::from_name(&c.effect).map_or(EffectScope::Subject, effect_scope);
                SessionCandidate {
                    effect: c.effect.clone(),
                    scope,
                    trial: (scope == EffectScope::Trial).then(|| name.to_string()),
                    evidence: c.evidence,
                    score_lm: c.score_lm,
                    cos_to_model: c.cos_to_model,
                    round: c.round,
                    delta_bic: c.delta_bic,
                    heldout_rms_nm: c.heldout_rms_nm,
                    heldout_dev_gain: c.heldout_dev_gain,
                    accepted: c.accepted,
                }
            })
            .collect();
        SessionDiagnosis {
            verdict: d.verdict,
            causes,
            unexplained_structure: d.unexplained_structure,
            structure_p_value: d.residual_analysis.structure_p_value,
            heldout: SessionHeldout {
                scheme: HeldoutScheme::WithinTrial,
                baseline_rms_nm: d.baseline.heldout_rms_nm,
                extended_rms_nm: d.extended.heldout_rms_nm,
                rms_reduction_pct: d.gain.heldout_rms_reduction_pct,
                deviance_reduction: d.gain.heldout_deviance_reduction,
                per_trial: vec![TrialHeldout {
                    name: name.to_string(),
                    baseline_rms_nm: d.baseline.heldout_rms_nm,
                    extended_rms_nm: d.extended.heldout_rms_nm,
                }],
            },
            delta_bic: d.gain.delta_bic,
            baseline_params: d.baseline.params.clone(),
            extended_params: d.extended.params.clone(),
            trial_fits: vec![SessionTrialFit {
                name: name.to_string(),
                baseline_rms_nm: d.baseline.rms_nm,
                extended_rms_nm: d.extended.rms_nm,
                structure_p_value: d.residual_analysis.structure_p_value,
            }],
            candidates,
            evaluations: 0,
            wall_s: 0.0,
            held_out_shape: None,
            given_params: Vec::new(),
        }
    }

    /// A summary for the terminal.
    #[must_use]
    pub fn summary_lines(&self) -> Vec<String> {
        let mut l = Vec::new();
        let v = match self.verdict {
            Verdict::Adequate => "ADEQUATE: the baseline model explains the session",
            Verdict::Deficient => "DEFICIENT: the baseline model misses something",
        };
        l.push(format!("session verdict  {v}"));
        if self.causes.is_empty() {
            l.push("causes           none".into());
        }
        for c in &self.causes {
            match (&c.values, &c.per_trial) {
                (Some(v), _) => l.push(format!(
                    "cause            {} (subject, shared): {}",
                    c.effect,
                    fmt_values(v)
                )),
                (None, Some(p)) => {
                    for (trial, v) in p {
                        l.push(format!(
                            "cause            {} (trial {trial}): {}",
                            c.effect,
                            fmt_values(v)
                        ));
                    }
                }
                (None, None) => l.push(format!("cause            {}", c.effect)),
            }
        }
        if self.unexplained_structure {
            l.push(format!(
                "structure        unexplained structure left (p = {:.1e})",
                self.structure_p_value
            ));
        }
        if let Some(h) = &self.held_out_shape {
            let list = |keeps: bool| -> String {
                h.per_trial
                    .iter()
                    .filter(|t| t.check.reproducible == keeps)
                    .map(|t| format!("{} (p {:.1e})", t.name, t.check.p_value))
                    .collect::<Vec<_>>()
                    .join(", ")
            };
            let (kept, not_kept) = (list(true), list(false));
            l.push(match (kept.is_empty(), not_kept.is_empty()) {
                (true, _) => format!("held-out shape   no trial keeps a reproducible shape: {not_kept}"),
                (false, true) => {
                    format!("held-out shape   reproducible in {kept}: the model is not adequate")
                }
                (false, false) => format!(
                    "held-out shape   reproducible in {kept}: the model is not adequate; not in {not_kept}"
                ),
            });
            if let Some(t) = h.scale_text() {
                l.push(format!(
                    "held-out gain    the model's moment scaled in {t}: the calibration's gain does \
                     not carry to these trials"
                ));
            }
        }
        l.extend(self.given_params_line());
        let scheme = match self.heldout.scheme {
            HeldoutScheme::LeaveOneTrialOut => "leaving one trial out",
            HeldoutScheme::WithinTrial => "within the trial",
        };
        l.push(format!(
            "held-out RMS     {:.3} → {:.3} N·m ({:+.1} %, {scheme}); ΔBIC {:.1}",
            self.heldout.baseline_rms_nm,
            self.heldout.extended_rms_nm,
            -self.heldout.rms_reduction_pct,
            self.delta_bic
        ));
        for (t, h) in self.trial_fits.iter().zip(&self.heldout.per_trial) {
            l.push(format!(
                "  {:<14} RMS {:.3} → {:.3} N·m, held out {:.3} → {:.3} N·m",
                t.name, t.baseline_rms_nm, t.extended_rms_nm, h.baseline_rms_nm, h.extended_rms_nm
            ));
        }
        l
    }
}

fn fmt_values(v: &BTreeMap<String, f64>) -> String {
    v.iter()
        .map(|(k, x)| format!("{k} {x:.4}"))
        .collect::<Vec<_>>()
        .join(", ")
}
