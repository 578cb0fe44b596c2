//! What a diagnosis reports of its flexible terms: the ranking of the vocabulary, the
//! extension with its terms' shapes and bands, and the named causes a flexible term replaced.

use serde::Serialize;

use super::variable::StateVariable;
use crate::report::signed_change;

/// A variable's flexible term added to the final model.
#[derive(Clone, Debug, PartialEq, Serialize)]
#[non_exhaustive]
pub struct VariableGain {
    /// State variable.
    pub variable: StateVariable,
    /// The variable's term fitted separately in the two directions of motion was its best
    /// form (the variable's function differs between plantarflexing and dorsiflexing).
    #[serde(skip_serializing_if = "std::ops::Not::not")]
    pub by_direction: bool,
    /// Held-out deviance of the final model minus that of the model with the term (χ² units;
    /// positive: the term predicts held-out data better), both cross-validated on 0.5 s
    /// blocks. The ranking's order.
    pub heldout_deviance_gain: f64,
    /// Pooled held-out RMS with the term on the blocks (N·m).
    pub heldout_rms_nm: f64,
    /// Fall of the pooled held-out RMS against the final model's on the blocks (%):
    /// `100 (1 − RMS_with / RMS_final)`.
    pub heldout_rms_reduction_pct: f64,
    /// BIC with the term minus the final model's.
    pub delta_bic: f64,
    /// Independent coefficients of the term.
    pub parameters: usize,
}

/// The fitted shape of one flexible term: its value at points of its variable with a 95 %
/// band. The term is centred: its mean over the trial is zero.
#[derive(Clone, Debug, PartialEq, Serialize)]
#[non_exhaustive]
pub struct FlexibleTerm {
    /// State variable.
    pub variable: StateVariable,
    /// For a term fitted separately in the two directions of motion, the sign of the velocity
    /// over which this shape holds (−1 plantarflexing, +1 dorsiflexing; the other direction's
    /// shape is the next term); absent for a term of the variable alone.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub direction: Option<f64>,
    /// Unit of `points` (empty: dimensionless).
    pub unit: String,
    /// Points of the variable (for `direction`: −1 and +1, the sign of the velocity).
    pub points: Vec<f64>,
    /// Term at each point (N·m).
    pub value_nm: Vec<f64>,
    /// Half-width of the 95 % band at each point (N·m; NaN when not computed).
    pub band_nm: Vec<f64>,
    /// The term's values searched on the data rather than fitted: a step's `change_point`
    /// (s) or a sinusoid's `frequency` (Hz) in time, the `transition_width` (°/s) of
    /// `tanh(q̇/w)` in direction, the speed at which the term reaches 76 % of its level, the
    /// `step_level` (in the variable's unit) of a step beside the hats of the angle or an
    /// activation.
    pub searched: Vec<SearchedValue>,
}

/// A value of a flexible term's shape searched on the data (a grid or a scan), not fitted as
/// a coefficient; it counts as one parameter in the BIC.
#[derive(Clone, Debug, PartialEq, Serialize)]
#[non_exhaustive]
pub struct SearchedValue {
    /// `change_point`, `frequency`, `transition_width` or `step_level`.
    pub name: String,
    /// The value found.
    pub value: f64,
    /// Its unit.
    pub unit: String,
}

/// The final model extended with the flexible terms of `depends_on`.
#[derive(Clone, Debug, PartialEq, Serialize)]
#[non_exhaustive]
pub struct FlexibleExtension {
    /// The variables of its terms.
    pub variables: Vec<StateVariable>,
    /// Pooled held-out RMS (N·m).
    pub heldout_rms_nm: f64,
    /// Reduction of the held-out RMS against the final catalogued model (%).
    pub heldout_rms_reduction_pct: f64,
    /// Held-out deviance gain against the final catalogued model.
    pub heldout_deviance_gain: f64,
    /// In-sample RMS (N·m).
    pub rms_nm: f64,
    /// BIC against the final catalogued model.
    pub delta_bic: f64,
    /// The terms' shapes.
    pub terms: Vec<FlexibleTerm>,
    /// Per-sample torque of the terms (N·m; not serialised; for the figures).
    #[serde(skip)]
    pub term_nm: Vec<f64>,
}

/// A catalogued effect the selection found that a flexible term in its own variable explains
/// better: not named.
#[derive(Clone, Debug, PartialEq, Serialize)]
#[non_exhaustive]
pub struct Replacement {
    /// Effect.
    pub effect: String,
    /// The variable whose flexible term explains its share better.
    pub variable: StateVariable,
    /// BIC of the model with the effect minus that with the flexible term instead (above
    /// `−margin`: not named).
    pub delta_bic: f64,
    /// Held-out deviance of the model with the effect minus that with the flexible term
    /// instead, on the term's folds, when the held-out contest replaced it (above
    /// `min_flexible_gain`: not named); `None` when the BIC review did.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub heldout_deviance_gain: Option<f64>,
}

impl Replacement {
    /// Why the effect is not named, in words: `<effect> …` without a full stop.
    pub fn reason(&self) -> String {
        match self.heldout_deviance_gain {
            None => format!(
                "{}: a flexible term in {} explains its share better (ΔBIC {:+.1})",
                self.effect,
                self.variable.name(),
                -self.delta_bic
            ),
            Some(g) => format!(
                "{}: a flexible term in {}, fitted in its place, predicts the held-out samples \
                 better (held-out deviance gain {g:.1}, ΔBIC {:+.1})",
                self.effect,
                self.variable.name(),
                -self.delta_bic
            ),
        }
    }
}

/// What the unexplained structure depends on (`unexplained` in `diagnosis.json`).
#[derive(Clone, Debug, PartialEq, Serialize)]
#[non_exhaustive]
pub struct Unexplained {
    /// The best one or two variables (empty: none of the vocabulary explains it).
    pub depends_on: Vec<StateVariable>,
    /// Every variable's term added to the final model, best held-out deviance gain first.
    pub ranking: Vec<VariableGain>,
    /// The model extended with the terms of `depends_on`.
    pub extension: Option<FlexibleExtension>,
    /// A catalogued effect not named whose shape, added to the final model, explains the
    /// structure as well as the flexible term in the best variable (by the margin).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub catalogued_shape: Option<String>,
    /// Catalogued effects the selection found that a flexible term explains better.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub replaced: Vec<Replacement>,
}

impl Unexplained {
    /// `depends_on` as the terms that tell it: each variable with whether its term was fitted
    /// separately in the two directions of motion (from the extension's terms). The
    /// `direction` such a term brings into `depends_on` is not told again unless the
    /// direction has a term of its own.
    pub fn told_variables(&self) -> Vec<(StateVariable, bool)> {
        let terms: Vec<(StateVariable, bool)> = self
            .extension
            .iter()
            .flat_map(|e| &e.terms)
            .map(|t| (t.variable, t.direction.is_some()))
            .collect();
        let any_split = terms.iter().any(|t| t.1);
        let mut out: Vec<(StateVariable, bool)> = Vec::new();
        for v in &self.depends_on {
            let told = match terms.iter().find(|t| t.0 == *v) {
                Some(t) => *t,
                None if *v == StateVariable::Direction && any_split => continue,
                None => (*v, false),
            };
            if !out.contains(&told) {
                out.push(told);
            }
        }
        out
    }

    /// Lines of the terminal summary.
    pub fn summary_lines(&self) -> Vec<String> {
        let mut l = Vec::new();
        for r in &self.replaced {
            l.push(format!("not named    {}", r.reason()));
        }
        match (&self.depends_on[..], &self.extension) {
            ([], _) | (_, None) => l.push(
                "depends on   none of angle, velocity, direction, acceleration, time, \
                 activation, activation_ta"
                    .to_string(),
            ),
            (_, Some(e)) => {
                let names: Vec<String> = self
                    .told_variables()
                    .iter()
                    .map(|(v, split)| {
                        format!("{}{}", v.name(), if *split { " by direction" } else { "" })
                    })
                    .collect();
                // the RMS can rise while the deviance falls (the whitening weighs fast
                // structure more than the RMS does): say which way each moved
                l.push(format!(
                    "depends on   {}: a flexible term {} the held-out RMS to {:.2} N·m ({}, \
                     held-out deviance {})",
                    names.join(" and "),
                    if e.heldout_rms_reduction_pct >= 0.0 {
                        "lowers"
                    } else {
                        "raises"
                    },
                    e.heldout_rms_nm,
                    signed_change(-e.heldout_rms_reduction_pct, " %"),
                    signed_change(-e.heldout_deviance_gain, "")
                ));
            }
        }
        for t in self.extension.iter().flat_map(|e| &e.terms) {
            for v in &t.searched {
                l.push(format!(
                    "searched     {}: {} {:.3} {}",
                    t.variable.name(),
                    v.name.replace('_', " "),
                    v.value,
                    v.unit
                ));
            }
        }
        if let Some(k) = &self.catalogued_shape {
            l.push(format!(
                "shape        that of {k} after all (its term explains the structure as well)"
            ));
        }
        l
    }
}
