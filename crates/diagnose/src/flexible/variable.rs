//! The state variables of the flexible terms' vocabulary, and those a catalogued effect's
//! shape lives in.

use muscle_model::{EffectKind, Muscle, TrialInputs};
use serde::Serialize;

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

    /// The variable at every sample of `inputs`, in its unit: degrees for the angle, velocity
    /// (and direction) and acceleration, seconds for time (the trial's clock), the mean sol,
    /// gm, gl envelope for activation, the TA envelope (`None` without one).
    pub fn samples(self, inputs: &TrialInputs) -> Option<Vec<f64>> {
        let deg = |x: &[f64]| x.iter().map(|a| a.to_degrees()).collect::<Vec<f64>>();
        Some(match self {
            StateVariable::Angle => deg(inputs.angle()),
            StateVariable::Velocity | StateVariable::Direction => deg(inputs.velocity()),
            StateVariable::Acceleration => deg(inputs.acceleration()),
            StateVariable::Time => inputs.times().to_vec(),
            StateVariable::Activation => (0..inputs.len())
                .map(|i| {
                    Muscle::ALL
                        .iter()
                        .map(|m| inputs.envelope(*m)[i])
                        .sum::<f64>()
                        / 3.0
                })
                .collect(),
            StateVariable::ActivationTa => inputs.envelope_ta()?.to_vec(),
        })
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
