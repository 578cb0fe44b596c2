//! Held-out validation of a calibrated model, the field's test of it: the model is calibrated
//! on part of a subject's recordings and judged on the part it has not seen, beside what it
//! has to beat.
//!
//! * [`folds()`]: leave one trial out, hold out the later strides of every trial, leave one
//!   condition out ([`FoldScheme`]).
//! * [`validate`]: each fold calibrated by simulated annealing on its training parts
//!   ([`identify_sa::identify_set`], the session's free parameters and bounds), then its
//!   held-out parts predicted and scored ([`FitScore`]: RMS error and R² over the judged
//!   samples), next to the [`LinearBaseline`] calibrated on the same parts and to given
//!   [`Peer`] parameters (e.g. another tool's calibration of the subject) predicted as they
//!   are. Folds run in parallel; the result does not depend on the thread count.
//!
//! A trial's samples are judged with its problem's weights (a CEINMS trial's moment samples);
//! a fold's parts are weights of 0 outside the part. When a trial's strides are known, each
//! stride inside a held-out part is also scored alone ([`StrideScore`]), flagged where the
//! recording checks flagged it, and the part's residual is tested for a reproducible shape
//! ([`HeldOutShape`]: the same miss in every held-out stride, or the miss the calibration left
//! in its training data coming back), against the scatter of the data rather than a fitted
//! noise model. Each held-out part also reports the scale of the model's moment it asks for
//! ([`MomentScale`]), cross-validated within the part: a trial whose EMG reaches the moment
//! with another gain is told apart from one whose shape is wrong.

mod baseline;
mod error;
mod folds;
mod run;
mod scale;
mod score;
mod shape;
mod strides;

pub use baseline::LinearBaseline;
pub use error::ValidateError;
pub use folds::{folds, Fold, FoldScheme, TrialPart};
pub use run::{
    validate, FoldResult, HeldOutScore, Peer, SchemeSummary, ValidateSettings, Validation,
    ValidationTrial,
};
pub use scale::{moment_scale, MomentScale, SCALE_BLOCKS, SCALE_MIN_GAIN_PCT};
pub use score::FitScore;
pub use shape::{HeldOutShape, MIN_STRIDES, SHAPE_BINS, SHAPE_EVIDENCE};
pub use strides::StrideScore;
