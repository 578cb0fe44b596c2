//! The isokinetic experiment (docs/formats.md, docs/dynamometer.md): trial files, protocols, dynamometer error
//! and synthetic EMG.
//!
//! * [`read_trial`], [`write_trial`] and the like: trial / unloaded CSV reading with validation (every error is one line naming
//!   the file, the line and the column) and round-trip-exact, atomic writing.
//! * [`Protocol`]: `seed`, `relaxed+N`, `cycles+N` sampled at 2048 Hz; a synthetic trial's
//!   protocol may hold the knee flexed ([`SynthProtocol`]: `knee90`, `relaxed+2@knee90`). A sweep of range
//!   `D = 35°` at speed `v = 30 °/s` with ramps of `t_r = 0.05 s` (acceleration `a = v/t_r`)
//!   lasts `T = D/v + t_r`; its displacement at time `τ` is `½aτ²` (τ < t_r),
//!   `½a t_r² + v(τ − t_r)` (cruise) and `D − ½a(T − τ)²` (last ramp).
//! * [`dynamometer_error`]: the error
//!   `ε(t) = offset + Σ_e A·e^{−(t−e)/τr}·sin(2πf(t−e)) + x_t + w_t`, the sum over every
//!   motion start, reversal and stop `e ≤ t`, `x_t = φx_{t−1} + σ√(1−φ²)ξ_t` with
//!   `φ = e^{−dt/τc}` (stationary start), `w_t ~ N(0, σ_w²)`; then the 12-bit ADC
//!   `step·round(x/step)`, `step = 1356/4096 N·m`, clamped to the codes −2048…2047.
//! * [`detect_events`]: motion starts, reversals and stops detected from a measured angle.
//! * [`Transient`] and [`DynamometerCorrection`]: the dynamometer correction estimated from an unloaded
//!   run (offset, damped-sinusoid transient, AR(1)+white random part) and subtracted from a
//!   trial at its own events (`docs/dynamometer.md`).
//! * [`synthetic_emg`]: raw EMG `x_c(t) = g_c·d_c(t)·c_c(t)`, `c_c` unit-RMS Gaussian noise
//!   band-limited to 20–450 Hz, `d_c ∈ [rest, 1]` the drive; with the knee flexed by `k` the
//!   gastrocnemii's active drive is `f(k) = 1 − 0.3·(1 − cos k)` times the extended knee's.
//! * [`rng`]: every random part is a `ChaCha8Rng` on its own stream of one seed.
//! * [`model_inputs()`]: a trial → the model's inputs (angle in rad, envelopes of docs/model.md, section 1).
//! * [`emg_crosstalk`] and [`remove_crosstalk`]: the TA's share in the raw triceps EMG, tested and
//!   removed before the envelopes are made.
//! * [`PreparedTrial`]: one trial prepared once for every job (crosstalk decision, model inputs,
//!   dynamometer correction, the torque a fit is compared with).
//! * [`synthesize`]: a whole synthetic experiment (trial, unloaded run, truth) from one seed.
//! * [`Strides`]: a trial's cycles as units, from the foot's ground force
//!   ([`strides_from_ground_force`]: stance while the vertical force exceeds 20 N, a stride from
//!   one foot strike to the next), a dynamometer's motion ([`strides_from_motion`]) or given
//!   events ([`strides_from_events`]); masks, weights and curves normalised to 0–100 % of the
//!   cycle or the stance.
//! * [`read_ceinms_trial`] and [`ceinms_model_params`]: a CEINMS trial folder and subject XML as the model's inputs and parameters
//!   (docs/real-data.md).
//!
//! ```
//! use experiment::{
//!     dynamometer_error, format_trial, parse_trial, quantise_in_place, synthetic_emg,
//!     DynamometerSettings, EmgSettings, Protocol, Recording,
//! };
//!
//! let trace: Protocol = "seed".parse()?;
//! let trace = trace.trace()?;
//! assert_eq!(trace.events.starts, vec![0.5]);
//! let dyn_settings = DynamometerSettings::default();
//! // The measured torque would be model torque + error; here the model torque is 0.
//! let mut torque = dynamometer_error(&trace, &dyn_settings, 7, Recording::Trial)?;
//! quantise_in_place(&mut torque, &dyn_settings);
//! let emg = synthetic_emg(&trace, &EmgSettings::default(), 7)?;
//! let trial = emg.to_trial(&trace, torque)?;
//! let text = format_trial(&trial)?;
//! let back = parse_trial(&text, "trial.csv")?;
//! assert_eq!(back, trial);
//! assert!((back.sample_rate_hz() - 2048.0).abs() < 1e-9);
//! # Ok::<(), experiment::ExperimentError>(())
//! ```

mod ceinms;
mod correction;
mod crosstalk;
mod dynamometer;
mod emg;
mod error;
mod events;
mod files;
mod model_inputs;
mod prepared;
mod protocol;
mod seeds;
mod strides;
mod synth;
pub mod synth_session;
mod transient;

pub use ceinms::{
    ceinms_model_params, ceinms_model_trial, ceinms_trial_dirs, least_squares, moment_fit,
    read_ceinms_trial, surae_muscle_name, CeinmsModelTrial, CeinmsSubjectParams, CEINMS_IDENTIFIED,
};
pub use correction::{
    fit_ar1_white, CorrectedTorque, DynamometerCorrection, DynamometerReport, TransientReport,
};
pub use crosstalk::{emg_crosstalk, remove_crosstalk, CrosstalkCheck, CrosstalkSettings};
pub use dynamometer::{
    dynamometer_error, quantise, quantise_in_place, random_error, random_error_with,
    systematic_error, systematic_error_at, unloaded_run, unloaded_run_with, DynamometerSettings,
    Recording,
};
pub use emg::{
    gastrocnemius_drive_factor, synthetic_emg, synthetic_emg_at_knee, EmgChannel, EmgMuscle,
    EmgSettings, SyntheticEmg, GASTROCNEMIUS_DRIVE_AT_90_DEG,
};
pub use error::{ErrorKind, ExperimentError, Result};
pub use events::{detect_events, detect_events_with, EventSettings};
pub use files::{
    format_f64, format_trial, format_unloaded, parse_trial, parse_trial_bytes, parse_trial_with,
    parse_unloaded, parse_unloaded_bytes, parse_unloaded_with, read_trial, read_unloaded,
    write_f64, write_trial, write_unloaded, ReadOptions, Trial, Unloaded, DEFAULT_MIN_DURATION_S,
    DEFAULT_TIME_TOLERANCE, EMG_PREFIX, TRIAL_OPTIONAL, TRIAL_REQUIRED, UNLOADED_REQUIRED,
};
pub use model_inputs::{
    envelope_peaks, model_inputs, model_inputs_named, model_inputs_referenced, EmgReferences,
    InputOptions, KNEE_AGREEMENT_DEG,
};
pub use prepared::{PreparedTrial, UnloadedCorrection};
pub use protocol::{
    Events, MotionPhase, MotionSettings, Protocol, ProtocolTrace, Segment, SynthProtocol,
    KNEE_RANGE_DEG, NOMINAL_SPEED_DEG_S, SPEED_RANGE_DEG_S,
};
pub use seeds::{rng, Stream};
pub use strides::{
    ground_force_cycles, stride_percent, strides_from_events, strides_from_ground_force,
    strides_from_motion, Stride, StridePart, StrideSource, Strides, MIN_STRIDE_S,
    STANCE_THRESHOLD_N,
};
pub use synth::{
    random_params, round_decimals, sorted_json, synthesize, synthesize_referenced,
    synthetic_recording, SynthConfig, Synthetic,
};
pub use transient::{Transient, TRANSIENT_MIN_EVIDENCE};
