//! The noise model of a diagnosis: the dynamometer correction (offset, event transient and
//! AR(1)-plus-white random part, estimated by `experiment::DynamometerCorrection`, see
//! `docs/dynamometer.md`) together with what the diagnosis needs on top of it: where it came
//! from, the whitening plans of the random part, and how well its low-frequency level is
//! known ([`level_dof`]).
//!
//! ```text
//! ε_sys(t) = c + Σ_e e^{−(t−e)/τ}·(B sin 2πf(t−e) + C cos 2πf(t−e)),   t ≥ e
//! y_t = x_t + v_t,   x_t = φ x_{t−1} + w_t,   w ~ N(0, σ_ar²(1−φ²)),   v ~ N(0, σ_w²)
//! ```
//!
//! Whitening: a scalar Kalman filter on that state-space model gives the innovations
//! `ν_t = y_t − φ x̂_{t−1}` with variances `S_t`; `ν_t/√S_t` are i.i.d. N(0, 1) under the model,
//! and `log L = −½ Σ_t (ln 2π S_t + ν_t²/S_t)` is the exact Gaussian log-likelihood.
//! Masked (held-out) samples are skipped by the filter (prediction only), which keeps the
//! likelihood of the remaining samples exact. The random part, its moment fit, whitening and
//! likelihood are the shared [`muscle_model::Ar1White`] (module `muscle_model::noise`).

pub use experiment::Transient;
use experiment::{fit_ar1_white, DynamometerCorrection, DynamometerReport};
use muscle_model::Ar1White;
use serde::Serialize;

/// Where the noise model came from.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum NoiseModelSource {
    /// Fitted on the unloaded run (offset, transients and random part).
    Unloaded,
    /// Estimated from the baseline residual of the trial itself (no unloaded run): the
    /// dynamometer offset cannot be told from `torque_offset` then.
    TrialResidual,
}

/// The noise model of the torque residual.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
#[non_exhaustive]
pub struct TrialNoiseModel {
    /// Where it was estimated.
    pub source: NoiseModelSource,
    /// Dynamometer offset `c` (N·m; 0 without an unloaded run).
    pub offset_nm: f64,
    /// Event transient.
    pub transient: Transient,
    /// AR(1) coefficient per sample at the trial's rate.
    pub phi: f64,
    /// Stationary SD of the AR(1) part (N·m).
    pub sd_ar_nm: f64,
    /// SD of the white part (N·m).
    pub sd_white_nm: f64,
    /// RMS of the remainder after the systematic part (N·m).
    pub remainder_rms_nm: f64,
    /// Effective degrees of freedom `ν` of the low-frequency level
    /// ([`low_frequency_level`]) as estimated from the record the random part was fitted
    /// on ([`level_dof`]): `2/CV²` of the estimate. `∞` (`null` in JSON) when the noise is
    /// known exactly.
    pub level_dof: f64,
}

impl TrialNoiseModel {
    /// Systematic part at times `t` (s from the first sample) given the event times.
    pub fn systematic(&self, times: &[f64], events: &[f64]) -> Vec<f64> {
        let mut out = vec![self.offset_nm; times.len()];
        self.transient.add_to(&mut out, times, events, 1.0);
        out
    }

    /// The noise model of a dynamometer correction fitted on a recording of `n` samples
    /// (which sets [`TrialNoiseModel::level_dof`]).
    pub fn from_correction(c: &DynamometerCorrection, source: NoiseModelSource, n: usize) -> Self {
        let r = c.random;
        let level_dof = match Ar1White::new(r.phi, r.sigma_ar, r.sigma_white.max(1e-5)) {
            Ok(m) => level_dof(&m, n, LEVEL_DOF_REPLICATES, LEVEL_DOF_SEED),
            Err(_) => f64::INFINITY,
        };
        TrialNoiseModel {
            source,
            offset_nm: c.offset_nm,
            transient: c.transient,
            phi: r.phi,
            sd_ar_nm: r.sigma_ar,
            sd_white_nm: r.sigma_white,
            remainder_rms_nm: c.remainder_rms_nm,
            level_dof,
        }
    }

    /// The correction as reported in the JSON outputs (`"dynamometer"`), with `dt_s` the
    /// sampling interval of the recording the model was fitted on: the same summary
    /// [`DynamometerCorrection::report`] gives.
    pub fn dynamometer(&self, dt_s: f64) -> DynamometerReport {
        let random = Ar1White {
            phi: self.phi,
            sigma_ar: self.sd_ar_nm,
            sigma_white: self.sd_white_nm,
        };
        DynamometerReport::new(self.offset_nm, &self.transient, &random, dt_s)
    }

    /// Whitening plan for a mask (`None`: every sample observed).
    pub fn plan(&self, n: usize, mask: Option<&[bool]>) -> WhitenPlan {
        self.random_part().plan(n, mask)
    }

    /// The random part as the shared AR(1)-plus-white model (white SD at least `10⁻⁵`).
    pub fn random_part(&self) -> Ar1White {
        Ar1White {
            phi: self.phi,
            sigma_ar: self.sd_ar_nm,
            sigma_white: self.sd_white_nm.max(1e-5),
        }
    }

    /// Lag-`k` autocorrelation of the random part (for comparison with the residual's).
    pub fn autocorrelation(&self, k: usize) -> f64 {
        let m = Ar1White {
            phi: self.phi,
            sigma_ar: self.sd_ar_nm,
            sigma_white: self.sd_white_nm,
        };
        m.autocorrelation(k.min(i32::MAX as usize) as u32)
    }
}

/// The noise power per sample at frequency 0, `σ_ar²(1+φ)/(1−φ) + σ_w²`: what a slow term's
/// evidence is measured against.
pub fn low_frequency_level(m: &Ar1White) -> f64 {
    m.sigma_ar.powi(2) * (1.0 + m.phi) / (1.0 - m.phi) + m.sigma_white.powi(2)
}

/// Records simulated by [`TrialNoiseModel::from_correction`] to find [`TrialNoiseModel::level_dof`].
pub const LEVEL_DOF_REPLICATES: usize = 128;

/// Seed of those records (fixed: the same recording gives the same diagnosis).
pub const LEVEL_DOF_SEED: u64 = 0x1e7e_1d0f;

/// Effective degrees of freedom of the low-frequency level that [`experiment::fit_ar1_white`] estimates
/// from `n` samples of the noise `m`: `ν = 2/CV²`, the coefficient of variation `CV` taken
/// over `replicates` records of `n` samples simulated from `m` (a parametric bootstrap), so
/// that the estimated level scatters like `level·χ²_ν/ν`.
///
/// Replicate `r` draws from its own ChaCha8 stream (`seed`, `r`), so the value does not depend
/// on the number of threads. The result is clamped to `[2, 10⁶]`; fewer than 16 samples or
/// 2 replicates give 2 (the record says almost nothing about the level).
pub fn level_dof(m: &Ar1White, n: usize, replicates: usize, seed: u64) -> f64 {
    use rand::SeedableRng;
    use rayon::prelude::*;
    if n < 16 || replicates < 2 {
        return 2.0;
    }
    let levels: Vec<f64> = (0..replicates)
        .into_par_iter()
        .map(|r| {
            let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
            rng.set_stream(r as u64);
            low_frequency_level(&fit_ar1_white(&simulate(m, n, &mut rng)))
        })
        .collect();
    let k = levels.len() as f64;
    let mean = levels.iter().sum::<f64>() / k;
    let var = levels.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / (k - 1.0);
    if !(mean > 0.0 && var.is_finite()) {
        return 2.0;
    }
    if var <= 0.0 {
        return 1e6;
    }
    (2.0 * mean * mean / var).clamp(2.0, 1e6)
}

/// `n` samples of the AR(1)-plus-white noise `m` from `rng`: `x₀ = σ_ar·ξ₀` (the stationary
/// start), `xᵢ = φ·xᵢ₋₁ + σ_ar·√(1−φ²)·ξᵢ`, `yᵢ = xᵢ + σ_w·ηᵢ`, with `ξᵢ` then `ηᵢ` drawn for each
/// sample in turn.
pub fn simulate(m: &Ar1White, n: usize, rng: &mut impl rand::Rng) -> Vec<f64> {
    use rand_distr::{Distribution, StandardNormal};
    let innov = m.sigma_ar * (1.0 - m.phi * m.phi).max(0.0).sqrt();
    let mut normal = || -> f64 { StandardNormal.sample(rng) };
    let mut x = m.sigma_ar * normal();
    (0..n)
        .map(|i| {
            if i > 0 {
                x = m.phi * x + innov * normal();
            }
            x + m.sigma_white * normal()
        })
        .collect()
}

/// Precomputed Kalman gains for one mask: whitening is then one pass per vector.
pub use muscle_model::WhitenPlan;

#[cfg(test)]
mod tests {
    use super::*;
    use crate::power::true_noise;
    use experiment::DynamometerSettings;

    /// The default dynamometer noise at 2048 Hz.
    fn default_noise() -> Ar1White {
        true_noise(&DynamometerSettings::default(), 2048.0).expect("valid default noise")
    }

    #[test]
    fn level_dof_of_an_unloaded_run_matches_the_scatter_of_full_noise_fits() {
        // `noise_scatter -- 200 1` (full fits of 200 simulated 8 s unloaded runs, systematic
        // part included) measured a 17.2 % SD of the level, i.e. ν = 2/0.172² ≈ 68
        let nu = level_dof(
            &default_noise(),
            8 * 2048,
            LEVEL_DOF_REPLICATES,
            LEVEL_DOF_SEED,
        );
        assert!((30.0..90.0).contains(&nu), "ν = {nu}");
        // a record four times longer pins the level about four times better
        let nu4 = level_dof(
            &default_noise(),
            32 * 2048,
            LEVEL_DOF_REPLICATES,
            LEVEL_DOF_SEED,
        );
        assert!((2.5..6.0).contains(&(nu4 / nu)), "ν = {nu} → {nu4}");
    }

    #[test]
    fn level_dof_is_reproducible_and_independent_of_the_threads() {
        let m = default_noise();
        let a = level_dof(&m, 4096, 32, 7);
        let one = rayon::ThreadPoolBuilder::new()
            .num_threads(1)
            .build()
            .expect("pool");
        let b = one.install(|| level_dof(&m, 4096, 32, 7));
        assert_eq!(a.to_bits(), b.to_bits());
        assert_ne!(a.to_bits(), level_dof(&m, 4096, 32, 8).to_bits());
        assert_eq!(level_dof(&m, 10, 32, 7), 2.0);
    }

    #[test]
    fn unloaded_fit_reports_finite_level_dof() {
        use rand::SeedableRng;
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(3);
        let y = simulate(&default_noise(), 8 * 2048, &mut rng);
        let c = DynamometerCorrection::fit(&y, 2048.0, &[], true).expect("a valid record");
        let fit = TrialNoiseModel::from_correction(&c, NoiseModelSource::Unloaded, y.len());
        assert!(fit.level_dof.is_finite() && fit.level_dof > 10.0, "{fit:?}");
    }
}
