//! Flexible terms: what a structure no catalogued effect explains depends on, and a model
//! extended with it (docs/diagnosis.md, "Beyond the catalogue").
//!
//! A flexible term in a state variable `v` adds to the model torque
//!
//! ```text
//! τ += Σ_j β_j h_j(v(t))
//! ```
//!
//! with piecewise-linear hat functions `h_j` on knots spread uniformly over the observed range
//! of `v` (five; four for the TA; about every 2 s in time), or, for `direction`, the single
//! column `sign(q̇)` (0 while the joint is still). Time is also tried with a step `1{t ≥ τ}`
//! added at the residual's most likely change point (`with_step`), and direction as
//! `tanh(q̇/w)` with the transition width `w` searched on the residual (`with_width`); the
//! better of the two forms (held-out gain in the ranking, BIC in the review) stands for the
//! variable, a searched value counting as one parameter in the BIC. Columns are centred on
//! their mean over the trial except in time (a constant is a function of time only). The vocabulary: `angle` (°),
//! `velocity` (°/s), `direction`, `acceleration` (°/s²), `time` (s), `activation` (the mean
//! normalised triceps surae envelope) and `activation_ta` (the normalised tibialis anterior
//! envelope).
//!
//! The stages, a file each: `basis` (a variable's columns), `forms` (the searched forms of time
//! and direction, and the simplest shape in time), `fit` (the fit by variable projection and
//! its cross-validation), `review` (no false story), `characterise` (the ranking and the
//! extension) and `report` (what the diagnosis reports of them).

use muscle_model::EffectKind;
use serde::Serialize;

mod basis;
mod characterise;
mod fit;
mod forms;
mod report;
mod review;

pub(crate) use characterise::{characterise, Characterisation};
pub(crate) use fit::without_effects;
pub(crate) use forms::ramp_column;
pub use report::{
    FlexibleExtension, FlexibleTerm, Replacement, SearchedValue, Unexplained, VariableGain,
};
pub(crate) use review::review_causes;

/// A state variable of the flexible terms' vocabulary.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum StateVariable {
    /// Ankle angle (°).
    Angle,
    /// Angular velocity (°/s).
    Velocity,
    /// Sign of the angular velocity.
    Direction,
    /// Angular acceleration (°/s²).
    Acceleration,
    /// Time since the start of the trial (s).
    Time,
    /// Mean normalised triceps surae envelope.
    Activation,
    /// Normalised tibialis anterior envelope.
    ActivationTa,
}

impl StateVariable {
    /// The vocabulary, in report order.
    pub const ALL: [StateVariable; 7] = [
        StateVariable::Angle,
        StateVariable::Velocity,
        StateVariable::Direction,
        StateVariable::Acceleration,
        StateVariable::Time,
        StateVariable::Activation,
        StateVariable::ActivationTa,
    ];

    /// Name in `diagnosis.json`.
    pub fn name(self) -> &'static str {
        match self {
            StateVariable::Angle => "angle",
            StateVariable::Velocity => "velocity",
            StateVariable::Direction => "direction",
            StateVariable::Acceleration => "acceleration",
            StateVariable::Time => "time",
            StateVariable::Activation => "activation",
            StateVariable::ActivationTa => "activation_ta",
        }
    }

    /// Unit of the variable's values (empty: dimensionless).
    pub fn unit(self) -> &'static str {
        match self {
            StateVariable::Angle => "°",
            StateVariable::Velocity => "°/s",
            StateVariable::Acceleration => "°/s²",
            StateVariable::Time => "s",
            StateVariable::Direction | StateVariable::Activation | StateVariable::ActivationTa => {
                ""
            }
        }
    }

    /// The variables a catalogued effect's torque is a function of, which its flexible
    /// alternatives are drawn from: an offset is a constant of time, fatigue a decay over time
    /// that scales the active force, an antagonist term follows the TA, eccentric enhancement
    /// and damping follow the velocity and its sign, inertia the acceleration, the passive
    /// torque and gravity the angle, and a delay shifts the activation.
    pub fn of_effect(kind: EffectKind) -> &'static [StateVariable] {
        use StateVariable as V;
        match kind {
            EffectKind::TorqueOffset => &[V::Time],
            EffectKind::PassiveJointTorque | EffectKind::Gravity => &[V::Angle],
            EffectKind::ElectromechanicalDelay => &[V::Activation],
            EffectKind::Fatigue => &[V::Time, V::Activation],
            EffectKind::AntagonistCoactivation => &[V::ActivationTa],
            EffectKind::EccentricEnhancement | EffectKind::ViscousDamping => {
                &[V::Velocity, V::Direction]
            }
            EffectKind::Inertia => &[V::Acceleration],
        }
    }
}

impl Serialize for StateVariable {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_str(self.name())
    }
}
