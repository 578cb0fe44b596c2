//! The sampling coordinates: F0 collapsed onto its exact Gaussian conditional, the rest whitened by a Laplace fit.
//!
//! The joint torque is linear in every muscle's F0 (the normalised tendon force does not depend
//! on it): `τ = Σ_j F0_j·g_j(t; θ) + c(t; θ)`, `θ` the other parameters. With the whitening
//! filter `W` of the noise model, `ỹ = W(y − c)`, `G̃ = W[g_j]`, `A = G̃ᵀG̃ = RRᵀ`,
//! `f̂ = A⁻¹G̃ᵀỹ`, `RSS = ỹᵀỹ − ỹᵀG̃f̂`:
//!
//! `ℓ(θ, f) = N(θ) − ½·RSS(θ) − ½·|Rᵀ(f − f̂)|²`.
//!
//! The sampler runs on `v = (z, u)` with `θ = θ̂ + L_θ·z` (`L_θ` the Cholesky factor of the
//! Laplace covariance of `θ` at the optimum) and `f = c(θ) + R⁻ᵀ·u`, `c` = `f̂` clamped into the
//! bounds (a shift for each `θ`, so the Jacobian is unchanged); then
//! `log π(v) = ℓ + ln|det ∂(θ, f)/∂(z, u)| = N − ½RSS − ½|Rᵀ(c − f̂) + u|² − ln det R + const`:
//! `u` is Gaussian with unit covariance given `θ` (up to the bounds), and near 0 even when the
//! unconstrained `f̂` lies outside the bounds. This removes the curved ridge between
//! F0 and the length parameters that a random walk in `(θ, f)` mixes across very slowly.
//! Outside the bounds the density is 0 (`−∞`).

use std::cell::RefCell;

use muscle_model::{simulate_into, MuscleField, ParamId, Problem, Workspace};

use crate::noise::{Noise, Whitener};
use crate::LogDensity;

/// Largest dimension handled with stack buffers.
const STACK_DIM: usize = 32;

#[derive(Default)]
struct Scratch {
    ws: Workspace,
    total: Vec<f64>,
    y: Vec<f64>,
    yw: Vec<f64>,
    g: [Vec<f64>; 3],
    gw: [Vec<f64>; 3],
}

thread_local! {
    static SCRATCH: RefCell<Scratch> = RefCell::new(Scratch::default());
}

/// A model evaluation in sampling coordinates.
pub(crate) struct Point {
    /// The log target `log π(v)` (with the Jacobian term).
    pub log_target: f64,
    /// The log-likelihood `ℓ(x)`.
    pub log_likelihood: f64,
}

/// The posterior in `(z, u)` coordinates (see the module documentation).
pub(crate) struct Conditional<'a> {
    problem: &'a Problem,
    whitener: Whitener,
    /// Runs `[start, end)` of included samples (the whole trial without weights).
    segments: Vec<(usize, usize)>,
    /// Free-parameter indices of the nonlinear parameters θ.
    nl: Vec<usize>,
    /// `(free index, muscle index)` of the F0 parameters.
    lin: Vec<(usize, usize)>,
    center: Vec<f64>,
    /// Lower Cholesky factor of θ's Laplace covariance, row-major |nl|×|nl|.
    chol_nl: Vec<f64>,
    zbounds: Vec<(f64, f64)>,
}

impl<'a> Conditional<'a> {
    /// Build the target around `center` (inside the bounds) with box half-width `k`.
    /// Returns the target and the simulations used for the Laplace factor.
    pub fn new(problem: &'a Problem, noise: &Noise, center: &[f64], k: f64) -> (Self, u64) {
        let n = problem.measured().len();
        let segments = match problem.weights() {
            None => vec![(0, n)],
            Some(w) => {
                let mut segs = Vec::new();
                let mut i = 0;
                while i < n {
                    if w[i] > 0.0 {
                        let s = i;
                        while i < n && w[i] > 0.0 {
                            i += 1;
                        }
                        segs.push((s, i));
                    } else {
                        i += 1;
                    }
                }
                segs
            }
        };
        let longest = segments.iter().map(|(a, b)| b - a).max().unwrap_or(0);
        let whitener = noise.whitener(longest);
        let mut nl = Vec::new();
        let mut lin = Vec::new();
        for (i, id) in problem.free().iter().enumerate() {
            match id {
                ParamId::Muscle(m, MuscleField::FomN) if problem.bounds()[i].0 > 0.0 => {
                    lin.push((i, m.index()))
                }
                _ => nl.push(i),
            }
        }
        let d = center.len();
        let mut target = Self {
            problem,
            whitener,
            segments,
            nl,
            lin,
            center: center.to_vec(),
            chol_nl: Vec::new(),
            zbounds: vec![(-k, k); d],
        };
        let (chol, sims) = target.laplace_nl();
        target.chol_nl = chol;
        (target, sims)
    }

    /// Whiten `e` segment by segment into `out` (masked samples dropped).
    fn whiten(&self, e: &[f64], out: &mut Vec<f64>) {
        out.clear();
        for &(a, b) in &self.segments {
            let start = out.len();
            out.resize(start + (b - a), 0.0);
            self.whitener.whiten(&e[a..b], &mut out[start..]);
        }
    }

    /// Cholesky factor of θ's block of `(Jᵀ_w J_w + diag(12/w²))⁻¹` at the centre: `J_w` the
    /// whitened Jacobian of the predicted torque (central differences of step `10⁻³·w`,
    /// one-sided at a bound), `diag(12/w²)` the precision of a Gaussian with the uniform
    /// prior's variance. The prior's diagonal if a simulation or a factorisation fails.
    fn laplace_nl(&self) -> (Vec<f64>, u64) {
        let x = &self.center;
        let d = x.len();
        let bounds = self.problem.bounds();
        let widths: Vec<f64> = bounds.iter().map(|(lo, hi)| hi - lo).collect();
        let m = self.nl.len();
        let prior_diag = || {
            let mut l = vec![0.0; m * m];
            for (a, &i) in self.nl.iter().enumerate() {
                l[a * m + a] = widths[i] / 12f64.sqrt();
            }
            l
        };
        let mut sims = 0u64;
        let mut cols: Vec<Vec<f64>> = Vec::with_capacity(d);
        for i in 0..d {
            let h = 1e-3 * widths[i];
            let (lo, hi) = bounds[i];
            let (a, b) = ((x[i] - h).max(lo), (x[i] + h).min(hi));
            let mut xa = x.clone();
            let mut xb = x.clone();
            xa[i] = a;
            xb[i] = b;
            sims += 2;
            let (Ok(pa), Ok(pb)) = (self.problem.predict(&xa), self.problem.predict(&xb)) else {
                return (prior_diag(), sims);
            };
            let diff: Vec<f64> = pb.iter().zip(&pa).map(|(p, q)| (p - q) / (b - a)).collect();
            let mut w = Vec::new();
            self.whiten(&diff, &mut w);
            cols.push(w);
        }
        let mut h = vec![0.0; d * d];
        for i in 0..d {
            for j in 0..=i {
                let v: f64 = cols[i].iter().zip(&cols[j]).map(|(p, q)| p * q).sum();
                h[i * d + j] = v;
                h[j * d + i] = v;
            }
            h[i * d + i] += 12.0 / (widths[i] * widths[i]);
        }
        let Some(cov) = spd_inverse(&h, d) else {
            return (prior_diag(), sims);
        };
        let mut block = vec![0.0; m * m];
        for (a, &i) in self.nl.iter().enumerate() {
            for (b, &j) in self.nl.iter().enumerate() {
                block[a * m + b] = cov[i * d + j];
            }
        }
        (cholesky(&block, m).unwrap_or_else(prior_diag), sims)
    }

    /// Evaluate at `v`, writing the model parameters into `x`. `None`: failed simulation;
    /// `log_target = −∞`: outside the bounds.
    pub fn eval(&self, v: &[f64], x: &mut [f64]) -> Option<Point> {
        let outside = Some(Point {
            log_target: f64::NEG_INFINITY,
            log_likelihood: f64::NEG_INFINITY,
        });
        let m = self.nl.len();
        x.copy_from_slice(&self.center);
        for (a, &i) in self.nl.iter().enumerate() {
            let row = &self.chol_nl[a * m..=a * m + a];
            x[i] += row
                .iter()
                .zip(&self.nl)
                .map(|(l, &j)| l * v[j])
                .sum::<f64>();
            let (lo, hi) = self.problem.bounds()[i];
            if !(x[i] >= lo && x[i] <= hi) {
                return outside;
            }
        }
        let (params, effects) = self.problem.params_from_vector(x).ok()?;
        let p = self.lin.len();
        SCRATCH.with(|cell| {
            let s = &mut *cell.borrow_mut();
            let n = self.problem.measured().len();
            s.total.resize(n, 0.0);
            simulate_into(
                &mut s.ws,
                self.problem.inputs(),
                &params,
                &effects,
                self.problem.settings(),
                &mut s.total,
            )
            .ok()?;
            // y − c, with c the torque that does not scale with a free F0.
            s.y.clear();
            s.y.extend(
                self.problem
                    .measured()
                    .iter()
                    .zip(&s.total)
                    .map(|(m, t)| m - t),
            );
            for (k, &(i, muscle)) in self.lin.iter().enumerate() {
                let tm = &s.ws.torque_muscle()[muscle];
                let f0 = x[i];
                s.g[k].clear();
                s.g[k].extend(tm.iter().map(|t| t / f0));
                for (y, t) in s.y.iter_mut().zip(tm) {
                    *y += t;
                }
            }
            let mut yw = std::mem::take(&mut s.yw);
            self.whiten(&s.y, &mut yw);
            s.yw = yw;
            for k in 0..p {
                let mut gw = std::mem::take(&mut s.gw[k]);
                self.whiten(&s.g[k], &mut gw);
                s.gw[k] = gw;
            }
            let mut a = [0.0; 9];
            let mut b = [0.0; 3];
            for k in 0..p {
                for l in 0..=k {
                    let v: f64 = s.gw[k].iter().zip(&s.gw[l]).map(|(p, q)| p * q).sum();
                    a[k * p + l] = v;
                    a[l * p + k] = v;
                }
                b[k] = s.gw[k].iter().zip(&s.yw).map(|(p, q)| p * q).sum();
            }
            let yy: f64 = s.yw.iter().map(|v| v * v).sum();
            let r = cholesky(&a[..p * p], p)?;
            // f̂ = A⁻¹b via R w = b, Rᵀ f̂ = w; RSS = yy − |w|².
            let mut w = [0.0; 3];
            for k in 0..p {
                let mut acc = b[k];
                for l in 0..k {
                    acc -= r[k * p + l] * w[l];
                }
                w[k] = acc / r[k * p + k];
            }
            let rss = yy - w[..p].iter().map(|v| v * v).sum::<f64>();
            // f̂ from Rᵀ f̂ = w; centre c = f̂ clamped into the bounds; f = c + R⁻ᵀ u, so that
            // Rᵀ(f − f̂) = Rᵀ(c − f̂) + u =: q and |ỹ − G̃f|² = RSS + |q|².
            let mut fh = [0.0; 3];
            solve_upper(&r, p, &w, &mut fh);
            let mut c = [0.0; 3];
            let mut uvec = [0.0; 3];
            for (k, &(i, _)) in self.lin.iter().enumerate() {
                let (lo, hi) = self.problem.bounds()[i];
                c[k] = fh[k].clamp(lo, hi);
                uvec[k] = v[i];
            }
            let mut delta = [0.0; 3];
            solve_upper(&r, p, &uvec, &mut delta);
            let mut f = [0.0; 3];
            let mut uu = 0.0;
            for k in 0..p {
                f[k] = c[k] + delta[k];
                let rt: f64 = (k..p).map(|l| r[l * p + k] * (c[l] - fh[l])).sum();
                let q = rt + uvec[k];
                uu += q * q;
            }
            let mut log_det_r = 0.0;
            for (k, &(i, _)) in self.lin.iter().enumerate() {
                x[i] = f[k];
                log_det_r += r[k * p + k].ln();
                let (lo, hi) = self.problem.bounds()[i];
                if !(f[k] >= lo && f[k] <= hi) {
                    return outside;
                }
            }
            let n_used: usize = self.segments.iter().map(|(a, b)| b - a).sum();
            let norm: f64 = if self.segments.len() == 1 {
                self.whitener.log_norm(n_used)
            } else {
                self.segments
                    .iter()
                    .map(|(a, b)| self.whitener.log_norm(b - a))
                    .sum()
            };
            let ll = norm - 0.5 * (rss.max(0.0) + uu);
            ll.is_finite().then_some(Point {
                log_target: ll - log_det_r,
                log_likelihood: ll,
            })
        })
    }
}

impl LogDensity for Conditional<'_> {
    fn dim(&self) -> usize {
        self.center.len()
    }
    fn bounds(&self) -> &[(f64, f64)] {
        &self.zbounds
    }
    fn log_density(&self, v: &[f64]) -> Option<f64> {
        let d = v.len();
        let r = if d <= STACK_DIM {
            let mut buf = [0.0; STACK_DIM];
            self.eval(v, &mut buf[..d])
        } else {
            let mut buf = vec![0.0; d];
            self.eval(v, &mut buf)
        };
        r.map(|p| p.log_target)
    }
    /// The model's bounds: the reported coordinates are the model's parameters.
    fn report_bounds(&self) -> &[(f64, f64)] {
        self.problem.bounds()
    }
    /// `log π(v)`, the model parameters at `v` and the log-likelihood `ℓ(x)` stored with a draw.
    fn evaluate(&self, v: &[f64], report: &mut [f64]) -> Option<(f64, f64)> {
        self.eval(v, report)
            .map(|p| (p.log_target, p.log_likelihood))
    }
}

/// Solve `Rᵀ x = b` for the lower-triangular `R` (row-major p×p).
fn solve_upper(r: &[f64], p: usize, b: &[f64], x: &mut [f64]) {
    for k in (0..p).rev() {
        let mut acc = b[k];
        for l in k + 1..p {
            acc -= r[l * p + k] * x[l];
        }
        x[k] = acc / r[k * p + k];
    }
}

/// Cholesky factor (lower, row-major) of the SPD matrix `a`; `None` if not positive definite.
pub(crate) fn cholesky(a: &[f64], d: usize) -> Option<Vec<f64>> {
    let mut l = vec![0.0; d * d];
    for i in 0..d {
        for j in 0..=i {
            let mut v = a[i * d + j];
            for k in 0..j {
                v -= l[i * d + k] * l[j * d + k];
            }
            if i == j {
                if !(v > 0.0 && v.is_finite()) {
                    return None;
                }
                l[i * d + i] = v.sqrt();
            } else {
                l[i * d + j] = v / l[j * d + j];
            }
        }
    }
    Some(l)
}

/// Inverse of the SPD matrix `a` through its Cholesky factor.
pub(crate) fn spd_inverse(a: &[f64], d: usize) -> Option<Vec<f64>> {
    let l = cholesky(a, d)?;
    let mut inv = vec![0.0; d * d];
    let mut col = vec![0.0; d];
    for c in 0..d {
        for i in 0..d {
            let mut v = if i == c { 1.0 } else { 0.0 };
            for k in 0..i {
                v -= l[i * d + k] * col[k];
            }
            col[i] = v / l[i * d + i];
        }
        for i in (0..d).rev() {
            let mut v = col[i];
            for k in i + 1..d {
                v -= l[k * d + i] * col[k];
            }
            col[i] = v / l[i * d + i];
        }
        for i in 0..d {
            inv[i * d + c] = col[i];
        }
    }
    Some(inv)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn inverse_of_known_matrix() {
        let a = [4.0, 2.0, 2.0, 3.0];
        let inv = spd_inverse(&a, 2).unwrap();
        let want = [3.0 / 8.0, -2.0 / 8.0, -2.0 / 8.0, 4.0 / 8.0];
        for (g, w) in inv.iter().zip(want) {
            assert!((g - w).abs() < 1e-14);
        }
        assert!(cholesky(&[1.0, 2.0, 2.0, 1.0], 2).is_none());
    }
}
