//! One muscle's torque `F̃T·F0·r(q)` at every sample, by any [`Formulation`]: the fast path
//! of [`crate::fast_simulation`], or [`ode::dopri5_dense`] on the reduced (`[a, LM]`, with
//! `LMT = LMT(q)` and `F̃T = fT(ε)` from the invariants) or the four-state system of
//! [`MuscleUnit`], from the static equilibrium (`ṽ = 0`) at `a = u(0)`.

use crate::effects::Effects;
use crate::error::ModelError;
use crate::fast_simulation::{self, Channel, Fibre};
use crate::inputs::TrialInputs;
use crate::joint_effects::delay_s;
use crate::musculotendon::{MuscleUnit, IX_FT, IX_LM, STATE_DIM};
use crate::params::{ModelParams, Muscle};
use crate::settings::{Formulation, SimSettings};
use crate::stats::SimStats;
use ode::OdeSystem;
use std::sync::Arc;

/// What the fast integration of `unit` needs: its channel (`current` when it matches), its
/// fibre constants and the equilibrium fibre length at the first sample.
pub(crate) fn fast_prepare(
    current: Option<&Arc<Channel>>,
    inputs: &TrialInputs,
    unit: &MuscleUnit,
    delay: f64,
) -> (Arc<Channel>, Fibre, f64) {
    let y0 = unit.equilibrium_state(
        inputs.envelope_at(unit.muscle.index(), inputs.times()[0] - delay),
        inputs.angle()[0],
    );
    let ch = fast_simulation::channel_for(current, inputs, unit, delay);
    (ch, fast_simulation::Fibre::new(unit), y0[IX_LM])
}

/// The integration error of muscle `muscle`.
pub(crate) fn integration_error(muscle: Muscle) -> impl FnOnce(ode::OdeError) -> ModelError {
    move |source| ModelError::Integration {
        muscle: muscle.name(),
        source,
    }
}

/// Unit-`F0` torque `F̃T·r(q)` of `unit` at every sample into `out` ([`Formulation::Fast`]).
#[allow(clippy::too_many_arguments)]
pub(crate) fn fast_unit_torque(
    current: &mut Option<Arc<Channel>>,
    lm: &mut Vec<f64>,
    inputs: &TrialInputs,
    unit: &MuscleUnit,
    delay: f64,
    settings: &SimSettings,
    out: &mut [f64],
) -> Result<SimStats, ModelError> {
    let (ch, fib, lm0) = fast_prepare(current.as_ref(), inputs, unit, delay);
    lm.resize(inputs.len(), 0.0);
    let stats = fast_simulation::run(&ch, inputs, &fib, lm0, settings, lm)
        .map_err(integration_error(unit.muscle))?;
    fast_simulation::unit_torque(&fib, &ch, lm, out);
    *current = Some(ch);
    Ok(stats)
}

struct UnitSystem<'a> {
    unit: &'a MuscleUnit,
    inputs: &'a TrialInputs,
    j: usize,
    delay: f64,
    reduced: bool,
}

impl OdeSystem<STATE_DIM> for UnitSystem<'_> {
    #[inline]
    fn rhs(&mut self, t: f64, y: &[f64; STATE_DIM], dydt: &mut [f64; STATE_DIM]) {
        let u = self.inputs.envelope_at(self.j, t - self.delay);
        if self.reduced {
            let q = self.inputs.angle_value_at(t);
            self.unit.derivative_reduced(u, q, y, dydt);
        } else {
            let (q, qd) = self.inputs.angle_at(t);
            self.unit.derivative(u, q, qd, y, dydt);
        }
    }
}

/// Integrates muscle `m` and writes its torque at every sample into `torque` and, when given,
/// every sample's state into `states`.
#[allow(clippy::too_many_arguments)]
pub(crate) fn run_muscle(
    current: &mut Option<Arc<Channel>>,
    inputs: &TrialInputs,
    params: &ModelParams,
    effects: &Effects,
    settings: &SimSettings,
    m: Muscle,
    torque: &mut [f64],
    mut states: Option<&mut [[f64; STATE_DIM]]>,
) -> Result<SimStats, ModelError> {
    let unit = MuscleUnit::new(params, m, effects);
    let delay = delay_s(effects);
    let t = inputs.times();
    let j = m.index();
    if settings.formulation == Formulation::Fast {
        let (ch, fib, lm0) = fast_prepare(current.as_ref(), inputs, &unit, delay);
        let mut lm = vec![0.0; inputs.len()];
        let stats = fast_simulation::run(&ch, inputs, &fib, lm0, settings, &mut lm)
            .map_err(integration_error(m))?;
        let f0 = unit.f0;
        let activation = states.is_some().then(|| ch.activation(inputs));
        for (i, &lmi) in lm.iter().enumerate() {
            let lmt = ch.lmt[i];
            let ft = fib.tendon_force(lmt, lmi);
            // the same operations as `fast::unit_torque` followed by the F0 scaling
            torque[i] = f0 * (ft * ch.r[i]);
            if let (Some(st), Some((a, z))) = (states.as_deref_mut(), activation) {
                st[i] = fast_simulation::state(a[i], z[i], lmi, lmt, ft);
            }
        }
        *current = Some(ch);
        return Ok(stats);
    }
    let y0 = unit.equilibrium_state(inputs.envelope_at(j, t[0] - delay), inputs.angle()[0]);
    let reduced = settings.formulation == Formulation::Reduced;
    let mut sys = UnitSystem {
        unit: &unit,
        inputs,
        j,
        delay,
        reduced,
    };
    let q = inputs.angle();
    let stats = ode::dopri5_dense(&mut sys, y0, t, &settings.adaptive(), |i, y| {
        if reduced {
            let mut yp = *y;
            unit.project(q[i], &mut yp);
            torque[i] = yp[IX_FT] * unit.f0 * unit.moment_arm(q[i]);
            if let Some(st) = states.as_deref_mut() {
                st[i] = yp;
            }
        } else {
            torque[i] = y[IX_FT] * unit.f0 * unit.moment_arm(q[i]);
            if let Some(st) = states.as_deref_mut() {
                st[i] = *y;
            }
        }
    })
    .map_err(integration_error(m))?;
    Ok(stats.into())
}
