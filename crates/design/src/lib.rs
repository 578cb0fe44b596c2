//! Protocol design: how precisely a set of isokinetic trials would identify the 9 muscle
//! parameters (LST, F0, α0 of soleus and gastrocnemii), before anyone is tested.
//!
//! For each candidate trial (knee angle, speed, cycles) the synthetic trial's EMG gives the
//! model's inputs; the torque's sensitivity to the parameters at the design point `θ₀`
//! ([`jacobian`], central differences) is whitened by the AR(1)+white noise of the
//! dynamometer ([`noise`]) and gives the trial's Fisher information; a protocol's information
//! is the sum over its trials, each trial's constant torque offset integrated out
//! ([`fisher`]):
//!
//! ```text
//! y_k = τ_k(θ) + d_k·1 + e_k,   e_k ~ AR(1)+white,   d_k ~ N(0, s²)
//! F   = Σ_k [ A_k − b_k b_kᵀ/(c_k + 1/s²) ],   A_k = (WJ_k)ᵀ(WJ_k), b_k = (WJ_k)ᵀ(W1), c_k = (W1)ᵀ(W1)
//! sd(θᵢ) ≈ sqrt((F⁻¹)ᵢᵢ)
//! ```
//!
//! This is the linearised (Laplace) posterior of the likelihood the MCMC identification
//! samples, at the true parameters; [`evaluate`] reports it in % of `θ₀`, with and without the
//! bounds' prior, and whether each parameter is identifiable.
//!
//! ```no_run
//! use design::{protocol_sds, DesignNoise, DesignProtocol, DesignSettings};
//! use muscle_model::ModelParams;
//!
//! let protocols: Vec<DesignProtocol> = ["knee0@30", "knee0@30,knee90@30,knee0@60"]
//!     .iter()
//!     .map(|s| s.parse())
//!     .collect::<Result<_, _>>()?;
//! let rows = protocol_sds(&protocols, &ModelParams::nominal(), &DesignNoise::synthetic(),
//!                         &DesignSettings::default())?;
//! // Three trials identify the soleus's F0 better than one.
//! assert!(rows[1].params[1].sd_pct < rows[0].params[1].sd_pct);
//! # Ok::<(), design::DesignError>(())
//! ```

pub mod error;
pub mod evaluate;
pub mod fisher;
pub mod jacobian;
pub mod noise;
pub mod protocol;

pub use error::{DesignError, Result};
pub use evaluate::{
    protocol_sds, trial_informations, uncertainty_of, DesignSettings, ParamUncertainty,
    ProtocolUncertainty, DEFAULT_EMG_DRAWS, DEFAULT_EMG_SEED, OFFSET_PRIOR_SD_NM,
};
pub use fisher::{fisher_information, posterior_sds, OffsetTreatment, TrialInformation};
pub use jacobian::{torque_jacobian, JacobianSettings, TorqueJacobian};
pub use noise::DesignNoise;
pub use protocol::{trial_inputs, trial_name, DesignProtocol};
