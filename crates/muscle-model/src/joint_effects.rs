//! The joint-level effects added to the muscles' torque, and the tibialis-anterior activation
//! the antagonist term needs:
//!
//! ```text
//! τ_effects = offset + s·(exp(k·q) − 1) + m·sin(q − φ) + b·q̇ − I·q̈ − g·a_TA
//! ȧ_TA      = (u_TA − a_TA)(k1·u_TA + k2),   u_TA = env_TA(t − d) clamped to [0, 1]
//! ```
//!
//! (each term only with its effect present; `docs/model.md` describes them).

use crate::activation::Activation;
use crate::effects::Effects;
use crate::error::ModelError;
use crate::inputs::TrialInputs;
use crate::params::ModelParams;
use crate::settings::SimSettings;
use ode::OdeSystem;

struct TaSystem<'a> {
    inputs: &'a TrialInputs,
    k1: f64,
    k2: f64,
    delay: f64,
}

impl OdeSystem<1> for TaSystem<'_> {
    #[inline]
    fn rhs(&mut self, t: f64, y: &[f64; 1], dydt: &mut [f64; 1]) {
        let u = self
            .inputs
            .envelope_ta_at(t - self.delay)
            .unwrap_or(0.0)
            .clamp(0.0, 1.0);
        dydt[0] = (u - y[0]) * (self.k1 * u + self.k2);
    }
}

/// The electromechanical delay (s; 0 without the effect).
pub(crate) fn delay_s(effects: &Effects) -> f64 {
    effects
        .electromechanical_delay
        .map_or(0.0, |d| d.delay_ms * 1e-3)
}

/// Integrates the TA activation `a_TA` at every sample into `out` (fails without a TA
/// envelope).
pub(crate) fn run_ta(
    inputs: &TrialInputs,
    params: &ModelParams,
    effects: &Effects,
    settings: &SimSettings,
    out: &mut [f64],
) -> Result<(), ModelError> {
    let delay = delay_s(effects);
    let t = inputs.times();
    let u0 = inputs
        .envelope_ta_at(t[0] - delay)
        .ok_or_else(|| {
            ModelError::input(
                "env_ta",
                "the antagonist_coactivation effect needs a TA envelope (emg_ta)",
            )
        })?
        .clamp(0.0, 1.0);
    let act = Activation::new(&params.activation);
    let mut sys = TaSystem {
        inputs,
        k1: act.k1,
        k2: act.k2,
        delay,
    };
    ode::dopri5_dense(&mut sys, [u0], t, &settings.adaptive(inputs), |i, y| {
        out[i] = y[0]
    })
    .map_err(|source| ModelError::Integration {
        muscle: "ta",
        source,
    })?;
    Ok(())
}

/// Adds the joint-level effects to `torque` (and returns nothing): offset, passive joint
/// torque, gravity, viscous damping, inertia and antagonist co-activation (`ta` = `a_TA`).
pub(crate) fn add_joint_effects(
    inputs: &TrialInputs,
    effects: &Effects,
    ta: &[f64],
    torque: &mut [f64],
) {
    let q = inputs.angle();
    let qd = inputs.velocity();
    let qdd = inputs.acceleration();
    if let Some(e) = effects.torque_offset {
        torque.iter_mut().for_each(|t| *t += e.offset_nm);
    }
    if let Some(e) = effects.passive_joint_torque {
        if e.scale_nm != 0.0 {
            for (t, &qi) in torque.iter_mut().zip(q) {
                *t += e.scale_nm * (e.stiffness_per_rad * qi).exp_m1();
            }
        }
    }
    if let Some(e) = effects.gravity {
        if e.moment_nm != 0.0 {
            let phi = e.phase_deg.to_radians();
            for (t, &qi) in torque.iter_mut().zip(q) {
                *t += e.moment_nm * (qi - phi).sin();
            }
        }
    }
    if let Some(e) = effects.viscous_damping {
        if e.b_nm_s_per_rad != 0.0 {
            for (t, &v) in torque.iter_mut().zip(qd) {
                *t += e.b_nm_s_per_rad * v;
            }
        }
    }
    if let Some(e) = effects.inertia {
        if e.i_kg_m2 != 0.0 {
            for (t, &acc) in torque.iter_mut().zip(qdd) {
                *t -= e.i_kg_m2 * acc;
            }
        }
    }
    if let Some(e) = effects.antagonist_coactivation {
        if e.gain_nm != 0.0 {
            for (t, &a) in torque.iter_mut().zip(ta) {
                *t -= e.gain_nm * a;
            }
        }
    }
}

/// Whether the antagonist term is active (it needs the TA activation).
pub(crate) fn needs_ta(effects: &Effects) -> bool {
    effects
        .antagonist_coactivation
        .is_some_and(|e| e.gain_nm != 0.0)
}

/// `∂τ_effects/∂θ` at every sample into `out`, for parameter `index` of the joint-level effect
/// `kind` (values from `effects`, an absent effect at its null values; `ta` = `a_TA` when the
/// antagonist's gain is asked for). The terms are explicit functions of their parameters:
///
/// ```text
/// ∂/∂c = 1,  ∂/∂s = exp(k·q) − 1,  ∂/∂k = s·q·exp(k·q),  ∂/∂m = sin(q − φ),
/// ∂/∂φ = −m·cos(q − φ)·π/180 (φ in degrees),  ∂/∂b = q̇,  ∂/∂I = −q̈,  ∂/∂g = −a_TA
/// ```
///
/// Returns false for a parameter that is not a joint-level term (delay, fatigue, `Flen`).
pub(crate) fn joint_effect_derivative(
    inputs: &TrialInputs,
    effects: &Effects,
    kind: crate::effects::EffectKind,
    index: usize,
    ta: &[f64],
    out: &mut [f64],
) -> bool {
    use crate::effects::EffectKind as K;
    let v = effects.values(kind).unwrap_or_else(|| kind.null_values());
    let q = inputs.angle();
    match (kind, index) {
        (K::TorqueOffset, 0) => out.fill(1.0),
        (K::PassiveJointTorque, 0) => {
            for (o, &qi) in out.iter_mut().zip(q) {
                *o = (v[1] * qi).exp_m1();
            }
        }
        (K::PassiveJointTorque, 1) => {
            for (o, &qi) in out.iter_mut().zip(q) {
                *o = v[0] * qi * (v[1] * qi).exp();
            }
        }
        (K::Gravity, 0) => {
            let phi = v[1].to_radians();
            for (o, &qi) in out.iter_mut().zip(q) {
                *o = (qi - phi).sin();
            }
        }
        (K::Gravity, 1) => {
            let phi = v[1].to_radians();
            let per_degree = std::f64::consts::PI / 180.0;
            for (o, &qi) in out.iter_mut().zip(q) {
                *o = -v[0] * (qi - phi).cos() * per_degree;
            }
        }
        (K::ViscousDamping, 0) => out.copy_from_slice(&inputs.velocity()[..out.len()]),
        (K::Inertia, 0) => {
            for (o, &a) in out.iter_mut().zip(inputs.acceleration()) {
                *o = -a;
            }
        }
        (K::AntagonistCoactivation, 0) if ta.len() == out.len() => {
            for (o, &a) in out.iter_mut().zip(ta) {
                *o = -a;
            }
        }
        _ => return false,
    }
    true
}
