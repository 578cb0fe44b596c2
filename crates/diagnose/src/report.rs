//! The diagnosis result: the `diagnosis.json` shape (docs/formats.md) and the terminal summary.

use std::collections::BTreeMap;

use muscle_model::EffectKind;
use serde::Serialize;

use crate::analysis::ResidualAnalysis;
use crate::noise::TrialNoiseModel;

/// `adequate` (no cause named) or `deficient`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
#[non_exhaustive]
pub enum Verdict {
    /// The baseline model explains the trial.
    Adequate,
    /// At least one catalogued effect, or unexplained structure, is missing from the model.
    Deficient,
}

/// A fitted model in the report.
#[derive(Clone, Debug, PartialEq, Serialize)]
#[non_exhaustive]
pub struct ModelReport {
    /// Effects and their fitted parameters (`{}` for the baseline).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub effects: Option<BTreeMap<String, BTreeMap<String, f64>>>,
    /// The 9 identified muscle parameters (`sol.lst_m`, …).
    pub params: BTreeMap<String, f64>,
    /// In-sample RMS of `measured − dynamometer systematic part − model` (N·m).
    pub rms_nm: f64,
    /// Cycle-wise cross-validated RMS (each cycle predicted by a fit without it) (N·m).
    pub heldout_rms_nm: f64,
    /// Exact Gaussian log-likelihood under the noise model.
    pub log_likelihood: f64,
    /// `−2 log L + k ln n`.
    pub bic: f64,
    /// Number of free parameters.
    pub n_params: usize,
    /// Uncertainty of the effect parameters, same shape as `effects` (extended model only):
    /// half the 68 % profile-likelihood interval (`effect_interval`), or the Laplace standard
    /// error where no interval could be computed.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub effect_uncertainty: Option<BTreeMap<String, BTreeMap<String, f64>>>,
    /// 68 % profile-likelihood interval of each effect parameter (extended model only).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub effect_interval: Option<BTreeMap<String, BTreeMap<String, ParamInterval>>>,
    /// Uncertainty of the muscle parameters: half the 68 % profile-likelihood interval
    /// (`param_interval`) for the final model, the Laplace standard error for a baseline that
    /// an effect extended.
    pub param_uncertainty: BTreeMap<String, f64>,
    /// 68 % profile-likelihood interval of each muscle parameter (final model only).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub param_interval: Option<BTreeMap<String, ParamInterval>>,
}

/// The 68 % profile-likelihood interval of one parameter: the values at which the best fit
/// with the parameter held there is worse by `Δ(−2 log L) = s²` (docs/diagnosis.md).
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
#[non_exhaustive]
pub struct ParamInterval {
    /// Lower end.
    pub lower: f64,
    /// Upper end.
    pub upper: f64,
    /// The lower end is the parameter's bound (the level is not reached inside the bounds).
    pub lower_at_bound: bool,
    /// The upper end is the parameter's bound.
    pub upper_at_bound: bool,
    /// Laplace (Gauss–Newton) standard error at the fit, for comparison.
    pub laplace_se: f64,
}

impl ParamInterval {
    pub(crate) fn new(iv: &crate::profile::ProfileInterval, laplace_se: f64) -> Self {
        ParamInterval {
            lower: iv.lower,
            upper: iv.upper,
            lower_at_bound: iv.lower_at_bound,
            upper_at_bound: iv.upper_at_bound,
            laplace_se,
        }
    }
}

/// Gain of the extended model over the baseline.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
#[non_exhaustive]
pub struct Gain {
    /// `100·(1 − heldout_ext/heldout_base)`.
    pub heldout_rms_reduction_pct: f64,
    /// `dev_base − dev_ext`, the fall of the held-out deviance (`Σ ν²/S` over the held-out
    /// samples, χ² units; positive favours the extension).
    pub heldout_deviance_reduction: f64,
    /// `BIC_ext − BIC_base` (negative favours the extension).
    pub delta_bic: f64,
    /// `log L_ext − log L_base`.
    pub delta_log_likelihood: f64,
    /// `100·(1 − rms_ext/rms_base)` in sample.
    pub rms_reduction_pct: f64,
}

/// One candidate extension.
#[derive(Clone, Debug, PartialEq, Serialize)]
#[non_exhaustive]
pub struct CandidateReport {
    /// Effect name.
    pub effect: String,
    /// Score-test evidence `LM − p ln n` at the round it was last scored (≈ expected BIC gain).
    pub evidence: f64,
    /// Score statistic `LM` (≈ χ²(p) under the null).
    pub score_lm: f64,
    /// Held-out RMS of the model with this candidate added (null if it was not refitted).
    pub heldout_rms_nm: Option<f64>,
    /// `BIC(with) − BIC(without)` of the refit (null if not refitted).
    pub delta_bic: Option<f64>,
    /// Relative held-out gain of the refit (%).
    pub heldout_gain_pct: Option<f64>,
    /// Fall of the held-out deviance with this candidate added (χ² units; null if not
    /// refitted, or after an exchange).
    pub heldout_dev_gain: Option<f64>,
    /// Cosine between its fitted signature and the span of the model's parameters.
    pub cos_to_model: f64,
    /// Selection round (0 = against the baseline).
    pub round: usize,
    /// Whether it was added to the model.
    pub accepted: bool,
    /// Whether it is confounded with the model's parameters (not testable here).
    pub confounded: bool,
    /// Fitted parameter values of the refit (if refitted).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub fitted: Option<BTreeMap<String, f64>>,
    /// For an effect not in the final model: the smallest size the ΔBIC rule would name in
    /// 95 % of trials like this one if every fit reached its optimum (same inputs, noise
    /// model and final model; see docs/diagnosis.md, method item 10), so a smaller effect
    /// may be present and missed. The decision's other rules and imperfect fits make the
    /// real limit somewhat larger (docs/studies/detection-limits.md). In the
    /// units of [`detection_limit_unit`]: `|offset|` N·m, passive torque at +15° at its worst
    /// stiffness N·m, `|moment|` at its worst phase N·m, delay ms, fatigue rate /s,
    /// antagonist gain N·m, `Flen − 1.4`, `|b|` N·m·s/rad, `I` kg·m².
    #[serde(skip_serializing_if = "Option::is_none")]
    pub detection_limit: Option<f64>,
    /// The shape at which `detection_limit` is reached (the worst): gravity's phase `φ` (°, in
    /// [−90°, 90°), the moment of either sign) or the passive torque's stiffness (1/rad);
    /// absent for the one-parameter effects.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub detection_limit_shape: Option<f64>,
}

impl CandidateReport {
    /// [`CandidateReport::detection_limit`] with three significant digits, its unit and, for
    /// gravity and the passive torque, the worst shape (e.g. `7.30 N·m at φ −12°`); `None` for an effect in the final model.
    pub fn detection_limit_text(&self) -> Option<String> {
        let kind = EffectKind::from_name(&self.effect)?;
        let x = self.detection_limit?;
        let shape = match (kind, self.detection_limit_shape) {
            (EffectKind::Gravity, Some(phi)) => format!(" at φ {phi:.0}°"),
            (EffectKind::PassiveJointTorque, Some(k)) => format!(" at k {k:.1}/rad"),
            _ => String::new(),
        };
        Some(format!("{} {}{shape}", sig3(x), detection_limit_unit(kind)))
    }
}

/// The unit (or quantity) of [`CandidateReport::detection_limit`] for an effect.
pub fn detection_limit_unit(kind: EffectKind) -> &'static str {
    match kind {
        EffectKind::TorqueOffset
        | EffectKind::PassiveJointTorque
        | EffectKind::Gravity
        | EffectKind::AntagonistCoactivation => "N·m",
        EffectKind::ElectromechanicalDelay => "ms",
        EffectKind::Fatigue => "/s",
        EffectKind::EccentricEnhancement => "Flen−1.4",
        EffectKind::ViscousDamping => "N·m·s/rad",
        EffectKind::Inertia => "kg·m²",
    }
}

/// `x` with three significant digits.
fn sig3(x: f64) -> String {
    if x == 0.0 || !x.is_finite() {
        return format!("{x}");
    }
    let digits = (2 - x.abs().log10().floor() as i32).max(0) as usize;
    format!("{x:.digits$}")
}

/// An alternative explanation that fits a named cause's data about as well: replacing the
/// cause by it changes the BIC by less than the ΔBIC margin and raises the held-out error by
/// less than the held-out margin, and the alternative has no more parameters than the cause or
/// a lower BIC, so this trial cannot tell the two apart.
#[derive(Clone, Debug, PartialEq, Serialize)]
#[non_exhaustive]
pub struct NearTie {
    /// The named cause.
    pub cause: String,
    /// The effect that could stand in for it.
    pub alternative: String,
    /// `BIC(model with the alternative) − BIC(named model)`: ≥ 0 when the named model is
    /// better, negative when the alternative is better by less than the margin.
    pub delta_bic: f64,
    /// Held-out RMS of the model with the alternative instead of the cause (N·m).
    pub heldout_rms_nm: f64,
}

/// The diagnosis of one trial (serialises to `diagnosis.json`, docs/formats.md).
#[derive(Clone, Debug, PartialEq, Serialize)]
#[non_exhaustive]
pub struct Diagnosis {
    /// `adequate` or `deficient`.
    pub verdict: Verdict,
    /// Named causes (effect names) in order of selection; empty when adequate.
    pub causes: Vec<String>,
    /// The final residual keeps structure that no catalogued effect explains.
    pub unexplained_structure: bool,
    /// What the structure left depends on (when `unexplained_structure`, or when a flexible
    /// term explained a cause the selection had found better than that cause).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub unexplained: Option<crate::Unexplained>,
    /// The baseline fit.
    pub baseline: ModelReport,
    /// The final model (the baseline again when no cause is named).
    pub extended: ModelReport,
    /// Gains.
    pub gain: Gain,
    /// Every candidate scored, best evidence first.
    pub candidates: Vec<CandidateReport>,
    /// Effects that cannot be told apart from the model's parameters on this trial.
    pub confounded: Vec<String>,
    /// Named causes with an alternative effect that explains the trial about as well
    /// (e.g. an offset and a gravity term over a 35° range of motion).
    pub near_ties: Vec<NearTie>,
    /// Noise model used.
    pub noise: TrialNoiseModel,
    /// How the held-out errors were cross-validated, e.g. `3 cycles held out in turn` or
    /// `5 folds of 0.5 s blocks`.
    pub cv_folds: String,
    /// Residual analysis (binned summaries and autocorrelation; per-sample series in memory).
    pub residual_analysis: ResidualAnalysis,
    /// Model simulations used.
    pub evaluations: usize,
    /// Wall time (s).
    pub wall_s: f64,
    /// Candidate effects this recording cannot test (an empty list is not written).
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub not_testable: Vec<NotTestable>,
    /// The raw-EMG test of each triceps channel for the TA's crosstalk (empty without a TA
    /// channel or raw EMG).
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub emg_crosstalk: Vec<experiment::CrosstalkCheck>,
    /// What removing the TA's share from the corrected channels was worth (only when a
    /// channel was corrected; every fit above used the corrected envelopes).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub emg_correction: Option<crate::EmgCorrection>,
    /// The residual a calibration that did not see the trial leaves on it, tested for a
    /// reproducible shape ([`Diagnosis::judge_held_out_shape`]; only for a recording without
    /// an unloaded run, diagnosed in a session).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub held_out_shape: Option<crate::HeldOutShapeCheck>,
    /// How the parameters given to `diagnose --session --params` predict the trial as they
    /// are, and the scale of their moment it asks for ([`Diagnosis::judge_given_params`]).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub given_params: Option<crate::GivenParamsFit>,
}

/// Why a candidate effect is not tested on a recording.
pub const NO_JOINT_ANGLE: &str = "not testable on this trial: no joint angle";

/// A candidate effect the recording cannot test, and why.
#[derive(Clone, Debug, PartialEq, Serialize)]
#[non_exhaustive]
pub struct NotTestable {
    /// Effect name.
    pub effect: String,
    /// Why it is not tested (e.g. [`NO_JOINT_ANGLE`]).
    pub reason: String,
}

fn fmt_effect(
    name: &str,
    vals: &BTreeMap<String, f64>,
    unc: Option<&BTreeMap<String, f64>>,
    int: Option<&BTreeMap<String, ParamInterval>>,
) -> String {
    let parts: Vec<String> = vals
        .iter()
        .map(
            |(k, v)| match (unc.and_then(|u| u.get(k)), int.and_then(|u| u.get(k))) {
                (Some(s), Some(iv)) => {
                    let end = |x: f64, at_bound: bool| {
                        if at_bound {
                            format!("bound {}", sig(x))
                        } else {
                            sig(x)
                        }
                    };
                    format!(
                        "{k} {} ± {} (68 % {} … {})",
                        sig(*v),
                        sig(*s),
                        end(iv.lower, iv.lower_at_bound),
                        end(iv.upper, iv.upper_at_bound)
                    )
                }
                (Some(s), None) => format!("{k} {} ± {}", sig(*v), sig(*s)),
                _ => format!("{k} {}", sig(*v)),
            },
        )
        .collect();
    format!("{name}: {}", parts.join(", "))
}

fn sig(v: f64) -> String {
    let a = v.abs();
    if a >= 100.0 {
        format!("{v:.0}")
    } else if a >= 10.0 {
        format!("{v:.1}")
    } else if a >= 1.0 {
        format!("{v:.2}")
    } else {
        format!("{v:.3}")
    }
}

impl Diagnosis {
    /// The command line that identifies the muscle parameters together with the named causes
    /// (`surae identify --method mcmc <trial_args> --with a,b`), `None` when nothing is named.
    /// `trial_args` are the arguments that name the trial (e.g. `--trial t.csv --unloaded u.csv`).
    pub fn identify_command(&self, trial_args: &str) -> Option<String> {
        if self.causes.is_empty() {
            return None;
        }
        let mut cmd = String::from("surae identify --method mcmc");
        if !trial_args.trim().is_empty() {
            cmd.push(' ');
            cmd.push_str(trial_args.trim());
        }
        cmd.push_str(" --with ");
        cmd.push_str(&self.causes.join(","));
        Some(cmd)
    }

    /// The `diagnosis.json` text (pretty-printed).
    pub fn to_json(&self) -> String {
        serde_json::to_string_pretty(self).unwrap_or_else(|e| format!("{{\"error\": \"{e}\"}}"))
    }

    /// The `diagnosis.json` value.
    pub fn to_json_value(&self) -> serde_json::Value {
        serde_json::to_value(self).unwrap_or(serde_json::Value::Null)
    }

    /// A caution when the noise model was fitted to the trial's own residual and its AR(1)
    /// correlation time `−Δt/ln φ` exceeds a quarter of the recording: the recording then
    /// holds fewer than four independent stretches of noise, a misfit as slow as the
    /// recording counts as noise, and every test loses power (what a short real recording
    /// without an unloaded run gives).
    fn slow_noise_caution(&self) -> Option<String> {
        let t = &self.residual_analysis.series.time_s;
        let phi = self.noise.phi;
        if self.noise.source != crate::noise::NoiseModelSource::TrialResidual
            || t.len() < 2
            || !(phi > 0.0 && phi < 1.0)
        {
            return None;
        }
        let dt = t[1] - t[0];
        let tc = -dt / phi.ln();
        let span = t[t.len() - 1] - t[0];
        (tc > 0.25 * span).then(|| {
            format!(
                "caution      noise correlation time {tc:.2} s against a {span:.2} s recording: \
                 a slow misfit counts as noise, the tests have little power"
            )
        })
    }

    /// A terminal summary of at most 20 lines.
    pub fn summary_lines(&self) -> Vec<String> {
        let mut l = Vec::new();
        let v = match self.verdict {
            Verdict::Adequate => "ADEQUATE: the baseline model explains this trial",
            Verdict::Deficient => "DEFICIENT: the baseline model misses something",
        };
        l.push(format!("verdict      {v}"));
        l.push(format!(
            "noise        {} (offset {:+.2} N·m, transient {:.1} N·m @ {:.1} Hz, AR(1) φ {:.3} sd {:.2}, white sd {:.2})",
            match self.noise.source {
                crate::noise::NoiseModelSource::Unloaded => "from the unloaded run",
                crate::noise::NoiseModelSource::TrialResidual => "from the trial residual (no unloaded run)",
            },
            self.noise.offset_nm,
            self.noise.transient.b_nm.hypot(self.noise.transient.c_nm),
            self.noise.transient.freq_hz,
            self.noise.phi,
            self.noise.sd_ar_nm,
            self.noise.sd_white_nm
        ));
        if let Some(line) = self.slow_noise_caution() {
            l.push(line);
        }
        l.push(format!(
            "baseline     RMS {:.2} N·m, held-out RMS {:.2} N·m ({})",
            self.baseline.rms_nm, self.baseline.heldout_rms_nm, self.cv_folds
        ));
        if self.causes.is_empty() {
            l.push("causes       none".into());
        } else {
            l.push(format!("causes       {}", self.causes.join(", ")));
            if let Some(eff) = &self.extended.effects {
                for (name, vals) in eff {
                    let unc = self
                        .extended
                        .effect_uncertainty
                        .as_ref()
                        .and_then(|u| u.get(name));
                    let int = self
                        .extended
                        .effect_interval
                        .as_ref()
                        .and_then(|u| u.get(name));
                    l.push(format!("  {}", fmt_effect(name, vals, unc, int)));
                }
            }
            l.push(format!(
                "extended     RMS {:.2} N·m, held-out RMS {:.2} N·m",
                self.extended.rms_nm, self.extended.heldout_rms_nm
            ));
            l.push(format!(
                "gain         held-out RMS {}, deviance {}, ΔBIC {:.1}, Δlog L {:.1}",
                signed_change(-self.gain.heldout_rms_reduction_pct, " %"),
                signed_change(-self.gain.heldout_deviance_reduction, ""),
                self.gain.delta_bic,
                self.gain.delta_log_likelihood
            ));
        }
        if !self.confounded.is_empty() {
            l.push(format!(
                "confounded   {} (cannot be told from the muscle parameters here)",
                self.confounded.join(", ")
            ));
        }
        for t in &self.near_ties {
            l.push(format!(
                "near tie     {} or {} (ΔBIC {:+.1}, held-out {:.3} N·m): not told apart here",
                t.cause, t.alternative, t.delta_bic, t.heldout_rms_nm
            ));
        }
        let ra = &self.residual_analysis;
        l.push(format!(
            "structure    {} (p = {:.1e}; motion steps LM {:.1}/{}, time blocks {:.1}/{}, \
             vocabulary {:.1}/{}{})",
            if self.unexplained_structure {
                "UNEXPLAINED structure remains in the residual"
            } else {
                "no unexplained structure"
            },
            ra.structure_p_value,
            ra.extended_structure_lm,
            ra.structure_df,
            ra.extended_time_structure_lm,
            ra.time_structure_df,
            ra.vocabulary_structure_lm,
            ra.vocabulary_structure_df,
            ra.vocabulary_structure_variable
                .map_or(String::new(), |v| format!(
                    " in {}{}",
                    v.name(),
                    if ra.vocabulary_structure_by_direction {
                        " by direction"
                    } else {
                        ""
                    }
                ))
        ));
        l.extend(crate::crosstalk_summary_line(
            &self.emg_crosstalk,
            self.emg_correction.as_ref(),
        ));
        if let Some(u) = &self.unexplained {
            l.extend(u.summary_lines());
        }
        if let Some(h) = &self.held_out_shape {
            l.extend(h.summary_lines());
        }
        if let Some(g) = &self.given_params {
            l.push(g.summary_line());
        }
        if !self.not_testable.is_empty() {
            let names: Vec<&str> = self
                .not_testable
                .iter()
                .map(|t| t.effect.as_str())
                .collect();
            let reason = &self.not_testable[0].reason;
            l.push(format!("not tested   {} ({reason})", names.join(", ")));
        }
        l.push(
            "candidates   effect                   evidence  held-out  ΔBIC  could be missed below"
                .into(),
        );
        for c in self.candidates.iter().take(19usize.saturating_sub(l.len())) {
            let limit = c.detection_limit_text().unwrap_or_default();
            l.push(
                format!(
                    "  {}{:<24} {:>9.1} {:>9} {:>8}  {limit}",
                    if c.accepted {
                        "*"
                    } else if self.near_ties.iter().any(|t| t.alternative == c.effect) {
                        "~"
                    } else if c.confounded {
                        "?"
                    } else {
                        " "
                    },
                    c.effect,
                    c.evidence,
                    c.heldout_rms_nm.map_or("-".into(), |h| format!("{h:.3}")),
                    c.delta_bic.map_or("-".into(), |d| format!("{d:.1}"))
                )
                .trim_end()
                .to_string(),
            );
        }
        l.push(format!(
            "work         {} simulations, {:.1} s",
            self.evaluations, self.wall_s
        ));
        l.truncate(20);
        l
    }
}

/// A change with its sign, a fall with the minus sign (`−14.8 %`, `+2.2 %`).
pub(crate) fn signed_change(v: f64, unit: &str) -> String {
    format!("{}{unit}", numerics::text::signed(v, 1))
}
