//! The ranking of the vocabulary and the extension of the final model.
//!
//! When the residual keeps structure, every variable's term is added to the
//! final model and ranked by its held-out deviance gain `G_v = D(model) − D(model + term)`;
//! `depends_on` holds the best variable whose `G_v` exceeds
//! [`DiagnoseSettings::min_flexible_gain`](crate::DiagnoseSettings::min_flexible_gain)
//! (`direction` before `velocity` when it reaches 80 % of the velocity term's gain), and the
//! next when adding it to the first gains that much again.

use muscle_model::EffectKind;
use rayon::prelude::*;

use crate::fit::{Context, Fit};
use crate::DiagnoseError;

use super::basis::{basis, FlexBasis};
use super::fit::{combine, cross_validate, fit_flexible, terms_of, time_folds, FlexFit, Folds};
use super::forms::with_searched_forms;
use super::report::{FlexibleExtension, Replacement, Unexplained, VariableGain};
use super::review::review;
use super::variable::StateVariable;

/// Share of the velocity term's held-out gain the direction term must reach to be reported
/// before it.
const COARSER_SHARE: f64 = 0.8;

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
    let bases: Vec<FlexBasis> = StateVariable::ALL
        .iter()
        .filter_map(|v| basis(ctx, *v))
        .flat_map(|b| with_searched_forms(ctx, b, &resid, Some(&fin.jac)))
        .collect();
    let blocks = time_folds(ctx);
    let problem = ctx.problem(&fin.kinds)?;
    let (block_rms, block_dev, ev) = cross_validate(ctx, &blocks, &problem, &fin.x, &[]);
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
            heldout_deviance_gain: reference.gain(f),
            heldout_rms_nm: f.model.heldout_rms,
            delta_bic: f.bic(nobs) - fin.bic(nobs),
            parameters: f.rank,
        })
        .collect();
    let chosen = chosen_terms(&reference, &fits, min_gain, &mut evaluations);
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
            depends_on: chosen
                .map(|c| c.iter().map(|b| b.variable).collect())
                .unwrap_or_default(),
            ranking,
            extension,
            catalogued_shape,
            replaced,
        },
        unneeded,
        evaluations,
    })
}

/// The final model's held-out errors under each fold scheme: a term in time is compared on
/// the time blocks, every other term on the trial's own folds.
struct Reference<'a> {
    ctx: &'a Context,
    fin: &'a Fit,
    blocks: Folds,
    block_rms: f64,
    block_dev: f64,
}

impl Reference<'_> {
    /// The folds on which a model with the terms `b` is cross-validated.
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

    /// The held-out deviance gain of `f` over the final model.
    fn gain(&self, f: &FlexFit) -> f64 {
        self.errors(&f.bases).1 - f.model.heldout_dev
    }
}

fn uses_time(b: &[FlexBasis]) -> bool {
    b.iter().any(|x| x.variable == StateVariable::Time)
}

/// Each of `bases` added alone to the final model, best held-out gain first, one per variable.
fn ranked_fits(
    reference: &Reference<'_>,
    bases: &[FlexBasis],
    evaluations: &mut usize,
) -> Vec<FlexFit> {
    let (ctx, fin) = (reference.ctx, reference.fin);
    let fits: Vec<Result<FlexFit, DiagnoseError>> = bases
        .par_iter()
        .map(|b| {
            let one = std::slice::from_ref(b);
            fit_flexible(
                ctx,
                &fin.kinds,
                &fin.x,
                one,
                Some(reference.folds_of(one)),
                false,
            )
        })
        .collect();
    // a variable whose term cannot be fitted (the model fails to simulate) is left out
    let mut fits: Vec<FlexFit> = fits.into_iter().flatten().collect();
    *evaluations += fits.iter().map(|f| f.model.evaluations).sum::<usize>();
    fits.sort_by(|a, b| reference.gain(b).total_cmp(&reference.gain(a)));
    // time with and without its step, direction with and without its searched width: the
    // better of the two stands for the variable
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
    evaluations: &mut usize,
) -> Option<Vec<FlexBasis>> {
    let (ctx, fin) = (reference.ctx, reference.fin);
    let gain = |f: &FlexFit| reference.gain(f);
    // The terms that generalise (held-out gain above the threshold), best first; the sign of
    // the velocity before a function of the velocity that gains at most a fifth more (the
    // coarser explanation, module docs).
    let mut eligible: Vec<&FlexFit> = fits.iter().filter(|f| gain(f) > min_gain).collect();
    let at = |v: StateVariable, e: &[&FlexFit]| e.iter().position(|f| f.bases[0].variable == v);
    if let (Some(iv), Some(id)) = (
        at(StateVariable::Velocity, &eligible),
        at(StateVariable::Direction, &eligible),
    ) {
        if iv < id && gain(eligible[id]) >= COARSER_SHARE * gain(eligible[iv]) {
            let d = eligible.remove(id);
            eligible.insert(iv, d);
        }
    }
    let mut chosen: Option<Vec<FlexBasis>> = None;
    if let Some(first) = eligible.first() {
        chosen = Some(first.bases.clone());
        if let Some(second) = eligible.get(1) {
            let pair = vec![first.bases[0].clone(), second.bases[0].clone()];
            let both = fit_flexible(
                ctx,
                &fin.kinds,
                &first.model.x,
                &pair,
                Some(reference.folds_of(&pair)),
                false,
            );
            // the pair's gain over the first alone, on the same folds
            let first_dev = if uses_time(&pair) && !uses_time(&first.bases) {
                fit_flexible(
                    ctx,
                    &fin.kinds,
                    &first.model.x,
                    &first.bases,
                    Some(&reference.blocks),
                    false,
                )
                .map(|again| {
                    *evaluations += again.model.evaluations;
                    again.model.heldout_dev
                })
                .unwrap_or(f64::NAN)
            } else {
                first.model.heldout_dev
            };
            if let Ok(both) = both {
                *evaluations += both.model.evaluations;
                if first_dev - both.model.heldout_dev > min_gain {
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
            * (1.0 - ff.model.heldout_rms / reference.errors(&ff.bases).0),
        heldout_deviance_gain: reference.gain(ff),
        rms_nm: ff.model.rms,
        delta_bic: ff.bic(nobs) - reference.fin.bic(nobs),
        terms: terms_of(ff),
        term_nm: combine(&cols, &ff.beta, reference.ctx.y.len()),
    }
}
