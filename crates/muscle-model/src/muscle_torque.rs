//! One muscle's torque `F̃T·F0·r` at every sample, by any [`Formulation`]: the fast path
//! of [`crate::fast_simulation`], or [`ode::dopri5_dense`] on the reduced (`[a, LM]`, with
//! `LMT` from the muscle's path and `F̃T = fT(ε)` from the invariants) or the four-state
//! system of [`MuscleUnit`] (driven by the path's `vMT`), from the static equilibrium
//! (`ṽ = 0`) at `a = u(0)`. The path ([`MusclePath`]) is the length polynomial with the knee
//! term, or the trial's geometry series; `u` is the muscle's own envelope channel.

use crate::effects::Effects;
use crate::error::ModelError;
use crate::fast_simulation::{self, Channel, Fibre};
use crate::inputs::TrialInputs;
use crate::joint_effects::delay_s;
use crate::musculotendon::{MuscleUnit, IX_FT, IX_LM, STATE_DIM};
use crate::path::MusclePath;
use crate::settings::{Formulation, SimSettings};
use crate::stats::SimStats;
use ode::OdeSystem;
use serde::Serialize;
use std::sync::Arc;

/// One muscle's part of a simulation.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct MuscleOutput {
    /// The muscle (`sol`, `gm`, `gl` or a fixed muscle's name).
    pub name: &'static str,
    /// Its torque `F̃T·F0·r` at the samples (N·m; negative for a dorsiflexor).
    pub torque: Vec<f64>,
    /// Its state `[a, F̃T, LM, LMT, ∫â]` at the samples (with
    /// [`SimSettings::record_states`]).
    pub states: Option<Vec<[f64; STATE_DIM]>>,
    /// Its integrator statistics.
    pub stats: SimStats,
}

/// `Σ_k torques[k]` sample by sample, in order, into `out` (the fixed muscles' sum: one
/// definition for every path, so that they agree bit for bit).
pub(crate) fn sum_torques<'a>(
    torques: impl Iterator<Item = &'a [f64]>,
    n: usize,
    out: &mut Vec<f64>,
) {
    out.clear();
    out.resize(n, 0.0);
    for t in torques {
        for (o, v) in out.iter_mut().zip(t) {
            *o += v;
        }
    }
}

/// The envelope channel that drives `unit` (its own name's); an error naming the muscle and
/// the channel when the trial does not have it.
pub(crate) fn envelope_of<'a>(
    inputs: &'a TrialInputs,
    unit: &MuscleUnit,
) -> Result<&'a [f64], ModelError> {
    let name = unit.name;
    inputs.envelope_named(name).ok_or_else(|| {
        ModelError::input(
            format!("envelope {name}"),
            format!(
                "muscle `{name}` is driven by the EMG envelope channel `{name}` (emg_{name}), \
                 which the trial does not have"
            ),
        )
    })
}

/// What the fast integration of `unit` needs: its channel (`current` when it matches), its
/// fibre constants and the equilibrium fibre length at the first sample.
pub(crate) fn fast_prepare(
    current: Option<&Arc<Channel>>,
    inputs: &TrialInputs,
    unit: &MuscleUnit,
    delay: f64,
) -> Result<(Arc<Channel>, Fibre, f64), ModelError> {
    let env = envelope_of(inputs, unit)?;
    let path = MusclePath::new(unit, inputs)?;
    let y0 = unit.equilibrium_state_lmt(
        inputs.envelope_value_at(env, inputs.times()[0] - delay),
        path.lmt_sample(inputs, 0),
    );
    let ch = fast_simulation::channel_for(current, inputs, unit, env, &path, delay);
    Ok((ch, fast_simulation::Fibre::new(unit), y0[IX_LM]))
}

/// The integration error of muscle `name`.
pub(crate) fn integration_error(name: &'static str) -> impl FnOnce(ode::OdeError) -> ModelError {
    move |source| ModelError::Integration {
        muscle: name,
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
    let (ch, fib, lm0) = fast_prepare(current.as_ref(), inputs, unit, delay)?;
    lm.resize(inputs.len(), 0.0);
    let stats = fast_simulation::run(&ch, inputs, &fib, lm0, settings, lm)
        .map_err(integration_error(unit.name))?;
    fast_simulation::unit_torque(&fib, &ch, lm, out);
    *current = Some(ch);
    Ok(stats)
}

struct UnitSystem<'a> {
    unit: &'a MuscleUnit,
    inputs: &'a TrialInputs,
    env: &'a [f64],
    path: MusclePath<'a>,
    delay: f64,
    reduced: bool,
}

impl OdeSystem<STATE_DIM> for UnitSystem<'_> {
    #[inline]
    fn rhs(&mut self, t: f64, y: &[f64; STATE_DIM], dydt: &mut [f64; STATE_DIM]) {
        let u = self.inputs.envelope_value_at(self.env, t - self.delay);
        if self.reduced {
            let lmt = self.path.lmt_at(self.inputs, t);
            self.unit.derivative_reduced_lmt(u, lmt, y, dydt);
        } else {
            let vmt = self.path.vmt_at(self.inputs, t);
            self.unit.derivative_vmt(u, vmt, y, dydt);
        }
    }
}

/// Integrates `unit` and writes its torque at every sample into `torque` and, when given,
/// every sample's state into `states`.
pub(crate) fn run_muscle(
    current: &mut Option<Arc<Channel>>,
    inputs: &TrialInputs,
    unit: &MuscleUnit,
    effects: &Effects,
    settings: &SimSettings,
    torque: &mut [f64],
    mut states: Option<&mut [[f64; STATE_DIM]]>,
) -> Result<SimStats, ModelError> {
    let unit = *unit;
    let delay = delay_s(effects);
    let t = inputs.times();
    if settings.formulation == Formulation::Fast {
        let (ch, fib, lm0) = fast_prepare(current.as_ref(), inputs, &unit, delay)?;
        let mut lm = vec![0.0; inputs.len()];
        let stats = fast_simulation::run(&ch, inputs, &fib, lm0, settings, &mut lm)
            .map_err(integration_error(unit.name))?;
        let f0 = unit.f0;
        let env = envelope_of(inputs, &unit)?;
        let activation = states.is_some().then(|| ch.activation(env, inputs));
        for (i, &lmi) in lm.iter().enumerate() {
            let lmt = ch.lmt[i];
            let ft = fib.tendon_force(lmt, lmi);
            // the same operations as `fast::unit_torque` followed by the F0 scaling
            torque[i] = f0 * (ft * ch.r[i]);
            if let (Some(st), Some((a, z, m))) = (states.as_deref_mut(), activation) {
                st[i] = fast_simulation::state(a[i * m], z[i * m], lmi, lmt, ft);
            }
        }
        *current = Some(ch);
        return Ok(stats);
    }
    let env = envelope_of(inputs, &unit)?;
    let path = MusclePath::new(&unit, inputs)?;
    let y0 = unit.equilibrium_state_lmt(
        inputs.envelope_value_at(env, t[0] - delay),
        path.lmt_sample(inputs, 0),
    );
    let reduced = settings.formulation == Formulation::Reduced;
    let mut sys = UnitSystem {
        unit: &unit,
        inputs,
        env,
        path,
        delay,
        reduced,
    };
    let stats = ode::dopri5_dense(&mut sys, y0, t, &settings.adaptive(inputs), |i, y| {
        let r = path.moment_arm_sample(inputs, i);
        if reduced {
            let mut yp = *y;
            unit.project_lmt(path.lmt_sample(inputs, i), &mut yp);
            torque[i] = yp[IX_FT] * unit.f0 * r;
            if let Some(st) = states.as_deref_mut() {
                st[i] = yp;
            }
        } else {
            torque[i] = y[IX_FT] * unit.f0 * r;
            if let Some(st) = states.as_deref_mut() {
                st[i] = *y;
            }
        }
    })
    .map_err(integration_error(unit.name))?;
    Ok(stats.into())
}
