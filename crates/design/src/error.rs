//! The crate's error type.

/// Everything that can go wrong when a protocol's information is computed.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum DesignError {
    /// A protocol string that does not name a list of trials.
    #[error("protocol '{protocol}': {reason}")]
    Protocol {
        /// The protocol as given.
        protocol: String,
        /// What is wrong with it.
        reason: String,
    },
    /// A trial of a protocol could not be synthesised.
    #[error("trial '{trial}': {reason}")]
    Synthesis {
        /// The trial (`knee0@30`, …).
        trial: String,
        /// Why it failed.
        reason: String,
    },
    /// The model could not be simulated at a perturbed parameter value.
    #[error("trial '{trial}': the simulation at {param} = {value} failed: {reason}")]
    Simulation {
        /// The trial.
        trial: String,
        /// The perturbed parameter (`sol.lst_m`, …) or `nominal`.
        param: String,
        /// Its value.
        value: f64,
        /// Why it failed.
        reason: String,
    },
    /// A noise model or setting outside its valid range.
    #[error("invalid {what}: {reason}")]
    Invalid {
        /// What was invalid (`noise`, `fd_step`, …).
        what: &'static str,
        /// Why.
        reason: String,
    },
    /// The information matrix cannot be inverted: some parameter combination does not change
    /// the torque at all in this protocol.
    #[error("protocol '{protocol}': the Fisher information is singular (some parameters do not change the torque)")]
    Singular {
        /// The protocol.
        protocol: String,
    },
}

/// The crate's result type.
pub type Result<T, E = DesignError> = std::result::Result<T, E>;
