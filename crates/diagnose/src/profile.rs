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

use crate::lm::minimise;
use numerics::LevenbergMarquardtSettings;

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
/// residual function `f` inside `bounds`; `s2` scales the cost differences (see the module
/// docs), `step0 > 0` is the first step out (e.g. the Laplace standard error). The two sides
/// are searched in parallel; the result does not depend on the number of threads.
///
/// Returns `None` when `k` is out of range or `step0`, `s2` or `cost` is not finite and positive
/// (`cost` may be 0).
#[allow(clippy::too_many_arguments)]
pub fn profile_interval<F>(
    f: &F,
    x: &[f64],
    cost: f64,
    k: usize,
    bounds: &[(f64, f64)],
    s2: f64,
    step0: f64,
    lm: &LevenbergMarquardtSettings,
    settings: &ProfileSettings,
) -> Option<ProfileInterval>
where
    F: Fn(&[f64]) -> Option<Vec<f64>> + Sync,
{
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
struct Search<'a, F> {
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

impl<F> Search<'_, F>
where
    F: Fn(&[f64]) -> Option<Vec<f64>> + Sync,
{
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
        let full = |z: &[f64], theta: f64| -> Vec<f64> {
            let mut v = Vec::with_capacity(x.len());
            v.extend_from_slice(&z[..k]);
            v.push(theta);
            v.extend_from_slice(&z[k..]);
            v
        };
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
            let g = |z: &[f64]| f(&full(z, theta));
            let Some(o) = minimise(&g, &warm, &others, self.lm) else {
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

#[cfg(test)]
mod tests {
    use super::*;

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
                let iv = profile_interval(&f, &xhat, cost, k, &bounds, 1.0, 0.3 * se[k], &lm, &ps)
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
        let cost = |f: &dyn Fn(&[f64]) -> Option<Vec<f64>>, x: &[f64]| {
            f(x).unwrap().iter().map(|r| r * r).sum::<f64>()
        };
        // minimum near x0 = 0.99 with σ(x0) ≈ 1: both bounds lie inside the 68 % level
        let f = |x: &[f64]| -> Option<Vec<f64>> { Some(vec![x[0] - 1.0, x[1] - x[0], 0.1 * x[1]]) };
        let bounds = [(0.5, 1.2), (-5.0, 5.0)];
        let o = minimise(&f, &[0.8, 0.0], &bounds, &lm).unwrap();
        let iv =
            profile_interval(&f, &o.x, cost(&f, &o.x), 0, &bounds, 1.0, 0.1, &lm, &ps).unwrap();
        assert!(iv.lower_at_bound && iv.upper_at_bound, "{iv:?}");
        assert_eq!((iv.lower, iv.upper), (0.5, 1.2));
        // unconstrained minimum near x0 = 1.98, outside the box: the fit sits at x0 = 1, where
        // d(θ) ≈ (θ − 2)² − 1, so the lower end is near 2 − √2
        let f = |x: &[f64]| -> Option<Vec<f64>> { Some(vec![x[0] - 2.0, x[1] - x[0], 0.1 * x[1]]) };
        let bounds = [(0.0, 1.0), (-5.0, 5.0)];
        let o = minimise(&f, &[0.8, 0.0], &bounds, &lm).unwrap();
        assert_eq!(o.x[0], 1.0);
        let iv =
            profile_interval(&f, &o.x, cost(&f, &o.x), 0, &bounds, 1.0, 0.1, &lm, &ps).unwrap();
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
        assert!(profile_interval(&f, &[0.0], 0.0, 1, &b, 1.0, 0.1, &lm, &ps).is_none());
        assert!(profile_interval(&f, &[0.0], 0.0, 0, &b, 1.0, 0.0, &lm, &ps).is_none());
        assert!(profile_interval(&f, &[0.0], 0.0, 0, &b, f64::NAN, 0.1, &lm, &ps).is_none());
    }
}
