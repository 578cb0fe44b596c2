//! `identify.json` as a type: what an identification reports, serialised as it is. The figures
//! and the summary read these fields; nothing reads the JSON back.

use serde::Serialize;
use std::collections::BTreeMap;

/// `identify.json` of one trial.
#[derive(Debug, Clone, Serialize)]
#[non_exhaustive]
pub struct IdentifyReport {
    /// `sa` or `mcmc`.
    pub method: &'static str,
    /// The estimate of every free parameter (the posterior mean for MCMC), by name.
    pub params: BTreeMap<String, f64>,
    /// Torque RMS at the estimate against the corrected torque (N·m).
    pub rms_nm: f64,
    /// Torque RMS at the estimate against the torque as recorded (N·m).
    pub rms_raw_nm: f64,
    /// Model evaluations.
    pub evaluations: u64,
    /// Wall time (s).
    pub wall_s: f64,
    /// The annealing chains (SA only).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub sa: Option<SaChainsReport>,
    /// The posterior (MCMC only), its members at the top level of the JSON.
    #[serde(flatten)]
    pub mcmc: Option<McmcReport>,
    /// The catalogued effects whose parameters were identified with the muscles'.
    pub with: Vec<&'static str>,
    /// The effects of the identified model, when any is switched on (docs/formats.md).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub effects: Option<serde_json::Value>,
    /// Whether the identified model leaves structure in its residual.
    pub adequacy: AdequacyReport,
    /// The raw-EMG crosstalk tests of the triceps channels against `emg_ta` (none without one).
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub emg_crosstalk: Vec<experiment::CrosstalkCheck>,
    /// The trial's name (its path, or `bundled:…`).
    pub trial: String,
    /// The seed of every random choice.
    pub seed: u64,
    /// How the unloaded run was used.
    pub noise: NoiseUseReport,
    /// The dynamometer correction subtracted (`null` without an unloaded run).
    pub dynamometer: Option<experiment::DynamometerReport>,
    /// The recording's checks.
    pub checks: recording::checks::TrialChecks,
    /// `100·|estimate − truth|/|truth|` of each parameter whose truth is known and not 0.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub errors_pct: Option<BTreeMap<String, f64>>,
}

/// The annealing chains of an SA identification (`"sa"`).
#[derive(Debug, Clone, Serialize)]
#[non_exhaustive]
pub struct SaChainsReport {
    /// Number of chains (starts).
    pub chains: usize,
    /// The chain whose end point was polished.
    pub best_chain: u32,
    /// Each chain's final cost.
    pub chain_costs: Vec<f64>,
}

/// What MCMC adds to `identify.json`.
#[derive(Debug, Clone, Serialize)]
#[non_exhaustive]
pub struct McmcReport {
    /// Each parameter's posterior summary, by name.
    pub posterior: BTreeMap<String, PosteriorReport>,
    /// R̂ < 1.01 and bulk ESS ≥ 400 for every parameter.
    pub converged: bool,
    /// Why sampling stopped.
    pub stop: String,
    /// Number of chains.
    pub chains: usize,
    /// Warm-up iterations per chain.
    pub warmup_iterations: usize,
    /// Sampling iterations per chain.
    pub sampling_iterations: usize,
    /// Random-walk acceptance rate.
    pub acceptance_rate: f64,
    /// Posterior modes the multi-start search found.
    pub modes: usize,
    /// Mode-jump acceptance rate.
    pub jump_acceptance_rate: f64,
    /// The ten strongest posterior correlations.
    pub correlations: Vec<CorrelationReport>,
    /// The whole posterior correlation matrix.
    pub posterior_correlation: CorrelationMatrixReport,
    /// The noise model of the likelihood.
    pub noise_model: identify_mcmc::NoiseParams,
    /// Per-trial fit at the posterior mean (one trial's; a session's are in its own `trials`).
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub trials: Vec<McmcTrialReport>,
    /// The No-U-Turn sampler's own statistics (`--method nuts` only).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub nuts: Option<NutsReport>,
}

/// What the No-U-Turn sampler adds to the MCMC report: its adaptation and its cost.
#[derive(Debug, Clone, Serialize)]
#[non_exhaustive]
pub struct NutsReport {
    /// Each chain's adapted step size.
    pub step_size: Vec<f64>,
    /// Whether the metric adapted in warm-up is dense (else diagonal).
    pub dense_metric: bool,
    /// Leapfrog steps per kept draw, all chains.
    pub mean_leapfrog: f64,
    /// Mean `accept_stat__` of the kept draws.
    pub mean_accept_stat: f64,
    /// Divergent transitions among the kept draws.
    pub divergences: u64,
    /// Divergent transitions in warm-up.
    pub warmup_divergences: u64,
    /// Kept draws whose tree reached the largest depth.
    pub max_depth_hits: u64,
    /// Gradient evaluations (each a simulation and its exact Jacobian), warm-up included.
    pub gradient_evaluations: u64,
    /// Gradient evaluations per bulk effective draw of the slowest parameter.
    pub gradients_per_effective_draw: f64,
}

/// One parameter's posterior.
#[derive(Debug, Clone, Copy, Serialize)]
#[non_exhaustive]
pub struct PosteriorReport {
    /// Posterior mean.
    pub mean: f64,
    /// Posterior sd.
    pub sd: f64,
    /// 5 % quantile.
    pub q05: f64,
    /// 95 % quantile.
    pub q95: f64,
    /// Rank-normalised split R̂.
    pub rhat: f64,
    /// Bulk effective sample size.
    pub ess_bulk: f64,
    /// Tail effective sample size.
    pub ess_tail: f64,
    /// The posterior sd is below half the prior's.
    pub identifiable: bool,
    /// Posterior sd ÷ prior sd.
    pub prior_sd_ratio: f64,
}

/// A posterior correlation between two parameters.
#[derive(Debug, Clone, Serialize)]
#[non_exhaustive]
pub struct CorrelationReport {
    /// First parameter.
    pub a: String,
    /// Second parameter.
    pub b: String,
    /// Correlation.
    pub r: f64,
}

/// The posterior correlation matrix with its parameter names.
#[derive(Debug, Clone, Serialize)]
#[non_exhaustive]
pub struct CorrelationMatrixReport {
    /// Row and column names.
    pub names: Vec<String>,
    /// Correlations, row by row.
    pub matrix: Vec<Vec<f64>>,
}

/// One trial's fit at the posterior mean.
#[derive(Debug, Clone, Serialize)]
#[non_exhaustive]
pub struct McmcTrialReport {
    /// The trial's name.
    pub name: String,
    /// RMS where the trial is judged (N·m).
    pub rms_nm: f64,
    /// R² where the trial is judged.
    pub r2: f64,
    /// RMS against the torque as measured (N·m).
    pub rms_raw_nm: f64,
    /// The trial's noise model.
    pub noise_model: identify_mcmc::NoiseParams,
}

/// The structure test of the identified model's residual (`"adequacy"`).
#[derive(Debug, Clone, Serialize)]
#[serde(untagged)]
#[non_exhaustive]
pub enum AdequacyReport {
    /// The test ran.
    Tested {
        /// p-value of the joint score test.
        structure_p: f64,
        /// `−log10 p`.
        structure_evidence: f64,
        /// The evidence above which structure is declared.
        threshold: f64,
        /// Whether the evidence exceeds the threshold.
        leaves_structure: bool,
        /// Score statistic of the motion terms.
        motion_lm: f64,
        /// Their degrees of freedom.
        motion_df: usize,
        /// Score statistic of the time terms.
        time_lm: f64,
        /// Their degrees of freedom.
        time_df: usize,
        /// The score statistic against the flexible basis of the state variable with the
        /// smallest p-value.
        vocabulary_lm: f64,
        /// Its degrees of freedom.
        vocabulary_df: usize,
        /// Its variable (`null` when no variable could be tested).
        vocabulary_variable: Option<diagnose::StateVariable>,
        /// Whether its basis was the variable's split by the direction of motion.
        vocabulary_by_direction: bool,
        /// What the structure suggests (`null` when none is left).
        warning: Option<String>,
    },
    /// The test could not run; the fields of [`AdequacyReport::Tested`] are `null`.
    Failed {
        /// Always `null`.
        structure_p: Option<f64>,
        /// Always `null`.
        structure_evidence: Option<f64>,
        /// Always `null`.
        threshold: Option<f64>,
        /// Always `null`.
        leaves_structure: Option<bool>,
        /// Always `null`.
        warning: Option<String>,
        /// Why the test could not run.
        error: String,
    },
}

impl AdequacyReport {
    /// The report of a test's outcome.
    pub fn of(a: &Result<diagnose::Adequacy, String>) -> Self {
        match a {
            Ok(a) => Self::Tested {
                structure_p: a.structure_p,
                // −log10 of p = 1 is −0
                structure_evidence: a.structure_evidence + 0.0,
                threshold: a.threshold,
                leaves_structure: a.leaves_structure(),
                motion_lm: a.motion_lm,
                motion_df: a.motion_df,
                time_lm: a.time_lm,
                time_df: a.time_df,
                vocabulary_lm: a.vocabulary_lm,
                vocabulary_df: a.vocabulary_df,
                vocabulary_variable: a.vocabulary_variable,
                vocabulary_by_direction: a.vocabulary_by_direction,
                warning: a.warning(),
            },
            Err(e) => Self::Failed {
                structure_p: None,
                structure_evidence: None,
                threshold: None,
                leaves_structure: None,
                warning: None,
                error: e.clone(),
            },
        }
    }

    /// The p-value, when the test ran.
    pub fn structure_p(&self) -> Option<f64> {
        match self {
            Self::Tested { structure_p, .. } => Some(*structure_p),
            Self::Failed { .. } => None,
        }
    }

    /// The warning, when the model leaves structure.
    pub fn warning(&self) -> Option<&str> {
        match self {
            Self::Tested { warning, .. } => warning.as_deref(),
            Self::Failed { .. } => None,
        }
    }
}

/// How an unloaded run was used (`"noise"`): its name, and with a correction its offset,
/// random error and the RMS of what was subtracted.
#[derive(Debug, Clone, Serialize)]
#[non_exhaustive]
pub struct NoiseUseReport {
    /// The unloaded run's name (`null` without one).
    pub unloaded: Option<String>,
    /// The correction's figures, when one was estimated.
    #[serde(flatten)]
    pub correction: Option<NoiseCorrectionReport>,
}

/// The figures of a dynamometer correction in `"noise"`.
#[derive(Debug, Clone, Copy, Serialize)]
#[non_exhaustive]
pub struct NoiseCorrectionReport {
    /// Constant offset (N·m).
    pub offset_nm: f64,
    /// Marginal sd of the random error (N·m).
    pub sigma_nm: f64,
    /// Its lag-1 autocorrelation.
    pub lag1_autocorrelation: f64,
    /// Its AR(1) coefficient.
    pub ar1_phi: f64,
    /// RMS of the subtracted cycle-locked error (N·m).
    pub subtracted_rms_nm: f64,
}

/// `identify.json` of a session: the shared parameters, each trial's fit, and what SA or
/// MCMC adds.
#[derive(Debug, Clone, Serialize)]
#[non_exhaustive]
pub struct SessionIdentifyReport {
    /// `sa` or `mcmc`.
    pub method: &'static str,
    /// The estimate of every free parameter, by name.
    pub params: BTreeMap<String, f64>,
    /// Torque RMS over the session's judged samples at the estimate (N·m).
    pub rms_nm: f64,
    /// MCMC: the same against the torques as measured (N·m).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub rms_raw_nm: Option<f64>,
    /// Each trial's fit.
    pub trials: Vec<SessionTrialReport>,
    /// Model evaluations.
    pub evaluations: u64,
    /// Wall time (s).
    pub wall_s: f64,
    /// SA: the annealing chains.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub sa: Option<SessionSaChainsReport>,
    /// MCMC: the posterior, its members at the top level of the JSON (its per-trial fits are
    /// in `trials`).
    #[serde(flatten)]
    pub mcmc: Option<McmcReport>,
    /// The session, the model at the estimate and its tests, at the top level of the JSON.
    #[serde(flatten)]
    pub context: SessionContextReport,
    /// `100·|estimate − truth|/|truth|`, when the truth is known.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub errors_pct: Option<BTreeMap<String, f64>>,
}

/// What a session's `identify.json` says of the session whatever the method.
#[derive(Debug, Clone, Serialize)]
#[non_exhaustive]
pub struct SessionContextReport {
    /// The session manifest (or CEINMS trial folder).
    pub session: String,
    /// The subject the manifest names.
    pub subject: Option<String>,
    /// The seed of every random choice.
    pub seed: u64,
    /// Each free parameter's bounds.
    pub bounds: BTreeMap<String, [f64; 2]>,
    /// Each trial's dynamometer correction (`null` without an unloaded run).
    pub dynamometer: Vec<Option<experiment::DynamometerReport>>,
    /// The session's model at the estimate (a parameters JSON).
    pub model: serde_json::Value,
    /// Its effects, when any is switched on.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub effects: Option<serde_json::Value>,
    /// The catalogued effects identified with the muscles.
    pub with: Vec<&'static str>,
    /// The structure test of the trial with the smallest p.
    pub adequacy: SessionAdequacyReport,
    /// How the session's EMG was normalised.
    pub emg_normalisation: super::super::session::EmgNormalisationReport,
}

/// One trial's fit in a session's `identify.json`.
#[derive(Debug, Clone, Serialize)]
#[non_exhaustive]
pub struct SessionTrialReport {
    /// The trial's name in the manifest.
    pub name: String,
    /// Where it was read from.
    pub source: String,
    /// RMS where the trial is judged (N·m).
    pub rms_nm: f64,
    /// R² where the trial is judged.
    pub r2: f64,
    /// SA: RMS at the session's own parameters (N·m).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub start_rms_nm: Option<f64>,
    /// SA: R² at the session's own parameters.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub start_r2: Option<f64>,
    /// MCMC: RMS against the torque as measured (N·m).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub rms_raw_nm: Option<f64>,
    /// MCMC: the trial's noise model.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub noise_model: Option<identify_mcmc::NoiseParams>,
    /// The trial's dynamometer correction.
    pub dynamometer: Option<experiment::DynamometerReport>,
    /// The recording's checks (`null` for a CEINMS trial).
    pub checks: Option<recording::checks::TrialChecks>,
    /// The raw-EMG crosstalk tests (none without `emg_ta`).
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub emg_crosstalk: Vec<experiment::CrosstalkCheck>,
    /// The structure test of this trial's residual.
    pub adequacy: AdequacyReport,
}

/// The annealing chains of a session's SA identification.
#[derive(Debug, Clone, Serialize)]
#[non_exhaustive]
pub struct SessionSaChainsReport {
    /// The chains, as for one trial.
    #[serde(flatten)]
    pub chains: SaChainsReport,
    /// Each chain's final RMS over the session (N·m).
    pub chain_rms_nm: Vec<f64>,
}

/// A session's structure test: the trial with the smallest p, named.
#[derive(Debug, Clone, Serialize)]
#[non_exhaustive]
pub struct SessionAdequacyReport {
    /// The test of that trial (its warning names the trial).
    #[serde(flatten)]
    pub test: AdequacyReport,
    /// The trial.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub trial: Option<String>,
}

impl SessionAdequacyReport {
    /// The test of the trial with the smallest p among `tests` (name, outcome), or a failure
    /// when none could be run.
    pub fn worst<'a>(
        tests: impl IntoIterator<Item = (&'a str, &'a Result<diagnose::Adequacy, String>)>,
    ) -> Self {
        let mut worst: Option<(&str, &diagnose::Adequacy)> = None;
        for (name, a) in tests {
            if let Ok(a) = a {
                if worst.is_none_or(|(_, w)| a.structure_p < w.structure_p) {
                    worst = Some((name, a));
                }
            }
        }
        match worst {
            Some((name, a)) => {
                let mut test = AdequacyReport::of(&Ok(a.clone()));
                if let AdequacyReport::Tested { warning, .. } = &mut test {
                    *warning = a.warning().map(|w| format!("trial {name}: {w}"));
                }
                Self {
                    test,
                    trial: Some(name.to_string()),
                }
            }
            None => Self {
                test: AdequacyReport::of(&Err(
                    "the structure test could not be run on any trial".into()
                )),
                trial: None,
            },
        }
    }
}
