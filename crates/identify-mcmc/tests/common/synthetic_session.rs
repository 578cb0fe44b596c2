//! Synthetic sessions for the session tests and the `session_coverage` example: one subject
//! (true parameters drawn uniformly inside the identification bounds by
//! `experiment::random_params`), several trials, each synthesised with its own unloaded run and
//! the nominal dynamometer error, each corrected by its own unloaded run.

use experiment::{random_params, synthesize, SynthConfig, SynthProtocol};
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
        for (k, p) in protocols.iter().enumerate() {
            let protocol: SynthProtocol = p.parse().expect("valid protocol");
            let cfg =
                SynthConfig::for_protocol(protocol, 1000 * replicate + k as u64).with_params(truth);
            let syn = synthesize(&cfg).expect("synthesis");
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

/// The linearised posterior sds (% of nominal) of knee0@30 + knee90@30 + knee0@60, in the
/// order sol, gm, gl × LST, F0, α0.
pub const EXPECTED_SD_PCT: [f64; 9] = [0.09, 0.66, 3.1, 0.85, 4.6, 5.6, 2.0, 9.8, 6.8];
