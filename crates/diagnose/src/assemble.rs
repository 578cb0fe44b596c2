//! The report of a diagnosis: every model's parameters with their uncertainty, the effects'
//! values, and the diagnosis assembled from the selection and the residual analysis
//! (docs/formats.md describes the fields).
//!
//! A parameter's uncertainty is the half-width of its 68 % profile-likelihood interval when
//! one was computed, else its Laplace standard error (`estimates` computes both).

use std::collections::BTreeMap;

use muscle_model::{EffectKind, ParamId};

use crate::estimates::standard_errors;
use crate::fit::{Context, Fit};
use crate::profile::ProfileInterval;
use crate::selection::Selection;
use crate::{
    CandidateReport, DiagnoseSettings, Diagnosis, Gain, ModelReport, NearTie, ParamInterval,
    ResidualAnalysis, Unexplained, Verdict,
};

/// The diagnosis of the selected model: verdict, named causes and their near ties, the
/// candidates (accepted first, then by evidence), the baseline's and the final model's reports
/// and the gain between them. `wall_s` is left at zero for the caller to set.
pub(crate) fn diagnosis(
    ctx: Context,
    selection: Selection,
    ra: ResidualAnalysis,
    unexplained: Option<Unexplained>,
    intervals: &[(usize, ProfileInterval)],
    settings: &DiagnoseSettings,
    evaluations: usize,
) -> Diagnosis {
    let nobs = ctx.plan.n_obs();
    let Selection {
        baseline,
        model: current,
        reports,
        confounded,
        mut ties,
    } = selection;
    let structure = ra.structure_evidence > settings.structure_threshold || unexplained.is_some();
    let causes: Vec<String> = current.kinds.iter().map(|k| k.name().to_string()).collect();
    let verdict = if causes.is_empty() && !structure {
        Verdict::Adequate
    } else {
        Verdict::Deficient
    };
    let near_ties: Vec<NearTie> = current
        .kinds
        .iter()
        .filter_map(|k| ties.remove(k))
        .flatten()
        .filter(|t| !causes.contains(&t.alternative))
        .collect();
    let mut candidates: Vec<CandidateReport> = reports.into_values().collect();
    candidates.sort_by(|a, b| {
        b.accepted
            .cmp(&a.accepted)
            .then(b.evidence.total_cmp(&a.evidence))
    });
    // the baseline's own intervals only when it is the final model
    let base_intervals: &[(usize, ProfileInterval)] = if current.kinds.is_empty() {
        intervals
    } else {
        &[]
    };
    let base_rep = model_report(&baseline, nobs, false, base_intervals);
    let ext_rep = model_report(&current, nobs, true, intervals);
    let gain = Gain {
        heldout_rms_reduction_pct: 100.0 * (1.0 - current.heldout_rms / baseline.heldout_rms),
        heldout_deviance_reduction: baseline.heldout_dev - current.heldout_dev,
        delta_bic: current.bic(nobs) - baseline.bic(nobs),
        delta_log_likelihood: current.loglik - baseline.loglik,
        rms_reduction_pct: 100.0 * (1.0 - current.rms / baseline.rms),
    };
    Diagnosis {
        verdict,
        causes,
        unexplained_structure: structure,
        unexplained,
        baseline: base_rep,
        extended: ext_rep,
        gain,
        candidates,
        confounded,
        near_ties,
        noise: ctx.noise,
        cv_folds: settings.cv_folds.describe_for(
            ctx.seg.cycles.len(),
            ctx.inputs.len(),
            ctx.inputs.fs(),
        ),
        residual_analysis: ra,
        evaluations,
        wall_s: 0.0,
        not_testable: Vec::new(),
        emg_crosstalk: Vec::new(),
        emg_correction: None,
        held_out_shape: None,
        given_params: None,
    }
}

/// Reports a gravity term with its phase in `[−90°, 90°)`: `m·sin(q − φ)` equals
/// `(−m)·sin(q − φ ∓ 180°)`, and the fit lands on either form; the one whose phase is nearest
/// zero reads as "a weight of moment `m` at angle `φ`" (the moment's interval is negated and
/// its ends swapped, the phase's shifted by the half turn).
fn canonical_gravity(
    effects: &mut BTreeMap<String, BTreeMap<String, f64>>,
    intervals: &mut BTreeMap<String, BTreeMap<String, ParamInterval>>,
) {
    let name = EffectKind::Gravity.name();
    let Some(g) = effects.get_mut(name) else {
        return;
    };
    let (Some(&m), Some(&phi)) = (g.get("moment_nm"), g.get("phase_deg")) else {
        return;
    };
    let shift = if phi >= 90.0 {
        -180.0
    } else if phi < -90.0 {
        180.0
    } else {
        return;
    };
    g.insert("moment_nm".into(), -m);
    g.insert("phase_deg".into(), phi + shift);
    if let Some(iv) = intervals.get_mut(name) {
        if let Some(m) = iv.get_mut("moment_nm") {
            *m = ParamInterval {
                lower: -m.upper,
                upper: -m.lower,
                lower_at_bound: m.upper_at_bound,
                upper_at_bound: m.lower_at_bound,
                laplace_se: m.laplace_se,
            };
        }
        if let Some(p) = iv.get_mut("phase_deg") {
            p.lower += shift;
            p.upper += shift;
        }
    }
}

/// The report of `fit`; a parameter with a profile interval in `intervals` gets its
/// half-width as uncertainty (else the Laplace standard error).
fn model_report(
    fit: &Fit,
    nobs: usize,
    extended: bool,
    intervals: &[(usize, ProfileInterval)],
) -> ModelReport {
    let se = standard_errors(fit, nobs);
    let mut params = BTreeMap::new();
    let mut punc = BTreeMap::new();
    let mut effects: BTreeMap<String, BTreeMap<String, f64>> = BTreeMap::new();
    let mut eunc: BTreeMap<String, BTreeMap<String, f64>> = BTreeMap::new();
    let mut eint: BTreeMap<String, BTreeMap<String, ParamInterval>> = BTreeMap::new();
    let mut pint: BTreeMap<String, ParamInterval> = BTreeMap::new();
    let interval = |j: usize| intervals.iter().find(|(ix, _)| *ix == j).map(|(_, iv)| iv);
    for (j, ((id, v), s)) in fit.free.iter().zip(&fit.x).zip(&se).enumerate() {
        match id {
            ParamId::Effect(k, i) => {
                let pn = k.params()[*i].name.to_string();
                effects
                    .entry(k.name().into())
                    .or_default()
                    .insert(pn.clone(), *v);
                let iv = interval(j);
                let unc = iv.map_or(*s, |iv| iv.half_width());
                eunc.entry(k.name().into())
                    .or_default()
                    .insert(pn.clone(), unc);
                if let Some(iv) = iv {
                    eint.entry(k.name().into())
                        .or_default()
                        .insert(pn, ParamInterval::new(iv, *s));
                }
            }
            _ => {
                params.insert(id.name(), *v);
                let iv = interval(j);
                punc.insert(id.name(), iv.map_or(*s, |iv| iv.half_width()));
                if let Some(iv) = iv {
                    pint.insert(id.name(), ParamInterval::new(iv, *s));
                }
            }
        }
    }
    canonical_gravity(&mut effects, &mut eint);
    ModelReport {
        effects: extended.then_some(effects),
        params,
        rms_nm: fit.rms,
        heldout_rms_nm: fit.heldout_rms,
        log_likelihood: fit.loglik,
        bic: fit.bic(nobs),
        n_params: fit.k(),
        effect_uncertainty: extended.then_some(eunc),
        effect_interval: extended.then_some(eint),
        param_interval: (!intervals.is_empty()).then_some(pint),
        param_uncertainty: punc,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn iv(lower: f64, upper: f64, lower_at_bound: bool) -> ParamInterval {
        ParamInterval {
            lower,
            upper,
            lower_at_bound,
            upper_at_bound: false,
            laplace_se: 0.5,
        }
    }

    #[test]
    fn gravity_is_reported_with_its_phase_near_zero() {
        let g = |m: f64, phi: f64| {
            let e = BTreeMap::from([(
                "gravity".to_string(),
                BTreeMap::from([("moment_nm".to_string(), m), ("phase_deg".to_string(), phi)]),
            )]);
            let i = BTreeMap::from([(
                "gravity".to_string(),
                BTreeMap::from([
                    ("moment_nm".to_string(), iv(m - 1.0, m + 2.0, true)),
                    ("phase_deg".to_string(), iv(phi - 3.0, phi + 4.0, false)),
                ]),
            )]);
            (e, i)
        };
        for (m, phi, want_phi) in [(6.0, 178.0, -2.0), (6.0, -175.0, 5.0), (6.0, 90.0, -90.0)] {
            let (mut e, mut i) = g(m, phi);
            canonical_gravity(&mut e, &mut i);
            assert_eq!(e["gravity"]["moment_nm"], -m);
            assert_eq!(e["gravity"]["phase_deg"], want_phi);
            let im = i["gravity"]["moment_nm"];
            assert_eq!((im.lower, im.upper), (-m - 2.0, -m + 1.0));
            assert!(!im.lower_at_bound && im.upper_at_bound);
            let ip = i["gravity"]["phase_deg"];
            assert_eq!((ip.lower, ip.upper), (want_phi - 3.0, want_phi + 4.0));
            // the term itself is unchanged
            for q in [-0.3_f64, 0.0, 0.4] {
                let before = m * (q - phi.to_radians()).sin();
                let after = -m * (q - want_phi.to_radians()).sin();
                assert!((before - after).abs() < 1e-12);
            }
        }
        // already canonical: untouched
        let (mut e, mut i) = g(-4.0, 10.0);
        let (e0, i0) = (e.clone(), i.clone());
        canonical_gravity(&mut e, &mut i);
        assert_eq!((e, i), (e0, i0));
    }
}
