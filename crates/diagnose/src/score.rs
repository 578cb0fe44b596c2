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

fn one_sided(kind: EffectKind) -> bool {
    matches!(
        kind,
        EffectKind::PassiveJointTorque
            | EffectKind::ElectromechanicalDelay
            | EffectKind::Fatigue
            | EffectKind::AntagonistCoactivation
    )
}

/// Raw (unwhitened) sensitivity variants of a candidate: each is (columns, maps β → values).
fn variants(
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

    fn perp(&self, v: &DVector<f64>) -> DVector<f64> {
        let c = self.q.tr_mul(v);
        v - &self.q * c
    }

    /// (LM, β, cos to span(J)) for whitened columns.
    fn test(&self, cols: &[DVector<f64>], one_sided: bool) -> Option<(f64, Vec<f64>, f64)> {
        let p = cols.len();
        let pc: Vec<DVector<f64>> = cols.iter().map(|c| self.perp(c)).collect();
        let mut a = DMatrix::zeros(p, p);
        let mut b = DVector::zeros(p);
        for i in 0..p {
            b[i] = pc[i].dot(&self.r);
            for j in 0..p {
                a[(i, j)] = pc[i].dot(&pc[j]);
            }
        }
        let beta = a.clone().cholesky()?.solve(&b);
        let mut lm = b.dot(&beta) / self.s2;
        let mut beta_v: Vec<f64> = beta.iter().copied().collect();
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

/// Scores every eligible candidate not yet in `fit`.
pub(crate) fn score_all(ctx: &Context, fit: &Fit, eligible: &[EffectKind]) -> Vec<Score> {
    let proj = Projector::new(ctx, fit);
    let n = proj.n;
    let todo: Vec<EffectKind> = eligible
        .iter()
        .copied()
        .filter(|k| !fit.kinds.contains(k))
        .collect();
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
