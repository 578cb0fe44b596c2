//! A recording given to the diagnosis as model inputs rather than as a trial CSV: the form a
//! CEINMS trial folder takes (envelopes on the EMG's grid, the subject's own musculotendon
//! lengths and moment arms, fixed muscles with their own envelopes, no ankle angle) and the
//! form a session's trials take, with the model's base parameters and effects.
//!
//! The measured torque `y_t` is compared with the model only where the weight `w_t` is
//! positive: a CEINMS moment file starts after the EMG (a lead-in of about 0.13 s), and the
//! samples before it carry `w_t = 0`. Weights are used as a mask, `w_t > 0` observed; the
//! likelihood keeps its own noise model on the observed samples.

use muscle_model::{Effects, ModelParams, TrialInputs};

use crate::DiagnoseError;

/// A recording prepared as model inputs, with the measured torque and the base model.
#[derive(Clone, Debug)]
pub struct DiagnosisRecording {
    /// The model's inputs (their angle is constant when the recording has none).
    pub inputs: TrialInputs,
    /// Measured joint torque (N·m) on the inputs' grid.
    pub torque_nm: Vec<f64>,
    /// Per-sample weights (`None`: every sample compared); samples of weight 0 are left out.
    pub weights: Option<Vec<f64>>,
    /// Base parameters: the start and bounds' centre of the 9 identified muscle parameters,
    /// every other value (fixed muscles included) held.
    pub params: ModelParams,
    /// Effects the base model carries at their values; they are not candidates.
    pub effects: Effects,
}

impl DiagnosisRecording {
    /// A recording compared at every sample, with nominal parameters and no effect.
    pub fn new(inputs: TrialInputs, torque_nm: Vec<f64>) -> Self {
        DiagnosisRecording {
            inputs,
            torque_nm,
            weights: None,
            params: ModelParams::nominal(),
            effects: Effects::none(),
        }
    }

    /// The same recording compared only where `weights` is positive.
    pub fn with_weights(mut self, weights: Vec<f64>) -> Self {
        self.weights = Some(weights);
        self
    }

    /// The same recording with base parameters `params` and base effects `effects`.
    pub fn with_model(mut self, params: ModelParams, effects: Effects) -> Self {
        self.params = params;
        self.effects = effects;
        self
    }

    /// The observed-sample mask (`None` when every sample is compared).
    pub(crate) fn observed(&self) -> Result<Option<Vec<bool>>, DiagnoseError> {
        let n = self.inputs.len();
        let bad = |reason: String| Err(DiagnoseError::Recording { reason });
        if self.torque_nm.len() != n {
            return bad(format!(
                "{} torque samples for {n} input samples",
                self.torque_nm.len()
            ));
        }
        let Some(w) = &self.weights else {
            if let Some(i) = self.torque_nm.iter().position(|v| !v.is_finite()) {
                return bad(format!("torque at sample {i} is not finite"));
            }
            return Ok(None);
        };
        if w.len() != n {
            return bad(format!("{} weights for {n} input samples", w.len()));
        }
        if let Some(i) = w.iter().position(|v| !(v.is_finite() && *v >= 0.0)) {
            return bad(format!(
                "weight {} at sample {i} is not a finite value ≥ 0",
                w[i]
            ));
        }
        let observed: Vec<bool> = w.iter().map(|v| *v > 0.0).collect();
        if let Some(i) = (0..n).find(|&i| observed[i] && !self.torque_nm[i].is_finite()) {
            return bad(format!("torque at sample {i} is not finite"));
        }
        let count = observed.iter().filter(|o| **o).count();
        if count < 16 {
            return bad(format!(
                "{count} samples of positive weight (at least 16 needed)"
            ));
        }
        Ok(Some(observed))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn still(n: usize) -> DiagnosisRecording {
        let inputs = TrialInputs::new(
            1000.0,
            0.0,
            vec![0.0; n],
            [vec![0.2; n], vec![0.2; n], vec![0.2; n]],
            None,
        )
        .unwrap();
        DiagnosisRecording::new(inputs, vec![10.0; n])
    }

    #[test]
    fn weights_become_the_observed_mask() {
        let mut w = vec![0.0; 100];
        w[30..].iter_mut().for_each(|v| *v = 1.0);
        let o = still(100).with_weights(w).observed().unwrap().unwrap();
        assert_eq!(o.iter().filter(|x| **x).count(), 70);
        assert!(!o[29] && o[30]);
        assert_eq!(still(100).observed().unwrap(), None);
    }

    #[test]
    fn torque_or_weights_that_do_not_fit_are_refused() {
        let msg = |r: &DiagnosisRecording| r.observed().unwrap_err().to_string();
        let mut short = still(100);
        short.torque_nm.pop();
        assert!(msg(&short).contains("99 torque samples for 100"));
        assert!(msg(&still(100).with_weights(vec![1.0; 99])).contains("99 weights"));
        let mut w = vec![1.0; 100];
        w[7] = f64::NAN;
        assert!(msg(&still(100).with_weights(w)).contains("sample 7"));
        let mut w = vec![0.0; 100];
        w[..10].iter_mut().for_each(|v| *v = 1.0);
        assert!(msg(&still(100).with_weights(w)).contains("10 samples of positive weight"));
        let mut nan = still(100);
        nan.torque_nm[50] = f64::NAN;
        assert!(msg(&nan).contains("sample 50"));
    }
}
