//! What the diagnosis reports to its observer, and the observer's way to stop it.

use std::ops::ControlFlow;

use crate::DiagnoseError;

/// Stage reported to the observer.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[non_exhaustive]
pub enum DiagnosisStage {
    /// Fitting the noise model.
    Noise,
    /// Fitting the baseline.
    Baseline,
    /// Ranking and refitting candidates in a round.
    Round(usize),
    /// Residual analysis.
    Analysis,
}

/// Progress report.
#[derive(Clone, Debug, PartialEq)]
#[non_exhaustive]
pub struct DiagnosisProgress {
    /// Stage of the diagnosis.
    pub stage: DiagnosisStage,
    /// Human message.
    pub message: String,
    /// Simulations so far.
    pub evaluations: usize,
}

/// An observer that never stops the diagnosis.
pub fn no_observer(_: &DiagnosisProgress) -> ControlFlow<()> {
    ControlFlow::Continue(())
}

/// Reports `stage` to the observer; its `Break` stops the diagnosis with
/// [`DiagnoseError::Cancelled`].
pub(crate) fn notify(
    obs: &mut dyn FnMut(&DiagnosisProgress) -> ControlFlow<()>,
    stage: DiagnosisStage,
    message: String,
    evaluations: usize,
) -> Result<(), DiagnoseError> {
    match obs(&DiagnosisProgress {
        stage,
        message,
        evaluations,
    }) {
        ControlFlow::Continue(()) => Ok(()),
        ControlFlow::Break(()) => Err(DiagnoseError::Cancelled),
    }
}
