//! Synthetic sessions for the session tests and the `session_coverage` example: one subject
//! (true parameters drawn uniformly inside the identification bounds by
//! `experiment::random_params`), several trials, each synthesised with its own unloaded run and
//! the nominal dynamometer error, the EMG normalised over the session's trials (as
//! `surae identify --session` reads them), each trial corrected by its own unloaded run.
//! [`SyntheticSession::linearised_sds_pct`] is the `design` crate's prediction for the same
//! trials, the yardstick of the posterior sds.

use design::{
    fisher_information, posterior_sds, torque_jacobian, DesignNoise, JacobianSettings,
    OffsetTreatment, TrialInformation,
};
use experiment::synth_session::synthesize_session_configs;
use experiment::{random_params, SynthConfig, SynthProtocol};
use identify_mcmc::{NoiseKind, NoiseSpec, SessionTrialLikelihood};
use muscle_model::{Effects, ModelParams, ParamId, Problem};
use rand::SeedableRng;

/// The protocol of issue-style acceptance sessions.
pub const THREE_TRIALS: [&str; 3] = ["knee0@30", "knee90@30", "knee0@60"];

/// A synthetic session: the truth, and each trial's problem (torque as measured) and noise.
pub struct SyntheticSession {
    /// The true parameters.
    pub truth: ModelParams,
    /// The trials' problems.
    pub problems: Vec<Problem>,
    /// The trials' noise sides (unloaded-run correction, AR(1)+white).
    pub noises: Vec<NoiseSpec>,
}

impl SyntheticSession {
    /// Replicate `replicate`: truth from `ChaCha8Rng::seed_from_u64(replicate)`, trial `k`
    /// synthesised with seed `1000·replicate + k`.
    pub fn new(protocols: &[&str], replicate: u64) -> Self {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(replicate);
        let truth = random_params(&mut rng, &ModelParams::nominal());
        Self::with_truth(protocols, replicate, truth)
    }

    /// The same with the given truth (e.g. the nominal parameters).
    pub fn with_truth(protocols: &[&str], replicate: u64, truth: ModelParams) -> Self {
        let mut problems = Vec::new();
        let mut noises = Vec::new();
        let configs: Vec<SynthConfig> = protocols
            .iter()
            .enumerate()
            .map(|(k, p)| {
                let protocol: SynthProtocol = p.parse().expect("valid protocol");
                SynthConfig::for_protocol(protocol, 1000 * replicate + k as u64).with_params(truth)
            })
            .collect();
        for syn in synthesize_session_configs(&configs).expect("synthesis") {
            problems.push(
                Problem::standard(syn.inputs.clone(), syn.trial.torque_nm.clone())
                    .expect("problem"),
            );
            noises.push(
                NoiseSpec::from_unloaded(&syn.trial, &syn.unloaded, NoiseKind::Ar1White)
                    .expect("unloaded run"),
            );
        }
        Self {
            truth,
            problems,
            noises,
        }
    }

    /// The trials as the sampler takes them.
    pub fn trials(&self) -> Vec<SessionTrialLikelihood<'_>> {
        self.problems
            .iter()
            .zip(&self.noises)
            .map(|(problem, noise)| SessionTrialLikelihood { problem, noise })
            .collect()
    }

    /// The linearised posterior sds (% of nominal) of these very trials at the truth: the
    /// Fisher information of each trial's noise-free torque (the `design` crate: Jacobian by
    /// central differences, the synthetic AR(1)+white noise, each trial's offset integrated out
    /// with the sampler's prior sd of 0.5 N·m) plus the uniform prior on the identification
    /// bounds taken as a Gaussian of the same variance.
    pub fn linearised_sds_pct(&self) -> Vec<f64> {
        let settings = JacobianSettings::default();
        let infos: Vec<TrialInformation> = self
            .problems
            .iter()
            .enumerate()
            .map(|(k, p)| {
                let jac =
                    torque_jacobian(&format!("trial {k}"), p.inputs(), &self.truth, &settings)
                        .expect("jacobian");
                let noise = DesignNoise::synthetic().at(jac.dt_s).expect("noise");
                TrialInformation::new(&jac, &noise)
            })
            .collect();
        let refs: Vec<&TrialInformation> = infos.iter().collect();
        let f = fisher_information(&refs, OffsetTreatment::Prior { sd_nm: 0.5 }).expect("fisher");
        let prior: Vec<f64> = self.problems[0]
            .bounds()
            .iter()
            .map(|(lo, hi)| 12.0 / ((hi - lo) * (hi - lo)))
            .collect();
        let sds = posterior_sds(&f, &prior, "session").expect("sds");
        sds.iter()
            .zip(nominal_values())
            .map(|(sd, v)| 100.0 * sd / v)
            .collect()
    }

    /// The true values of the identified parameters, in vector order.
    pub fn true_values(&self) -> Vec<f64> {
        ParamId::identified()
            .iter()
            .map(|id| id.get(&self.truth, &Effects::none()))
            .collect()
    }
}

/// The nominal values of the identified parameters (sds are quoted in % of them).
pub fn nominal_values() -> Vec<f64> {
    ParamId::identified()
        .iter()
        .map(|id| id.get(&ModelParams::nominal(), &Effects::none()))
        .collect()
}

/// The posterior sds (% of nominal) a linearised analysis outside this project gave for
/// knee0@30 + knee90@30 + knee0@60, in the order sol, gm, gl × LST, F0, α0; printed for
/// comparison only (its gastrocnemius α0 values are below what the torque's sensitivity to them
/// allows, docs/design.md).
pub const REFERENCE_TABLE_SD_PCT: [f64; 9] = [0.09, 0.66, 3.1, 0.85, 4.6, 5.6, 2.0, 9.8, 6.8];
