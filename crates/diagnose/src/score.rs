//! Cheap ranking of the candidate extensions: the score (Lagrange-multiplier) test from each extension's sensitivity at its null value.
//!
//! With `r` the whitened residual of the current fit, `J` its whitened Jacobian (QR: `J = QR`)
//! and `S` the whitened sensitivity columns of a candidate at its null value,
//! `P⊥ = I − QQᵀ`, `β = (SᵀP⊥S)⁻¹SᵀP⊥r`, the statistic is
//! `LM = rᵀP⊥S·β / s²`, `s² = rᵀr/(n − m)`, ≈ χ²(p) under the null. The *evidence*
//! `LM − p·ln n` approximates the BIC gain of adding the candidate. One-sided extensions
//! (`scale ≥ 0`, `delay ≥ 0`, `rate ≥ 0`, `gain ≥ 0`) score 0 when `β` points outside.
//! The confounding measure is the cosine between the candidate's fitted direction `Sβ` and
//! `span(J)`.

use muscle_model::EffectKind;
use nalgebra::{DMatrix, DVector};
use rayon::prelude::*;

use crate::fit::{Context, Fit};

/// Stiffness grid (1/rad) over which the passive joint torque is profiled.
pub const PASSIVE_STIFFNESS_GRID: [f64; 6] = [3.0, 5.0, 8.0, 11.0, 15.0, 20.0];

/// The score of one candidate.
#[derive(Clone, Debug)]
pub(crate) struct Score {
    pub kind: EffectKind,
    pub lm: f64,
    pub evidence: f64,
    pub cos_baseline: f64,
    /// Start values of the effect's parameters (one Gauss–Newton step from the null).
    pub start: [f64; 2],
}

pub(crate) fn one_sided(kind: EffectKind) -> bool {
    matches!(
        kind,
        EffectKind::PassiveJointTorque
            | EffectKind::ElectromechanicalDelay
            | EffectKind::Fatigue
            | EffectKind::AntagonistCoactivation
    )
}

/// Raw (unwhitened) sensitivity variants of a candidate: each is (columns, maps β → values).
pub(crate) fn variants(
    ctx: &Context,
    fit: &Fit,
    kind: EffectKind,
) -> Vec<(Vec<Vec<f64>>, Box<dyn Fn(&[f64]) -> [f64; 2] + Sync>)> {
    let q = ctx.inputs.angle();
    let sim_diff = |v: [f64; 2], index: usize, delta: f64, central: bool| -> Option<Vec<f64>> {
        let mut kinds = fit.kinds.clone();
        kinds.push(kind);
        let problem = ctx.problem(&kinds).ok()?;
        let mut x = fit.x.clone();
        let np = kind.params().len();
        x.extend_from_slice(&v[..np]);
        let base_i = fit.x.len() + index;
        let mut xp = x.clone();
        xp[base_i] += delta;
        let p1 = problem.predict(&xp).ok()?;
        let p0 = if central {
            let mut xm = x.clone();
            xm[base_i] -= delta;
            problem.predict(&xm).ok()?
        } else {
            fit.pred.clone()
        };
        let d = if central { 2.0 * delta } else { delta };
        Some(p1.iter().zip(&p0).map(|(a, b)| (a - b) / d).collect())
    };
    let null = kind.null_values();
    match kind {
        EffectKind::TorqueOffset => {
            vec![(vec![vec![1.0; q.len()]], Box::new(|b: &[f64]| [b[0], 0.0]))]
        }
        EffectKind::PassiveJointTorque => PASSIVE_STIFFNESS_GRID
            .iter()
            .map(|&k| {
                let col: Vec<f64> = q.iter().map(|a| (k * a).exp() - 1.0).collect();
                let f: Box<dyn Fn(&[f64]) -> [f64; 2] + Sync> =
                    Box::new(move |b: &[f64]| [b[0], k]);
                (vec![col], f)
            })
            .collect(),
        EffectKind::Gravity => vec![(
            vec![
                q.iter().map(|a| a.sin()).collect(),
                q.iter().map(|a| a.cos()).collect(),
            ],
            Box::new(|b: &[f64]| [b[0].hypot(b[1]), (-b[1]).atan2(b[0]).to_degrees()]),
        )],
        EffectKind::ElectromechanicalDelay => sim_diff(null, 0, 10.0, false)
            .map(|c| {
                vec![(
                    vec![c],
                    Box::new(|b: &[f64]| [b[0], 0.0]) as Box<dyn Fn(&[f64]) -> [f64; 2] + Sync>,
                )]
            })
            .unwrap_or_default(),
        EffectKind::Fatigue => sim_diff(null, 0, 0.005, false)
            .map(|c| {
                vec![(
                    vec![c],
                    Box::new(|b: &[f64]| [b[0], 0.0]) as Box<dyn Fn(&[f64]) -> [f64; 2] + Sync>,
                )]
            })
            .unwrap_or_default(),
        EffectKind::AntagonistCoactivation => sim_diff(null, 0, 10.0, false)
            .map(|c| {
                vec![(
                    vec![c],
                    Box::new(|b: &[f64]| [b[0], 0.0]) as Box<dyn Fn(&[f64]) -> [f64; 2] + Sync>,
                )]
            })
            .unwrap_or_default(),
        EffectKind::EccentricEnhancement => sim_diff(null, 0, 0.05, true)
            .map(|c| {
                vec![(
                    vec![c],
                    Box::new(|b: &[f64]| [1.4 + b[0], 0.0])
                        as Box<dyn Fn(&[f64]) -> [f64; 2] + Sync>,
                )]
            })
            .unwrap_or_default(),
        EffectKind::ViscousDamping => vec![(
            vec![ctx.inputs.velocity().to_vec()],
            Box::new(|b: &[f64]| [b[0], 0.0]),
        )],
        EffectKind::Inertia => vec![(
            vec![ctx.inputs.acceleration().iter().map(|a| -a).collect()],
            Box::new(|b: &[f64]| [b[0], 0.0]),
        )],
    }
}

/// Whitened projection machinery of one fit.
pub(crate) struct Projector {
    q: DMatrix<f64>,
    r: DVector<f64>,
    s2: f64,
    n: usize,
}

impl Projector {
    pub fn new(ctx: &Context, fit: &Fit) -> Self {
        let n = ctx.plan.n_obs();
        let m = fit.jac.ncols();
        let q = fit.jac.clone().qr().q();
        let r = DVector::from_column_slice(&fit.white);
        let s2 = (r.norm_squared() / (n - m).max(1) as f64).max(1e-12);
        Projector { q, r, s2, n }
    }

    /// The projector of a whitened Jacobian `jac` and residual `white` over `n` observed
    /// samples (a session's trials stacked).
    pub fn from_parts(jac: &DMatrix<f64>, white: &[f64], n: usize) -> Self {
        let m = jac.ncols();
        let q = jac.clone().qr().q();
        let r = DVector::from_column_slice(white);
        let s2 = (r.norm_squared() / (n - m).max(1) as f64).max(1e-12);
        Projector { q, r, s2, n }
    }

    fn perp(&self, v: &DVector<f64>) -> DVector<f64> {
        let c = self.q.tr_mul(v);
        v - &self.q * c
    }

    /// (LM, β, cos to span(J)) for whitened columns.
    pub fn test(&self, cols: &[DVector<f64>], one_sided: bool) -> Option<(f64, Vec<f64>, f64)> {
        let p = cols.len();
        let pc: Vec<DVector<f64>> = cols.iter().map(|c| self.perp(c)).collect();
        let mut a = vec![0.0; p * p];
        let mut b = DVector::zeros(p);
        for i in 0..p {
            b[i] = pc[i].dot(&self.r);
            for j in 0..p {
                a[i * p + j] = pc[i].dot(&pc[j]);
            }
        }
        let mut beta_v: Vec<f64> = b.iter().copied().collect();
        numerics::cholesky::cholesky_solve_in_place(&mut a, &mut beta_v).ok()?;
        let beta = DVector::from_column_slice(&beta_v);
        let mut lm = b.dot(&beta) / self.s2;
        let dir: DVector<f64> = if p == 1 && one_sided && beta[0] < 0.0 {
            lm = 0.0;
            beta_v[0] = 0.0;
            cols[0].clone()
        } else {
            let mut d = DVector::zeros(cols[0].len());
            for i in 0..p {
                d += &cols[i] * beta[i];
            }
            d
        };
        let dn = dir.norm();
        let cos = if dn > 0.0 {
            let inside = &dir - self.perp(&dir);
            inside.norm() / dn
        } else {
            1.0
        };
        Some((lm, beta_v, cos))
    }
}

/// The eligible effects not yet in `fit`.
fn untested(fit: &Fit, eligible: &[EffectKind]) -> Vec<EffectKind> {
    eligible
        .iter()
        .copied()
        .filter(|k| !fit.kinds.contains(k))
        .collect()
}

/// Scores every eligible candidate not yet in `fit`.
pub(crate) fn score_all(ctx: &Context, fit: &Fit, eligible: &[EffectKind]) -> Vec<Score> {
    let proj = Projector::new(ctx, fit);
    let n = proj.n;
    let todo = untested(fit, eligible);
    todo.par_iter()
        .filter_map(|&kind| {
            let vars = variants(ctx, fit, kind);
            let mut best: Option<Score> = None;
            for (cols, map) in vars {
                let wcols: Vec<DVector<f64>> = cols
                    .iter()
                    .map(|c| {
                        let mut w = vec![0.0; c.len()];
                        ctx.plan.whiten(c, &mut w);
                        DVector::from_vec(w)
                    })
                    .collect();
                let Some((lm, beta, cos)) = proj.test(&wcols, one_sided(kind)) else {
                    continue;
                };
                let mut start = map(&beta);
                for (i, ps) in kind.params().iter().enumerate() {
                    start[i] = start[i].clamp(ps.lower, ps.upper);
                }
                let p = cols.len() as f64;
                let s = Score {
                    kind,
                    lm,
                    evidence: lm - p * (n as f64).ln(),
                    cos_baseline: cos,
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

/// Start vector of the extended model: the fit's parameters then the candidate's start values.
pub(crate) fn extended_start(fit: &Fit, s: &Score) -> Vec<f64> {
    let mut x = fit.x.clone();
    let np = s.kind.params().len();
    x.extend_from_slice(&s.start[..np]);
    x
}

/// Stiffness (1/rad) at which the passive joint torque's detection limit is stated.
pub const PASSIVE_LIMIT_STIFFNESS: f64 = 8.0;

/// The noncentrality at which the ΔBIC rule (margin `max_delta_bic`) names an effect of `k`
/// parameters in 95 % of trials on `n_obs` samples ([`crate::power::rule_power`] = 0.95;
/// bisection).
pub(crate) fn lambda_95(k: usize, n_obs: usize, max_delta_bic: f64) -> f64 {
    let (mut lo, mut hi) = (0.0f64, 1.0f64);
    while crate::power::rule_power(hi, k, n_obs, max_delta_bic) < 0.95 {
        hi *= 2.0;
    }
    while hi - lo > 1e-6 * hi {
        let mid = 0.5 * (lo + hi);
        if crate::power::rule_power(mid, k, n_obs, max_delta_bic) < 0.95 {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    0.5 * (lo + hi)
}

/// The smallest size of each eligible effect not in `fit` that the ΔBIC rule would name in
/// 95 % of trials like this one, in the effect's headline units (see
/// [`crate::report::CandidateReport::detection_limit`]).
///
/// An effect of size `θ` hidden in this trial would leave, after the model's own parameters
/// have absorbed what they can, a noncentrality `λ(θ)`: the whitened sum of squares of the
/// fit to the noise-free torque `pred + τ_θ` (`pred` the fit's prediction, `τ_θ` the effect's
/// torque), the quantity [`crate::power::noncentrality`] computes. The ΔBIC rule names it
/// in 95 % of trials when `λ = λ₉₅` ([`lambda_95`], the effect's number of parameters).
/// Two steps per effect:
///
/// 1. linearised at `fit`: `λ(θ) ≈ θ²‖P⊥s‖²`, `s` the whitened sensitivity of the score
///    test, gives `θ₁ = √(λ₉₅/‖P⊥s‖²)`. This is optimistic: the muscle parameters absorb
///    more than their first-order directions (on the antagonist limit trials `5900…5907`,
///    `θ₁` is 0.57–0.71× the limit implied by `power::noncentrality`);
/// 2. the fit's model is refitted from `fit.x` to the noise-free torque with the effect at
///    `θ₁` (Levenberg–Marquardt, up to 60 iterations), and with `λ ∝ θ²` the limit is
///    `θ₁·√(λ₉₅/λ(θ₁))`.
///
/// Directions: gravity with `φ = 0` (`m sin q`), the passive torque at stiffness
/// [`PASSIVE_LIMIT_STIFFNESS`].
pub(crate) fn detection_limits(
    ctx: &Context,
    fit: &Fit,
    eligible: &[EffectKind],
    max_delta_bic: f64,
) -> Vec<(EffectKind, f64, usize)> {
    let proj = Projector::new(ctx, fit);
    let n = proj.n;
    let todo = untested(fit, eligible);
    // λ₉₅ depends only on the number of parameters (1 or 2): found once per number
    let lambdas = [1, 2].map(|k| lambda_95(k, n, max_delta_bic));
    let torque_15 = (PASSIVE_LIMIT_STIFFNESS * crate::scenarios::PASSIVE_REFERENCE_RAD).exp() - 1.0;
    todo.par_iter()
        .filter_map(|&kind| {
            let vars = variants(ctx, fit, kind);
            // the column of the headline direction and the headline per unit of it
            let (col, per_unit) = match kind {
                EffectKind::PassiveJointTorque => {
                    let i = PASSIVE_STIFFNESS_GRID
                        .iter()
                        .position(|k| *k == PASSIVE_LIMIT_STIFFNESS)?;
                    (vars.into_iter().nth(i)?.0.into_iter().next()?, torque_15)
                }
                _ => (vars.into_iter().next()?.0.into_iter().next()?, 1.0),
            };
            let mut w = vec![0.0; col.len()];
            ctx.plan.whiten(&col, &mut w);
            let info = proj.perp(&DVector::from_vec(w)).norm_squared();
            if !(info > 0.0 && info.is_finite()) {
                return None;
            }
            let lambda = match kind.params().len() {
                k @ 1..=2 => lambdas[k - 1],
                k => lambda_95(k, n, max_delta_bic),
            };
            let linear = (lambda / info).sqrt() * per_unit;
            // the effect's parameters at headline size `linear`
            let values: [f64; 2] = match kind {
                EffectKind::PassiveJointTorque => [linear / torque_15, PASSIVE_LIMIT_STIFFNESS],
                EffectKind::EccentricEnhancement => [1.4 + linear, 0.0],
                _ => [linear, 0.0],
            };
            let (refitted, evaluations) = absorbed(ctx, fit, kind, values)?;
            if !(refitted > 0.0 && refitted.is_finite()) {
                return Some((kind, linear, evaluations));
            }
            Some((kind, linear * (lambda / refitted).sqrt(), evaluations))
        })
        .collect()
}

/// `λ`: the whitened sum of squares left when `fit`'s model is refitted (from `fit.x`) to
/// the noise-free torque of `fit` plus effect `kind` at `values`, and the simulations used.
fn absorbed(ctx: &Context, fit: &Fit, kind: EffectKind, values: [f64; 2]) -> Option<(f64, usize)> {
    let mut kinds = fit.kinds.clone();
    kinds.push(kind);
    let with = ctx.problem(&kinds).ok()?;
    let mut x = fit.x.clone();
    x.extend_from_slice(&values[..kind.params().len()]);
    let target = with.predict(&x).ok()?;
    let clean = Context {
        inputs: ctx.inputs.clone(),
        y: target,
        noise: ctx.noise,
        seg: ctx.seg.clone(),
        plan: ctx.plan.clone(),
        folds: Vec::new(),
        lm: numerics::LevenbergMarquardtSettings {
            max_iterations: 60,
            ftol_rel: 1e-10,
            ..ctx.lm
        },
        cv_lm: ctx.cv_lm,
        extended_extra_starts: 0,
        start_seed: ctx.start_seed,
        params: ctx.params,
        effects: ctx.effects,
        observed: ctx.observed.clone(),
    };
    let refit = clean
        .fit_from(&fit.kinds, std::slice::from_ref(&fit.x), false)
        .ok()?;
    Some((refit.white_ss, refit.evaluations + 1))
}
