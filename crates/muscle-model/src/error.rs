//! The crate's error type: every failure is a value naming what went wrong.

/// Errors of the muscle model: bad parameters, bad inputs and failed simulations.
///
/// A failed simulation ([`ModelError::Integration`], [`ModelError::NonFinite`]) is
/// recoverable for an optimiser or a sampler: treat it as a rejected candidate.
#[derive(thiserror::Error, Debug, Clone, PartialEq)]
#[non_exhaustive]
pub enum ModelError {
    /// A JSON document could not be parsed at all.
    #[error("invalid JSON: {message}")]
    Json {
        /// The parser's message (with line and column).
        message: String,
    },
    /// A key that the parameters or effects format does not know.
    #[error("unknown key `{key}`{}", if expected.is_empty() { String::new() } else { format!(" (expected one of: {expected})") })]
    UnknownKey {
        /// Full dotted path of the offending key, e.g. `muscles.sol.lst`.
        key: String,
        /// The keys allowed at that place, comma-separated.
        expected: String,
    },
    /// A value that is not allowed (wrong type, non-physical, out of range).
    #[error("invalid value for `{key}`: {reason}")]
    InvalidValue {
        /// Full dotted path of the key, e.g. `muscles.sol.lst_m`.
        key: String,
        /// Why it is rejected.
        reason: String,
    },
    /// A parameter name (`sol.lst_m`, `electromechanical_delay.delay_ms`, ...) that does not exist.
    #[error("unknown parameter name `{name}`")]
    UnknownParam {
        /// The name given.
        name: String,
    },
    /// Trial inputs that cannot be simulated.
    #[error("invalid trial input `{what}`: {reason}")]
    InvalidInput {
        /// Which input (e.g. `angle_rad`, `env[gm]`, `fs`).
        what: String,
        /// Why it is rejected.
        reason: String,
    },
    /// A vector whose length does not match what is expected.
    #[error("length mismatch for `{what}`: expected {expected}, got {got}")]
    Length {
        /// Which vector.
        what: String,
        /// Expected length.
        expected: usize,
        /// Actual length.
        got: usize,
    },
    /// The ODE integration of one muscle failed.
    #[error("integration of muscle `{muscle}` failed: {source}")]
    Integration {
        /// `sol`, `gm`, `gl`, a fixed muscle's name, or `ta` (also the antagonist activation).
        muscle: &'static str,
        /// The integrator's error.
        source: ode::OdeError,
    },
    /// The simulation produced a non-finite value.
    #[error("non-finite {what} at sample {index}")]
    NonFinite {
        /// What was non-finite.
        what: &'static str,
        /// Sample index.
        index: usize,
    },
    /// A derivative the model cannot take exactly (the caller may difference instead).
    #[error("no exact derivative with respect to `{param}`: {reason}")]
    NoExactDerivative {
        /// The parameter's name (or `formulation`).
        param: String,
        /// Why.
        reason: &'static str,
    },
}

impl ModelError {
    pub(crate) fn invalid(key: impl Into<String>, reason: impl Into<String>) -> Self {
        ModelError::InvalidValue {
            key: key.into(),
            reason: reason.into(),
        }
    }
    pub(crate) fn input(what: impl Into<String>, reason: impl Into<String>) -> Self {
        ModelError::InvalidInput {
            what: what.into(),
            reason: reason.into(),
        }
    }
}
