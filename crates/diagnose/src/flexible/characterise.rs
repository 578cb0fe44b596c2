//! The ranking of the vocabulary and the extension of the final model.
//!
//! When the residual keeps structure, every variable's term is added to the final model,
//! cross-validated on the same folds (0.5 s blocks, `time_folds`), and ranked by its held-out
//! deviance gain `G_v = D(model) − D(model + term)` on them; the fall of the held-out RMS
//! `R_v = 1 − RMS(model + term)/RMS(model)` is reported beside it. `depends_on` holds the best
//! variable whose `G_v` exceeds
//! [`DiagnoseSettings::min_flexible_gain`](crate::DiagnoseSettings::min_flexible_gain)
//! (`direction` before `velocity` unless the velocity's term beats it by the BIC margin
//! [`flexible_margin_bic`](crate::DiagnoseSettings::flexible_margin_bic)), and the next when
//! adding it to the first gains `min_flexible_gain` again. The extension with the terms of
//! `depends_on` is cross-validated as the model is (a term in time on the blocks, any other on
//! the trial's own folds), so that its held-out RMS is the error `validate` measures.
//!
//! Every term is ranked on the blocks because a term in time has to be: a whole cycle held out
//! can only be extrapolated into by hats in time. Ranked on the trial's folds, the other terms'
//! gains would be measured against a different reference (the final model's held-out deviance
//! is larger on the blocks), and a term in time can then come first while predicting worse
//! than the term in the variable the structure lives in (generated trial 63 717 492, a
//! function of the velocity: `G` 1 043 for time on the blocks at a held-out RMS of 2.32 N·m,
//! 993 for the velocity on the cycles at 1.64 N·m; on the blocks the velocity gains 1 333).
//! The deviance, not the RMS, orders them: a function of the velocity that lives in the ramps
//! is a small part of the RMS and a large part of the whitened residual.

use muscle_model::EffectKind;
use rayon::prelude::*;

use crate::fit::{Context, Fit};
use crate::DiagnoseError;

use super::basis::{basis, by_direction, variables_of, FlexBasis};
use super::fit::{combine, cross_validate, fit_flexible, terms_of, time_folds, FlexFit, Folds};
use super::forms::with_searched_forms;
use super::report::{FlexibleExtension, Replacement, Unexplained, VariableGain};
use super::review::review;
use super::variable::StateVariable;

/// The ranking of the vocabulary on the final model `fin` and its extension (module docs).
pub(crate) struct Characterisation {
    pub unexplained: Unexplained,
    /// Named causes that the extension makes unnecessary (to be dropped by the caller, who
    /// then characterises the smaller model again).
    pub unneeded: Vec<Replacement>,
    pub evaluations: usize,
}

/// Ranks the vocabulary's flexible terms on the final model `fin` and extends it with the best
/// one or two (module docs); `catalogued` are the effects eligible on this trial.
pub(crate) fn characterise(
    ctx: &Context,
    fin: &Fit,
    catalogued: &[EffectKind],
    replaced: Vec<Replacement>,
    min_gain: f64,
    margin_bic: f64,
    nobs: usize,
) -> Result<Characterisation, DiagnoseError> {
    let mut evaluations = 0;
    let resid: Vec<f64> = ctx.y.iter().zip(&fin.pred).map(|(a, b)| a - b).collect();
    // each variable's forms, and the angle's, acceleration's and activation's hats fitted
    // separately in the two directions of motion (a product with the direction, which the
    // vocabulary test flags on the same split, is told by the variable it multiplies)
    let bases: Vec<FlexBasis> = StateVariable::ALL
        .iter()
        .filter_map(|v| basis(ctx, *v))
        .flat_map(|b| {
            let split = by_direction(ctx, &b);
            with_searched_forms(ctx, b, &resid, Some(&fin.jac))
                .into_iter()
                .chain(split)
        })
        .collect();
    let blocks = time_folds(ctx);
    let problem = ctx.problem(&fin.kinds)?;
    let (block_rms, block_dev, ev) = cross_validate(ctx, &blocks, &problem, &fin.x, &[], 0.0);
    evaluations += ev;
    let reference = Reference {
        ctx,
        fin,
        blocks,
        block_rms,
        block_dev,
    };
    let fits = ranked_fits(&reference, &bases, &mut evaluations);
    let ranking: Vec<VariableGain> = fits
        .iter()
        .map(|f| VariableGain {
            variable: f.bases[0].variable,
            by_direction: f.bases[0].by_direction,
            heldout_deviance_gain: reference.ranked_gain(f),
            heldout_rms_nm: f.model.heldout_rms,
            heldout_rms_reduction_pct: 100.0 * reference.ranked_rms_fall(f),
            delta_bic: f.bic(nobs) - fin.bic(nobs),
            parameters: f.rank,
        })
        .collect();
    let chosen = chosen_terms(
        &reference,
        &fits,
        min_gain,
        (margin_bic, nobs),
        &mut evaluations,
    );
    let mut catalogued_shape = None;
    let mut unneeded = Vec::new();
    let extension = match &chosen {
        None => None,
        Some(chosen) => {
            let ff = fit_flexible(
                ctx,
                &fin.kinds,
                &fin.x,
                chosen,
                Some(reference.folds_of(chosen)),
                true,
            )?;
            evaluations += ff.model.evaluations;
            // a named cause the extension makes unnecessary is not named either
            if let Ok((u, ev)) = review(ctx, &ff.model, ff.bic(nobs), chosen, margin_bic, nobs) {
                evaluations += ev;
                unneeded = u;
            }
            let (shape, ev) = catalogued_shape_of(
                &reference,
                chosen[0].variable,
                &fits,
                catalogued,
                &replaced,
                margin_bic,
                nobs,
            );
            evaluations += ev;
            catalogued_shape = shape;
            Some(extension_of(&reference, &ff, nobs))
        }
    };
    Ok(Characterisation {
        unexplained: Unexplained {
            depends_on: chosen.map(|c| variables_of(&c)).unwrap_or_default(),
            ranking,
            extension,
            catalogued_shape,
            replaced,
        },
        unneeded,
        evaluations,
    })
}

/// The final model's held-out errors under each fold scheme: the ranking and a term in time
/// on the time blocks, the extension by any other term on the trial's own folds.
struct Reference<'a> {
    ctx: &'a Context,
    fin: &'a Fit,
    blocks: Folds,
    block_rms: f64,
    block_dev: f64,
}

impl Reference<'_> {
    /// The folds on which the extension with the terms `b` is cross-validated.
    fn folds_of(&self, b: &[FlexBasis]) -> &Folds {
        if uses_time(b) {
            &self.blocks
        } else {
            &self.ctx.folds
        }
    }

    /// The final model's held-out (RMS, deviance) on the folds of `b`.
    fn errors(&self, b: &[FlexBasis]) -> (f64, f64) {
        if uses_time(b) {
            (self.block_rms, self.block_dev)
        } else {
            (self.fin.heldout_rms, self.fin.heldout_dev)
        }
    }

    /// The held-out deviance gain of the extension `f` over the final model.
    fn gain(&self, f: &FlexFit) -> f64 {
        self.errors(&f.bases).1 - f.model.heldout_dev
    }

    /// The held-out deviance gain of a ranked fit `f` (cross-validated on the blocks).
    fn ranked_gain(&self, f: &FlexFit) -> f64 {
        self.block_dev - f.model.heldout_dev
    }

    /// The fall of the held-out RMS that a ranked fit `f` brings, as a fraction of the final
    /// model's on the blocks.
    fn ranked_rms_fall(&self, f: &FlexFit) -> f64 {
        rms_fall(f.model.heldout_rms, self.block_rms)
    }
}

/// `1 − with/without`, the fall of a held-out RMS (0 when there was none to lower).
fn rms_fall(with: f64, without: f64) -> f64 {
    if without > 0.0 {
        1.0 - with / without
    } else {
        0.0
    }
}

fn uses_time(b: &[FlexBasis]) -> bool {
    b.iter().any(|x| x.variable == StateVariable::Time)
}

/// Each of `bases` added alone to the final model and cross-validated on the blocks, best
/// held-out deviance gain first, one per variable.
fn ranked_fits(
    reference: &Reference<'_>,
    bases: &[FlexBasis],
    evaluations: &mut usize,
) -> Vec<FlexFit> {
    let (ctx, fin) = (reference.ctx, reference.fin);
    let fits: Vec<Result<FlexFit, DiagnoseError>> = bases
        .par_iter()
        .map(|b| {
            fit_flexible(
                ctx,
                &fin.kinds,
                &fin.x,
                std::slice::from_ref(b),
                Some(&reference.blocks),
                false,
            )
        })
        .collect();
    // a variable whose term cannot be fitted (the model fails to simulate) is left out
    let mut fits: Vec<FlexFit> = fits.into_iter().flatten().collect();
    *evaluations += fits.iter().map(|f| f.model.evaluations).sum::<usize>();
    fits.sort_by(|a, b| {
        reference
            .ranked_gain(b)
            .total_cmp(&reference.ranked_gain(a))
    });
    // time with its hats alone, with a step and with a sinusoid, direction with and without
    // its searched width: the best form stands for the variable
    let mut seen = Vec::new();
    fits.retain(|f| {
        let v = f.bases[0].variable;
        let first = !seen.contains(&v);
        seen.push(v);
        first
    });
    fits
}

/// The terms of the extension: the best that generalises, and the next when adding it to the
/// first gains that much again (`None` when no term generalises).
fn chosen_terms(
    reference: &Reference<'_>,
    fits: &[FlexFit],
    min_gain: f64,
    (margin_bic, nobs): (f64, usize),
    evaluations: &mut usize,
) -> Option<Vec<FlexBasis>> {
    let (ctx, fin) = (reference.ctx, reference.fin);
    // The terms that generalise (held-out deviance gain above the threshold), best first; the
    // sign of the velocity before a function of the velocity that does not beat it by the BIC
    // margin (the coarser explanation, module docs).
    let mut eligible: Vec<&FlexFit> = fits
        .iter()
        .filter(|f| reference.ranked_gain(f) > min_gain)
        .collect();
    let at = |v: StateVariable, e: &[&FlexFit]| e.iter().position(|f| f.bases[0].variable == v);
    if let (Some(iv), Some(id)) = (
        at(StateVariable::Velocity, &eligible),
        at(StateVariable::Direction, &eligible),
    ) {
        if iv < id && eligible[id].bic(nobs) - eligible[iv].bic(nobs) < margin_bic {
            let d = eligible.remove(id);
            eligible.insert(iv, d);
        }
    }
    let mut chosen: Option<Vec<FlexBasis>> = None;
    if let Some(first) = eligible.first() {
        chosen = Some(first.bases.clone());
        if let Some(second) = eligible.get(1) {
            // the pair's gain over the first alone, on the blocks as the ranking
            let pair = vec![first.bases[0].clone(), second.bases[0].clone()];
            if let Ok(both) = fit_flexible(
                ctx,
                &fin.kinds,
                &first.model.x,
                &pair,
                Some(&reference.blocks),
                false,
            ) {
                *evaluations += both.model.evaluations;
                if first.model.heldout_dev - both.model.heldout_dev > min_gain {
                    chosen = Some(pair);
                }
            }
        }
    }
    chosen
}

/// The catalogued effect of the extension's best variable `top` that explains it as well after
/// all, by the naming rule: its BIC beats a flexible term in each of its own variables by the
/// margin (an effect already replaced lost that comparison); with the simulations spent.
fn catalogued_shape_of(
    reference: &Reference<'_>,
    top: StateVariable,
    fits: &[FlexFit],
    catalogued: &[EffectKind],
    replaced: &[Replacement],
    margin_bic: f64,
    nobs: usize,
) -> (Option<String>, usize) {
    let (ctx, fin) = (reference.ctx, reference.fin);
    let mut evaluations = 0;
    let single_bic = |v: StateVariable| {
        fits.iter()
            .find(|f| f.bases[0].variable == v)
            .map(|f| f.bic(nobs))
    };
    let mut best: Option<(EffectKind, f64)> = None;
    for &k in catalogued.iter().filter(|k| {
        !fin.kinds.contains(k)
            && !replaced.iter().any(|r| r.effect == k.name())
            && StateVariable::of_effect(**k).contains(&top)
    }) {
        let mut kinds = fin.kinds.clone();
        kinds.push(k);
        let mut x0 = fin.x.clone();
        x0.extend(k.null_values().iter().take(k.params().len()));
        if let Ok(cf) = ctx.fit(&kinds, &x0, false) {
            evaluations += cf.evaluations;
            let d = StateVariable::of_effect(k)
                .iter()
                .filter_map(|v| single_bic(*v))
                .fold(f64::INFINITY, f64::min)
                - cf.bic(nobs);
            if d >= margin_bic && best.is_none_or(|(_, b)| d > b) {
                best = Some((k, d));
            }
        }
    }
    (best.map(|(k, _)| k.name().to_string()), evaluations)
}

/// The report of the extension `ff` of the final model.
fn extension_of(reference: &Reference<'_>, ff: &FlexFit, nobs: usize) -> FlexibleExtension {
    let cols: Vec<&Vec<f64>> = ff.bases.iter().flat_map(|b| b.cols.iter()).collect();
    FlexibleExtension {
        variables: ff.variables(),
        heldout_rms_nm: ff.model.heldout_rms,
        heldout_rms_reduction_pct: 100.0
            * rms_fall(ff.model.heldout_rms, reference.errors(&ff.bases).0),
        heldout_deviance_gain: reference.gain(ff),
        rms_nm: ff.model.rms,
        delta_bic: ff.bic(nobs) - reference.fin.bic(nobs),
        terms: terms_of(ff),
        term_nm: combine(&cols, &ff.beta, reference.ctx.y.len()),
    }
}
