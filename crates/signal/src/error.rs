//! The crate's single error type, [`SignalError`].

use thiserror::Error;

/// Everything that can go wrong in filter design, filtering or normalisation.
#[derive(Debug, Clone, PartialEq, Error)]
#[non_exhaustive]
pub enum SignalError {
    /// A Butterworth filter needs order `N ≥ 1`.
    #[error("filter order must be at least 1 (got {order})")]
    InvalidOrder {
        /// The order that was asked for.
        order: usize,
    },
    /// The sampling frequency must be finite and strictly positive.
    #[error("sampling frequency must be finite and > 0 Hz (got {fs_hz})")]
    InvalidSamplingRate {
        /// The sampling frequency that was given, in Hz.
        fs_hz: f64,
    },
    /// A cutoff frequency is not strictly between 0 and the Nyquist frequency `fs/2`.
    #[error("cutoff {cutoff_hz} Hz must lie strictly between 0 and the Nyquist frequency {nyquist_hz} Hz")]
    CutoffOutOfRange {
        /// The offending cutoff, in Hz.
        cutoff_hz: f64,
        /// `fs / 2`, in Hz.
        nyquist_hz: f64,
    },
    /// The band edges of a band-pass / band-stop filter are not increasing.
    #[error("band edges out of order: low edge {low_hz} Hz must be below high edge {high_hz} Hz")]
    BandEdgesOutOfOrder {
        /// The first (lower) edge that was given, in Hz.
        low_hz: f64,
        /// The second (upper) edge that was given, in Hz.
        high_hz: f64,
    },
    /// A second-order section is not usable (`a0 ≠ 1` or non-finite coefficient).
    #[error("second-order section {index} is invalid: {reason}")]
    InvalidSection {
        /// Row of the offending section.
        index: usize,
        /// What is wrong with it.
        reason: &'static str,
    },
    /// A filter must have at least one second-order section.
    #[error("a filter needs at least one second-order section")]
    EmptySos,
    /// Zero-phase filtering needs `len(x) > padlen` (scipy's rule).
    #[error("signal has {len} samples; zero-phase filtering needs more than padlen = {padlen}")]
    SignalTooShort {
        /// Number of samples given.
        len: usize,
        /// The padding length the filter needs (`len` must exceed it).
        padlen: usize,
    },
    /// An input sample is NaN or infinite.
    #[error("sample {index} is not finite ({value})")]
    NonFiniteSample {
        /// Index of the first non-finite sample.
        index: usize,
        /// Its value.
        value: f64,
    },
    /// A user-given MVC reference must be finite and strictly positive.
    #[error("MVC reference must be finite and > 0 (got {mvc})")]
    InvalidMvc {
        /// The reference that was given.
        mvc: f64,
    },
    /// Normalising by the trial maximum is impossible when that maximum is not positive
    /// (e.g. an all-zero channel) or the envelope is empty.
    #[error("cannot normalise by the trial maximum: envelope maximum is {max} over {len} samples (all-zero or empty channel?)")]
    NonPositiveMaximum {
        /// The maximum of the envelope (`-inf` for an empty envelope).
        max: f64,
        /// Number of samples in the envelope.
        len: usize,
    },
    /// A block statistic needs at least `min_blocks` whole blocks.
    #[error("{len} samples make fewer than {min_blocks} blocks of {block_len}")]
    TooFewBlocks {
        /// Number of samples given.
        len: usize,
        /// The block length asked for.
        block_len: usize,
        /// How many whole blocks are needed.
        min_blocks: usize,
    },
    /// A signal that must carry power is zero everywhere.
    #[error("{what} is zero everywhere")]
    ZeroSignal {
        /// Which signal.
        what: &'static str,
    },
    /// Two buffers that must have matching sizes do not.
    #[error("length mismatch for {what}: expected {expected}, got {got}")]
    LengthMismatch {
        /// Which buffer is wrong.
        what: &'static str,
        /// Size it should have.
        expected: usize,
        /// Size it has.
        got: usize,
    },
}

/// Return the first non-finite sample of `x` as an error.
pub(crate) fn check_finite(x: &[f64]) -> Result<(), SignalError> {
    match x.iter().position(|v| !v.is_finite()) {
        Some(index) => Err(SignalError::NonFiniteSample {
            index,
            value: x[index],
        }),
        None => Ok(()),
    }
}
