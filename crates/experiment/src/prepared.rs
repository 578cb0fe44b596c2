//! One trial prepared once for every job: the EMG crosstalk decision, the model inputs, the
//! dynamometer correction from the unloaded run and the torque it leaves.
//!
//! [`PreparedTrial::prepare`] runs the stages in the order a fit needs them:
//!
//! 1. the model inputs of the trial as read ([`crate::model_inputs_named`]), which validates its
//!    EMG columns with messages that name the file;
//! 2. the TA's crosstalk in the raw triceps EMG ([`crate::emg_crosstalk`]); when a channel
//!    carries it, the channel is corrected on the raw signal and the inputs are made again,
//!    the uncorrected ones kept to measure what the correction is worth;
//! 3. with an unloaded run, the dynamometer correction fitted to it
//!    ([`DynamometerCorrection::from_unloaded`]) and subtracted from the trial's torque at the
//!    trial's own motion events ([`DynamometerCorrection::correct`]): `y = τ_measured − s(t)`.
//!
//! Identification, the MCMC likelihood, the structure test and the diagnosis all read the
//! same [`PreparedTrial`], so a trial's inputs and correction are computed once per job.

use muscle_model::{ModelError, Problem, TrialInputs};

use crate::correction::{CorrectedTorque, DynamometerCorrection};
use crate::crosstalk::{emg_crosstalk, remove_crosstalk, CrosstalkCheck, CrosstalkSettings};
use crate::error::{ErrorKind, ExperimentError, Result};
use crate::files::{Trial, Unloaded};
use crate::model_inputs::{
    model_inputs_named, model_inputs_referenced, EmgReferences, InputOptions,
};
use crate::protocol::Events;

/// A dynamometer correction with what the noise model needs of the unloaded run it was fitted
/// on (its length and rate).
#[derive(Clone, Copy, Debug, PartialEq)]
#[non_exhaustive]
pub struct UnloadedCorrection {
    /// The correction fitted to the unloaded run.
    pub correction: DynamometerCorrection,
    /// Number of samples of the unloaded run.
    pub samples: usize,
    /// Its sampling rate (Hz).
    pub rate_hz: f64,
}

impl UnloadedCorrection {
    /// The correction of an unloaded run ([`DynamometerCorrection::from_unloaded`]).
    ///
    /// # Errors
    /// As [`DynamometerCorrection::from_unloaded`].
    pub fn fit(unloaded: &Unloaded) -> Result<Self> {
        Ok(Self {
            correction: DynamometerCorrection::from_unloaded(unloaded)?,
            samples: unloaded.torque_nm.len(),
            rate_hz: unloaded.sample_rate_hz(),
        })
    }
}

/// A trial prepared for fitting (module docs).
#[derive(Clone, Debug)]
#[non_exhaustive]
pub struct PreparedTrial {
    /// The trial as fitted: as read, with the TA's crosstalk removed from the raw triceps EMG
    /// when a channel carried it.
    pub trial: Trial,
    /// How the EMG columns became envelopes.
    pub options: InputOptions,
    /// The model inputs of [`PreparedTrial::trial`].
    pub inputs: TrialInputs,
    /// The model inputs without the crosstalk correction, when one was made.
    pub uncorrected_inputs: Option<TrialInputs>,
    /// The crosstalk test of each triceps channel (empty without a TA channel, on envelopes, or
    /// with the test off).
    pub crosstalk: Vec<CrosstalkCheck>,
    /// The dynamometer correction, when an unloaded run was given.
    pub unloaded: Option<UnloadedCorrection>,
    /// The trial's torque with the correction subtracted, the part subtracted and the events
    /// it was placed at, when an unloaded run was given.
    pub corrected: Option<CorrectedTorque>,
}

impl PreparedTrial {
    /// Prepares `trial` (named `name` in errors) with its optional unloaded run (module docs).
    ///
    /// # Errors
    /// Invalid EMG or knee columns, a crosstalk test that cannot run at the trial's rate, an
    /// unloaded run that cannot be analysed or is sampled at another rate, or a trial angle
    /// whose events cannot be detected.
    pub fn prepare(
        trial: &Trial,
        unloaded: Option<&Unloaded>,
        options: &InputOptions,
        crosstalk: &CrosstalkSettings,
        name: &str,
    ) -> Result<Self> {
        let as_read = model_inputs_named(trial, options, name)?;
        let checks = emg_crosstalk(trial, crosstalk, options.emg_is_envelope, name)?;
        let (fitted, inputs, uncorrected_inputs) = match remove_crosstalk(trial, &checks) {
            Some(t) => {
                let inputs = model_inputs_named(&t, options, name)?;
                (t, inputs, Some(as_read))
            }
            None => (trial.clone(), as_read, None),
        };
        Self::corrected_by(
            fitted,
            inputs,
            uncorrected_inputs,
            checks,
            unloaded,
            options,
            name,
        )
    }

    /// A trial whose crosstalk was already tested (`crosstalk`) and removed (`as_recorded`,
    /// the trial before the removal, when a channel was corrected), its EMG normalised by
    /// `references` (a session's, in place of the trial's own maxima), then corrected by its
    /// unloaded run as [`PreparedTrial::prepare`] corrects it.
    ///
    /// # Errors
    /// As [`PreparedTrial::prepare`]; a reference that is not finite and > 0.
    pub fn referenced(
        trial: &Trial,
        as_recorded: Option<&Trial>,
        crosstalk: Vec<CrosstalkCheck>,
        unloaded: Option<&Unloaded>,
        options: &InputOptions,
        references: &EmgReferences,
        name: &str,
    ) -> Result<Self> {
        let inputs = model_inputs_referenced(trial, options, references, name)?;
        let uncorrected_inputs = as_recorded
            .map(|t| model_inputs_referenced(t, options, references, name))
            .transpose()?;
        Self::corrected_by(
            trial.clone(),
            inputs,
            uncorrected_inputs,
            crosstalk,
            unloaded,
            options,
            name,
        )
    }

    /// The last stage: the dynamometer correction of `unloaded` subtracted from `trial`.
    fn corrected_by(
        trial: Trial,
        inputs: TrialInputs,
        uncorrected_inputs: Option<TrialInputs>,
        crosstalk: Vec<CrosstalkCheck>,
        unloaded: Option<&Unloaded>,
        options: &InputOptions,
        name: &str,
    ) -> Result<Self> {
        let (unloaded, corrected) = match unloaded {
            Some(u) => {
                let (fu, fs) = (u.sample_rate_hz(), trial.sample_rate_hz());
                if (fu - fs).abs() > 1e-6 * fs || fu.is_nan() {
                    return Err(ExperimentError::File {
                        path: name.to_string(),
                        kind: ErrorKind::Conflict,
                        reason: format!(
                            "the unloaded run is sampled at {fu} Hz but the trial at {fs} Hz"
                        ),
                    });
                }
                let c = UnloadedCorrection::fit(u)?;
                let corrected = c.correction.correct(&trial)?;
                (Some(c), Some(corrected))
            }
            None => (None, None),
        };
        Ok(Self {
            trial,
            options: *options,
            inputs,
            uncorrected_inputs,
            crosstalk,
            unloaded,
            corrected,
        })
    }

    /// The torque as measured (N·m).
    #[must_use]
    pub fn raw_torque(&self) -> &[f64] {
        &self.trial.torque_nm
    }

    /// The torque a fit is compared with: corrected when an unloaded run was given, else as
    /// measured (N·m).
    #[must_use]
    pub fn measured(&self) -> &[f64] {
        self.corrected
            .as_ref()
            .map_or(&self.trial.torque_nm, |c| &c.torque_nm)
    }

    /// The dynamometer correction, when an unloaded run was given.
    #[must_use]
    pub fn correction(&self) -> Option<&DynamometerCorrection> {
        self.unloaded.as_ref().map(|u| &u.correction)
    }

    /// The systematic part subtracted from the torque, when an unloaded run was given (N·m).
    #[must_use]
    pub fn systematic(&self) -> Option<&[f64]> {
        self.corrected.as_ref().map(|c| c.systematic_nm.as_slice())
    }

    /// The trial's motion events the correction was placed at, when an unloaded run was given.
    #[must_use]
    pub fn events(&self) -> Option<&Events> {
        self.corrected.as_ref().map(|c| &c.events)
    }

    /// RMS of the subtracted systematic part (N·m); 0 without an unloaded run.
    #[must_use]
    pub fn subtracted_rms_nm(&self) -> f64 {
        self.systematic().map_or(0.0, numerics::rms)
    }

    /// The standard identification problem on [`PreparedTrial::measured`]: nominal base, the
    /// nine muscle parameters free ([`Problem::standard`]).
    ///
    /// # Errors
    /// A problem the model rejects.
    pub fn standard_problem(&self) -> std::result::Result<Problem, ModelError> {
        Problem::standard(self.inputs.clone(), self.measured().to_vec())
    }
}
