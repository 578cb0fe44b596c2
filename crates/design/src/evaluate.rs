//! Expected posterior sds of the identified parameters for a list of protocols.
//!
//! Every distinct trial is synthesised, differenced and whitened once, however many
//! protocols contain it; each protocol then sums its trials' information
//! ([`crate::fisher`]) and inverts it. Reported per parameter, in % of its value at the
//! design point `θ₀`:
//!
//! ```text
//! sd_pct            = 100·sqrt(diag(F⁻¹))/θ₀                  (no prior)
//! sd_pct_with_prior = 100·sqrt(diag((F + diag(12/w²))⁻¹))/θ₀  (bounds' uniform prior as a Gaussian)
//! prior_sd_pct      = 100·(w/√12)/θ₀
//! identifiable      = sd_with_prior < prior_sd/2
//! ```

use std::collections::BTreeMap;

use muscle_model::ModelParams;
use serde::Serialize;

use crate::error::Result;
use crate::fisher::{fisher_information, posterior_sds, OffsetTreatment, TrialInformation};
use crate::jacobian::{torque_jacobian, JacobianSettings};
use crate::noise::DesignNoise;
use crate::protocol::{trial_inputs, trial_name, DesignProtocol};

/// The first EMG seed of the synthetic trials whose inputs a design uses.
pub const DEFAULT_EMG_SEED: u64 = 1;

/// How many EMG realisations (seeds) each trial's information is averaged over. One
/// realisation's sds differ from another's by up to a factor 2 (the synthetic drive's slow
/// wobble decides how well force–length and force–velocity effects are told apart); the mean
/// of 16 moves by about 10 % at most from one set of seeds to another (tested).
pub const DEFAULT_EMG_DRAWS: usize = 16;

/// The prior sd of a trial's offset left after the unloaded run's correction (N·m), the value
/// the MCMC identification integrates out.
pub const OFFSET_PRIOR_SD_NM: f64 = 0.5;

/// Everything a design depends on besides the protocols, the parameters and the noise.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DesignSettings {
    /// The Jacobian's differencing.
    pub jacobian: JacobianSettings,
    /// Each trial's offset ([`OffsetTreatment::Prior`] with [`OFFSET_PRIOR_SD_NM`]).
    pub offset: OffsetTreatment,
    /// First seed of the synthetic EMG ([`DEFAULT_EMG_SEED`]); realisation `k` uses
    /// `emg_seed + k`.
    pub emg_seed: u64,
    /// Number of EMG realisations averaged per trial ([`DEFAULT_EMG_DRAWS`]; at least 1).
    pub emg_draws: usize,
}

impl Default for DesignSettings {
    fn default() -> Self {
        Self {
            jacobian: JacobianSettings::default(),
            offset: OffsetTreatment::Prior {
                sd_nm: OFFSET_PRIOR_SD_NM,
            },
            emg_seed: DEFAULT_EMG_SEED,
            emg_draws: DEFAULT_EMG_DRAWS,
        }
    }
}

/// One parameter's expected uncertainty under one protocol.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct ParamUncertainty {
    /// `sol.lst_m`, ….
    pub name: String,
    /// Its value at the design point.
    pub value: f64,
    /// Posterior sd without a prior (% of `value`).
    pub sd_pct: f64,
    /// Posterior sd with the bounds' prior as a Gaussian (% of `value`).
    pub sd_pct_with_prior: f64,
    /// The bounds' prior sd `w/√12` (% of `value`).
    pub prior_sd_pct: f64,
    /// `sd_pct_with_prior < prior_sd_pct/2`.
    pub identifiable: bool,
}

/// A protocol's expected uncertainties.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct ProtocolUncertainty {
    /// The protocol as given.
    pub protocol: String,
    /// Its trials' names.
    pub trials: Vec<String>,
    /// Per parameter, in the order of `muscle_model::ParamId::identified`.
    pub params: Vec<ParamUncertainty>,
}

/// The whitened information of every distinct trial of `protocols`, keyed by trial name: the
/// mean over `settings.emg_draws` EMG realisations.
///
/// # Errors
/// A trial that cannot be synthesised or simulated, an invalid noise model, or no
/// realisation asked for.
pub fn trial_informations(
    protocols: &[DesignProtocol],
    params: &ModelParams,
    noise: &DesignNoise,
    settings: &DesignSettings,
) -> Result<BTreeMap<String, TrialInformation>> {
    let mut out = BTreeMap::new();
    for t in protocols.iter().flat_map(|p| &p.trials) {
        let name = trial_name(t);
        if out.contains_key(&name) {
            continue;
        }
        let mut draws = Vec::with_capacity(settings.emg_draws);
        for k in 0..settings.emg_draws as u64 {
            let inputs = trial_inputs(t, settings.emg_seed.wrapping_add(k))?;
            let jac = torque_jacobian(&name, &inputs, params, &settings.jacobian)?;
            draws.push(TrialInformation::new(&jac, &noise.at(jac.dt_s)?));
        }
        out.insert(name, TrialInformation::mean(&draws)?);
    }
    Ok(out)
}

/// The expected posterior sds of the 9 identified parameters under each protocol, at the
/// parameter point `params` (see the module docs).
///
/// # Errors
/// A trial that cannot be synthesised or simulated, an invalid noise model, or a singular
/// information matrix.
pub fn protocol_sds(
    protocols: &[DesignProtocol],
    params: &ModelParams,
    noise: &DesignNoise,
    settings: &DesignSettings,
) -> Result<Vec<ProtocolUncertainty>> {
    let infos = trial_informations(protocols, params, noise, settings)?;
    protocols
        .iter()
        .map(|p| uncertainty_of(p, &infos, params, settings.offset))
        .collect()
}

/// One protocol's uncertainties from the trials' information (all of its trials must be in
/// `infos`, as [`trial_informations`] gives them).
///
/// # Errors
/// A trial missing from `infos`, or a singular information matrix.
pub fn uncertainty_of(
    protocol: &DesignProtocol,
    infos: &BTreeMap<String, TrialInformation>,
    params: &ModelParams,
    offset: OffsetTreatment,
) -> Result<ProtocolUncertainty> {
    let names = protocol.trial_names();
    let mut trials = Vec::with_capacity(names.len());
    for n in &names {
        trials.push(infos.get(n).ok_or_else(|| crate::DesignError::Invalid {
            what: "protocol",
            reason: format!("no information computed for trial '{n}'"),
        })?);
    }
    let f = fisher_information(&trials, offset)?;
    let ids = muscle_model::ParamId::identified();
    let none = muscle_model::Effects::none();
    let values: Vec<f64> = ids.iter().map(|id| id.get(params, &none)).collect();
    let widths: Vec<f64> = ids
        .iter()
        .map(|id| {
            let (lo, hi) = id.default_bounds(params, &none);
            hi - lo
        })
        .collect();
    let sd = posterior_sds(&f, &vec![0.0; ids.len()], &protocol.text)?;
    let precision: Vec<f64> = widths.iter().map(|w| 12.0 / (w * w)).collect();
    let sd_prior = posterior_sds(&f, &precision, &protocol.text)?;
    let params = ids
        .iter()
        .enumerate()
        .map(|(i, id)| {
            let v = values[i].abs();
            let prior_sd = widths[i] / 12f64.sqrt();
            ParamUncertainty {
                name: id.name(),
                value: values[i],
                sd_pct: 100.0 * sd[i] / v,
                sd_pct_with_prior: 100.0 * sd_prior[i] / v,
                prior_sd_pct: 100.0 * prior_sd / v,
                identifiable: sd_prior[i] < 0.5 * prior_sd,
            }
        })
        .collect();
    Ok(ProtocolUncertainty {
        protocol: protocol.text.clone(),
        trials: names,
        params,
    })
}
