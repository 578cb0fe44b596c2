//! Simulation of a trial: each muscle's ODE integrated with Dormand–Prince 5(4), and the
//! torque at every sample (dissertation eq. 7) plus the joint-level effects,
//!
//! ```text
//! τ(tᵢ) = τ_effects(tᵢ) + Σ_j F̃T_j(tᵢ)·F0_j·r_j(tᵢ)
//! ```
//!
//! over sol, gm, gl and the model's fixed muscles (`r_j < 0` for a dorsiflexor).
//!
//! [`simulate`] returns everything ([`SimOutput`]); [`simulate_into`] and the fused prediction
//! of the identification problem reuse a [`Workspace`] and its per-muscle cache.

use crate::effects::Effects;
use crate::error::ModelError;
use crate::inputs::TrialInputs;
use crate::joint_effects::{add_joint_effects, needs_ta, run_ta};
pub use crate::muscle_torque::MuscleOutput;
use crate::muscle_torque::{run_muscle, sum_torques};
use crate::musculotendon::{MuscleUnit, STATE_DIM};
use crate::params::{ModelParams, Muscle};
use crate::settings::{Formulation, SimSettings};
use crate::stats::SimStats;
use crate::workspace::{update_muscles, Workspace};
use serde::Serialize;

/// Result of a simulation, one value per input sample.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct SimOutput {
    /// Sample times (s).
    pub time: Vec<f64>,
    /// Total joint torque including effects (N·m, plantarflexion > 0).
    pub torque: Vec<f64>,
    /// Every muscle's torque, state and statistics: sol, gm, gl (at [`Muscle::index`]), then
    /// the fixed muscles in the order of [`ModelParams::fixed`].
    pub muscles: Vec<MuscleOutput>,
    /// Sum of the joint-level effect torques (offset, passive, gravity, damping, inertia,
    /// antagonist) (N·m).
    pub torque_effects: Vec<f64>,
    /// TA activation `a_TA` at the samples when `antagonist_coactivation` is active.
    pub activation_ta: Option<Vec<f64>>,
}

impl SimOutput {
    /// Total integrator statistics.
    pub fn total_stats(&self) -> SimStats {
        let mut t = SimStats::default();
        for m in &self.muscles {
            t.add(m.stats);
        }
        t
    }

    /// Torque of sol, gm or gl at the samples (N·m).
    pub fn torque_of(&self, m: Muscle) -> &[f64] {
        &self.muscles[m.index()].torque
    }

    /// State of sol, gm or gl at the samples, when recorded.
    pub fn states_of(&self, m: Muscle) -> Option<&[[f64; STATE_DIM]]> {
        self.muscles[m.index()].states.as_deref()
    }

    /// The muscle called `name`, if the model has it.
    pub fn muscle_named(&self, name: &str) -> Option<&MuscleOutput> {
        self.muscles.iter().find(|m| m.name == name)
    }
}

fn check(
    params: &ModelParams,
    effects: &Effects,
    settings: &SimSettings,
) -> Result<(), ModelError> {
    params.validate()?;
    effects.validate()?;
    if !(settings.rtol > 0.0 && settings.atol > 0.0 && settings.h_max > 0.0) {
        return Err(ModelError::invalid(
            "settings",
            "rtol, atol and h_max must be positive",
        ));
    }
    Ok(())
}

/// Simulates a trial and returns torques (and states with [`SimSettings::record_states`]).
///
/// Fails with [`ModelError::InvalidValue`] for invalid parameters or effects, with
/// [`ModelError::InvalidInput`] when `antagonist_coactivation` is active without a TA envelope,
/// and with [`ModelError::Integration`] / [`ModelError::NonFinite`] when the simulation fails.
pub fn simulate(
    inputs: &TrialInputs,
    params: &ModelParams,
    effects: &Effects,
    settings: &SimSettings,
) -> Result<SimOutput, ModelError> {
    check(params, effects, settings)?;
    let n = inputs.len();
    let mut muscles = Vec::with_capacity(3 + params.fixed.len());
    for unit in MuscleUnit::all(params, effects) {
        let mut torque = vec![0.0; n];
        let mut states = settings.record_states.then(|| vec![[0.0; STATE_DIM]; n]);
        let stats = run_muscle(
            &mut None,
            inputs,
            &unit,
            effects,
            settings,
            &mut torque,
            states.as_deref_mut(),
        )?;
        muscles.push(MuscleOutput {
            name: unit.name,
            torque,
            states,
            stats,
        });
    }
    let activation_ta = if needs_ta(effects) {
        let mut ta = vec![0.0; n];
        run_ta(inputs, params, effects, settings, &mut ta)?;
        Some(ta)
    } else {
        None
    };
    let mut torque_effects = vec![0.0; n];
    add_joint_effects(
        inputs,
        effects,
        activation_ta.as_deref().unwrap_or(&[]),
        &mut torque_effects,
    );
    let tm = |j: usize| &muscles[j].torque;
    let mut torque: Vec<f64> = (0..n)
        .map(|i| torque_effects[i] + tm(0)[i] + tm(1)[i] + tm(2)[i])
        .collect();
    if muscles.len() > 3 {
        let mut fixed = Vec::new();
        sum_torques(muscles[3..].iter().map(|m| &m.torque[..]), n, &mut fixed);
        for (t, f) in torque.iter_mut().zip(&fixed) {
            *t += f;
        }
    }
    if let Some(i) = torque.iter().position(|x| !x.is_finite()) {
        return Err(ModelError::NonFinite {
            what: "torque",
            index: i,
        });
    }
    Ok(SimOutput {
        time: inputs.times().to_vec(),
        torque,
        muscles,
        torque_effects,
        activation_ta,
    })
}

/// Allocation-free (after the first call) simulation for hot loops: writes the total torque at
/// every sample into `torque` (length = number of samples) and returns the summed integrator
/// statistics. The per-muscle torques stay available in [`Workspace::torque_muscle`].
pub fn simulate_into(
    ws: &mut Workspace,
    inputs: &TrialInputs,
    params: &ModelParams,
    effects: &Effects,
    settings: &SimSettings,
    torque: &mut [f64],
) -> Result<SimStats, ModelError> {
    check(params, effects, settings)?;
    let n = inputs.len();
    if torque.len() != n {
        return Err(ModelError::Length {
            what: "torque".into(),
            expected: n,
            got: torque.len(),
        });
    }
    let total = update_muscles(ws, inputs, params, effects, settings)?;
    if settings.formulation == Formulation::Fast {
        ws.scale_unit_torques(n);
    }
    ws.copy_fixed_outputs();
    let ta = ws.ta_activation(inputs, params, effects, settings)?;
    torque.fill(0.0);
    add_joint_effects(inputs, effects, ta, torque);
    let tm = ws.torque_muscle();
    let (t0, t1, t2) = (&tm[0].torque, &tm[1].torque, &tm[2].torque);
    let fixed = ws.fixed_torque(n);
    for (i, t) in torque.iter_mut().enumerate() {
        *t += t0[i] + t1[i] + t2[i];
        if let Some(f) = fixed {
            *t += f[i];
        }
        if !t.is_finite() {
            return Err(ModelError::NonFinite {
                what: "torque",
                index: i,
            });
        }
    }
    Ok(total)
}

/// What [`predict_into`] compares the prediction with: measured torque and optional weights.
pub(crate) struct Target<'a> {
    pub(crate) measured: &'a [f64],
    pub(crate) weights: Option<&'a [f64]>,
}

/// The total torque of [`simulate_into`] (bit for bit) into `out`, and with a `target` the
/// weighted sum of squares `Σ wᵢ (mᵢ − outᵢ)²` computed in the same pass (returned; 0 without
/// a target). With [`Formulation::Fast`] this is one pass over the cached unit torques;
/// [`Workspace::torque_muscle`] is not updated then.
pub(crate) fn predict_into(
    ws: &mut Workspace,
    inputs: &TrialInputs,
    params: &ModelParams,
    effects: &Effects,
    settings: &SimSettings,
    out: &mut [f64],
    target: Option<Target<'_>>,
) -> Result<f64, ModelError> {
    let n = inputs.len();
    if settings.formulation != Formulation::Fast {
        simulate_into(ws, inputs, params, effects, settings, out)?;
        return Ok(target.map_or(0.0, |t| sum_squares(out, t)));
    }
    check(params, effects, settings)?;
    if out.len() != n {
        return Err(ModelError::Length {
            what: "torque".into(),
            expected: n,
            got: out.len(),
        });
    }
    update_muscles(ws, inputs, params, effects, settings)?;
    ws.update_effects_torque(inputs, params, effects, settings)?;
    let ([f0, f1, f2], [g0, g1, g2], e) = ws.fast_terms(n);
    // the operations of `simulate_into`: effects, then `+= F0₀g₀ + F0₁g₁ + F0₂g₂`
    for i in 0..n {
        out[i] = e[i] + (f0 * g0[i] + f1 * g1[i] + f2 * g2[i]);
    }
    if let Some(f) = ws.fixed_torque(n) {
        for (o, f) in out.iter_mut().zip(f) {
            *o += f;
        }
    }
    let has_target = target.is_some();
    let ss = target.map_or(0.0, |t| sum_squares(out, t));
    // with a target, a non-finite prediction makes the sum non-finite (0·∞ is NaN too)
    if !has_target || !ss.is_finite() {
        if let Some(i) = out.iter().position(|x| !x.is_finite()) {
            return Err(ModelError::NonFinite {
                what: "torque",
                index: i,
            });
        }
    }
    Ok(ss)
}

/// `Σ wᵢ (mᵢ − pᵢ)²` (`wᵢ = 1` without weights), accumulated in four interleaved partial
/// sums (a fixed order: deterministic, and independent of where the prediction came from).
fn sum_squares(pred: &[f64], t: Target<'_>) -> f64 {
    let n = pred.len().min(t.measured.len());
    let (p, m) = (&pred[..n], &t.measured[..n]);
    let mut acc = [0.0_f64; 4];
    let n4 = n - n % 4;
    match t.weights {
        None => {
            for i in (0..n4).step_by(4) {
                for l in 0..4 {
                    let d = m[i + l] - p[i + l];
                    acc[l] += d * d;
                }
            }
            for i in n4..n {
                let d = m[i] - p[i];
                acc[i - n4] += d * d;
            }
        }
        Some(w) => {
            let w = &w[..n];
            for i in (0..n4).step_by(4) {
                for l in 0..4 {
                    let d = m[i + l] - p[i + l];
                    acc[l] += w[i + l] * d * d;
                }
            }
            for i in n4..n {
                let d = m[i] - p[i];
                acc[i - n4] += w[i] * d * d;
            }
        }
    }
    (acc[0] + acc[1]) + (acc[2] + acc[3])
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fused_prediction_matches_simulate_into_bit_for_bit() {
        let tr = crate::synthetic::seed_like_trial(512.0).unwrap();
        let p = ModelParams::nominal();
        let s = SimSettings::default();
        let e1 = Effects::from_json_str(
            r#"{"torque_offset": {"offset_nm": 1.5}, "gravity": {"moment_nm": 2.0}}"#,
        )
        .unwrap();
        let e2 = Effects::from_json_str(r#"{"torque_offset": {"offset_nm": -0.5}}"#).unwrap();
        let measured: Vec<f64> = simulate(&tr, &p, &Effects::none(), &s)
            .unwrap()
            .torque
            .iter()
            .map(|t| t + 0.25)
            .collect();
        let mut ws = Workspace::new();
        let mut out = vec![0.0; tr.len()];
        let mut q = p;
        for (k, e) in [e1, e1, e2, Effects::none(), e2].iter().enumerate() {
            q.muscles[k % 3].fom_n *= 1.01;
            // simulate_into's sum order (simulate adds the effects first: equal to rounding)
            let mut want = vec![0.0; tr.len()];
            simulate_into(&mut Workspace::new(), &tr, &q, e, &s, &mut want).unwrap();
            let slow = simulate(&tr, &q, e, &s).unwrap().torque;
            assert!(want.iter().zip(&slow).all(|(a, b)| (a - b).abs() < 1e-9));
            let t = Target {
                measured: &measured,
                weights: None,
            };
            let ss = predict_into(&mut ws, &tr, &q, e, &s, &mut out, Some(t)).unwrap();
            assert_eq!(out, want, "call {k}");
            let direct: f64 = measured
                .iter()
                .zip(&want)
                .map(|(m, w)| (m - w) * (m - w))
                .sum();
            assert!(
                (ss - direct).abs() <= 1e-12 * direct,
                "call {k}: {ss} vs {direct}"
            );
        }
    }
}
