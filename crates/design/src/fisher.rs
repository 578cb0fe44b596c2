//! The Fisher information of a trial and of a set of trials, with one constant torque offset
//! per trial as a nuisance parameter.
//!
//! With the whitening `W` of the AR(1)+white noise (`muscle_model::WhitenPlan`: `W·e` is
//! i.i.d. `N(0, 1)` when `e` is the noise), a trial's torque Jacobian `J` (`n × p`) and its
//! offset column `1` give
//!
//! ```text
//! A = (WJ)ᵀ(WJ),   b = (WJ)ᵀ(W1),   c = (W1)ᵀ(W1).
//! ```
//!
//! A trial's offset `d ~ N(0, s²)` (a prior sd `s` left after the unloaded run's correction)
//! integrated out leaves the information on `θ`
//!
//! ```text
//! F_trial = A − b·bᵀ/(c + 1/s²)
//! ```
//!
//! (the Schur complement of the offset in the joint information); `s = 0` (offset known)
//! gives `A`, `s = ∞` (offset free) `A − b·bᵀ/c`. Offsets of different trials are
//! independent, so a protocol's information is the sum `F = Σ_trials F_trial`, and the
//! expected posterior covariance without a prior is `F⁻¹`.
//!
//! The uniform prior on the bounds `[l, u]` has variance `w²/12` (`w = u − l`); taken as a
//! Gaussian of that variance it adds `diag(12/w²)`: `Σ_prior = (F + diag(12/w²))⁻¹`.

use muscle_model::Ar1White;
use serde::Serialize;

use crate::error::{DesignError, Result};
use crate::jacobian::TorqueJacobian;

/// How each trial's constant torque offset enters.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum OffsetTreatment {
    /// No offset: the dynamometer's offset is known exactly.
    Known,
    /// One offset per trial with a Gaussian prior of this sd (N·m), integrated out.
    Prior {
        /// Prior sd (N·m).
        sd_nm: f64,
    },
    /// One offset per trial with a flat prior.
    Free,
}

/// A trial's whitened information blocks `A`, `b·bᵀ`, `c` (see the module docs).
///
/// `c` depends only on the noise and the number of samples, so the mean of several
/// realisations of a trial (EMG seeds; [`TrialInformation::mean`]) keeps the marginal exact:
/// the mean of `A − b·bᵀ/(c + 1/s²)` is `mean(A) − mean(b·bᵀ)/(c + 1/s²)`.
#[derive(Clone, Debug, PartialEq)]
pub struct TrialInformation {
    /// Number of parameters `p`.
    pub dim: usize,
    /// `A = (WJ)ᵀ(WJ)`, row-major `p × p`.
    pub a: Vec<f64>,
    /// `b·bᵀ` with `b = (WJ)ᵀ(W1)`, row-major `p × p`.
    pub bbt: Vec<f64>,
    /// `c = (W1)ᵀ(W1)`.
    pub c: f64,
    /// Samples of the trial that count.
    pub samples: usize,
}

impl TrialInformation {
    /// Whitens the Jacobian's columns and the offset column with `noise` (sampled at the
    /// trial's own interval) and forms their inner products.
    #[must_use]
    pub fn new(jac: &TorqueJacobian, noise: &Ar1White) -> Self {
        Self::observed(jac, noise, None)
    }

    /// [`TrialInformation::new`] counting only the samples where `mask` is true (the others
    /// are skipped by the whitening filter, which keeps the likelihood of the rest exact).
    #[must_use]
    pub fn observed(jac: &TorqueJacobian, noise: &Ar1White, mask: Option<&[bool]>) -> Self {
        let n = jac.columns.first().map_or(0, Vec::len);
        let plan = noise.plan(n, mask);
        let mut w: Vec<Vec<f64>> = jac
            .columns
            .iter()
            .map(|col| {
                let mut out = vec![0.0; n];
                plan.whiten(col, &mut out);
                out
            })
            .collect();
        let mut ones = vec![0.0; n];
        plan.whiten(&vec![1.0; n], &mut ones);
        w.push(ones);
        let p = jac.columns.len();
        let dot = |x: &[f64], y: &[f64]| x.iter().zip(y).map(|(a, b)| a * b).sum::<f64>();
        let mut a = vec![0.0; p * p];
        for i in 0..p {
            for j in i..p {
                let v = dot(&w[i], &w[j]);
                a[i * p + j] = v;
                a[j * p + i] = v;
            }
        }
        let b: Vec<f64> = (0..p).map(|i| dot(&w[i], &w[p])).collect();
        let bbt = (0..p * p).map(|k| b[k / p] * b[k % p]).collect();
        let c = dot(&w[p], &w[p]);
        Self {
            dim: p,
            a,
            bbt,
            c,
            samples: plan.n_obs(),
        }
    }

    /// The mean information of several realisations of one trial (same length and noise).
    ///
    /// # Errors
    /// [`DesignError::Invalid`] when `infos` is empty or the realisations differ in
    /// dimension, samples or `c`.
    pub fn mean(infos: &[TrialInformation]) -> Result<Self> {
        let first = infos.first().ok_or(DesignError::Invalid {
            what: "trial information",
            reason: "no realisation to average".into(),
        })?;
        let k = infos.len() as f64;
        let mut out = Self {
            a: vec![0.0; first.a.len()],
            bbt: vec![0.0; first.bbt.len()],
            ..first.clone()
        };
        for t in infos {
            let same_c = (t.c - first.c).abs() <= 1e-9 * first.c.abs();
            if t.dim != first.dim || t.samples != first.samples || !same_c {
                return Err(DesignError::Invalid {
                    what: "trial information",
                    reason: "realisations of different lengths or noise".into(),
                });
            }
            for (o, v) in out.a.iter_mut().zip(&t.a) {
                *o += v / k;
            }
            for (o, v) in out.bbt.iter_mut().zip(&t.bbt) {
                *o += v / k;
            }
        }
        Ok(out)
    }

    /// The information on `θ` with the offset treated as `offset`.
    #[must_use]
    pub fn marginal(&self, offset: OffsetTreatment) -> Vec<f64> {
        let extra = match offset {
            OffsetTreatment::Known => return self.a.clone(),
            OffsetTreatment::Prior { sd_nm } if sd_nm <= 0.0 => return self.a.clone(),
            OffsetTreatment::Prior { sd_nm } => 1.0 / (sd_nm * sd_nm),
            OffsetTreatment::Free => 0.0,
        };
        let denom = self.c + extra;
        self.a
            .iter()
            .zip(&self.bbt)
            .map(|(a, bb)| a - bb / denom)
            .collect()
    }
}

/// `F = Σ_trials F_trial` (row-major `p × p`).
///
/// # Errors
/// [`DesignError::Invalid`] when there is no trial or the trials have different dimensions.
pub fn fisher_information(
    trials: &[&TrialInformation],
    offset: OffsetTreatment,
) -> Result<Vec<f64>> {
    let p = trials.first().map(|t| t.dim).ok_or(DesignError::Invalid {
        what: "protocol",
        reason: "no trial".into(),
    })?;
    let mut f = vec![0.0; p * p];
    for t in trials {
        if t.dim != p {
            return Err(DesignError::Invalid {
                what: "protocol",
                reason: "trials with different parameter sets".into(),
            });
        }
        for (fi, m) in f.iter_mut().zip(t.marginal(offset)) {
            *fi += m;
        }
    }
    Ok(f)
}

/// `sqrt(diag((F + diag(prior_precision))⁻¹))`.
///
/// # Errors
/// [`DesignError::Singular`] (naming `protocol`) when the matrix is not positive definite.
pub fn posterior_sds(f: &[f64], prior_precision: &[f64], protocol: &str) -> Result<Vec<f64>> {
    let p = prior_precision.len();
    let mut m = f.to_vec();
    for (i, pp) in prior_precision.iter().enumerate() {
        m[i * p + i] += pp;
    }
    // Scale to unit diagonal first: the parameters' units differ by six orders of magnitude.
    let d: Vec<f64> = (0..p).map(|i| m[i * p + i].sqrt()).collect();
    if d.iter().any(|x| !(x.is_finite() && *x > 0.0)) {
        return Err(DesignError::Singular {
            protocol: protocol.to_string(),
        });
    }
    for i in 0..p {
        for j in 0..p {
            m[i * p + j] /= d[i] * d[j];
        }
    }
    let inv = numerics::cholesky::spd_inverse(&m, p).map_err(|_| DesignError::Singular {
        protocol: protocol.to_string(),
    })?;
    Ok((0..p).map(|i| inv[i * p + i].sqrt() / d[i]).collect())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The Schur complement equals the θ block of the inverse of the joint information with
    /// the offset's prior precision added, on a 2-parameter example.
    #[test]
    fn offset_marginal_is_the_schur_complement() {
        let t = TrialInformation {
            dim: 2,
            a: vec![4.0, 1.0, 1.0, 3.0],
            bbt: vec![2.25, -0.75, -0.75, 0.25],
            c: 2.0,
            samples: 10,
        };
        let s = 0.7f64;
        let joint = vec![
            4.0,
            1.0,
            1.5,
            1.0,
            3.0,
            -0.5,
            1.5,
            -0.5,
            2.0 + 1.0 / (s * s),
        ];
        let inv = numerics::cholesky::spd_inverse(&joint, 3).unwrap();
        let sd = posterior_sds(
            &t.marginal(OffsetTreatment::Prior { sd_nm: s }),
            &[0.0; 2],
            "x",
        )
        .unwrap();
        assert!((sd[0] - inv[0].sqrt()).abs() < 1e-12);
        assert!((sd[1] - inv[4].sqrt()).abs() < 1e-12);
        // Known ≤ prior ≤ free in variance.
        let known = posterior_sds(&t.marginal(OffsetTreatment::Known), &[0.0; 2], "x").unwrap();
        let free = posterior_sds(&t.marginal(OffsetTreatment::Free), &[0.0; 2], "x").unwrap();
        assert!(known[0] < sd[0] && sd[0] < free[0]);
    }

    #[test]
    fn singular_information_is_an_error() {
        let f = vec![1.0, 1.0, 1.0, 1.0];
        let e = posterior_sds(&f, &[0.0; 2], "knee0@30").unwrap_err();
        assert!(e.to_string().contains("knee0@30"));
    }
}
