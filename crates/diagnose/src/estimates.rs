//! What a fit says about its own parameters: the effects' fitted values, the Laplace standard
//! errors `√diag(s²(JᵀJ)⁻¹)` with `s² = max(1, ‖r‖²/(n − p))` on the whitened residual `r`,
//! an effect's significance against its null, and the 68 % profile-likelihood intervals.
//!
//! The assembly of the report, the selection and its rules all read these; they live apart
//! from all three so that none of them imports another for them.

use std::collections::BTreeMap;

use muscle_model::{EffectKind, ParamId};

use crate::fit::{Context, Fit};
use crate::profile::{ProfileInterval, ProfileSettings};
use crate::DiagnoseError;

/// The fitted values of effect `kind`'s parameters in `fit`, by parameter name.
pub(crate) fn effect_values(fit: &Fit, kind: EffectKind) -> BTreeMap<String, f64> {
    let mut m = BTreeMap::new();
    for (id, v) in fit.free.iter().zip(&fit.x) {
        if let ParamId::Effect(k, i) = id {
            if *k == kind {
                m.insert(kind.params()[*i].name.to_string(), *v);
            }
        }
    }
    m
}

/// Largest `|θ − null|/SE` over the effect's parameters in a fit.
pub(crate) fn effect_significance(fit: &Fit, kind: EffectKind, nobs: usize) -> f64 {
    let se = standard_errors(fit, nobs);
    let null = kind.null_values();
    fit.free
        .iter()
        .zip(&fit.x)
        .zip(&se)
        .filter_map(|((id, v), s)| match id {
            ParamId::Effect(k, i) if *k == kind && *s > 0.0 => Some((v - null[*i]).abs() / s),
            _ => None,
        })
        .fold(0.0, f64::max)
}

/// Scale of the whitened residual, `s² = max(1, ‖r‖²/(n − p))` (1 when the noise model is right).
pub(crate) fn residual_scale(fit: &Fit, nobs: usize) -> f64 {
    (fit.white_ss / (nobs - fit.k()).max(1) as f64).max(1.0)
}

/// The 68 % profile-likelihood interval of every parameter of `fit` (index into `fit.x`,
/// interval), computed in parallel; the first step out is the Laplace standard error.
///
/// The Laplace standard errors `√diag(s²(JᵀJ)⁻¹)` of the pennation angles and tendon slack
/// lengths are far too small: the cost is flat along curved valleys in which the muscles
/// trade off against each other, and the forward-difference Jacobian sees only the local
/// curvature. On `diag_one 20240609 '{"antagonist_coactivation":{"gain_nm":9.32}}' --ta` sol
/// α0 has a Laplace SE of 0.16° against an MCMC posterior SD of 1.74° and a profile half-width
/// of 1.82° (docs/diagnosis.md).
pub(crate) fn profile_intervals(
    ctx: &Context,
    fit: &Fit,
    nobs: usize,
    settings: &ProfileSettings,
) -> Result<Vec<(usize, ProfileInterval)>, DiagnoseError> {
    ctx.profiles(
        fit,
        residual_scale(fit, nobs),
        &standard_errors(fit, nobs),
        settings,
    )
}

/// The Laplace standard errors `√diag(s²(JᵀJ)⁻¹)` of `fit`'s parameters (a pseudo-inverse
/// when `JᵀJ` is singular; NaN when that fails too).
pub(crate) fn standard_errors(fit: &Fit, nobs: usize) -> Vec<f64> {
    let jtj = fit.jac.tr_mul(&fit.jac);
    let p = fit.k();
    let s2 = residual_scale(fit, nobs);
    match jtj.clone().try_inverse() {
        Some(inv) => (0..p).map(|i| (s2 * inv[(i, i)]).max(0.0).sqrt()).collect(),
        None => {
            let svd = jtj.svd(true, true);
            match svd.pseudo_inverse(1e-12) {
                Ok(inv) => (0..p).map(|i| (s2 * inv[(i, i)]).max(0.0).sqrt()).collect(),
                Err(_) => vec![f64::NAN; p],
            }
        }
    }
}
