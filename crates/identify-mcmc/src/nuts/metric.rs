//! The Euclidean metric of the Hamiltonian: diagonal (Stan's `diag_e`) or dense (`dense_e`).
//!
//! With the inverse metric `Σ` (the posterior covariance in the unconstrained coordinates, as
//! warm-up estimates it) the kinetic energy is `½ pᵀΣp`, the momentum is drawn from
//! `N(0, Σ⁻¹)` (`p = L⁻ᵀz` with `Σ = LLᵀ`, `z ~ N(0, I)`), a position step moves by `εΣp`, and
//! the no-U-turn criterion uses `p♯ = Σp`. A dense `Σ` undoes the correlations between the
//! parameters, which a diagonal one leaves for the trajectory to wind along.

use numerics::cholesky::{cholesky, solve_lower_transpose_in_place};
use rand::Rng;
use rand_chacha::ChaCha8Rng;
use rand_distr::StandardNormal;

/// The inverse metric `Σ`.
#[derive(Clone, Debug)]
pub(super) enum Metric {
    /// `Σ = diag(v)`.
    Diagonal(Vec<f64>),
    /// `Σ` row-major `d×d` and its Cholesky factor `L` (row-major, lower).
    Dense { cov: Vec<f64>, chol: Vec<f64> },
}

impl Metric {
    /// `Σ = I` of the chosen kind.
    pub(super) fn unit(d: usize, dense: bool) -> Self {
        if dense {
            let mut cov = vec![0.0; d * d];
            for i in 0..d {
                cov[i * d + i] = 1.0;
            }
            Metric::Dense {
                chol: cov.clone(),
                cov,
            }
        } else {
            Metric::Diagonal(vec![1.0; d])
        }
    }

    /// `pᵀΣp`.
    pub(super) fn quadratic(&self, p: &[f64]) -> f64 {
        match self {
            Metric::Diagonal(v) => p.iter().zip(v).map(|(p, m)| p * p * m).sum(),
            Metric::Dense { cov, .. } => {
                let d = p.len();
                let mut s = 0.0;
                for i in 0..d {
                    let row: f64 = cov[i * d..(i + 1) * d]
                        .iter()
                        .zip(p)
                        .map(|(c, q)| c * q)
                        .sum();
                    s += p[i] * row;
                }
                s
            }
        }
    }

    /// `q += eps·Σp`.
    pub(super) fn step_position(&self, q: &mut [f64], p: &[f64], eps: f64) {
        match self {
            Metric::Diagonal(v) => {
                for ((q, p), m) in q.iter_mut().zip(p).zip(v) {
                    *q += eps * m * p;
                }
            }
            Metric::Dense { cov, .. } => {
                let d = p.len();
                for (i, qi) in q.iter_mut().enumerate() {
                    let row: f64 = cov[i * d..(i + 1) * d]
                        .iter()
                        .zip(p)
                        .map(|(c, x)| c * x)
                        .sum();
                    *qi += eps * row;
                }
            }
        }
    }

    /// `out = Σp`.
    pub(super) fn sharp(&self, p: &[f64], out: &mut [f64]) {
        match self {
            Metric::Diagonal(v) => {
                for ((o, p), m) in out.iter_mut().zip(p).zip(v) {
                    *o = p * m;
                }
            }
            Metric::Dense { cov, .. } => {
                let d = p.len();
                for (i, o) in out.iter_mut().enumerate() {
                    *o = cov[i * d..(i + 1) * d]
                        .iter()
                        .zip(p)
                        .map(|(c, x)| c * x)
                        .sum();
                }
            }
        }
    }

    /// Draws `p ~ N(0, Σ⁻¹)` into `p`.
    pub(super) fn sample(&self, p: &mut [f64], rng: &mut ChaCha8Rng) {
        match self {
            Metric::Diagonal(v) => {
                for (p, m) in p.iter_mut().zip(v) {
                    let n: f64 = rng.sample(StandardNormal);
                    *p = n / m.sqrt();
                }
            }
            Metric::Dense { chol, .. } => {
                for p in p.iter_mut() {
                    *p = rng.sample(StandardNormal);
                }
                solve_lower_transpose_in_place(chol, p);
            }
        }
    }

    /// The inverse metric as CmdStan writes it: the diagonal, or every element row by row.
    pub(super) fn elements(&self) -> Vec<f64> {
        match self {
            Metric::Diagonal(v) => v.clone(),
            Metric::Dense { cov, .. } => cov.clone(),
        }
    }

    /// Replaces `Σ` by the regularised estimate of `welford` (Stan's: `n/(n+5)·S +
    /// 10⁻³·5/(n+5)·I`), keeping the kind, and restarts the estimator. A dense estimate
    /// that is not positive definite (too few draws) leaves `Σ` unchanged.
    pub(super) fn update(&mut self, welford: &mut Welford) {
        let n = welford.n;
        let d = welford.mean.len();
        if n >= 2.0 {
            let shrink = n / (n + 5.0);
            let ridge = 1e-3 * (5.0 / (n + 5.0));
            let s = |i: usize, j: usize| welford.m2[i * d + j] / (n - 1.0);
            match self {
                Metric::Diagonal(v) => {
                    for (i, vi) in v.iter_mut().enumerate() {
                        *vi = shrink * s(i, i) + ridge;
                    }
                }
                Metric::Dense { cov, chol } => {
                    let mut c = vec![0.0; d * d];
                    for i in 0..d {
                        for j in 0..d {
                            c[i * d + j] = shrink * s(i, j) + if i == j { ridge } else { 0.0 };
                        }
                    }
                    if let Ok(l) = cholesky(&c, d) {
                        *cov = c;
                        *chol = l;
                    }
                }
            }
        }
        welford.restart();
    }
}

/// Welford's running mean and (co)variance of the warm-up draws in a metric window.
pub(super) struct Welford {
    n: f64,
    mean: Vec<f64>,
    /// `Σ (x − x̄_old)(x − x̄_new)ᵀ`, row-major `d×d` (only the diagonal for a diagonal metric).
    m2: Vec<f64>,
    full: bool,
}

impl Welford {
    pub(super) fn new(d: usize, full: bool) -> Self {
        Self {
            n: 0.0,
            mean: vec![0.0; d],
            m2: vec![0.0; d * d],
            full,
        }
    }

    pub(super) fn add(&mut self, q: &[f64]) {
        self.n += 1.0;
        let d = q.len();
        let old: Vec<f64> = self.mean.clone();
        for (m, &x) in self.mean.iter_mut().zip(q) {
            *m += (x - *m) / self.n;
        }
        for i in 0..d {
            let a = q[i] - old[i];
            if self.full {
                let row = &mut self.m2[i * d..(i + 1) * d];
                for ((m, x), mean) in row.iter_mut().zip(q).zip(&self.mean) {
                    *m += a * (x - mean);
                }
            } else {
                self.m2[i * d + i] += (q[i] - self.mean[i]) * a;
            }
        }
    }

    fn restart(&mut self) {
        self.n = 0.0;
        self.mean.iter_mut().for_each(|m| *m = 0.0);
        self.m2.iter_mut().for_each(|m| *m = 0.0);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;

    #[test]
    fn welford_matches_two_pass() {
        let xs = [
            [1.0, 0.5],
            [4.0, 2.0],
            [2.5, 1.0],
            [-3.0, -1.0],
            [0.5, 0.7],
            [7.0, 3.5],
        ];
        let n = xs.len() as f64;
        let mean = |k: usize| xs.iter().map(|x| x[k]).sum::<f64>() / n;
        let cov = |a: usize, b: usize| {
            xs.iter()
                .map(|x| (x[a] - mean(a)) * (x[b] - mean(b)))
                .sum::<f64>()
                / (n - 1.0)
        };
        for full in [false, true] {
            let mut w = Welford::new(2, full);
            xs.iter().for_each(|x| w.add(x));
            let mut m = Metric::unit(2, full);
            m.update(&mut w);
            let e = m.elements();
            let reg = |s: f64, diag: bool| {
                n / (n + 5.0) * s + if diag { 1e-3 * 5.0 / (n + 5.0) } else { 0.0 }
            };
            if full {
                assert!((e[0] - reg(cov(0, 0), true)).abs() < 1e-12);
                assert!((e[1] - reg(cov(0, 1), false)).abs() < 1e-12);
                assert!((e[2] - e[1]).abs() < 1e-15);
                assert!((e[3] - reg(cov(1, 1), true)).abs() < 1e-12);
            } else {
                assert!((e[0] - reg(cov(0, 0), true)).abs() < 1e-12);
                assert!((e[1] - reg(cov(1, 1), true)).abs() < 1e-12);
            }
        }
    }

    #[test]
    fn dense_momentum_has_the_inverse_covariance() {
        // Σ = [[4, 1.8], [1.8, 1]]: p ~ N(0, Σ⁻¹), so pᵀΣp averages d = 2
        let cov = vec![4.0, 1.8, 1.8, 1.0];
        let m = Metric::Dense {
            chol: cholesky(&cov, 2).unwrap(),
            cov,
        };
        let mut rng = ChaCha8Rng::seed_from_u64(5);
        let mut p = [0.0; 2];
        let k = 40_000;
        let mean: f64 = (0..k)
            .map(|_| {
                m.sample(&mut p, &mut rng);
                m.quadratic(&p)
            })
            .sum::<f64>()
            / k as f64;
        assert!((mean - 2.0).abs() < 0.05, "{mean}");
        let mut s = [0.0; 2];
        m.sharp(&[1.0, 2.0], &mut s);
        assert_eq!(s, [4.0 + 3.6, 1.8 + 2.0]);
    }
}
