//! A small bounded Levenberg–Marquardt for whitened least squares with a finite-difference Jacobian.
//!
//! Minimises `‖r(x)‖²` over a box. Steps are taken in unit-box coordinates
//! `z = (x − l)/(u − l)`; each iteration solves
//! `(JᵀJ + λ·diag(JᵀJ)) δ = −Jᵀr` on the free coordinates (a coordinate at a bound whose
//! gradient points outwards is held), clamps `z + δ` into `[0, 1]`, and accepts it when the
//! cost decreases (`λ ← λ/3`), else `λ ← 4λ`. The Jacobian columns are forward differences
//! (`h = 10⁻³` of the range, backwards at the upper bound), evaluated in parallel; the result
//! does not depend on the number of threads.

use nalgebra::{DMatrix, DVector};
use rayon::prelude::*;

/// Settings of [`minimise`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LmSettings {
    /// Maximum number of Jacobian evaluations.
    pub max_iterations: usize,
    /// Finite-difference step in unit-box coordinates.
    pub fd_step: f64,
    /// Stop when an accepted step lowers the cost by less than this fraction.
    pub ftol_rel: f64,
    /// Initial damping.
    pub lambda0: f64,
}

impl Default for LmSettings {
    fn default() -> Self {
        LmSettings {
            max_iterations: 30,
            fd_step: 1e-3,
            ftol_rel: 1e-7,
            lambda0: 1e-3,
        }
    }
}

/// Result of [`minimise`].
#[derive(Clone, Debug)]
pub struct LmOutcome {
    /// Best point.
    pub x: Vec<f64>,
    /// `‖r(x)‖²`.
    pub cost: f64,
    /// Residual at `x`.
    pub residual: Vec<f64>,
    /// Jacobian `∂r/∂x` (x units) at the last linearisation point (`x` unless the last step
    /// was accepted without relinearising).
    pub jacobian: DMatrix<f64>,
    /// Residual evaluations used.
    pub evaluations: usize,
    /// Iterations (Jacobians).
    pub iterations: usize,
}

/// Finite-difference Jacobian (x units) of `f` at `x` with residual `r0`.
pub fn jacobian<F>(
    f: &F,
    x: &[f64],
    r0: &[f64],
    bounds: &[(f64, f64)],
    h: f64,
) -> Option<DMatrix<f64>>
where
    F: Fn(&[f64]) -> Option<Vec<f64>> + Sync,
{
    let p = x.len();
    let n = r0.len();
    let cols: Vec<Option<Vec<f64>>> = (0..p)
        .into_par_iter()
        .map(|j| {
            let (lo, hi) = bounds[j];
            let mut step = h * (hi - lo);
            if x[j] + step > hi {
                step = -step;
            }
            let mut xp = x.to_vec();
            xp[j] += step;
            let r = f(&xp)?;
            Some(r.iter().zip(r0).map(|(a, b)| (a - b) / step).collect())
        })
        .collect();
    let mut jm = DMatrix::zeros(n, p);
    for (j, c) in cols.into_iter().enumerate() {
        let c = c?;
        jm.set_column(j, &DVector::from_vec(c));
    }
    Some(jm)
}

/// Minimises `‖f(x)‖²` from `x0` inside `bounds`; `None` if `f` fails at `x0`.
pub fn minimise<F>(f: &F, x0: &[f64], bounds: &[(f64, f64)], s: &LmSettings) -> Option<LmOutcome>
where
    F: Fn(&[f64]) -> Option<Vec<f64>> + Sync,
{
    let p = x0.len();
    let width: Vec<f64> = bounds.iter().map(|(l, u)| u - l).collect();
    let mut x: Vec<f64> = x0
        .iter()
        .zip(bounds)
        .map(|(v, (l, u))| v.clamp(*l, *u))
        .collect();
    let mut r = f(&x)?;
    let mut cost: f64 = r.iter().map(|v| v * v).sum();
    let mut evals = 1;
    let mut lambda = s.lambda0;
    let mut iterations = 0;
    let mut jac = jacobian(f, &x, &r, bounds, s.fd_step)?;
    evals += p;
    'outer: while iterations < s.max_iterations {
        iterations += 1;
        // unit-box Jacobian
        let mut jz = jac.clone();
        for j in 0..p {
            let mut c = jz.column_mut(j);
            c *= width[j];
        }
        let jtj = jz.tr_mul(&jz);
        let g = jz.tr_mul(&DVector::from_column_slice(&r));
        let z: Vec<f64> = (0..p).map(|j| (x[j] - bounds[j].0) / width[j]).collect();
        let free: Vec<usize> = (0..p)
            .filter(|&j| !((z[j] <= 0.0 && g[j] > 0.0) || (z[j] >= 1.0 && g[j] < 0.0)))
            .collect();
        if free.is_empty() {
            break;
        }
        let m = free.len();
        loop {
            let mut a = DMatrix::zeros(m, m);
            let mut b = DVector::zeros(m);
            for (ii, &i) in free.iter().enumerate() {
                b[ii] = -g[i];
                for (jj, &j) in free.iter().enumerate() {
                    a[(ii, jj)] = jtj[(i, j)];
                }
                a[(ii, ii)] += lambda * jtj[(i, i)].max(1e-12);
            }
            let Some(d) = a.cholesky().map(|c| c.solve(&b)) else {
                lambda *= 4.0;
                if lambda > 1e12 {
                    break 'outer;
                }
                continue;
            };
            let mut xn = x.clone();
            for (ii, &i) in free.iter().enumerate() {
                let zn = (z[i] + d[ii]).clamp(0.0, 1.0);
                xn[i] = bounds[i].0 + zn * width[i];
            }
            let rn = f(&xn);
            evals += 1;
            let cn = rn
                .as_ref()
                .map_or(f64::INFINITY, |v| v.iter().map(|e| e * e).sum::<f64>());
            if cn.is_finite() && cn < cost {
                let gain = (cost - cn) / cost.max(1e-300);
                x = xn;
                r = rn.unwrap_or_default();
                cost = cn;
                lambda = (lambda / 3.0).max(1e-9);
                if gain < s.ftol_rel {
                    break 'outer;
                }
                match jacobian(f, &x, &r, bounds, s.fd_step) {
                    Some(j) => jac = j,
                    None => break 'outer,
                }
                evals += p;
                break;
            }
            lambda *= 4.0;
            if lambda > 1e10 {
                break 'outer;
            }
        }
    }
    Some(LmOutcome {
        x,
        cost,
        residual: r,
        jacobian: jac,
        evaluations: evals,
        iterations,
    })
}
