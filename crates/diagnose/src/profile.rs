//! Profile-likelihood intervals of single parameters of a whitened least-squares fit.
//!
//! With the noise model fixed, `−2 log L(x) = ‖r(x)‖² + const` for the whitened residual `r`.
//! For parameter `k` the profile is
//!
//! ```text
//! d(θ) = ( min_{x : x_k = θ} ‖r(x)‖²  −  ‖r(x̂)‖² ) / s²,      s² = max(1, ‖r(x̂)‖²/(n − p))
//! ```
//!
//! (every other parameter refitted inside its bounds), and the interval is `{θ : d(θ) ≤ Δ}`
//! (`Δ = 1`: 68.3 %, `Δ = 3.84`: 95 %), cut at the parameter's bounds. For a linear model
//! `√d(θ) = |θ − θ̂|/σ̂` exactly, so the interval is the Laplace `θ̂ ± σ̂√Δ`; where the model is
//! not linear the profile follows the curved valley along which the other parameters
//! compensate, which the Laplace approximation at `x̂` does not see. On a relaxed+2 trial with
//! a 9.3 N·m antagonist torque (`diag_one 20240609 '{"antagonist_coactivation":{"gain_nm":9.32}}'
//! --ta`) the Laplace standard error of sol α0 is 0.16°, its MCMC posterior SD 1.74°
//! (identify-mcmc example `ta_posterior`) and the profile half-width 1.82° (docs/diagnosis.md).
//!
//! Each side is searched on `√d`, which is close to linear in `θ`: the first refit is one
//! Laplace standard error out, the next steps rescale by `1/√d(θ)` until the level is
//! bracketed, then interpolate linearly in `√d` inside the bracket. Every refit starts from
//! the last refit inside the interval (the fit itself first).

use crate::lm::minimise_residuals;
use numerics::{LevenbergMarquardtSettings, Residuals};

/// Settings of the profile-likelihood intervals of the final model's parameters
/// (docs/diagnosis.md).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ProfileSettings {
    /// Level `Δ` of `d(θ)` that ends the interval (1: 68.3 %).
    pub level: f64,
    /// Refits per side at most.
    pub max_refits: usize,
    /// Stop when `|√d − √Δ| ≤ tol·√Δ`.
    pub tol: f64,
    /// Levenberg–Marquardt iterations of one refit (used by the diagnosis; the refits start
    /// from the previous point of the profile, so few are needed).
    pub lm_iterations: usize,
    /// Relative cost decrease below which a refit stops (used by the diagnosis).
    pub ftol_rel: f64,
}

impl Default for ProfileSettings {
    fn default() -> Self {
        ProfileSettings {
            level: 1.0,
            max_refits: 6,
            tol: 0.1,
            lm_iterations: 10,
            ftol_rel: 1e-6,
        }
    }
}

/// A profile-likelihood interval.
#[derive(Clone, Copy, Debug, PartialEq)]
#[non_exhaustive]
pub struct ProfileInterval {
    /// Lower end (the lower bound when `lower_at_bound`).
    pub lower: f64,
    /// Upper end (the upper bound when `upper_at_bound`).
    pub upper: f64,
    /// `d` stays below the level down to the lower bound.
    pub lower_at_bound: bool,
    /// `d` stays below the level up to the upper bound.
    pub upper_at_bound: bool,
    /// Lowest `d` met on the profile (negative: a refit found a lower cost than the fit).
    pub min_d: f64,
    /// Residual evaluations used.
    pub evaluations: usize,
}

impl ProfileInterval {
    /// Half the width.
    pub fn half_width(&self) -> f64 {
        0.5 * (self.upper - self.lower)
    }
}

/// The profile interval of parameter `k` of the fit `x̂` (cost `cost = ‖f(x̂)‖²`) of the
/// residuals `f` inside `bounds` (each refit takes their exact Jacobian when they carry one); `s2` scales the cost differences (see the module
/// docs), `step0 > 0` is the first step out (e.g. the Laplace standard error). The two sides
/// are searched in parallel; the result does not depend on the number of threads.
///
/// Returns `None` when `k` is out of range or `step0`, `s2` or `cost` is not finite and positive
/// (`cost` may be 0).
#[allow(clippy::too_many_arguments)]
pub fn profile_interval<F: Residuals + ?Sized>(
    f: &F,
    x: &[f64],
    cost: f64,
    k: usize,
    bounds: &[(f64, f64)],
    s2: f64,
    step0: f64,
    lm: &LevenbergMarquardtSettings,
    settings: &ProfileSettings,
) -> Option<ProfileInterval> {
    if k >= x.len()
        || x.len() != bounds.len()
        || !(step0.is_finite() && step0 > 0.0)
        || !(s2.is_finite() && s2 > 0.0)
        || !(cost.is_finite() && cost >= 0.0)
        || !(settings.level > 0.0 && settings.tol > 0.0)
    {
        return None;
    }
    let search = Search {
        f,
        x,
        cost,
        k,
        bounds,
        s2,
        step0,
        lm,
        settings,
    };
    let (lo, hi) = rayon::join(|| search.side(-1.0), || search.side(1.0));
    Some(ProfileInterval {
        lower: lo.end,
        upper: hi.end,
        lower_at_bound: lo.at_bound,
        upper_at_bound: hi.at_bound,
        min_d: lo.min_d.min(hi.min_d),
        evaluations: lo.evaluations + hi.evaluations,
    })
}

/// The arguments of [`profile_interval`], shared by its two sides.
struct Search<'a, F: ?Sized> {
    f: &'a F,
    x: &'a [f64],
    cost: f64,
    k: usize,
    bounds: &'a [(f64, f64)],
    s2: f64,
    step0: f64,
    lm: &'a LevenbergMarquardtSettings,
    settings: &'a ProfileSettings,
}

struct Side {
    end: f64,
    at_bound: bool,
    min_d: f64,
    evaluations: usize,
}

impl<F: Residuals + ?Sized> Search<'_, F> {
    /// One side (`dir = ±1`) of the interval.
    fn side(&self, dir: f64) -> Side {
        let (f, x, k, bounds) = (self.f, self.x, self.k, self.bounds);
        let (cost, s2, settings) = (self.cost, self.s2, self.settings);
        let theta0 = x[k];
        let limit = if dir < 0.0 { bounds[k].0 } else { bounds[k].1 };
        // largest distance from θ̂ to the bound on this side
        let room = (limit - theta0) * dir;
        let target = settings.level.sqrt();
        let mut out = Side {
            end: limit,
            at_bound: true,
            min_d: 0.0,
            evaluations: 0,
        };
        if room <= 0.0 {
            return out;
        }
        let others: Vec<(f64, f64)> = bounds
            .iter()
            .enumerate()
            .filter(|&(j, _)| j != k)
            .map(|(_, b)| *b)
            .collect();
        let mut warm: Vec<f64> = x
            .iter()
            .enumerate()
            .filter(|&(j, _)| j != k)
            .map(|(_, v)| *v)
            .collect();
        // (distance, √d) of the farthest point inside the level and of the nearest one outside
        let mut inside = (0.0, 0.0);
        let mut outside: Option<(f64, f64)> = None;
        let mut delta = (self.step0 * target).min(room);
        for _ in 0..settings.max_refits {
            let theta = theta0 + dir * delta;
            let g = Pinned { r: f, k, theta };
            let Some(o) = minimise_residuals(&g, &warm, &others, self.lm) else {
                // the model cannot be simulated here: treat as far outside
                outside = Some((delta, f64::INFINITY));
                break;
            };
            out.evaluations += o.evaluations;
            let d = (o.cost - cost) / s2;
            out.min_d = out.min_d.min(d);
            let r = d.max(0.0).sqrt();
            if (r - target).abs() <= settings.tol * target {
                out.end = theta;
                out.at_bound = false;
                return out;
            }
            if r < target {
                inside = (delta, r);
                warm = o.x;
                if delta >= room {
                    return out; // the level is not reached inside the bounds
                }
            } else {
                outside = Some((delta, r));
            }
            delta = match outside {
                Some((d_out, r_out)) => {
                    let (d_in, r_in) = inside;
                    d_in + (target - r_in) * (d_out - d_in) / (r_out - r_in)
                }
                None if r > 0.0 => (delta * target / r).min(4.0 * delta),
                None => 4.0 * delta,
            }
            .min(room);
        }
        // not converged within the refits: interpolate the bracket (or the last point inside)
        out.at_bound = false;
        out.end = theta0
            + dir
                * match outside {
                    Some((d_out, r_out)) if r_out.is_finite() => {
                        let (d_in, r_in) = inside;
                        d_in + (target - r_in) * (d_out - d_in) / (r_out - r_in)
                    }
                    Some((d_out, _)) => 0.5 * (inside.0 + d_out),
                    None => inside.0,
                };
        out
    }
}

/// The residuals with parameter `k` held at `theta`, as a function of the others: `z` is `x`
/// without its `k`-th entry, and the exact Jacobian (when the residuals carry one) is theirs
/// without its `k`-th column.
struct Pinned<'a, R: ?Sized> {
    r: &'a R,
    k: usize,
    theta: f64,
}

/// A thread's scratch for [`Pinned`]: the residuals' own, the full point and the full Jacobian.
struct PinnedScratch<W> {
    inner: W,
    x: Vec<f64>,
    jac: Vec<f64>,
}

impl<R: Residuals + ?Sized> Pinned<'_, R> {
    fn full(&self, z: &[f64], x: &mut Vec<f64>) {
        x.clear();
        x.extend_from_slice(&z[..self.k]);
        x.push(self.theta);
        x.extend_from_slice(&z[self.k..]);
    }
}

impl<R: Residuals + ?Sized> Residuals for Pinned<'_, R> {
    type Workspace = PinnedScratch<R::Workspace>;
    fn workspace(&self) -> Self::Workspace {
        PinnedScratch {
            inner: self.r.workspace(),
            x: Vec::new(),
            jac: Vec::new(),
        }
    }
    fn residuals(&self, z: &[f64], ws: &mut Self::Workspace, out: &mut Vec<f64>) -> bool {
        self.full(z, &mut ws.x);
        self.r.residuals(&ws.x, &mut ws.inner, out)
    }
    fn jacobian(&self, z: &[f64], ws: &mut Self::Workspace, jac: &mut [f64]) -> Option<bool> {
        if z.is_empty() {
            return None;
        }
        let m = jac.len() / z.len();
        self.full(z, &mut ws.x);
        ws.jac.resize(m * ws.x.len(), 0.0);
        if !self.r.jacobian(&ws.x, &mut ws.inner, &mut ws.jac)? {
            return Some(false);
        }
        for (j, col) in jac.chunks_mut(m).enumerate() {
            let from = if j < self.k { j } else { j + 1 };
            col.copy_from_slice(&ws.jac[from * m..(from + 1) * m]);
        }
        Some(true)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::lm::{minimise, VecResiduals};

    /// `r(x) = y − a·e^{−b·t}` with its exact Jacobian: each refit of the profile holds one
    /// parameter and takes the other's column of that Jacobian; the interval equals the one
    /// found by differences.
    #[test]
    fn a_profile_with_the_exact_jacobian_matches_the_differenced_one() {
        struct Decay {
            t: Vec<f64>,
            y: Vec<f64>,
        }
        impl Residuals for Decay {
            type Workspace = ();
            fn workspace(&self) {}
            fn residuals(&self, x: &[f64], _: &mut (), out: &mut Vec<f64>) -> bool {
                out.clear();
                out.extend(
                    self.t
                        .iter()
                        .zip(&self.y)
                        .map(|(t, y)| y - x[0] * (-x[1] * t).exp()),
                );
                true
            }
            fn jacobian(&self, x: &[f64], _: &mut (), jac: &mut [f64]) -> Option<bool> {
                let m = self.t.len();
                for (i, t) in self.t.iter().enumerate() {
                    let e = (-x[1] * t).exp();
                    jac[i] = -e;
                    jac[m + i] = x[0] * t * e;
                }
                Some(true)
            }
        }
        let t: Vec<f64> = (0..40).map(|i| i as f64 / 8.0).collect();
        let y: Vec<f64> = t
            .iter()
            .enumerate()
            .map(|(i, ti)| 3.0 * (-0.7 * ti).exp() + ((i * 29 % 13) as f64 - 6.0) / 20.0)
            .collect();
        let exact = Decay { t, y };
        let differenced = |x: &[f64]| {
            let mut out = Vec::new();
            exact.residuals(x, &mut (), &mut out).then_some(out)
        };
        let bounds = [(0.1, 10.0), (0.01, 5.0)];
        let lm = LevenbergMarquardtSettings::default();
        let fit = minimise_residuals(&exact, &[1.0, 0.3], &bounds, &lm).expect("a fit");
        let cost: f64 = differenced(&fit.x).unwrap().iter().map(|r| r * r).sum();
        let ps = ProfileSettings {
            tol: 0.01,
            ..Default::default()
        };
        for k in 0..2 {
            let a = profile_interval(&exact, &fit.x, cost, k, &bounds, 1.0, 0.05, &lm, &ps)
                .expect("exact");
            let b = profile_interval(
                &VecResiduals(&differenced),
                &fit.x,
                cost,
                k,
                &bounds,
                1.0,
                0.05,
                &lm,
                &ps,
            )
            .expect("differenced");
            let width = b.upper - b.lower;
            assert!(width > 0.0 && !a.lower_at_bound && !a.upper_at_bound);
            assert!(
                (a.lower - b.lower).abs() < 0.02 * width
                    && (a.upper - b.upper).abs() < 0.02 * width,
                "k {k}: exact [{}, {}] differenced [{}, {}]",
                a.lower,
                a.upper,
                b.lower,
                b.upper
            );
        }
    }

    /// Linear model `y = a + b·t` with known unit noise: the profile interval of each
    /// coefficient is exactly `θ̂ ± σ̂` (and `± 1.96σ̂` at level 3.84).
    #[test]
    fn linear_model_profile_equals_the_standard_error() {
        let t: Vec<f64> = (0..50).map(|i| i as f64 / 10.0).collect();
        // deterministic "noise"
        let y: Vec<f64> = t
            .iter()
            .enumerate()
            .map(|(i, ti)| 2.0 + 0.5 * ti + ((i * 37 % 11) as f64 - 5.0) / 4.0)
            .collect();
        let f = |x: &[f64]| -> Option<Vec<f64>> {
            Some(
                t.iter()
                    .zip(&y)
                    .map(|(ti, yi)| yi - x[0] - x[1] * ti)
                    .collect(),
            )
        };
        // least squares by the normal equations
        let n = t.len() as f64;
        let (st, stt) = (t.iter().sum::<f64>(), t.iter().map(|v| v * v).sum::<f64>());
        let (sy, sty) = (
            y.iter().sum::<f64>(),
            t.iter().zip(&y).map(|(a, b)| a * b).sum::<f64>(),
        );
        let det = n * stt - st * st;
        let xhat = [(stt * sy - st * sty) / det, (n * sty - st * sy) / det];
        let cost: f64 = f(&xhat).unwrap().iter().map(|r| r * r).sum();
        // covariance (JᵀJ)⁻¹ with s² = 1
        let se = [(stt / det).sqrt(), (n / det).sqrt()];
        let bounds = [(-10.0, 10.0), (-10.0, 10.0)];
        let lm = LevenbergMarquardtSettings::default();
        for (level, z) in [(1.0, 1.0), (3.84, 3.84f64.sqrt())] {
            let ps = ProfileSettings {
                level,
                tol: 0.01,
                ..Default::default()
            };
            for k in 0..2 {
                let iv = profile_interval(
                    &VecResiduals(&f),
                    &xhat,
                    cost,
                    k,
                    &bounds,
                    1.0,
                    0.3 * se[k],
                    &lm,
                    &ps,
                )
                .unwrap();
                assert!(!iv.lower_at_bound && !iv.upper_at_bound);
                for end in [iv.lower, iv.upper] {
                    let rel = ((end - xhat[k]).abs() - z * se[k]).abs() / (z * se[k]);
                    assert!(
                        rel < 0.04,
                        "k {k} level {level}: {end} vs {} ± {}",
                        xhat[k],
                        z * se[k]
                    );
                }
                assert!(iv.min_d > -1e-6);
            }
        }
    }

    /// A bound inside the level ends the interval there and says so; a fit at its bound has an
    /// empty side.
    #[test]
    fn bounds_cut_the_interval() {
        let lm = LevenbergMarquardtSettings::default();
        let ps = ProfileSettings {
            tol: 0.01,
            ..Default::default()
        };
        // minimum near x0 = 0.99 with σ(x0) ≈ 1: both bounds lie inside the 68 % level
        let f = |x: &[f64]| -> Option<Vec<f64>> { Some(vec![x[0] - 1.0, x[1] - x[0], 0.1 * x[1]]) };
        let bounds = [(0.5, 1.2), (-5.0, 5.0)];
        // the first parameter's interval from the fit of `f` inside `bounds`
        fn first<F: Fn(&[f64]) -> Option<Vec<f64>> + Sync>(
            f: &F,
            bounds: &[(f64, f64)],
            lm: &LevenbergMarquardtSettings,
            ps: &ProfileSettings,
        ) -> (Vec<f64>, ProfileInterval) {
            let o = minimise(f, &[0.8, 0.0], bounds, lm).unwrap();
            let cost = f(&o.x).unwrap().iter().map(|r| r * r).sum::<f64>();
            let iv = profile_interval(&VecResiduals(f), &o.x, cost, 0, bounds, 1.0, 0.1, lm, ps);
            (o.x, iv.unwrap())
        }
        let (_, iv) = first(&f, &bounds, &lm, &ps);
        assert!(iv.lower_at_bound && iv.upper_at_bound, "{iv:?}");
        assert_eq!((iv.lower, iv.upper), (0.5, 1.2));
        // unconstrained minimum near x0 = 1.98, outside the box: the fit sits at x0 = 1, where
        // d(θ) ≈ (θ − 2)² − 1, so the lower end is near 2 − √2
        let f = |x: &[f64]| -> Option<Vec<f64>> { Some(vec![x[0] - 2.0, x[1] - x[0], 0.1 * x[1]]) };
        let bounds = [(0.0, 1.0), (-5.0, 5.0)];
        let (x, iv) = first(&f, &bounds, &lm, &ps);
        assert_eq!(x[0], 1.0);
        assert!(iv.upper_at_bound && iv.upper == 1.0, "{iv:?}");
        assert!(
            !iv.lower_at_bound && (iv.lower - 0.584).abs() < 0.03,
            "{iv:?}"
        );
    }

    #[test]
    fn rejects_bad_arguments() {
        let f = |x: &[f64]| -> Option<Vec<f64>> { Some(vec![x[0]]) };
        let lm = LevenbergMarquardtSettings::default();
        let ps = ProfileSettings::default();
        let b = [(-1.0, 1.0)];
        assert!(
            profile_interval(&VecResiduals(&f), &[0.0], 0.0, 1, &b, 1.0, 0.1, &lm, &ps).is_none()
        );
        assert!(
            profile_interval(&VecResiduals(&f), &[0.0], 0.0, 0, &b, 1.0, 0.0, &lm, &ps).is_none()
        );
        assert!(profile_interval(
            &VecResiduals(&f),
            &[0.0],
            0.0,
            0,
            &b,
            f64::NAN,
            0.1,
            &lm,
            &ps
        )
        .is_none());
    }
}
