//! Which effects a session shares across its trials and which each trial has on its own.
//!
//! An effect of the **subject** takes one value for every trial: the non-muscular tissue's
//! passive torque, the electromechanical delay, eccentric enhancement, the fatigue rate, the
//! antagonist's gain (the tibialis anterior's torque per unit of its normalised EMG, normalised
//! over the session), and the damping and inertia of the foot and footplate (the same foot on
//! the same footplate about the same axis whatever the knee angle or the speed). An effect of a
//! **trial**'s setup takes one value per trial: the torque offset (the dynamometer is zeroed,
//! and the foot strapped, anew for each trial) and gravity (the foot's and attachment's weight
//! acts through where the limb sits on the footplate, which moves between trials).

use muscle_model::EffectKind;
use serde::Serialize;

/// Whether an effect takes one value for the whole session or one per trial.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum EffectScope {
    /// A property of the subject: one value shared by every trial.
    Subject,
    /// A property of a trial's setup: one value per trial.
    Trial,
}

/// The scope of an effect (module docs).
#[must_use]
pub fn effect_scope(kind: EffectKind) -> EffectScope {
    match kind {
        EffectKind::TorqueOffset | EffectKind::Gravity => EffectScope::Trial,
        EffectKind::PassiveJointTorque
        | EffectKind::ElectromechanicalDelay
        | EffectKind::Fatigue
        | EffectKind::AntagonistCoactivation
        | EffectKind::EccentricEnhancement
        | EffectKind::ViscousDamping
        | EffectKind::Inertia => EffectScope::Subject,
    }
}
