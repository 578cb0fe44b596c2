//! Which effects the model names: greedy forward selection of the candidate effects, the
//! joint fit of two that only generalise together, and the exchange pass that lets a later
//! effect replace an earlier one (docs/diagnosis.md). The rules that judge one fit against
//! another are in [`crate::rules`].

use std::collections::BTreeMap;
use std::ops::ControlFlow;

use muscle_model::{EffectKind, ParamId};
use rayon::prelude::*;

use crate::estimates::effect_values;
use crate::fit::{Context, Fit};
use crate::progress::{notify, DiagnosisProgress, DiagnosisStage};
use crate::rules::{clear_of_null, generalises, judge, near_tie, replaces, simpler_tie, Refit};
use crate::score;
use crate::{CandidateReport, DiagnoseError, DiagnoseSettings, NearTie};

/// The outcome of the selection.
pub(crate) struct Selection {
    /// The model without effects: the baseline fit, or a refit of it from a candidate's values
    /// that fits better.
    pub baseline: Fit,
    /// The final model.
    pub model: Fit,
    /// Every candidate ranked, by effect.
    pub reports: BTreeMap<EffectKind, CandidateReport>,
    /// Effects nearly collinear with the model's parameters and not named.
    pub confounded: Vec<String>,
    /// Near ties of each named cause.
    pub ties: BTreeMap<EffectKind, Vec<NearTie>>,
}

/// Selects the effects of the model, starting from `baseline` with the `eligible` candidates;
/// the simulations spent are added to `evaluations`.
///
/// Each round ranks the candidates by their score test on the current residual, refits the
/// leaders, and accepts the best that passes the held-out and ΔBIC rules; with two or more
/// causes the exchange pass follows.
pub(crate) fn select(
    ctx: &Context,
    mut baseline: Fit,
    eligible: &[EffectKind],
    settings: &DiagnoseSettings,
    nobs: usize,
    observer: &mut dyn FnMut(&DiagnosisProgress) -> ControlFlow<()>,
    evaluations: &mut usize,
) -> Result<Selection, DiagnoseError> {
    let mut current = baseline.clone();
    let mut reports: BTreeMap<EffectKind, CandidateReport> = BTreeMap::new();
    // near ties of each cause, from the round that named it (replaced by the exchange pass's)
    let mut ties: BTreeMap<EffectKind, Vec<NearTie>> = BTreeMap::new();
    for round in 0..settings.max_effects {
        notify(
            observer,
            DiagnosisStage::Round(round),
            format!("round {}: ranking extensions", round + 1),
            *evaluations,
        )?;
        let mut scores = score::score_all(ctx, &current, eligible);
        *evaluations += 4 * scores.len();
        scores.sort_by(|a, b| b.evidence.total_cmp(&a.evidence));
        record_scores(&scores, round, settings, &mut reports);
        let leaders = leaders(&scores, settings, rms_decides(ctx));
        if leaders.is_empty() {
            break;
        }
        let fits: Vec<Fit> = refit_leaders(ctx, &current, &current.kinds, &leaders, evaluations)?
            .into_iter()
            .map(|(f, _)| f)
            .collect();
        // Judge the candidates against the current fit. Before one is accepted, the current
        // model is refitted from the leader's values of its own parameters: when that beats
        // the current fit, part of the leader's gain was a better optimum of parameters the
        // current model already has (e.g. a delay of 3 ms on a no-effect trial), so the
        // current fit is replaced and the candidates are judged again.
        let mut rechecked = false;
        let best = loop {
            let judged: Vec<Refit> = fits.iter().map(|f| judge(f, &current, nobs)).collect();
            let passing = passing(&judged, &mut reports, settings, nobs, rms_decides(ctx));
            let Some(lead) = passing.first() else {
                break None;
            };
            let lead_ties = |lead: &Refit| -> Vec<NearTie> {
                passing[1..]
                    .iter()
                    .filter_map(|r| near_tie(lead.kind, lead.fit, r.kind, r.fit, settings, nobs))
                    .collect()
            };
            if rechecked {
                ties.insert(lead.kind, lead_ties(lead));
                break Some(lead.kind);
            }
            rechecked = true;
            let x0: Vec<f64> = current
                .free
                .iter()
                .map(|id| {
                    let i = lead.fit.free.iter().position(|f| f == id);
                    i.map_or(0.0, |i| lead.fit.x[i])
                })
                .collect();
            // a start the model cannot be differentiated at (a finite difference that leaves
            // the region it simulates in) is no better optimum: the leader stands
            let alt = match ctx.fit_from(&current.kinds, &[x0], true) {
                Ok(a) => a,
                Err(DiagnoseError::Fit { .. }) | Err(DiagnoseError::Model(_)) => {
                    ties.insert(lead.kind, lead_ties(lead));
                    break Some(lead.kind);
                }
                Err(e) => return Err(e),
            };
            *evaluations += alt.evaluations;
            if alt.white_ss < current.white_ss {
                if current.kinds.is_empty() {
                    baseline = alt.clone();
                }
                current = alt;
                continue;
            }
            ties.insert(lead.kind, lead_ties(lead));
            break Some(lead.kind);
        };
        let Some(best_kind) = best else {
            // No single extension generalises, but two may only together: each alone leaves
            // the other's error in the held-out cycles (a delay with fatigue). The two with the
            // strongest in-sample evidence are fitted jointly and both accepted when the pair
            // passes against the current model and each of its halves.
            if settings.pairs && current.kinds.len() + 2 <= settings.max_effects {
                let (pair, ev) = joint_pair(ctx, &current, &fits, settings, nobs, &reports)?;
                *evaluations += ev;
                if let Some(pair) = pair {
                    for k in &pair.kinds[current.kinds.len()..] {
                        if let Some(rep) = reports.get_mut(k) {
                            rep.accepted = true;
                        }
                    }
                    current = pair;
                    continue;
                }
            }
            break;
        };
        let Some(best) = fits
            .into_iter()
            .find(|f| f.kinds.last() == Some(&best_kind))
        else {
            break;
        };
        if let Some(rep) = reports.get_mut(&best_kind) {
            rep.accepted = true;
        }
        current = best;
    }
    if settings.exchange && current.kinds.len() >= 2 {
        notify(
            observer,
            DiagnosisStage::Round(settings.max_effects),
            "checking each cause against the alternatives".into(),
            *evaluations,
        )?;
        let (fit, ev) = exchange(
            ctx,
            current,
            eligible,
            settings,
            nobs,
            &mut reports,
            &mut ties,
        )?;
        *evaluations += ev;
        current = fit;
    }
    let confounded = confounded_of(&mut reports);
    Ok(Selection {
        baseline,
        model: current,
        reports,
        confounded,
        ties,
    })
}

/// Enters the round's score tests into the candidates' reports; a candidate nearly collinear
/// with the model's parameters and still asked for by the residual is refitted like the
/// others, and reported as confounded unless accepted.
fn record_scores(
    scores: &[score::Score],
    round: usize,
    settings: &DiagnoseSettings,
    reports: &mut BTreeMap<EffectKind, CandidateReport>,
) {
    for s in scores {
        let conf = s.cos_baseline > settings.confound_cos && s.lm >= settings.min_score_lm;
        reports.insert(
            s.kind,
            CandidateReport {
                effect: s.kind.name().into(),
                evidence: s.evidence,
                score_lm: s.lm,
                heldout_rms_nm: None,
                delta_bic: None,
                heldout_gain_pct: None,
                heldout_dev_gain: None,
                cos_to_model: s.cos_baseline,
                round,
                accepted: false,
                confounded: conf,
                fitted: None,
                detection_limit: None,
                detection_limit_shape: None,
            },
        );
    }
}

/// Whether the held-out RMS must fall too (`rules::generalises`): the noise model was fitted
/// to the trial's own residual.
fn rms_decides(ctx: &Context) -> bool {
    ctx.noise.source == crate::noise::NoiseModelSource::TrialResidual
}

/// The refits that pass the held-out, ΔBIC and null rules against the current model, best
/// first (their judgements also enter the candidates' reports).
fn passing<'a>(
    judged: &'a [Refit<'a>],
    reports: &mut BTreeMap<EffectKind, CandidateReport>,
    settings: &DiagnoseSettings,
    nobs: usize,
    rms_decides: bool,
) -> Vec<&'a Refit<'a>> {
    let mut passing: Vec<&Refit> = Vec::new();
    for r in judged {
        if let Some(rep) = reports.get_mut(&r.kind) {
            rep.heldout_rms_nm = Some(r.fit.heldout_rms);
            rep.delta_bic = Some(r.delta_bic);
            rep.heldout_gain_pct = Some(r.gain_pct);
            rep.heldout_dev_gain = Some(r.dev_gain);
            rep.fitted = Some(effect_values(r.fit, r.kind));
        }
        let clear = clear_of_null(r.fit, r.kind, reports, settings, nobs);
        if generalises(r, settings, rms_decides) && r.delta_bic < settings.max_delta_bic && clear {
            passing.push(r);
        }
    }
    // Without an unloaded run the held-out RMS a user measures ranks the passing candidates;
    // with one the deviance under the independent noise model does, through the BIC.
    if rms_decides {
        passing.sort_by(|a, b| a.fit.heldout_rms.total_cmp(&b.fit.heldout_rms));
    } else {
        passing.sort_by(|a, b| a.delta_bic.total_cmp(&b.delta_bic));
    }
    // Parsimony: a passing candidate with fewer parameters that the data cannot tell
    // from the best one leads instead (the fewest parameters, then the first in the ranking
    // above).
    if let Some(first) = passing.first().copied() {
        if let Some(i) = (1..passing.len())
            .filter(|&i| simpler_tie(passing[i].fit, first.fit, settings, nobs))
            .min_by_key(|&i| (passing[i].fit.k(), i))
        {
            let r = passing.remove(i);
            passing.insert(0, r);
        }
    }
    passing
}

/// The confounded candidates not accepted, by name; an accepted candidate is no longer
/// reported as confounded.
fn confounded_of(reports: &mut BTreeMap<EffectKind, CandidateReport>) -> Vec<String> {
    let mut confounded: Vec<String> = Vec::new();
    for rep in reports.values_mut() {
        if rep.confounded && !rep.accepted && !confounded.contains(&rep.effect) {
            confounded.push(rep.effect.clone());
        }
        if rep.accepted {
            rep.confounded = false;
        }
    }
    confounded
}

/// The joint fit of the two refits of a round with the lowest ΔBIC below the margin (when no
/// single one passed): returned when it passes the held-out and ΔBIC rules against `current`
/// and its BIC also beats each single refit by the margin (both halves are needed), with the
/// simulations spent.
fn joint_pair(
    ctx: &Context,
    current: &Fit,
    fits: &[Fit],
    settings: &DiagnoseSettings,
    nobs: usize,
    reports: &BTreeMap<EffectKind, CandidateReport>,
) -> Result<(Option<Fit>, usize), DiagnoseError> {
    let mut strong: Vec<&Fit> = fits
        .iter()
        .filter(|f| f.bic(nobs) - current.bic(nobs) < settings.max_delta_bic)
        .collect();
    strong.sort_by(|a, b| a.bic(nobs).total_cmp(&b.bic(nobs)));
    let [a, b] = match strong.as_slice() {
        [a, b, ..] => [*a, *b],
        _ => return Ok((None, 0)),
    };
    let (ka, kb) = (
        *a.kinds.last().expect("a refit adds an effect"),
        *b.kinds.last().expect("a refit adds an effect"),
    );
    let mut kinds = current.kinds.clone();
    kinds.extend([ka, kb]);
    let mut x0 = current.x.clone();
    for (f, k) in [(a, ka), (b, kb)] {
        x0.extend(
            f.free
                .iter()
                .zip(&f.x)
                .filter(|(id, _)| matches!(id, ParamId::Effect(e, _) if *e == k))
                .map(|(_, v)| *v),
        );
    }
    let pair = match ctx.fit(&kinds, &x0, true) {
        Ok(f) => f,
        Err(DiagnoseError::Fit { .. }) | Err(DiagnoseError::Model(_)) => return Ok((None, 0)),
        Err(e) => return Err(e),
    };
    let ev = pair.evaluations;
    let r = judge(&pair, current, nobs);
    let halves = [a, b]
        .iter()
        .all(|f| pair.bic(nobs) - f.bic(nobs) < settings.max_delta_bic);
    let clear = [ka, kb]
        .iter()
        .all(|k| clear_of_null(&pair, *k, reports, settings, nobs));
    let passes = generalises(&r, settings, rms_decides(ctx))
        && r.delta_bic < settings.max_delta_bic
        && halves
        && clear;
    Ok((passes.then_some(pair), ev))
}

/// The exchange pass over a model with two or more effects (forward selection is greedy: an
/// effect accepted early can stand in for two that come later, e.g. a gravity term fitted to
/// an offset while a fatigue drift was still missing, and is then kept).
///
/// Each cause of the forward rounds in turn is dropped, the rest refitted, and one forward
/// round run on that model (scores, then refits of the leaders other than the dropped cause).
/// The best refit replaces the model when its held-out error is not higher and its BIC is
/// lower by more than the ΔBIC margin ([`DiagnoseSettings::max_delta_bic`]), or lower at all
/// when it has fewer parameters (an offset for a two-parameter gravity term). The other
/// refits within the margin are recorded in `ties` as near ties of the cause. Returns the
/// final model and the simulations spent.
fn exchange(
    ctx: &Context,
    mut current: Fit,
    eligible: &[EffectKind],
    settings: &DiagnoseSettings,
    nobs: usize,
    reports: &mut BTreeMap<EffectKind, CandidateReport>,
    ties: &mut BTreeMap<EffectKind, Vec<NearTie>>,
) -> Result<(Fit, usize), DiagnoseError> {
    let mut evaluations = 0;
    for dropped in current.kinds.clone() {
        let rest: Vec<EffectKind> = current
            .kinds
            .iter()
            .copied()
            .filter(|k| *k != dropped)
            .collect();
        let x0: Vec<f64> = current
            .free
            .iter()
            .zip(&current.x)
            .filter(|(id, _)| !matches!(id, ParamId::Effect(k, _) if *k == dropped))
            .map(|(_, v)| *v)
            .collect();
        let reduced = ctx.fit(&rest, &x0, false)?;
        evaluations += reduced.evaluations;
        let mut scores: Vec<score::Score> = score::score_all(ctx, &reduced, eligible)
            .into_iter()
            .filter(|s| s.kind != dropped && !rest.contains(&s.kind))
            .collect();
        evaluations += 4 * scores.len();
        scores.sort_by(|a, b| b.evidence.total_cmp(&a.evidence));
        let leaders = leaders(&scores, settings, rms_decides(ctx));
        let mut alts = refit_leaders(ctx, &reduced, &rest, &leaders, &mut evaluations)?;
        // by the same margin as an added effect, or as a simpler model the data cannot tell
        // from the current one (an offset for a gravity term); other alternatives within the
        // margins are near ties
        let mut best: Option<usize> = None;
        for (i, (f, _)) in alts.iter().enumerate() {
            if replaces(f, &current, settings, nobs)
                && best.is_none_or(|b| f.bic(nobs) < alts[b].0.bic(nobs))
            {
                best = Some(i);
            }
        }
        let Some(best) = best else {
            let found = alts
                .iter()
                .filter_map(|(f, s)| near_tie(dropped, &current, s.kind, f, settings, nobs))
                .collect();
            ties.insert(dropped, found);
            continue;
        };
        let (fit, s) = alts.swap_remove(best);
        ties.remove(&dropped);
        // the replaced model is a near tie of the new one when it is within the margin
        let found = std::iter::once((&current, dropped))
            .chain(alts.iter().map(|(f, a)| (f, a.kind)))
            .filter_map(|(f, k)| near_tie(s.kind, &fit, k, f, settings, nobs))
            .collect();
        ties.insert(s.kind, found);
        if let Some(rep) = reports.get_mut(&dropped) {
            rep.accepted = false;
        }
        if let Some(rep) = reports.get_mut(&s.kind) {
            rep.accepted = true;
            rep.evidence = s.evidence;
            rep.score_lm = s.lm;
            rep.heldout_rms_nm = Some(fit.heldout_rms);
            rep.delta_bic = Some(fit.bic(nobs) - reduced.bic(nobs));
            // the dropped-cause model was not cross-validated
            rep.heldout_gain_pct = None;
            rep.heldout_dev_gain = None;
            rep.fitted = Some(effect_values(&fit, s.kind));
        }
        current = fit;
    }
    Ok((current, evaluations))
}

/// The leaders of a ranking sorted by evidence: the candidates whose score statistic reaches
/// [`DiagnoseSettings::min_score_lm`], as many as [`DiagnoseSettings::refits`] allows.
fn leaders<'s>(
    scores: &'s [score::Score],
    settings: &DiagnoseSettings,
    rms_decides: bool,
) -> Vec<&'s score::Score> {
    scores
        .iter()
        .filter(|s| s.lm >= settings.min_score_lm)
        .take(settings.refits(rms_decides))
        .collect()
}

/// The refits of `from` (the model of effects `kinds`) with each leader added, in parallel,
/// each started where its score test puts the effect, with the leader's score. A refit that
/// cannot be fitted or simulated drops out (its candidate stays unrefitted); any other error
/// stops the diagnosis. The simulations spent are added to `evaluations`.
fn refit_leaders<'s>(
    ctx: &Context,
    from: &Fit,
    kinds: &[EffectKind],
    leaders: &[&'s score::Score],
    evaluations: &mut usize,
) -> Result<Vec<(Fit, &'s score::Score)>, DiagnoseError> {
    let refits: Vec<Result<Fit, DiagnoseError>> = leaders
        .par_iter()
        .map(|s| {
            let mut kinds = kinds.to_vec();
            kinds.push(s.kind);
            ctx.fit(&kinds, &score::extended_start(from, s), true)
        })
        .collect();
    let mut fits = Vec::new();
    for (r, s) in refits.into_iter().zip(leaders) {
        match r {
            Ok(f) => {
                *evaluations += f.evaluations;
                fits.push((f, *s));
            }
            Err(DiagnoseError::Fit { .. }) | Err(DiagnoseError::Model(_)) => {}
            Err(e) => return Err(e),
        }
    }
    Ok(fits)
}
