//! Which terms the joint model of a session names: greedy forward selection over the shared
//! effects and the effects of each trial, ranked by the score test on the stacked whitened
//! residual, judged by the BIC of the joint fit and by leaving one trial out.
//!
//! A round scores every term the model does not carry yet: each effect of the subject once
//! (its sensitivity stacked over the trials that can test it), each effect of a trial's setup
//! once per trial (its sensitivity in that trial's rows, zero elsewhere). The leaders are
//! refitted jointly; one is accepted when `ΔBIC = BIC_ext − BIC < ` the margin, its
//! leave-one-trial-out deviance is not higher and, when a trial has no unloaded run, its
//! pooled held-out RMS is lower, and, when its
//! signature is nearly collinear with the model's parameters, its estimate lies ≥ 3 standard
//! errors from its null. Before a leader is accepted, the current model is refitted from the
//! leader's values of the parameters it already has, so that a better optimum of those is not
//! credited to the new term. The effects named are at most
//! [`crate::DiagnoseSettings::max_effects`] kinds; an effect of a trial's setup found in a
//! second trial adds a term, not a cause.

use std::ops::ControlFlow;

use muscle_model::EffectKind;
use nalgebra::DVector;
use rayon::prelude::*;

use super::joint::{Joint, JointFit, Layout, Term};
use super::scope::{effect_scope, EffectScope};
use crate::fit::{latin_hypercube, Fit};
use crate::progress::{notify, DiagnosisProgress, DiagnosisStage};
use crate::score::{one_sided, variants, JacobianComplementProjector};
use crate::{DiagnoseError, DiagnoseSettings};

/// A term scored (and, for the leaders, refitted) in a round.
#[derive(Clone, Debug)]
pub(crate) struct TermReport {
    pub term: Term,
    pub evidence: f64,
    pub score_lm: f64,
    pub cos_to_model: f64,
    pub round: usize,
    pub delta_bic: Option<f64>,
    pub heldout_rms: Option<f64>,
    pub heldout_dev_gain: Option<f64>,
    pub accepted: bool,
}

/// The outcome of the selection.
pub(crate) struct JointSelection {
    pub baseline: JointFit,
    pub model: JointFit,
    pub reports: Vec<TermReport>,
}

/// A term's score test.
struct Scored {
    term: Term,
    lm: f64,
    evidence: f64,
    cos: f64,
    /// Start values of the term's parameters in the joint vector's coordinates.
    start: Vec<f64>,
}

/// Runs the baseline fit and the forward selection; the simulations spent are added to
/// `evaluations`.
pub(crate) fn select(
    joint: &Joint<'_>,
    settings: &DiagnoseSettings,
    observer: &mut dyn FnMut(&DiagnosisProgress) -> ControlFlow<()>,
    evaluations: &mut usize,
) -> Result<JointSelection, DiagnoseError> {
    let n = joint.n_obs();
    notify(
        observer,
        DiagnosisStage::Baseline,
        "fitting the session's baseline (9 shared muscle parameters)".into(),
        *evaluations,
    )?;
    let mut starts = vec![joint.base_muscles.to_vec()];
    starts.extend(latin_hypercube(
        &joint.muscle_bounds,
        settings.baseline_extra_starts,
        settings.start_seed,
    ));
    let mut baseline = joint.fit(&Layout::new(Vec::new()), &starts, true)?;
    *evaluations += baseline.evaluations;
    let mut current = baseline.clone();
    let mut reports: Vec<TermReport> = Vec::new();
    // a trial without an unloaded run has its noise model fitted to its own residual: then
    // every candidate reaching the threshold is refitted and the pooled held-out RMS ranks
    // them (`DiagnoseSettings::refits`)
    let rms_decides = joint
        .members
        .iter()
        .any(|m| m.ctx.noise.source == crate::noise::NoiseModelSource::TrialResidual);
    for round in 0..settings.max_effects + joint.members.len() {
        notify(
            observer,
            DiagnosisStage::Round(round),
            format!("session round {}: ranking extensions", round + 1),
            *evaluations,
        )?;
        let todo = open_terms(joint, &current.layout, settings);
        let mut scores = score_terms(joint, &current, &todo);
        // the simulated sensitivities (delay, fatigue, antagonist, eccentric) of each trial
        *evaluations += 4 * scores.len() * joint.members.len();
        scores.sort_by(|a, b| b.evidence.total_cmp(&a.evidence));
        for s in &scores {
            let rep = TermReport {
                term: s.term,
                evidence: s.evidence,
                score_lm: s.lm,
                cos_to_model: s.cos,
                round,
                delta_bic: None,
                heldout_rms: None,
                heldout_dev_gain: None,
                accepted: false,
            };
            match reports.iter_mut().find(|r| r.term == s.term) {
                Some(r) => *r = rep,
                None => reports.push(rep),
            }
        }
        let leaders: Vec<&Scored> = scores
            .iter()
            .filter(|s| s.lm >= settings.min_score_lm)
            .take(settings.refits(rms_decides))
            .collect();
        if leaders.is_empty() {
            break;
        }
        let refits: Vec<Result<JointFit, DiagnoseError>> = leaders
            .par_iter()
            .map(|s| {
                let layout = current.layout.with(s.term);
                let mut x0 = current.x.clone();
                x0.extend(&s.start);
                let mut x1 = x0.clone();
                x1[..9].copy_from_slice(&joint.base_muscles);
                let starts = if x1 == x0 { vec![x0] } else { vec![x0, x1] };
                joint.fit(&layout, &starts, true)
            })
            .collect();
        let mut fits: Vec<(JointFit, &Scored)> = Vec::new();
        for (r, s) in refits.into_iter().zip(&leaders) {
            match r {
                Ok(f) => {
                    *evaluations += f.evaluations;
                    fits.push((f, *s));
                }
                Err(DiagnoseError::Fit { .. }) | Err(DiagnoseError::Model(_)) => {}
                Err(e) => return Err(e),
            }
        }
        let mut rechecked = false;
        let best = loop {
            let mut passing: Vec<(usize, f64)> = Vec::new();
            for (i, (f, s)) in fits.iter().enumerate() {
                let d = f.bic(n) - current.bic(n);
                let dev_gain = match (&f.heldout, &current.heldout) {
                    (Some(a), Some(b)) => Some(b.dev - a.dev),
                    _ => None,
                };
                if let Some(r) = reports.iter_mut().find(|r| r.term == s.term) {
                    r.delta_bic = Some(d);
                    r.heldout_rms = f.heldout.as_ref().map(|h| h.rms);
                    r.heldout_dev_gain = dev_gain;
                }
                // where a trial's noise model is fitted to its own residual (no unloaded run)
                // the held-out deviance is not enough: a cause must also lower the error a
                // user measures on the trial left out, the pooled leave-one-trial-out RMS (on
                // CEINMS's four trials eccentric enhancement raised it while its deviance
                // fell); with unloaded runs the deviance decides, as for one trial
                let rms_falls = match (&f.heldout, &current.heldout) {
                    (Some(a), Some(b)) if rms_decides => a.rms < b.rms,
                    _ => true,
                };
                let generalises =
                    rms_falls && dev_gain.is_none_or(|dg| dg >= settings.min_heldout_dev_gain);
                let clear = s.cos <= settings.confound_cos || significance(f, n) >= 3.0;
                if d < settings.max_delta_bic && generalises && clear {
                    let rank = match &f.heldout {
                        Some(h) if rms_decides => h.rms,
                        _ => d,
                    };
                    passing.push((i, rank));
                }
            }
            passing.sort_by(|a, b| a.1.total_cmp(&b.1));
            let Some(&(lead, _)) = passing.first() else {
                break None;
            };
            if rechecked {
                break Some(lead);
            }
            rechecked = true;
            // the current model refitted from the leader's values of its own parameters
            let x0 = fits[lead].0.x[..current.layout.dim].to_vec();
            // a start the model cannot be differentiated at is no better optimum
            let alt = match joint.fit(&current.layout, &[x0], true) {
                Ok(a) => a,
                Err(DiagnoseError::Fit { .. }) | Err(DiagnoseError::Model(_)) => {
                    break Some(lead);
                }
                Err(e) => return Err(e),
            };
            *evaluations += alt.evaluations;
            if alt.white_ss < current.white_ss {
                if current.layout.terms.is_empty() {
                    baseline = alt.clone();
                }
                current = alt;
                continue;
            }
            break Some(lead);
        };
        let Some(best) = best else {
            break;
        };
        let (fit, s) = fits.swap_remove(best);
        if let Some(r) = reports.iter_mut().find(|r| r.term == s.term) {
            r.accepted = true;
        }
        current = fit;
    }
    Ok(JointSelection {
        baseline,
        model: current,
        reports,
    })
}

/// The terms a round scores: each candidate effect of the subject some trial can test, and
/// each candidate effect of a trial's setup for each trial that can test it, that the model
/// does not carry; once the model names `max_effects` kinds, only terms of those kinds.
fn open_terms(joint: &Joint<'_>, layout: &Layout, settings: &DiagnoseSettings) -> Vec<Term> {
    let mut kinds: Vec<EffectKind> = layout.terms.iter().map(|t| t.kind).collect();
    kinds.dedup();
    kinds.sort();
    kinds.dedup();
    let full = kinds.len() >= settings.max_effects;
    let mut out = Vec::new();
    for &kind in &settings.candidates {
        if full && !kinds.contains(&kind) {
            continue;
        }
        let testers: Vec<usize> = (0..joint.members.len())
            .filter(|&m| joint.members[m].eligible.contains(&kind))
            .collect();
        let terms: Vec<Term> = match effect_scope(kind) {
            EffectScope::Subject if !testers.is_empty() => vec![Term { kind, trial: None }],
            EffectScope::Subject => Vec::new(),
            EffectScope::Trial => testers
                .iter()
                .map(|&m| Term {
                    kind,
                    trial: Some(m),
                })
                .collect(),
        };
        out.extend(terms.into_iter().filter(|t| !layout.terms.contains(t)));
    }
    out
}

/// The score test of each term on the stacked residual of `fit` (in parallel).
fn score_terms(joint: &Joint<'_>, fit: &JointFit, todo: &[Term]) -> Vec<Scored> {
    let n = joint.n_obs();
    let proj = JacobianComplementProjector::from_parts(&fit.jac, &fit.white, n);
    let views: Vec<Fit> = (0..joint.members.len())
        .map(|m| joint.member_view(fit, m))
        .collect();
    let total = fit.white.len();
    todo.par_iter()
        .filter_map(|&term| {
            let readers: Vec<usize> = (0..joint.members.len())
                .filter(|&m| joint.reads(&term, m))
                .collect();
            let per: Vec<_> = readers
                .iter()
                .map(|&m| variants(&joint.members[m].ctx, &views[m], term.kind))
                .collect();
            let nv = per.first()?.len();
            if nv == 0 || per.iter().any(|v| v.len() != nv) {
                return None;
            }
            let mut best: Option<Scored> = None;
            for v in 0..nv {
                let ncols = per[0][v].0.len();
                let cols: Vec<DVector<f64>> = (0..ncols)
                    .map(|c| {
                        let mut big = vec![0.0; total];
                        for (r, &m) in readers.iter().enumerate() {
                            let raw = &per[r][v].0[c];
                            let at = joint.rows[m];
                            joint.members[m]
                                .ctx
                                .plan
                                .whiten(raw, &mut big[at..at + raw.len()]);
                        }
                        DVector::from_vec(big)
                    })
                    .collect();
                let Some((lm, beta, cos)) = proj.test(&cols, one_sided(term.kind)) else {
                    continue;
                };
                let ps = term.kind.params();
                let start: Vec<f64> = if term.kind == EffectKind::Gravity {
                    // the columns are sin q and cos q: β is (A, B) itself
                    beta.iter()
                        .map(|b| b.clamp(ps[0].lower, ps[0].upper))
                        .collect()
                } else {
                    let vals = (per[0][v].1)(&beta);
                    ps.iter()
                        .zip(vals)
                        .map(|(p, x)| x.clamp(p.lower, p.upper))
                        .collect()
                };
                let s = Scored {
                    term,
                    lm,
                    evidence: lm - ncols as f64 * (n as f64).ln(),
                    cos,
                    start,
                };
                if best.as_ref().is_none_or(|b| s.lm > b.lm) {
                    best = Some(s);
                }
            }
            best
        })
        .collect()
}

/// How many Gauss–Newton standard errors `√(s²(JᵀJ)⁻¹)` the last term of `fit` lies from
/// its null (the largest over its parameters; 0 when the information is singular).
fn significance(fit: &JointFit, n: usize) -> f64 {
    let Some(i) = fit.layout.terms.len().checked_sub(1) else {
        return 0.0;
    };
    let t = fit.layout.terms[i];
    let s2 = fit.white_ss / n.saturating_sub(fit.k()).max(1) as f64;
    let Some(cov) = fit.jac.tr_mul(&fit.jac).try_inverse() else {
        return 0.0;
    };
    let null = t.kind.null_values();
    fit.layout
        .slots(i)
        .enumerate()
        .map(|(j, s)| {
            // a gravity term's linear coordinates are 0 at its null
            let at = if t.kind == EffectKind::Gravity {
                0.0
            } else {
                null[j]
            };
            let se = (s2 * cov[(s, s)]).sqrt();
            if se > 0.0 {
                (fit.x[s] - at).abs() / se
            } else {
                0.0
            }
        })
        .fold(0.0, f64::max)
}
