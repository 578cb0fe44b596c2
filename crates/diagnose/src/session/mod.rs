//! Diagnosis of a session: several trials of one subject with one set of muscle parameters
//! (docs/diagnosis-method.md, "Sessions").
//!
//! Each trial keeps its own noise model (from its unloaded run, or from its baseline's
//! residual) and its own dynamometer correction; the 9 muscle parameters are shared. The
//! catalogued effects split by [`effect_scope`]: an effect of the subject is one term of the
//! joint model read by every trial that can test it, an effect of a trial's setup one term per
//! trial ([`joint`]). The terms are selected forward ([`select`]): score tests on the trials'
//! stacked whitened residuals, joint refits of the leaders, acceptance by the joint BIC and by
//! the leave-one-trial-out held-out error. The final residual of every trial is tested for
//! structure; the session's p-value is the Bonferroni minimum over its trials.
//!
//! A session of one trial is that trial's own diagnosis ([`SessionDiagnosis::of_one_trial`]):
//! its within-trial cross-validation, its verdict and causes.

mod joint;
mod report;
mod scope;
mod select;

use std::collections::BTreeMap;
use std::ops::ControlFlow;
use std::time::Instant;

use experiment::UnloadedCorrection;
use muscle_model::ParamId;

use crate::analysis;
use crate::baseline::eligible_candidates;
use crate::context::{self, Target};
use crate::progress::{notify, DiagnosisProgress, DiagnosisStage};
use crate::{DiagnoseError, DiagnoseSettings, DiagnosisRecording, Verdict};
use joint::{Joint, Member};
use select::JointSelection;

pub use report::{
    HeldoutScheme, SessionCandidate, SessionCause, SessionDiagnosis, SessionHeldout,
    SessionTrialFit, TrialHeldout,
};
pub use scope::{effect_scope, EffectScope};

/// One trial of a session: its model inputs (EMG normalised over the session), measured
/// torque, compared samples and base model, and its unloaded run when it has one.
#[derive(Clone, Debug)]
pub struct SessionMember<'a> {
    /// The trial's name in the session.
    pub name: String,
    /// The trial as model inputs and measured torque.
    pub recording: DiagnosisRecording,
    /// Its unloaded run (the noise model and the dynamometer's systematic part), if any.
    pub unloaded: Option<&'a UnloadedCorrection>,
}

/// Diagnoses a session jointly (module docs); a session of one trial is that trial's own
/// diagnosis ([`SessionDiagnosis::of_one_trial`] of it diagnosed as a prepared recording with
/// its unloaded run).
///
/// # Errors
/// Invalid settings, no trial, a trial that cannot be prepared (its torque, weights, motion
/// or unloaded run; the error names the trial), trials whose 9 muscle parameters have
/// different base values, a baseline that cannot be simulated, or a stop by the observer.
pub fn diagnose_session(
    members: &[SessionMember<'_>],
    settings: &DiagnoseSettings,
    observer: &mut dyn FnMut(&DiagnosisProgress) -> ControlFlow<()>,
) -> Result<SessionDiagnosis, DiagnoseError> {
    let t0 = Instant::now();
    settings.validate()?;
    match members {
        [] => {
            return Err(DiagnoseError::Recording {
                reason: "a session needs at least one trial".into(),
            })
        }
        [one] => {
            let d = crate::run_member(&one.recording, one.unloaded, settings, observer)?;
            return Ok(SessionDiagnosis::of_one_trial(&one.name, &d));
        }
        _ => {}
    }
    // the shared muscle parameters start from, and are bounded around, one set of base values
    let base = |m: &SessionMember<'_>| {
        let r = &m.recording;
        ParamId::identified().map(|p| p.get(&r.params, &r.effects).to_bits())
    };
    if let Some(m) = members.iter().find(|m| base(m) != base(&members[0])) {
        return Err(DiagnoseError::Recording {
            reason: format!(
                "trial `{}`: the trials of a session share their muscle parameters, this one \
                 has other base values",
                m.name
            ),
        });
    }
    notify(
        observer,
        DiagnosisStage::Noise,
        "preparing the session's trials".into(),
        0,
    )?;
    let mut evaluations = 0;
    let mut prepared = Vec::with_capacity(members.len());
    for m in members {
        let (member, ev) = prepare(m, settings).map_err(|e| match e {
            DiagnoseError::Cancelled => e,
            e => DiagnoseError::Recording {
                reason: format!("trial `{}`: {e}", m.name),
            },
        })?;
        evaluations += ev;
        prepared.push(member);
    }
    let joint = Joint::new(&prepared)?;
    let sel = select::select(&joint, settings, observer, &mut evaluations)?;
    notify(
        observer,
        DiagnosisStage::Analysis,
        "session residual analysis".into(),
        evaluations,
    )?;
    let mut d = assemble(&joint, &sel, settings);
    d.evaluations = evaluations;
    d.wall_s = t0.elapsed().as_secs_f64();
    Ok(d)
}

/// The fitting context of one trial and the simulations its noise model used.
fn prepare(
    m: &SessionMember<'_>,
    settings: &DiagnoseSettings,
) -> Result<(Member, usize), DiagnoseError> {
    let rec = &m.recording;
    let observed = rec.observed()?;
    let inputs = rec.inputs.clone();
    let seg = context::segment(&inputs, observed.as_deref())?;
    let target = Target {
        torque_nm: &rec.torque_nm,
        observed,
        params: rec.params,
        effects: rec.effects,
        emg: Default::default(),
    };
    let (ctx, ev) = context::trial_context(target, m.unloaded, inputs, seg, settings)?;
    let eligible = eligible_candidates(&ctx, settings);
    Ok((
        Member {
            name: m.name.clone(),
            ctx,
            eligible,
        },
        ev,
    ))
}

/// The session's report from the selection.
fn assemble(
    joint: &Joint<'_>,
    sel: &JointSelection,
    settings: &DiagnoseSettings,
) -> SessionDiagnosis {
    let n = joint.n_obs();
    let names: Vec<String> = joint.members.iter().map(|m| m.name.clone()).collect();
    let (base, fin) = (&sel.baseline, &sel.model);

    // causes: one per effect, in order of selection; a trial's effect lists its trials
    let mut causes: Vec<SessionCause> = Vec::new();
    for (i, t) in fin.layout.terms.iter().enumerate() {
        let values = joint.term_values(fin, i);
        let name = t.kind.name().to_string();
        match t.trial {
            None => causes.push(SessionCause {
                effect: name,
                scope: EffectScope::Subject,
                values: Some(values),
                per_trial: None,
            }),
            Some(k) => {
                let trial = names[k].clone();
                match causes.iter_mut().find(|c| c.effect == name) {
                    Some(c) => {
                        c.per_trial
                            .get_or_insert_with(BTreeMap::new)
                            .insert(trial, values);
                    }
                    None => causes.push(SessionCause {
                        effect: name,
                        scope: EffectScope::Trial,
                        values: None,
                        per_trial: Some(BTreeMap::from([(trial, values)])),
                    }),
                }
            }
        }
    }

    // structure left in each trial's final residual; Bonferroni over the trials
    let trials: Vec<SessionTrialFit> = (0..joint.members.len())
        .map(|m| {
            let ctx = &joint.members[m].ctx;
            let ra = analysis::analyse(
                ctx,
                &joint.member_view(base, m),
                &joint.member_view(fin, m),
                settings.structure_threshold,
            );
            SessionTrialFit {
                name: names[m].clone(),
                baseline_rms_nm: base.rms[m],
                extended_rms_nm: fin.rms[m],
                structure_p_value: ra.structure_p_value,
            }
        })
        .collect();
    let p_min = trials
        .iter()
        .map(|t| t.structure_p_value)
        .fold(1.0, f64::min);
    let structure_p_value = (p_min * trials.len() as f64).min(1.0);
    let unexplained = -structure_p_value.max(1e-300).log10() > settings.structure_threshold;

    let (hb, he) = (base.heldout.as_ref(), fin.heldout.as_ref());
    let nan = f64::NAN;
    let heldout = SessionHeldout {
        scheme: HeldoutScheme::LeaveOneTrialOut,
        baseline_rms_nm: hb.map_or(nan, |h| h.rms),
        extended_rms_nm: he.map_or(nan, |h| h.rms),
        rms_reduction_pct: match (hb, he) {
            (Some(b), Some(e)) => report::reduction_pct(b.rms, e.rms),
            _ => nan,
        },
        deviance_reduction: match (hb, he) {
            (Some(b), Some(e)) => b.dev - e.dev,
            _ => nan,
        },
        per_trial: (0..names.len())
            .map(|m| TrialHeldout {
                name: names[m].clone(),
                baseline_rms_nm: hb.map_or(nan, |h| h.per_trial_rms[m]),
                extended_rms_nm: he.map_or(nan, |h| h.per_trial_rms[m]),
            })
            .collect(),
    };

    let mut candidates: Vec<SessionCandidate> = sel
        .reports
        .iter()
        .map(|r| SessionCandidate {
            effect: r.term.kind.name().to_string(),
            scope: effect_scope(r.term.kind),
            trial: r.term.trial.map(|k| names[k].clone()),
            evidence: r.evidence,
            score_lm: r.score_lm,
            cos_to_model: r.cos_to_model,
            round: r.round,
            delta_bic: r.delta_bic,
            heldout_rms_nm: r.heldout_rms,
            heldout_dev_gain: r.heldout_dev_gain,
            accepted: r.accepted,
        })
        .collect();
    candidates.sort_by(|a, b| b.evidence.total_cmp(&a.evidence));

    let verdict = if causes.is_empty() && !unexplained {
        Verdict::Adequate
    } else {
        Verdict::Deficient
    };
    SessionDiagnosis {
        verdict,
        causes,
        unexplained_structure: unexplained,
        structure_p_value,
        heldout,
        delta_bic: fin.bic(n) - base.bic(n),
        baseline_params: Joint::muscle_values(base),
        extended_params: Joint::muscle_values(fin),
        trial_fits: trials,
        candidates,
        evaluations: 0,
        wall_s: 0.0,
        held_out_shape: None,
        given_params: Vec::new(),
    }
}
