//! Posterior summaries: moments, quantiles, diagnostics, identifiability, correlations.

use serde::{Deserialize, Serialize};

use crate::diagnostics;

/// Summary of one parameter's posterior draws.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[non_exhaustive]
pub struct Summary {
    /// Pooled mean.
    pub mean: f64,
    /// Pooled standard deviation (denominator `S − 1`).
    pub sd: f64,
    /// 5 % quantile (R's type 7).
    pub q05: f64,
    /// 95 % quantile (R's type 7).
    pub q95: f64,
    /// [`diagnostics::rhat`].
    pub rhat: f64,
    /// [`diagnostics::ess_bulk`].
    pub ess_bulk: f64,
    /// [`diagnostics::ess_tail`].
    pub ess_tail: f64,
    /// Standard deviation of the uniform prior on the bounds, `width/√12`.
    pub prior_sd: f64,
    /// `sd / prior_sd`: 1 means the data taught nothing about the parameter.
    pub prior_sd_ratio: f64,
    /// `sd < prior_sd/2`: the data narrowed the parameter down.
    pub identifiable: bool,
}

impl Summary {
    /// Summarise the chains of one parameter whose prior is uniform on `bounds`.
    /// Empty input gives NaN statistics and `identifiable = false`.
    ///
    /// ```
    /// use identify_mcmc::Summary;
    /// let a = [0.1, 0.2, 0.3, 0.4, 0.5, 0.6];
    /// let b = [0.15, 0.25, 0.35, 0.45, 0.55, 0.65];
    /// let s = Summary::from_chains(&[&a, &b], (0.0, 1.0));
    /// assert!((s.mean - 0.375).abs() < 1e-12);
    /// assert!((s.prior_sd - 1.0 / 12f64.sqrt()).abs() < 1e-15);
    /// ```
    pub fn from_chains(chains: &[&[f64]], bounds: (f64, f64)) -> Self {
        let all: Vec<f64> = chains.iter().flat_map(|c| c.iter().copied()).collect();
        let s = all.len() as f64;
        let mean = if all.is_empty() {
            f64::NAN
        } else {
            all.iter().sum::<f64>() / s
        };
        let sd = if all.len() < 2 {
            f64::NAN
        } else {
            (all.iter().map(|v| (v - mean) * (v - mean)).sum::<f64>() / (s - 1.0)).sqrt()
        };
        let prior_sd = (bounds.1 - bounds.0) / 12f64.sqrt();
        let ratio = sd / prior_sd;
        Self {
            mean,
            sd,
            q05: diagnostics::quantile7(&all, 0.05),
            q95: diagnostics::quantile7(&all, 0.95),
            rhat: diagnostics::rhat(chains),
            ess_bulk: diagnostics::ess_bulk(chains),
            ess_tail: diagnostics::ess_tail(chains),
            prior_sd,
            prior_sd_ratio: ratio,
            identifiable: ratio < 0.5,
        }
    }
}

/// One entry of the posterior correlation matrix.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[non_exhaustive]
pub struct CorrelationPair {
    /// First parameter index.
    pub i: usize,
    /// Second parameter index (`j > i`).
    pub j: usize,
    /// Pearson correlation of the pooled draws.
    pub r: f64,
}

/// Pearson correlation matrix of pooled draws indexed `[parameter][chain][draw]`.
/// Every parameter's [`Summary`] from `draws[i][c]` (parameter `i`, chain `c`) and its
/// `bounds[i]`, in parallel.
pub(crate) fn summaries(draws: &[Vec<Vec<f64>>], bounds: &[(f64, f64)]) -> Vec<Summary> {
    use rayon::prelude::*;
    (0..draws.len())
        .into_par_iter()
        .map(|i| {
            let slices: Vec<&[f64]> = draws[i].iter().map(|c| c.as_slice()).collect();
            Summary::from_chains(&slices, bounds[i])
        })
        .collect()
}

/// Entries involving a constant parameter are NaN (the diagonal stays 1).
pub fn correlation_matrix(draws: &[Vec<Vec<f64>>]) -> Vec<Vec<f64>> {
    let d = draws.len();
    let pooled: Vec<Vec<f64>> = draws
        .iter()
        .map(|p| p.iter().flatten().copied().collect())
        .collect();
    let centred: Vec<Vec<f64>> = pooled
        .iter()
        .map(|v| {
            let m = v.iter().sum::<f64>() / v.len() as f64;
            v.iter().map(|x| x - m).collect()
        })
        .collect();
    let ss: Vec<f64> = centred
        .iter()
        .map(|v| v.iter().map(|x| x * x).sum())
        .collect();
    let mut c = vec![vec![f64::NAN; d]; d];
    for i in 0..d {
        c[i][i] = 1.0;
        for j in 0..i {
            let cross: f64 = centred[i].iter().zip(&centred[j]).map(|(a, b)| a * b).sum();
            let denom = (ss[i] * ss[j]).sqrt();
            let r = if denom > 0.0 {
                (cross / denom).clamp(-1.0, 1.0)
            } else {
                f64::NAN
            };
            c[i][j] = r;
            c[j][i] = r;
        }
    }
    c
}

/// Every pair `i < j` of a correlation matrix, strongest `|r|` first (NaN last,
/// ties in index order).
pub fn strongest_correlations(corr: &[Vec<f64>]) -> Vec<CorrelationPair> {
    let d = corr.len();
    let mut pairs: Vec<CorrelationPair> = (0..d)
        .flat_map(|i| (i + 1..d).map(move |j| (i, j)))
        .map(|(i, j)| CorrelationPair {
            i,
            j,
            r: corr[i][j],
        })
        .collect();
    let key = |p: &CorrelationPair| if p.r.is_nan() { -1.0 } else { p.r.abs() };
    pairs.sort_by(|a, b| key(b).total_cmp(&key(a)));
    pairs
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn correlation_of_linear_relation_is_one() {
        let x: Vec<f64> = (0..20).map(|i| i as f64).collect();
        let y: Vec<f64> = x.iter().map(|v| 3.0 - 2.0 * v).collect();
        let z: Vec<f64> = (0..20).map(|i| ((i * 7) % 5) as f64).collect();
        let draws = vec![vec![x], vec![y], vec![z]];
        let c = correlation_matrix(&draws);
        assert!((c[0][1] + 1.0).abs() < 1e-12);
        let pairs = strongest_correlations(&c);
        assert_eq!((pairs[0].i, pairs[0].j), (0, 1));
        assert_eq!(pairs.len(), 3);
        assert!(pairs[1].r.abs() >= pairs[2].r.abs());
    }

    #[test]
    fn identifiable_when_much_narrower_than_prior() {
        let a: Vec<f64> = (0..100)
            .map(|i| 0.5 + 0.001 * ((i * 13) % 17) as f64)
            .collect();
        let s = Summary::from_chains(&[&a], (0.0, 1.0));
        assert!(s.identifiable && s.prior_sd_ratio < 0.05);
        let u: Vec<f64> = (0..100).map(|i| i as f64 / 99.0).collect();
        let s = Summary::from_chains(&[&u], (0.0, 1.0));
        assert!(!s.identifiable && (s.prior_sd_ratio - 1.0).abs() < 0.05);
    }
}
