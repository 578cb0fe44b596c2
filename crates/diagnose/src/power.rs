//! What a trial can tell at best about an effect: the noncentrality of the likelihood-ratio
//! test and the detection rate it allows, whatever the decision rule.
//!
//! Let `τ*` be the noise-free torque of the true model (with the effect) and `W` the whitening
//! of the noise model (module [`crate::noise`]). The baseline (9 muscle parameters, no effect)
//! fitted to `τ*` leaves
//!
//! ```text
//! λ = min_θ ‖W (τ* − τ_base(θ))‖²
//! ```
//!
//! the part of the effect that no muscle parameter can absorb, measured in units of the noise.
//! With noise, the likelihood-ratio statistic `2Δlog L` of the model with the effect (`k`
//! parameters) against the baseline is, to first order, noncentral `χ²_k(λ)`. A rule that
//! names the effect when `ΔBIC = −2Δlog L + k ln n` is below `β` (the ΔBIC margin, −10)
//! therefore names it with probability at most
//!
//! ```text
//! P(χ²_k(λ) > k ln n − β),    P(χ²_k(λ) > c) = Σ_j Pois(j; λ/2) · P(χ²_{k+2j} > c)
//! ```
//!
//! and no test with false-alarm rate `α` per candidate does better than
//! `P(χ²_k(λ) > χ²_{k, 1−α})`. With effects in the null model (the baseline plus, say,
//! `torque_offset`), `λ` measures what the effect adds to that model: whether a gravity term
//! can be told from an offset at all. Both are upper bounds: they assume the noise model is known,
//! the fits reach their optima and no other candidate competes. A measured detection rate far
//! below them points at the method; one close to them at the data.
//!
//! # Example
//!
//! ```no_run
//! use diagnose::power::{noncentrality, rule_power, true_noise};
//! use diagnose::scenarios::hidden_trial_sized;
//! use experiment::DynamometerSettings;
//! use muscle_model::EffectKind;
//!
//! let t = hidden_trial_sized(EffectKind::Inertia, 0.1, 8900)?;
//! let fs = t.synthetic.trial.sample_rate_hz();
//! let noise = true_noise(&DynamometerSettings::default(), fs)?;
//! let settings = diagnose::DiagnoseSettings::default();
//! let info = noncentrality(&t.synthetic.trial, &t.synthetic.model_torque, &[], &noise,
//!                          &settings)?;
//! println!("λ = {:.1}, ΔBIC rule names it at most {:.0} % of the time", info.lambda,
//!          100.0 * rule_power(info.lambda, 1, info.n_obs, settings.max_delta_bic));
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

use experiment::{DynamometerSettings, Trial};
use muscle_model::{Ar1White, EffectKind};

use crate::context::segment_motion;
use crate::fit::{latin_hypercube, Context};
use crate::noise::{NoiseModelSource, Transient, TrialNoiseModel};
use crate::{DiagnoseError, DiagnoseSettings};
use numerics::LevenbergMarquardtSettings;

/// The null model's misfit to a noise-free trial.
#[derive(Clone, Debug, PartialEq)]
#[non_exhaustive]
pub struct Information {
    /// `λ`: whitened sum of squares of the null model's best fit to the noise-free torque.
    pub lambda: f64,
    /// RMS of that fit's residual (N·m), unwhitened.
    pub rms_nm: f64,
    /// Samples (the `n` of the BIC).
    pub n_obs: usize,
    /// Simulations spent.
    pub evaluations: usize,
}

/// `λ` of [`Information`]: the null model, the baseline with the effects `null` (none: the
/// baseline alone), fitted from the nominal parameters (effects at their null values) and
/// [`DiagnoseSettings::baseline_extra_starts`] Latin-hypercube starts, the lowest cost winning
/// (Levenberg–Marquardt run to convergence: at least 300 iterations and a relative decrease of
/// 10⁻¹²), to `clean_torque` (the noise-free torque of the true model on `trial`'s inputs, one
/// value per sample) by least squares whitened with `noise`.
///
/// # Errors
/// Invalid settings, a trial that cannot be turned into inputs or segmented, a
/// `clean_torque` of another length or with a non-finite value, or a baseline that cannot be
/// simulated.
pub fn noncentrality(
    trial: &Trial,
    clean_torque: &[f64],
    null: &[EffectKind],
    noise: &Ar1White,
    settings: &DiagnoseSettings,
) -> Result<Information, DiagnoseError> {
    settings.validate()?;
    let inputs = experiment::model_inputs(trial, &settings.input_options)?;
    let seg = segment_motion(&inputs)?;
    let n = inputs.len();
    if clean_torque.len() != n || clean_torque.iter().any(|v| !v.is_finite()) {
        return Err(DiagnoseError::Settings {
            name: "clean_torque",
            reason: format!(
                "needs {n} finite values (one per sample of the trial), got {}",
                clean_torque.len()
            ),
        });
    }
    let model = TrialNoiseModel {
        source: NoiseModelSource::Unloaded,
        offset_nm: 0.0,
        transient: Transient::none(),
        phi: noise.phi,
        sd_ar_nm: noise.sigma_ar,
        sd_white_nm: noise.sigma_white,
        remainder_rms_nm: 0.0,
        level_dof: f64::INFINITY,
    };
    let plan = model.plan(n, None);
    // to convergence: with the diagnosis's stopping rule (30 iterations, relative decrease
    // 10⁻⁷) a fit to a noise-free trial without effect stops at λ ≈ 0.5, not ≈ 0
    let lm = LevenbergMarquardtSettings {
        max_iterations: settings.lm.max_iterations.max(300),
        ftol_rel: settings.lm.ftol_rel.min(1e-12),
        ..settings.lm
    };
    let ctx = Context {
        inputs,
        y: clean_torque.to_vec(),
        noise: model,
        seg,
        plan,
        folds: Vec::new(),
        lm,
        cv_lm: lm,
        extended_extra_starts: settings.extended_extra_starts,
        start_seed: settings.start_seed,
        params: muscle_model::ModelParams::nominal(),
        effects: muscle_model::Effects::none(),
        observed: None,
        exact_jacobian: settings.exact_jacobian,
    };
    let mut x0 = ctx.base_muscles().to_vec();
    for k in null {
        x0.extend(&k.null_values()[..k.params().len()]);
    }
    let bounds = ctx.problem(null)?.bounds().to_vec();
    let mut starts = vec![x0];
    starts.extend(latin_hypercube(
        &bounds,
        settings.baseline_extra_starts,
        settings.start_seed,
    ));
    let fit = ctx.fit_from(null, &starts, false)?;
    Ok(Information {
        lambda: fit.white_ss,
        rms_nm: fit.rms,
        n_obs: ctx.plan.n_obs(),
        evaluations: fit.evaluations,
    })
}

/// The detection size of a torque disturbance of any shape in `trial` (which must not hold
/// it), as the detection limits of the catalogued effects are defined
/// (docs/studies/limit-calibration.md): the peak size `θ` at which a one-parameter term of
/// exactly the disturbance's shape would be named by the ΔBIC rule in 95 % of trials,
/// `λ(θ) = λ₉₅`.
///
/// The trial is prepared and its noise model estimated as the diagnosis does (with its
/// unloaded run when given), and the baseline fitted. `λ(θ)` is the whitened sum of squares
/// left when the baseline is refitted to its own prediction plus the disturbance scaled to
/// peak `θ`: what the muscle parameters cannot absorb. From the given peak `θ₀`,
/// `θ₁ = θ₀·√(λ₉₅/λ(θ₀))`, refitted once more at `θ₁` (the muscle parameters absorb a larger
/// share of a larger disturbance, so `λ ∝ θ²` holds only to first order).
///
/// # Errors
/// Invalid settings or trial, a disturbance of another length than the trial, not finite or
/// all zero, a baseline that cannot be simulated, or a refit that cannot be done.
pub fn disturbance_detection_size(
    trial: &Trial,
    unloaded: Option<&experiment::Unloaded>,
    disturbance_nm: &[f64],
    settings: &DiagnoseSettings,
) -> Result<f64, DiagnoseError> {
    settings.validate()?;
    let prepared = settings.prepare(trial, unloaded)?;
    let n = prepared.inputs.len();
    let peak = disturbance_nm.iter().fold(0.0_f64, |m, a| m.max(a.abs()));
    if disturbance_nm.len() != n || disturbance_nm.iter().any(|v| !v.is_finite()) || peak == 0.0 {
        return Err(DiagnoseError::Settings {
            name: "disturbance_nm",
            reason: format!(
                "needs {n} finite values, not all zero (one per sample of the trial), got {}",
                disturbance_nm.len()
            ),
        });
    }
    let (ctx, _) = crate::context::prepared_context(
        &prepared,
        muscle_model::ModelParams::nominal(),
        muscle_model::Effects::none(),
        settings,
    )?;
    let baseline = crate::baseline::fit_baseline(&ctx, settings)?;
    let pred = ctx.problem(&[])?.predict(&baseline.x)?;
    let lambda_95 = crate::score::lambda_95(1, ctx.plan.n_obs(), settings.max_delta_bic);
    let mut size = peak;
    for _ in 0..2 {
        let target: Vec<f64> = pred
            .iter()
            .zip(disturbance_nm)
            .map(|(p, d)| p + d * size / peak)
            .collect();
        let (lambda, _) =
            crate::score::refit_absorbs(&ctx, &baseline, target, false).ok_or_else(|| {
                DiagnoseError::Fit {
                    model: "baseline".into(),
                    reason: format!("cannot be refitted to the disturbance at {size} N·m"),
                }
            })?;
        if !(lambda > 0.0 && lambda.is_finite()) {
            return Err(DiagnoseError::Settings {
                name: "disturbance_nm",
                reason: format!("the baseline absorbs a disturbance of {size} N·m entirely"),
            });
        }
        size *= (lambda_95 / lambda).sqrt();
    }
    Ok(size)
}

/// The random part of the simulated dynamometer error (docs/dynamometer.md) at `fs` Hz, as [`noncentrality`] wants
/// it: AR(1) with `φ = exp(−1/(fs·τc))` and SD `σ_ar`, plus white noise whose variance
/// includes the ADC's quantisation, `σ_w² + step²/12`.
///
/// # Errors
/// Settings that give no valid AR(1) model (e.g. a non-positive `fs`).
pub fn true_noise(s: &DynamometerSettings, fs: f64) -> Result<Ar1White, DiagnoseError> {
    let q = s.quantisation_step_nm();
    Ok(Ar1White::new(
        s.ar1_phi(1.0 / fs),
        s.ar1_sd_nm,
        (s.white_sd_nm.powi(2) + q * q / 12.0).sqrt(),
    )?)
}

pub use crate::noise::low_frequency_level;

/// The noncentral χ² tail and the central χ² quantile the power rules use (in
/// `numerics::special`).
pub use numerics::special::{chi2_upper_quantile, noncentral_chi2_survival};

/// The most often a ΔBIC rule with margin `max_delta_bic` can name an effect of `k`
/// parameters with noncentrality `lambda` on `n_obs` samples: `P(χ²_k(λ) > k ln n − β)`.
pub fn rule_power(lambda: f64, k: usize, n_obs: usize, max_delta_bic: f64) -> f64 {
    noncentral_chi2_survival(k as f64 * (n_obs as f64).ln() - max_delta_bic, k, lambda)
}

/// The most often a one-parameter effect with noncentrality `lambda` is named by the ΔBIC
/// rule *and* kept by a review that asks it to beat a one-coefficient rival by `margin` in
/// BIC (docs/diagnosis-method.md, "No false story": fatigue against a ramp in time).
///
/// To first order, with `â` and `b̂` the unit directions the effect and the rival leave
/// once the model's parameters have absorbed what they can, and `cos = â·b̂`, the two
/// statistics are `X = â·(s + ε) ~ N(√λ, 1)` and `Y = b̂·(s + ε) = cos·X + √(1 − cos²)·Z`:
/// the rule names the effect when `X² > ln n − β`, and the review keeps it when
/// `X² − Y² ≥ margin` (same number of parameters, so the BIC difference is the
/// log-likelihood's). Integrated over `X` (trapezoids of 0.005 over ±10 around `√λ`):
///
/// ```text
/// P = ∫ φ(x − √λ) 1{x² > max(ln n − β, margin)} [Φ((r − cos·x)/σ) − Φ((−r − cos·x)/σ)] dx,
/// r = √(x² − margin), σ = √(1 − cos²)
/// ```
///
/// With `cos` = 0 it is [`rule_power`] (for `k` = 1, up to the review's own noise); it falls
/// to 0 as the rival's direction nears the effect's.
///
/// ```
/// use diagnose::power::{rule_power, rule_power_against};
/// let (lambda, n) = (40.0, 17_000);
/// let alone = rule_power(lambda, 1, n, -10.0);
/// assert!((rule_power_against(lambda, 0.0, n, -10.0, 2.0) - alone).abs() < 1e-3);
/// assert!(rule_power_against(lambda, 0.9, n, -10.0, 2.0) < alone - 0.1);
/// ```
pub fn rule_power_against(
    lambda: f64,
    cos: f64,
    n_obs: usize,
    max_delta_bic: f64,
    margin: f64,
) -> f64 {
    use numerics::special::normal_cdf;
    let mu = lambda.max(0.0).sqrt();
    let c = cos.clamp(-1.0, 1.0);
    let sigma = (1.0 - c * c).max(0.0).sqrt();
    let floor = ((n_obs as f64).ln() - max_delta_bic).max(margin);
    let kept = |x: f64| -> f64 {
        if x * x <= floor {
            return 0.0;
        }
        let r = (x * x - margin).max(0.0).sqrt();
        if sigma < 1e-12 {
            return f64::from((c * x).abs() <= r);
        }
        normal_cdf((r - c * x) / sigma) - normal_cdf((-r - c * x) / sigma)
    };
    let h = 0.005;
    let steps = (20.0 / h) as usize;
    let density = |x: f64| (-0.5 * (x - mu) * (x - mu)).exp() / (2.0 * std::f64::consts::PI).sqrt();
    let mut sum = 0.0;
    for i in 0..=steps {
        let x = mu - 10.0 + h * i as f64;
        let w = if i == 0 || i == steps { 0.5 } else { 1.0 };
        sum += w * density(x) * kept(x);
    }
    (sum * h).clamp(0.0, 1.0)
}

/// The most often any test with false-alarm rate `alpha` can detect an effect of `k`
/// parameters with noncentrality `lambda`: `P(χ²_k(λ) > χ²_{k,1−α})`.
pub fn test_power(lambda: f64, k: usize, alpha: f64) -> f64 {
    noncentral_chi2_survival(chi2_upper_quantile(alpha, k), k, lambda)
}

/// The Wilson score interval of a binomial proportion: `k` successes in `n` trials, two-sided
/// confidence `1 − alpha` (`z` the normal quantile, from [`chi2_upper_quantile`] with one
/// degree of freedom). `(0, 1)` when `n` = 0.
///
/// ```
/// // 19 of 20 at 95 %: [0.764, 0.991]
/// let (lo, hi) = diagnose::power::wilson_interval(19, 20, 0.05);
/// assert!((lo - 0.764).abs() < 1e-3 && (hi - 0.991).abs() < 1e-3);
/// ```
pub fn wilson_interval(k: usize, n: usize, alpha: f64) -> (f64, f64) {
    if n == 0 {
        return (0.0, 1.0);
    }
    let z2 = chi2_upper_quantile(alpha, 1);
    let (k, n) = (k.min(n) as f64, n as f64);
    let p = k / n;
    let denom = 1.0 + z2 / n;
    let centre = (p + z2 / (2.0 * n)) / denom;
    let half = (z2 * (p * (1.0 - p) / n + z2 / (4.0 * n * n))).sqrt() / denom;
    ((centre - half).max(0.0), (centre + half).min(1.0))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_rival_costs_power_as_its_direction_nears_the_effects() {
        let n = 17_000;
        let mut last = f64::INFINITY;
        for c in [0.0, 0.3, 0.6, 0.8, 0.9, 0.95, 0.99] {
            let p = rule_power_against(40.0, c, n, -10.0, 2.0);
            assert!(p <= last + 1e-12, "cos {c}: {p} after {last}");
            last = p;
        }
        assert!(last < 0.6, "{last}");
        // the same direction: the review can never prefer the effect by 2
        assert_eq!(rule_power_against(400.0, 1.0, n, -10.0, 2.0), 0.0);
        // and a larger effect is kept more often
        assert!(
            rule_power_against(80.0, 0.9, n, -10.0, 2.0)
                > rule_power_against(40.0, 0.9, n, -10.0, 2.0)
        );
    }

    #[test]
    fn wilson_interval_matches_published_values() {
        // Newcombe (1998), Stat. Med. 17:857, table I: 81/263 → 0.2553–0.3662,
        // 15/148 → 0.0624–0.1605, 0/20 → 0–0.1611
        let close =
            |a: (f64, f64), b: (f64, f64)| (a.0 - b.0).abs() < 5e-4 && (a.1 - b.1).abs() < 5e-4;
        assert!(close(wilson_interval(81, 263, 0.05), (0.2553, 0.3662)));
        assert!(close(wilson_interval(15, 148, 0.05), (0.0624, 0.1605)));
        assert!(close(wilson_interval(0, 20, 0.05), (0.0, 0.1611)));
        assert_eq!(wilson_interval(3, 0, 0.05), (0.0, 1.0));
        let (lo, hi) = wilson_interval(20, 20, 0.05);
        assert!(
            (hi - 1.0).abs() < 1e-9 && (lo - 0.8389).abs() < 5e-4,
            "{lo} {hi}"
        );
    }

    #[test]
    fn the_spec_noise_has_its_low_frequency_level() {
        let m = true_noise(&DynamometerSettings::default(), 2048.0).expect("valid");
        assert!((m.phi - (-1.0 / (2048.0 * 0.03f64)).exp()).abs() < 1e-12);
        // 1.2²·(1+φ)/(1−φ) + 0.4² + (1356/4096)²/12 = 177.1 N·m² per sample
        assert!((low_frequency_level(&m) - 177.1).abs() < 0.05, "{m:?}");
        assert!(true_noise(&DynamometerSettings::default(), -1.0).is_err());
    }

    #[test]
    fn quantile_inverts_the_tail() {
        assert!((chi2_upper_quantile(0.05, 1) - 3.841_459).abs() < 1e-5);
        assert!((chi2_upper_quantile(1e-3, 2) - 13.815_511).abs() < 1e-5);
        // the rule's power rises with λ and is the central tail at λ = 0
        let n = 17_000;
        let p0 = rule_power(0.0, 1, n, -10.0);
        let central = numerics::special::chi2_survival((n as f64).ln() + 10.0, 1);
        assert!((p0 - central).abs() < 1e-12);
        let ps: Vec<f64> = [5.0, 20.0, 40.0]
            .iter()
            .map(|l| rule_power(*l, 1, n, -10.0))
            .collect();
        assert!(p0 < ps[0] && ps[0] < ps[1] && ps[1] < ps[2], "{p0} {ps:?}");
        assert!(test_power(20.0, 1, 1e-3) > rule_power(20.0, 1, n, -10.0));
    }
}
