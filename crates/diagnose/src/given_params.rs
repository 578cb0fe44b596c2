//! Does the calibration a user brings carry to the trial diagnosed?
//!
//! `diagnose --session … --params identify.json` diagnoses the trials with a calibration made
//! elsewhere, for instance on the same subject walking at another speed. The diagnosis refits
//! the muscle parameters on each trial, so its own baseline says nothing about whether that
//! calibration holds there. This check does: the model at the parameters given, as they are,
//! predicts each trial (its RMS error and R²), and the scale of that moment the trial asks for
//! is judged by predicting one half of the trial from the other (`validate`'s
//! [`MomentScale`]: `k̂ = Σ w y ŷ / Σ w ŷ²`, alternate strides or ten blocks, asked for when
//! the scaled prediction is better by 2 % or more). A trial that asks for another scale is
//! not adequate: the calibration's EMG-to-moment gain does not carry to it.

use serde::Serialize;
use validate::MomentScale;

use crate::report::Verdict;
use crate::{Diagnosis, SessionDiagnosis};

/// How the parameters given predict one trial as they are.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
#[non_exhaustive]
pub struct GivenParamsFit {
    /// RMS error of the model at the parameters given, where the trial is judged (N·m).
    pub rms_nm: f64,
    /// Its R².
    pub r2: f64,
    /// The scale of that moment the trial asks for (`None` when it cannot be cut in two).
    pub scale: Option<MomentScale>,
}

impl GivenParamsFit {
    /// The fit of the parameters given.
    #[must_use]
    pub fn new(rms_nm: f64, r2: f64, scale: Option<MomentScale>) -> Self {
        Self { rms_nm, r2, scale }
    }

    /// The trial asks for another scale of the given calibration's moment.
    #[must_use]
    pub fn scale_differs(&self) -> bool {
        self.scale.is_some_and(|s| s.differs)
    }

    /// The terminal line, e.g. `given params RMS 32.51 N·m, R² 0.805 at the parameters given;
    /// its moment × 0.87: RMS 32.72 → 29.77 N·m, one half predicted from the other: …`.
    #[must_use]
    pub fn summary_line(&self) -> String {
        let mut l = format!(
            "given params RMS {:.2} N·m, R² {:.3} at the parameters given",
            self.rms_nm, self.r2
        );
        if let Some(s) = self.scale {
            l.push_str(&format!(
                "; its moment × {:.2}: RMS {:.2} → {:.2} N·m, one half predicted from the other",
                s.factor, s.rms_nm, s.cross_validated_rms_nm
            ));
            if s.differs {
                l.push_str(
                    ": the calibration's EMG-to-moment gain does not carry to this trial, \
                     the model is not adequate",
                );
            }
        }
        l
    }
}

/// One trial's [`GivenParamsFit`] in a session.
#[derive(Clone, Debug, PartialEq, Serialize)]
#[non_exhaustive]
pub struct TrialGivenParamsFit {
    /// Trial name.
    pub name: String,
    /// Its fit.
    #[serde(flatten)]
    pub fit: GivenParamsFit,
}

impl Diagnosis {
    /// Records how the parameters given predict the trial; a trial that asks for another
    /// scale of their moment is not adequate.
    pub fn judge_given_params(&mut self, fit: GivenParamsFit) {
        if fit.scale_differs() {
            self.verdict = Verdict::Deficient;
        }
        self.given_params = Some(fit);
    }
}

impl SessionDiagnosis {
    /// Records every trial's [`GivenParamsFit`] (`(trial name, fit)`); the session is not
    /// adequate when a trial asks for another scale of the given calibration's moment.
    pub fn judge_given_params(&mut self, per_trial: Vec<(String, GivenParamsFit)>) {
        if per_trial.iter().any(|(_, f)| f.scale_differs()) {
            self.verdict = Verdict::Deficient;
        }
        self.given_params = per_trial
            .into_iter()
            .map(|(name, fit)| TrialGivenParamsFit { name, fit })
            .collect();
    }

    /// The session's line: the trials whose scale differs, or `None` when none does.
    #[must_use]
    pub fn given_params_line(&self) -> Option<String> {
        let list: Vec<String> = self
            .given_params
            .iter()
            .filter_map(|t| {
                t.fit.scale.filter(|s| s.differs).map(|s| {
                    format!(
                        "{} × {:.2} (RMS {:.2} → {:.2} N·m)",
                        t.name, s.factor, s.rms_nm, s.cross_validated_rms_nm
                    )
                })
            })
            .collect();
        (!list.is_empty()).then(|| {
            format!(
                "given params     the calibration's moment scaled in {}: its EMG-to-moment gain \
                 does not carry to these trials",
                list.join(", ")
            )
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn fit(gain: f64) -> GivenParamsFit {
        let predicted: Vec<f64> = (0..200).map(|i| 20.0 * (i as f64 * 0.1).sin()).collect();
        let y: Vec<f64> = predicted.iter().map(|p| gain * p).collect();
        let scale =
            validate::moment_scale(&y, &predicted, &[1.0; 200], std::slice::from_ref(&(0..200)));
        GivenParamsFit::new(1.0, 0.9, scale)
    }

    #[test]
    fn a_calibration_at_another_gain_is_told_and_the_right_one_is_not() {
        let off = fit(0.6);
        assert!(off.scale_differs());
        assert!(
            off.summary_line().contains("× 0.60"),
            "{}",
            off.summary_line()
        );
        assert!(off.summary_line().contains("does not carry"));
        let right = fit(1.0);
        assert!(!right.scale_differs());
        assert!(!right.summary_line().contains("does not carry"));
    }
}
