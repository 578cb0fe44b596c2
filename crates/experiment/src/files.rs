//! Trial and unloaded-run CSV files (`docs/formats.md`): validating reader, round-trip-exact
//! atomic writer.
//!
//! `records` defines what the files hold, `number` the number format, `table` the
//! delimited-text reader both file kinds share, `trial` and `unloaded` the readers of each
//! kind, and `writer` the writers.

mod number;
mod records;
mod table;
mod trial;
mod unloaded;
mod writer;

pub use number::{format_f64, write_f64};
pub use records::{
    ReadOptions, Trial, Unloaded, DEFAULT_MIN_DURATION_S, DEFAULT_TIME_TOLERANCE, EMG_PREFIX,
    TRIAL_OPTIONAL, TRIAL_REQUIRED, UNLOADED_REQUIRED,
};
pub use trial::{parse_trial, parse_trial_bytes, parse_trial_with, read_trial};
pub use unloaded::{parse_unloaded, parse_unloaded_bytes, parse_unloaded_with, read_unloaded};
pub use writer::{format_trial, format_unloaded, write_trial, write_unloaded};
