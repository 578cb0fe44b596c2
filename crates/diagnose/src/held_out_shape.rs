//! Adequacy judged by the residual a calibration leaves on data it did not see.
//!
//! On a recording without an unloaded run (gait with inverse dynamics, a CEINMS trial) the
//! noise model is fitted to the baseline's own residual, and an AR(1) fitted there takes
//! correlation times as long as a stance: it absorbs the misfit, and the structure tests that
//! use it find nothing. The test here uses no noise model. The caller (the application's
//! `diagnose --session`) calibrates the model on part of the session and predicts the rest, by
//! `validate`'s folds; each held-out part's residual `e = measured − model` is cut into its
//! cycles (strides, or the part itself for a trial of one stance), each cycle averaged in
//! phases, and the part's shape is tested against the data's own scatter: across its strides
//! (sign flips), and against the shape the same calibration left where it was fitted
//! (Student's t). A part whose `p < 10⁻³` *keeps a reproducible shape*.
//!
//! A trial is judged over its held-out parts: `p = min(1, m·min_k p_k)` over its `m` parts
//! (Bonferroni), and it is **not adequate** when that keeps a reproducible shape, whatever
//! the noise-model tests said. A session is not adequate when any of its trials is not; its
//! `p = min(1, T·min_t p_t)` over its `T` trials is reported beside.
//!
//! Each part also carries the scale of the model's moment it asks for (`validate`'s
//! `MomentScale`: `k̂ = Σ w y ŷ / Σ w ŷ²`, judged by predicting one half of the part from the
//! other). A trial with a part that asks for another scale is not adequate either: the
//! calibration's EMG-to-moment gain does not carry to it, whatever its shape.

use serde::Serialize;
use validate::MomentScale;

use crate::report::Verdict;
use crate::{Diagnosis, SessionDiagnosis};

/// `−log10 p` above which a held-out residual keeps a reproducible shape.
pub const HELD_OUT_SHAPE_EVIDENCE: f64 = 3.0;

/// One held-out part of a trial: the fold that predicted it and its shape test.
#[derive(Clone, Debug, PartialEq, Serialize)]
#[non_exhaustive]
pub struct HeldOutShapePart {
    /// The fold (e.g. `leave_one_trial_out`'s `without FastWalking`).
    pub fold: String,
    /// Cycles of the part the test used (its strides, or 1).
    pub segments: usize,
    /// The held-out RMS error of the calibrated model on the part (N·m).
    pub rms_nm: f64,
    /// Its R².
    pub r2: f64,
    /// p-value of the part's shape test.
    pub p_value: f64,
    /// The scale of the model's moment the part asks for, cross-validated within it
    /// (`validate`'s [`MomentScale`]; `None` when it was not measured).
    pub scale: Option<MomentScale>,
}

impl HeldOutShapePart {
    /// A part's test.
    #[must_use]
    pub fn new(fold: String, segments: usize, rms_nm: f64, r2: f64, p_value: f64) -> Self {
        Self {
            fold,
            segments,
            rms_nm,
            r2,
            p_value,
            scale: None,
        }
    }

    /// The same part with the scale of the model's moment it asks for.
    #[must_use]
    pub fn with_scale(mut self, scale: Option<MomentScale>) -> Self {
        self.scale = scale;
        self
    }

    /// The part asks for another scale of the model's moment ([`MomentScale::differs`]).
    fn scale_differs(&self) -> bool {
        self.scale.is_some_and(|s| s.differs)
    }
}

/// A trial's held-out shape test over its held-out parts (module docs).
#[derive(Clone, Debug, PartialEq, Serialize)]
#[non_exhaustive]
pub struct HeldOutShapeCheck {
    /// The trial's held-out parts.
    pub parts: Vec<HeldOutShapePart>,
    /// Bonferroni p-value over the parts (1 without parts).
    pub p_value: f64,
    /// Whether the trial's held-out residual keeps a reproducible shape.
    pub reproducible: bool,
    /// Whether a held-out part of the trial asks for another scale of the model's moment: the
    /// calibration's EMG-to-moment gain does not carry to it.
    pub scale_differs: bool,
}

/// `min(1, m·min p)` of `m` p-values (1 for none).
fn bonferroni(p: impl Iterator<Item = f64>) -> f64 {
    let (n, min) = p.fold((0usize, 1.0f64), |(n, m), v| (n + 1, m.min(v)));
    (min * n.max(1) as f64).min(1.0)
}

fn keeps_shape(p: f64) -> bool {
    -p.max(1e-300).log10() > HELD_OUT_SHAPE_EVIDENCE
}

impl HeldOutShapeCheck {
    /// The trial's check from its parts' tests.
    #[must_use]
    pub fn of_parts(parts: Vec<HeldOutShapePart>) -> Self {
        let p_value = bonferroni(parts.iter().map(|p| p.p_value));
        let scale_differs = parts.iter().any(HeldOutShapePart::scale_differs);
        Self {
            parts,
            p_value,
            reproducible: keeps_shape(p_value),
            scale_differs,
        }
    }

    /// `true` when the calibration does not carry to the trial: a reproducible held-out shape
    /// or another gain.
    #[must_use]
    pub fn not_adequate(&self) -> bool {
        self.reproducible || self.scale_differs
    }

    /// The parts that ask for another gain, e.g. `× 0.69 (RMS 49.40 → 27.18 N·m, one half
    /// predicted from the other)`.
    fn scale_text(&self) -> Option<String> {
        let list: Vec<String> = self
            .parts
            .iter()
            .filter_map(|p| p.scale.filter(|s| s.differs))
            .map(|s| {
                format!(
                    "× {:.2} (RMS {:.2} → {:.2} N·m, one half predicted from the other)",
                    s.factor, s.rms_nm, s.cross_validated_rms_nm
                )
            })
            .collect();
        (!list.is_empty()).then(|| list.join("; "))
    }

    /// The terminal lines of the check: the shape test, and the gain when a part asks for
    /// another.
    #[must_use]
    pub fn summary_lines(&self) -> Vec<String> {
        let parts: Vec<String> = self
            .parts
            .iter()
            .map(|p| {
                format!(
                    "{}: {} cycle(s), RMS {:.2} N·m, R² {:.3}, p {:.1e}",
                    p.fold, p.segments, p.rms_nm, p.r2, p.p_value
                )
            })
            .collect();
        let mut lines = vec![format!(
            "held out     residual shape p = {:.1e} ({}): {}",
            self.p_value,
            parts.join("; "),
            if self.reproducible {
                "reproducible, the model is not adequate"
            } else {
                "no reproducible shape"
            }
        )];
        if let Some(t) = self.scale_text() {
            lines.push(format!(
                "held-out gain the model's moment {t}: the calibration's gain does not carry \
                 to this trial, the model is not adequate"
            ));
        }
        lines
    }
}

/// The session's held-out shape tests, one per trial that has held-out parts.
#[derive(Clone, Debug, PartialEq, Serialize)]
#[non_exhaustive]
pub struct SessionHeldOutShape {
    /// Per trial, by name.
    pub per_trial: Vec<TrialHeldOutShape>,
    /// Bonferroni p-value over the trials (reported; the verdict is each trial's).
    pub p_value: f64,
    /// Whether any trial's held-out residual keeps a reproducible shape.
    pub reproducible: bool,
    /// Whether a held-out part of any trial asks for another scale of the model's moment.
    pub scale_differs: bool,
}

impl SessionHeldOutShape {
    /// The trials that ask for another gain, e.g. `Running1 × 0.73 (RMS 43.35 → 28.01 N·m)`.
    #[must_use]
    pub fn scale_text(&self) -> Option<String> {
        let list: Vec<String> = self
            .per_trial
            .iter()
            .filter_map(|t| t.check.scale_text().map(|s| format!("{} {s}", t.name)))
            .collect();
        (!list.is_empty()).then(|| list.join(", "))
    }
}

/// One trial's check in [`SessionHeldOutShape`].
#[derive(Clone, Debug, PartialEq, Serialize)]
#[non_exhaustive]
pub struct TrialHeldOutShape {
    /// Trial name.
    pub name: String,
    /// Its check.
    #[serde(flatten)]
    pub check: HeldOutShapeCheck,
}

impl Diagnosis {
    /// Records the trial's held-out shape test; a trial whose held-out residual keeps a
    /// reproducible shape, or that asks for another gain, is not adequate.
    pub fn judge_held_out_shape(&mut self, check: HeldOutShapeCheck) {
        if check.not_adequate() {
            self.verdict = Verdict::Deficient;
        }
        self.held_out_shape = Some(check);
    }
}

impl SessionDiagnosis {
    /// Records every trial's held-out shape test (`(trial name, check)`); the session is not
    /// adequate when any trial's held-out residual keeps a reproducible shape or asks for
    /// another gain.
    pub fn judge_held_out_shape(&mut self, per_trial: Vec<(String, HeldOutShapeCheck)>) {
        let p_value = bonferroni(per_trial.iter().map(|(_, c)| c.p_value));
        let reproducible = per_trial.iter().any(|(_, c)| c.reproducible);
        let scale_differs = per_trial.iter().any(|(_, c)| c.scale_differs);
        if reproducible || scale_differs {
            self.verdict = Verdict::Deficient;
        }
        self.held_out_shape = Some(SessionHeldOutShape {
            per_trial: per_trial
                .into_iter()
                .map(|(name, check)| TrialHeldOutShape { name, check })
                .collect(),
            p_value,
            reproducible,
            scale_differs,
        });
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn part(p: f64) -> HeldOutShapePart {
        HeldOutShapePart::new("fold".into(), 1, 10.0, 0.8, p)
    }

    #[test]
    fn a_trial_keeps_a_shape_when_its_bonferroni_p_is_below_the_threshold() {
        let c = HeldOutShapeCheck::of_parts(vec![part(4e-4), part(0.5)]);
        assert!((c.p_value - 8e-4).abs() < 1e-15);
        assert!(c.reproducible);
        let c = HeldOutShapeCheck::of_parts(vec![part(6e-4), part(0.5)]);
        assert!(!c.reproducible, "1.2e-3 is above 1e-3");
        let none = HeldOutShapeCheck::of_parts(Vec::new());
        assert_eq!(none.p_value, 1.0);
        assert!(!none.reproducible);
    }

    #[test]
    fn a_trial_that_asks_for_another_gain_is_not_adequate_whatever_its_shape() {
        let predicted: Vec<f64> = (0..300).map(|i| 30.0 * (i as f64 * 0.06).sin()).collect();
        let w = vec![1.0; 300];
        let scaled = |g: f64| {
            let y: Vec<f64> = predicted.iter().map(|p| g * p).collect();
            validate::moment_scale(&y, &predicted, &w, std::slice::from_ref(&(0..300)))
        };
        let check = HeldOutShapeCheck::of_parts(vec![part(0.5).with_scale(scaled(0.7))]);
        assert!(!check.reproducible && check.scale_differs && check.not_adequate());
        assert!(
            check.summary_lines().concat().contains("× 0.70"),
            "{}",
            check.summary_lines().concat()
        );
        let same = HeldOutShapeCheck::of_parts(vec![part(0.5).with_scale(scaled(1.0))]);
        assert!(!same.not_adequate());
        assert_eq!(same.summary_lines().len(), 1);
    }
}
