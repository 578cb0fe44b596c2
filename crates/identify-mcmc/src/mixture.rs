//! A mode-jumping independence proposal: a mixture of multivariate Student-t densities.
//!
//! With probability `p` a step proposes, for a chosen subset `S` of the coordinates,
//! `y_S ~ q = Σ_m w_m·t_ν(μ_m, Σ_m)` independently of the current state (the other
//! coordinates are kept), and accepts with the Metropolis–Hastings probability
//!
//! `α = min(1, π(y)·q(x_S) / (π(x)·q(y_S)))`.
//!
//! The kernel leaves `π` invariant for any fixed mixture, so it can be mixed with the random walk
//! step by step. When the components sit on the posterior's modes (found by a multi-start
//! optimisation, each with its Laplace covariance) a chain crosses between modes that a random
//! walk would need an exponentially long time to connect; with heavy tails (`ν` small) and
//! inflated covariances the ratio `π/q` stays bounded where the posterior is wider than the
//! Laplace fit, which keeps the acceptance rate healthy.
//!
//! A draw from one component: `y = μ + L·z·√(ν/χ²_ν)`, `z ~ N(0, I)`, `LLᵀ = Σ`. Its log density
//! up to the constant shared by all components (same `ν` and dimension `k`):
//! `−ln det L − (ν+k)/2·ln(1 + |L⁻¹(y − μ)|²/ν)`.

use rand::Rng;
use rand_distr::{ChiSquared, Distribution, StandardNormal};

use numerics::cholesky::{cholesky, solve_lower_in_place};

use crate::McmcError;

#[derive(Clone, Debug, PartialEq)]
struct Component {
    log_weight: f64,
    mean: Vec<f64>,
    /// Lower Cholesky factor, row-major k×k.
    chol: Vec<f64>,
    log_det: f64,
}

/// One mixture component before validation: weight, mean and covariance (row-major k×k).
#[derive(Clone, Debug, PartialEq)]
pub struct ComponentSpec {
    /// Unnormalised weight (> 0).
    pub weight: f64,
    /// Mean, `k` values.
    pub mean: Vec<f64>,
    /// Covariance, row-major `k×k`, symmetric positive definite.
    pub cov: Vec<f64>,
}

/// The independence mixture proposal of the module documentation.
#[derive(Clone, Debug, PartialEq)]
pub struct MixtureProposal {
    coords: Vec<usize>,
    components: Vec<Component>,
    /// The components given to [`MixtureProposal::new`] (kept by every refit).
    base: Vec<Component>,
    nu: f64,
    probability: f64,
    chi2: ChiSquared<f64>,
    refit: usize,
    refit_inflation: f64,
}

impl MixtureProposal {
    /// Build the proposal over the sampler coordinates `coords` (each index once) from
    /// `components`, with `ν = nu` degrees of freedom, used at a step with probability
    /// `probability`.
    ///
    /// # Errors
    /// No component, a mean or covariance of the wrong length, a covariance that is not
    /// positive definite, a non-positive weight, `ν ≤ 0`, or `probability ∉ [0, 1]`.
    pub fn new(
        coords: Vec<usize>,
        components: &[ComponentSpec],
        nu: f64,
        probability: f64,
    ) -> Result<Self, McmcError> {
        let bad = |name: &'static str, value: String, reason: &'static str| {
            Err(McmcError::InvalidSetting {
                name,
                value,
                reason,
            })
        };
        let k = coords.len();
        if k == 0 || components.is_empty() {
            return bad(
                "mixture",
                format!("{k} coordinates, {} components", components.len()),
                "needs at least one coordinate and one component",
            );
        }
        if !(nu.is_finite() && nu > 0.0) {
            return bad("mixture.nu", nu.to_string(), "must be finite and > 0");
        }
        if !(0.0..=1.0).contains(&probability) {
            return bad(
                "mixture.probability",
                probability.to_string(),
                "must lie in [0, 1]",
            );
        }
        let total: f64 = components.iter().map(|c| c.weight).sum();
        let mut out = Vec::with_capacity(components.len());
        for c in components {
            if !(c.weight.is_finite() && c.weight > 0.0) {
                return bad("mixture.weight", c.weight.to_string(), "must be > 0");
            }
            if c.mean.len() != k || c.cov.len() != k * k || c.mean.iter().any(|v| !v.is_finite()) {
                return bad(
                    "mixture.component",
                    format!("mean {} / cov {} values", c.mean.len(), c.cov.len()),
                    "mean needs k finite values and cov k×k",
                );
            }
            let Ok(chol) = cholesky(&c.cov, k) else {
                return bad(
                    "mixture.cov",
                    "not positive definite".into(),
                    "covariance must be symmetric positive definite",
                );
            };
            let log_det = (0..k).map(|i| chol[i * k + i].ln()).sum();
            out.push(Component {
                log_weight: (c.weight / total).ln(),
                mean: c.mean.clone(),
                chol,
                log_det,
            });
        }
        Ok(Self {
            coords,
            base: out.clone(),
            components: out,
            nu,
            probability,
            refit: 0,
            refit_inflation: 1.0,
            chi2: ChiSquared::new(nu).map_err(|_| McmcError::InvalidSetting {
                name: "mixture.nu",
                value: nu.to_string(),
                reason: "must be finite and > 0",
            })?,
        })
    }

    /// Refit during warm-up: at every convergence check of the warm-up the sampler pools the
    /// second half of every chain's warm-up states and replaces the mixture by
    /// [`MixtureProposal::refitted`] with up to `components` clusters, covariances scaled by
    /// `inflation²`. Frozen when warm-up ends.
    #[must_use]
    pub fn with_refit(mut self, components: usize, inflation: f64) -> Self {
        self.refit = components;
        self.refit_inflation = if inflation.is_finite() && inflation > 0.0 {
            inflation
        } else {
            1.0
        };
        self
    }

    /// Maximum number of fitted components of a refit (0: the mixture is fixed).
    pub fn refit_components(&self) -> usize {
        self.refit
    }

    /// The mixture refitted to `points` (each `coords().len()` long, e.g. pooled warm-up
    /// states): k-means++ seeding and Lloyd iterations with `K = min(refit, n/(20(k+1)))`
    /// clusters, each cluster with at least `5(k+1)` points becoming a component with the
    /// cluster's mean, its covariance times `inflation²` (plus a ridge of 10⁻⁹ of its mean
    /// diagonal) and 70 % of the weight in proportion to its size; the components given to
    /// [`MixtureProposal::new`] share the other 30 % as before. `None` when no cluster is
    /// usable (too few points or degenerate covariances).
    pub fn refitted<R: Rng + ?Sized>(&self, points: &[Vec<f64>], rng: &mut R) -> Option<Self> {
        let k = self.coords.len();
        let n = points.len();
        let kk = self.refit.min(n / (20 * (k + 1)));
        if kk == 0 {
            return None;
        }
        let dist2 =
            |a: &[f64], b: &[f64]| -> f64 { a.iter().zip(b).map(|(x, y)| (x - y) * (x - y)).sum() };
        // k-means++ seeding.
        let mut centers: Vec<Vec<f64>> = vec![points[rng.random_range(0..n)].clone()];
        let mut d2: Vec<f64> = points.iter().map(|p| dist2(p, &centers[0])).collect();
        while centers.len() < kk {
            let total: f64 = d2.iter().sum();
            if total.is_nan() || total <= 0.0 {
                break;
            }
            let mut u = rng.random::<f64>() * total;
            let mut pick = n - 1;
            for (i, &v) in d2.iter().enumerate() {
                if u < v {
                    pick = i;
                    break;
                }
                u -= v;
            }
            centers.push(points[pick].clone());
            for (v, p) in d2.iter_mut().zip(points) {
                *v = v.min(dist2(p, &centers[centers.len() - 1]));
            }
        }
        let mut label = vec![0usize; n];
        for _ in 0..30 {
            let mut changed = false;
            for (l, p) in label.iter_mut().zip(points) {
                let mut best = (f64::INFINITY, 0);
                for (c, ctr) in centers.iter().enumerate() {
                    let v = dist2(p, ctr);
                    if v < best.0 {
                        best = (v, c);
                    }
                }
                changed |= *l != best.1;
                *l = best.1;
            }
            let mut sums = vec![vec![0.0; k]; centers.len()];
            let mut counts = vec![0usize; centers.len()];
            for (l, p) in label.iter().zip(points) {
                counts[*l] += 1;
                for (s, v) in sums[*l].iter_mut().zip(p) {
                    *s += v;
                }
            }
            for (c, ctr) in centers.iter_mut().enumerate() {
                if counts[c] > 0 {
                    for (x, s) in ctr.iter_mut().zip(&sums[c]) {
                        *x = s / counts[c] as f64;
                    }
                }
            }
            if !changed {
                break;
            }
        }
        let s2 = self.refit_inflation * self.refit_inflation;
        let mut fitted = Vec::new();
        let mut used = 0usize;
        for (c, ctr) in centers.iter().enumerate() {
            let members: Vec<&Vec<f64>> = points
                .iter()
                .zip(&label)
                .filter(|(_, &l)| l == c)
                .map(|(p, _)| p)
                .collect();
            if members.len() < 5 * (k + 1) {
                continue;
            }
            let mut cov = vec![0.0; k * k];
            for p in &members {
                for i in 0..k {
                    for j in 0..=i {
                        cov[i * k + j] += (p[i] - ctr[i]) * (p[j] - ctr[j]);
                    }
                }
            }
            let denom = (members.len() - 1) as f64;
            let mut diag = 0.0;
            for i in 0..k {
                for j in 0..=i {
                    let v = s2 * cov[i * k + j] / denom;
                    cov[i * k + j] = v;
                    cov[j * k + i] = v;
                }
                diag += cov[i * k + i] / k as f64;
            }
            for i in 0..k {
                cov[i * k + i] += 1e-9 * diag;
            }
            let Ok(chol) = cholesky(&cov, k) else {
                continue;
            };
            let log_det = (0..k).map(|i| chol[i * k + i].ln()).sum();
            used += members.len();
            fitted.push((members.len(), ctr.clone(), chol, log_det));
        }
        if fitted.is_empty() {
            return None;
        }
        let mut components: Vec<Component> = fitted
            .into_iter()
            .map(|(count, mean, chol, log_det)| Component {
                log_weight: (0.7 * count as f64 / used as f64).ln(),
                mean,
                chol,
                log_det,
            })
            .collect();
        components.extend(self.base.iter().map(|c| Component {
            log_weight: c.log_weight + 0.3f64.ln(),
            ..c.clone()
        }));
        Some(Self {
            components,
            ..self.clone()
        })
    }

    /// Probability of a mixture step instead of a random-walk step.
    pub fn probability(&self) -> f64 {
        self.probability
    }

    /// Number of components.
    pub fn len(&self) -> usize {
        self.components.len()
    }

    /// Whether there is no component (never true for a built proposal).
    pub fn is_empty(&self) -> bool {
        self.components.is_empty()
    }

    /// The sampler coordinates the proposal draws.
    pub fn coords(&self) -> &[usize] {
        &self.coords
    }

    /// Overwrite `y[coords]` with a draw from the mixture (other entries untouched).
    pub fn sample<R: Rng + ?Sized>(&self, rng: &mut R, y: &mut [f64]) {
        let u: f64 = rng.random();
        let mut acc = 0.0;
        let mut pick = self.components.len() - 1;
        for (m, c) in self.components.iter().enumerate() {
            acc += c.log_weight.exp();
            if u < acc {
                pick = m;
                break;
            }
        }
        self.sample_component(pick, rng, y);
    }

    /// Overwrite `y[coords]` with a draw from component `m` (modulo the number of components).
    pub fn sample_component<R: Rng + ?Sized>(&self, m: usize, rng: &mut R, y: &mut [f64]) {
        let c = &self.components[m % self.components.len()];
        let k = self.coords.len();
        let w: f64 = self.chi2.sample(rng);
        let s = (self.nu / w.max(1e-300)).sqrt();
        let mut z = [0.0f64; 32];
        let mut zv;
        let z: &mut [f64] = if k <= 32 {
            &mut z[..k]
        } else {
            zv = vec![0.0; k];
            &mut zv
        };
        for zi in z.iter_mut() {
            *zi = rng.sample(StandardNormal);
        }
        for (a, &i) in self.coords.iter().enumerate() {
            let lz: f64 = c.chol[a * k..=a * k + a]
                .iter()
                .zip(z.iter())
                .map(|(l, z)| l * z)
                .sum();
            y[i] = c.mean[a] + s * lz;
        }
    }

    /// `ln q(x[coords])` up to a constant shared by all points.
    pub fn log_density(&self, x: &[f64]) -> f64 {
        let k = self.coords.len();
        let mut best = f64::NEG_INFINITY;
        let mut terms = [0.0f64; 64];
        let mut tv;
        let terms: &mut [f64] = if self.components.len() <= 64 {
            &mut terms[..self.components.len()]
        } else {
            tv = vec![0.0; self.components.len()];
            &mut tv
        };
        for (t, c) in terms.iter_mut().zip(&self.components) {
            // Forward substitution L w = x − μ, accumulating |w|².
            let mut w = [0.0f64; 32];
            let mut wv;
            let w: &mut [f64] = if k <= 32 {
                &mut w[..k]
            } else {
                wv = vec![0.0; k];
                &mut wv
            };
            for ((wa, &i), mu) in w.iter_mut().zip(&self.coords).zip(&c.mean) {
                *wa = x[i] - mu;
            }
            solve_lower_in_place(&c.chol, w);
            let q: f64 = w.iter().map(|v| v * v).sum();
            *t = c.log_weight - c.log_det - 0.5 * (self.nu + k as f64) * (q / self.nu).ln_1p();
            best = best.max(*t);
        }
        if !best.is_finite() {
            return best;
        }
        best + terms.iter().map(|t| (t - best).exp()).sum::<f64>().ln()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;
    use rand_chacha::ChaCha8Rng;

    #[test]
    fn one_component_density_matches_the_student_t_formula() {
        // k = 2, Σ = [[4, 1], [1, 2]], ν = 5: compare differences of log densities with the
        // closed form (the shared constant cancels).
        let spec = ComponentSpec {
            weight: 1.0,
            mean: vec![1.0, -1.0],
            cov: vec![4.0, 1.0, 1.0, 2.0],
        };
        let mix = MixtureProposal::new(vec![0, 2], &[spec], 5.0, 0.5).unwrap();
        let det: f64 = 4.0 * 2.0 - 1.0;
        let quad = |x: f64, y: f64| {
            let (dx, dy) = (x - 1.0, y + 1.0);
            (2.0 * dx * dx - 2.0 * dx * dy + 4.0 * dy * dy) / det
        };
        let exact = |x: f64, y: f64| -0.5 * det.ln() - 3.5 * (1.0 + quad(x, y) / 5.0).ln();
        let p = [0.3, 99.0, 0.7];
        let q = [-2.0, 99.0, 1.5];
        let got = mix.log_density(&p) - mix.log_density(&q);
        let want = exact(0.3, 0.7) - exact(-2.0, 1.5);
        assert!((got - want).abs() < 1e-12, "{got} vs {want}");
        assert!((mix.log_density(&p) - exact(0.3, 0.7)).abs() < 1e-12);
    }

    #[test]
    fn draws_follow_the_mixture_weights_and_leave_other_coordinates_alone() {
        let a = ComponentSpec {
            weight: 3.0,
            mean: vec![-5.0],
            cov: vec![0.25],
        };
        let b = ComponentSpec {
            weight: 1.0,
            mean: vec![5.0],
            cov: vec![0.25],
        };
        let mix = MixtureProposal::new(vec![1], &[a, b], 30.0, 1.0).unwrap();
        let mut rng = ChaCha8Rng::seed_from_u64(1);
        let n = 20_000;
        let mut right = 0usize;
        let mut y = [7.0, 0.0];
        for _ in 0..n {
            mix.sample(&mut rng, &mut y);
            assert_eq!(y[0], 7.0);
            right += usize::from(y[1] > 0.0);
        }
        let frac = right as f64 / n as f64;
        // 0.25 ± 4 binomial standard errors.
        assert!(
            (frac - 0.25).abs() < 4.0 * (0.25f64 * 0.75 / n as f64).sqrt(),
            "{frac}"
        );
    }

    #[test]
    fn invalid_specifications_are_errors() {
        let ok = ComponentSpec {
            weight: 1.0,
            mean: vec![0.0],
            cov: vec![1.0],
        };
        assert!(MixtureProposal::new(vec![0], &[], 4.0, 0.1).is_err());
        assert!(MixtureProposal::new(vec![0], std::slice::from_ref(&ok), 0.0, 0.1).is_err());
        assert!(MixtureProposal::new(vec![0], std::slice::from_ref(&ok), 4.0, 1.5).is_err());
        let neg = ComponentSpec {
            cov: vec![-1.0],
            ..ok.clone()
        };
        assert!(MixtureProposal::new(vec![0], &[neg], 4.0, 0.1).is_err());
        let short = ComponentSpec { mean: vec![], ..ok };
        assert!(MixtureProposal::new(vec![0], &[short], 4.0, 0.1).is_err());
    }
}
