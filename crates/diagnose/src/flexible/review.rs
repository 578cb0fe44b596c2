//! No false story: a named catalogued effect `e` stays named only when the model with it
//! beats, by [`DiagnoseSettings::flexible_margin_bic`](crate::DiagnoseSettings::flexible_margin_bic)
//! in BIC, the model without it but with a flexible term in each variable its shape lives in
//! ([`StateVariable::of_effect`]), in time also a ramp (`simplest_in_time`: twelve hats
//! would cost eleven parameters more than fatigue's rate);
//! otherwise the flexible term is reported instead. Once the
//! extension is known the review runs again with the extension's terms added to both sides,
//! and the extension alone (the model without the effect and with no other term) is one more
//! alternative: a cause that only helps the extension along is not named.

use rayon::prelude::*;

use crate::fit::{Context, Fit};
use crate::DiagnoseError;

use super::basis::{basis, FlexBasis};
use super::fit::{fit_flexible, without_effects, FlexFit};
use super::forms::{simplest_in_time, with_searched_forms};
use super::report::Replacement;
use super::variable::StateVariable;

/// For each effect of `model` (or only those in `only`), the model without it plus a flexible
/// term in each of `vars(effect)` (or `extra` added to every model, and `extra` alone as one
/// more alternative). Returns the effects a
/// flexible alternative beats (`BIC(with) > BIC(without + term) − margin`) and the
/// simulations spent. `reference` is the model they are compared with (its BIC).
pub(super) fn review(
    ctx: &Context,
    model: &Fit,
    reference_bic: f64,
    extra: &[FlexBasis],
    margin_bic: f64,
    nobs: usize,
) -> Result<(Vec<Replacement>, usize), DiagnoseError> {
    let mut out = Vec::new();
    let mut evaluations = 0;
    for &kind in &model.kinds {
        let (kinds, x) = without_effects(model, &[kind]);
        // a step in time, or the width of a change of direction, is searched on what the
        // model without the effect leaves
        let searched = [StateVariable::Time, StateVariable::Direction];
        let resid: Vec<f64> = if StateVariable::of_effect(kind)
            .iter()
            .any(|v| searched.contains(v))
        {
            let pred = ctx.problem(&kinds)?.predict(&x)?;
            ctx.y.iter().zip(&pred).map(|(a, b)| a - b).collect()
        } else {
            Vec::new()
        };
        // each of its own variables' terms, beside the extension's (when not among them)
        let mut alternatives: Vec<Vec<FlexBasis>> = StateVariable::of_effect(kind)
            .iter()
            .filter_map(|v| basis(ctx, *v))
            .flat_map(|b| {
                // the extension's own term stands for its variable
                if extra.iter().any(|e| e.variable == b.variable) {
                    vec![b]
                } else if b.variable == StateVariable::Time {
                    let mut v = simplest_in_time(ctx);
                    v.extend(with_searched_forms(ctx, b, &resid, None));
                    v
                } else {
                    with_searched_forms(ctx, b, &resid, None)
                }
            })
            .map(|b| {
                let mut set = extra.to_vec();
                if !set.iter().any(|e| e.variable == b.variable) {
                    set.push(b);
                }
                set
            })
            .collect();
        // the extension alone, without the effect: a cause that only helps the extension's
        // term along is not needed (an electromechanical delay beside a slipping strap's term
        // in time, trial 9 503 010: the extension alone is 2.9 in BIC better)
        if !extra.is_empty() && !alternatives.iter().any(|a| a.len() == extra.len()) {
            alternatives.push(extra.to_vec());
        }
        let fits: Vec<Result<FlexFit, DiagnoseError>> = alternatives
            .par_iter()
            .map(|b| fit_flexible(ctx, &kinds, &x, b, None, false))
            .collect();
        let mut best: Option<(StateVariable, f64)> = None;
        // an alternative that cannot be fitted does not replace anything
        for f in fits.into_iter().flatten() {
            evaluations += f.model.evaluations;
            let d = reference_bic - f.bic(nobs);
            if best.is_none_or(|(_, b)| d > b) {
                best = Some((f.bases.last().expect("a term").variable, d));
            }
        }
        if let Some((variable, d)) = best {
            // named only when BIC(with the effect) ≤ BIC(flexible instead) − margin
            if d > -margin_bic {
                out.push(Replacement {
                    effect: kind.name().to_string(),
                    variable,
                    delta_bic: d,
                });
            }
        }
    }
    Ok((out, evaluations))
}

/// The no-false-story review of the selected causes (module docs): for each named effect, the
/// model without it plus a flexible term in each of its own variables.
pub(crate) fn review_causes(
    ctx: &Context,
    model: &Fit,
    margin_bic: f64,
    nobs: usize,
) -> Result<(Vec<Replacement>, usize), DiagnoseError> {
    review(ctx, model, model.bic(nobs), &[], margin_bic, nobs)
}
