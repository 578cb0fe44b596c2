//! Simulation of a trial: each muscle's ODE integrated with Dormand–Prince 5(4), torque at every
//! sample (dissertation eq. 7) plus the SPEC §6 joint-level effects.

use crate::effects::Effects;
use crate::error::ModelError;
use crate::fast::Channel;
use crate::inputs::TrialInputs;
use crate::params::{ModelParams, Muscle};
use crate::unit::{MuscleUnit, IX_FT, IX_LM, STATE_DIM};
use ode::{AdaptiveSettings, OdeSystem};
use serde::{Deserialize, Serialize};
use std::sync::Arc;

/// Integration settings of a simulation.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct SimSettings {
    /// Relative tolerance of the Dormand–Prince error control.
    pub rtol: f64,
    /// Absolute tolerance (state units: activation, normalised force, metres).
    pub atol: f64,
    /// Largest step (s).
    pub h_max: f64,
    /// Step limit per muscle.
    pub max_steps: usize,
    /// Keep the per-sample states in [`SimOutput::states`].
    pub record_states: bool,
    /// Which (mathematically equivalent) form of the ODE is integrated.
    pub formulation: Formulation,
}

/// How the SPEC §3 system is integrated. Both have the same exact solution; they differ in
/// how integration error behaves.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Formulation {
    /// The four states `[a, F̃T, LM, LMT]` integrated as written in SPEC §3, driven by
    /// `vMT = r(q)·q̇`. Integration error makes `LMT` drift from `LMT(q)` and `F̃T` from
    /// `fT(ε)`, and a step that misses a fast feature of `q̇` (quantised or noisy angle data)
    /// leaves a lasting error.
    FourState,
    /// Only `a` and `LM` are integrated; `LMT = LMT(q(t))` and `F̃T = fT(ε(LMT, LM))` are
    /// evaluated from the invariants, so they hold exactly and `q̇` is not needed. Robust to
    /// quantised or noisy angles. [`SimSettings::tight`] uses it.
    Reduced,
    /// The reduced system with its inputs precomputed once per trial (default): activation
    /// `a`, `â`, the fatigue factor and `LMT(q)` at every sample (activation integrated once
    /// with RK4, 4 substeps per sample interval; cubic Hermite between samples), so each
    /// muscle integrates only its fibre length `LM`. Same exact solution as
    /// [`Formulation::Reduced`]; the error control acts on `LM` alone. The per-trial part is
    /// kept with the [`TrialInputs`] (shared by their clones and by every thread and
    /// [`Workspace`]) and reused while the trial, the activation parameters, the delay and
    /// the fatigue rate stay the same.
    #[default]
    Fast,
}

impl Default for SimSettings {
    /// `rtol = 1e-6`, `atol = 1e-8`, `h_max = 30 ms`, [`Formulation::Fast`]: about 1e-3 N·m
    /// RMS from [`SimSettings::tight`] on the seed fixture (`docs/benchmarks.md`).
    fn default() -> Self {
        SimSettings {
            rtol: 1e-6,
            atol: 1e-8,
            h_max: 0.03,
            max_steps: 1_000_000,
            record_states: false,
            formulation: Formulation::Fast,
        }
    }
}

impl SimSettings {
    /// Tight settings for reference runs (`rtol = 1e-10`, `atol = 1e-12`,
    /// [`Formulation::Reduced`], `h_max = 10 ms`).
    pub fn tight() -> Self {
        SimSettings {
            rtol: 1e-10,
            atol: 1e-12,
            h_max: 0.01,
            max_steps: 1_000_000,
            record_states: false,
            formulation: Formulation::Reduced,
        }
    }

    /// The same settings with states recorded.
    #[must_use]
    pub fn with_states(mut self) -> Self {
        self.record_states = true;
        self
    }

    pub(crate) fn adaptive(&self) -> AdaptiveSettings {
        AdaptiveSettings {
            rtol: self.rtol,
            atol: self.atol,
            h_max: self.h_max,
            max_steps: self.max_steps,
            ..AdaptiveSettings::default()
        }
    }
}

/// Integrator work of one muscle.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct SimStats {
    /// Accepted steps.
    pub accepted: usize,
    /// Rejected steps.
    pub rejected: usize,
    /// Right-hand-side evaluations.
    pub rhs_calls: usize,
}

impl From<ode::Stats> for SimStats {
    fn from(s: ode::Stats) -> Self {
        SimStats {
            accepted: s.accepted,
            rejected: s.rejected,
            rhs_calls: s.rhs_calls,
        }
    }
}

/// Result of a simulation, one value per input sample.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct SimOutput {
    /// Sample times (s).
    pub time: Vec<f64>,
    /// Total joint torque including effects (N·m, plantarflexion > 0).
    pub torque: Vec<f64>,
    /// Torque of each muscle `F̃T·F0·r(q)` (N·m), indexed by [`Muscle::index`].
    pub torque_muscle: [Vec<f64>; 3],
    /// Sum of the joint-level effect torques (offset, passive, gravity, damping, inertia,
    /// antagonist) (N·m).
    pub torque_effects: Vec<f64>,
    /// Per muscle, per sample state `[a, F̃T, LM, LMT, ∫â]` (with
    /// [`SimSettings::record_states`]).
    pub states: Option<[Vec<[f64; STATE_DIM]>; 3]>,
    /// TA activation `a_TA` at the samples when `antagonist_coactivation` is active.
    pub activation_ta: Option<Vec<f64>>,
    /// Integrator statistics per muscle.
    pub stats: [SimStats; 3],
}

impl SimOutput {
    /// Total integrator statistics.
    pub fn total_stats(&self) -> SimStats {
        let mut t = SimStats::default();
        for s in &self.stats {
            t.accepted += s.accepted;
            t.rejected += s.rejected;
            t.rhs_calls += s.rhs_calls;
        }
        t
    }
}

/// Reusable scratch memory for [`simulate_into`] (one per thread).
#[derive(Clone, Debug, Default)]
pub struct Workspace {
    torque_muscle: [Vec<f64>; 3],
    ta: Vec<f64>,
    channels: [Option<Arc<Channel>>; 3],
    /// Fibre length of each muscle at the samples (scratch of the fast integrator).
    lm: [Vec<f64>; 3],
    slots: [[Slot; 2]; 3],
    newest: [usize; 3],
    /// `F0` of each muscle in the last fast call (the slot `newest` holds its unit torque).
    f0: [f64; 3],
    /// Joint-level effect torque and what it was computed from (effects without the
    /// antagonist term are cached; with it they are recomputed).
    effects_key: Option<(u64, usize, Effects)>,
    effects_torque: Vec<f64>,
    hits: u64,
    misses: u64,
}

/// What a cached per-muscle result was computed from (everything but `F0`).
#[derive(Clone, Copy, Debug, PartialEq)]
struct SlotKey {
    uid: u64,
    n: usize,
    unit: MuscleUnit,
    delay: f64,
    rtol: f64,
    atol: f64,
    h_max: f64,
    max_steps: usize,
}

/// One cached muscle: `F̃T·r` at the samples (torque per newton of `F0`).
#[derive(Clone, Debug, Default)]
struct Slot {
    key: Option<SlotKey>,
    unit_torque: Vec<f64>,
    stats: SimStats,
}

impl Workspace {
    /// An empty workspace (grows on first use).
    pub fn new() -> Self {
        Workspace::default()
    }

    /// Per-muscle torques of the last [`simulate_into`] call.
    pub fn torque_muscle(&self) -> &[Vec<f64>; 3] {
        &self.torque_muscle
    }

    /// `(reused, integrated)`: how many per-muscle results [`simulate_into`] took from this
    /// workspace's cache and how many it integrated, since the workspace was made.
    ///
    /// With [`Formulation::Fast`] each muscle's result (its torque per newton of `F0`) is kept
    /// for the two most recent parameter sets of that muscle; a call whose muscle constants
    /// (all but `F0`), trial, delay and tolerances match a kept one reuses it, bit for bit
    /// (the muscles are independent given the inputs). An annealing move that changes one
    /// muscle therefore integrates one muscle, and a move of `F0` alone integrates none.
    pub fn cache_counts(&self) -> (u64, u64) {
        (self.hits, self.misses)
    }
}

/// What the fast integration of `unit` needs: its channel (`current` when it matches), its
/// fibre constants and the equilibrium fibre length at the first sample.
fn fast_prepare(
    current: Option<&Arc<Channel>>,
    inputs: &TrialInputs,
    unit: &MuscleUnit,
    delay: f64,
) -> (Arc<Channel>, crate::fast::Fibre, f64) {
    let y0 = unit.equilibrium_state(
        inputs.envelope_at(unit.muscle.index(), inputs.times()[0] - delay),
        inputs.angle()[0],
    );
    let ch = crate::fast::channel_for(current, inputs, unit, delay);
    (ch, crate::fast::Fibre::new(unit), y0[IX_LM])
}

/// The integration error of muscle `muscle`.
fn integration_error(muscle: Muscle) -> impl FnOnce(ode::OdeError) -> ModelError {
    move |source| ModelError::Integration {
        muscle: muscle.name(),
        source,
    }
}

/// Unit-`F0` torque `F̃T·r(q)` of `unit` at every sample into `out` ([`Formulation::Fast`]).
#[allow(clippy::too_many_arguments)]
fn fast_unit_torque(
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
    let stats = crate::fast::run(&ch, inputs, &fib, lm0, settings, lm)
        .map_err(integration_error(unit.muscle))?;
    crate::fast::unit_torque(&fib, &ch, lm, out);
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

fn delay_s(effects: &Effects) -> f64 {
    effects
        .electromechanical_delay
        .map_or(0.0, |d| d.delay_ms * 1e-3)
}

/// Integrates muscle `m` and writes its torque at every sample into `torque` and, when given,
/// every sample's state into `states`.
#[allow(clippy::too_many_arguments)]
fn run_muscle(
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
        let stats = crate::fast::run(&ch, inputs, &fib, lm0, settings, &mut lm)
            .map_err(integration_error(m))?;
        let f0 = unit.f0;
        let activation = states.is_some().then(|| ch.activation(inputs));
        for (i, &lmi) in lm.iter().enumerate() {
            let lmt = ch.lmt[i];
            let ft = fib.tendon_force(lmt, lmi);
            // the same operations as `fast::unit_torque` followed by the F0 scaling
            torque[i] = f0 * (ft * ch.r[i]);
            if let (Some(st), Some((a, z))) = (states.as_deref_mut(), activation) {
                st[i] = crate::fast::state(a[i], z[i], lmi, lmt, ft);
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

fn run_ta(
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
    let act = crate::activation::Activation::new(&params.activation);
    let mut sys = TaSystem {
        inputs,
        k1: act.k1,
        k2: act.k2,
        delay,
    };
    ode::dopri5_dense(&mut sys, [u0], t, &settings.adaptive(), |i, y| {
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
fn add_joint_effects(inputs: &TrialInputs, effects: &Effects, ta: &[f64], torque: &mut [f64]) {
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

fn needs_ta(effects: &Effects) -> bool {
    effects
        .antagonist_coactivation
        .is_some_and(|e| e.gain_nm != 0.0)
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
    let mut torque_muscle: [Vec<f64>; 3] = [vec![0.0; n], vec![0.0; n], vec![0.0; n]];
    let mut states: Option<[Vec<[f64; STATE_DIM]>; 3]> = settings
        .record_states
        .then(|| std::array::from_fn(|_| vec![[0.0; STATE_DIM]; n]));
    let mut stats = [SimStats::default(); 3];
    let mut channels: [Option<Arc<Channel>>; 3] = Default::default();
    for m in Muscle::ALL {
        let j = m.index();
        stats[j] = run_muscle(
            &mut channels[j],
            inputs,
            params,
            effects,
            settings,
            m,
            &mut torque_muscle[j],
            states.as_mut().map(|s| &mut s[j][..]),
        )?;
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
    let torque: Vec<f64> = (0..n)
        .map(|i| {
            torque_effects[i] + torque_muscle[0][i] + torque_muscle[1][i] + torque_muscle[2][i]
        })
        .collect();
    if let Some(i) = torque.iter().position(|x| !x.is_finite()) {
        return Err(ModelError::NonFinite {
            what: "torque",
            index: i,
        });
    }
    Ok(SimOutput {
        time: inputs.times().to_vec(),
        torque,
        torque_muscle,
        torque_effects,
        states,
        activation_ta,
        stats,
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
        for j in 0..3 {
            let f0 = ws.f0[j];
            let g = &ws.slots[j][ws.newest[j]].unit_torque;
            let buf = &mut ws.torque_muscle[j];
            buf.resize(n, 0.0);
            for (b, g) in buf.iter_mut().zip(g) {
                *b = f0 * g;
            }
        }
    }
    let ta_active = needs_ta(effects);
    if ta_active {
        ws.ta.resize(n, 0.0);
        run_ta(inputs, params, effects, settings, &mut ws.ta)?;
    }
    torque.fill(0.0);
    add_joint_effects(
        inputs,
        effects,
        if ta_active { &ws.ta } else { &[] },
        torque,
    );
    let [t0, t1, t2] = &ws.torque_muscle;
    for (i, t) in torque.iter_mut().enumerate() {
        *t += t0[i] + t1[i] + t2[i];
        if !t.is_finite() {
            return Err(ModelError::NonFinite {
                what: "torque",
                index: i,
            });
        }
    }
    Ok(total)
}

/// Brings the per-muscle results of `ws` up to date: with [`Formulation::Fast`] the cache slots
/// (`ws.newest`, `ws.f0`), otherwise `ws.torque_muscle`. Returns the summed statistics.
fn update_muscles(
    ws: &mut Workspace,
    inputs: &TrialInputs,
    params: &ModelParams,
    effects: &Effects,
    settings: &SimSettings,
) -> Result<SimStats, ModelError> {
    let n = inputs.len();
    let mut total = SimStats::default();
    let delay = delay_s(effects);
    if settings.formulation == Formulation::Fast {
        update_fast(ws, inputs, params, effects, settings, delay)?;
        for j in 0..3 {
            let s = ws.slots[j][ws.newest[j]].stats;
            total.accepted += s.accepted;
            total.rejected += s.rejected;
            total.rhs_calls += s.rhs_calls;
        }
        return Ok(total);
    }
    for m in Muscle::ALL {
        let j = m.index();
        let buf = &mut ws.torque_muscle[j];
        buf.resize(n, 0.0);
        let s = run_muscle(
            &mut ws.channels[j],
            inputs,
            params,
            effects,
            settings,
            m,
            buf,
            None,
        )?;
        total.accepted += s.accepted;
        total.rejected += s.rejected;
        total.rhs_calls += s.rhs_calls;
    }
    Ok(total)
}

/// [`update_muscles`] with [`Formulation::Fast`]: muscles whose slot matches are reused; the
/// others are integrated, together when there are several ([`crate::fast::run_lanes`], the
/// same bits as one by one).
fn update_fast(
    ws: &mut Workspace,
    inputs: &TrialInputs,
    params: &ModelParams,
    effects: &Effects,
    settings: &SimSettings,
    delay: f64,
) -> Result<(), ModelError> {
    let n = inputs.len();
    let mut todo: [Option<(MuscleUnit, SlotKey)>; 3] = [None; 3];
    for m in Muscle::ALL {
        let j = m.index();
        let unit = MuscleUnit::new(params, m, effects);
        let key = SlotKey {
            uid: inputs.uid(),
            n,
            unit: MuscleUnit { f0: 1.0, ..unit },
            delay,
            rtol: settings.rtol,
            atol: settings.atol,
            h_max: settings.h_max,
            max_steps: settings.max_steps,
        };
        ws.f0[j] = unit.f0;
        match ws.slots[j].iter().position(|sl| sl.key == Some(key)) {
            Some(k) => {
                ws.hits += 1;
                ws.newest[j] = k;
            }
            None => {
                ws.misses += 1;
                todo[j] = Some((unit, key));
            }
        }
    }
    let count = todo.iter().flatten().count();
    if count == 0 {
        return Ok(());
    }
    // the slot each integrated muscle writes (the one not holding the newest result)
    for (j, t) in todo.iter().enumerate() {
        if t.is_some() {
            let k = 1 - ws.newest[j];
            ws.slots[j][k].key = None;
            ws.slots[j][k].unit_torque.resize(n, 0.0);
            ws.newest[j] = k;
        }
    }
    if count == 1 {
        let j = todo.iter().position(Option::is_some).unwrap_or(0);
        if let Some((unit, key)) = todo[j] {
            let sl = &mut ws.slots[j][ws.newest[j]];
            sl.stats = fast_unit_torque(
                &mut ws.channels[j],
                &mut ws.lm[j],
                inputs,
                &unit,
                delay,
                settings,
                &mut sl.unit_torque,
            )?;
            sl.key = Some(key);
        }
        return Ok(());
    }
    let mut prepared: [Option<(Arc<Channel>, crate::fast::Fibre, f64)>; 3] = [None, None, None];
    for j in 0..3 {
        if let Some((unit, _)) = &todo[j] {
            prepared[j] = Some(fast_prepare(ws.channels[j].as_ref(), inputs, unit, delay));
        }
    }
    for lm in &mut ws.lm {
        lm.resize(n, 0.0);
    }
    let [lm0, lm1, lm2] = &mut ws.lm;
    let mut bufs = [Some(&mut lm0[..]), Some(&mut lm1[..]), Some(&mut lm2[..])];
    let lanes: [_; 3] = std::array::from_fn(|j| {
        let buf = bufs[j].take();
        prepared[j]
            .as_ref()
            .zip(buf)
            .map(|((ch, fib, lm0), buf)| (&**ch, fib, *lm0, buf))
    });
    let stats = crate::fast::run_lanes(lanes, inputs, settings)
        .map_err(|(j, e)| integration_error(Muscle::ALL[j])(e))?;
    for j in 0..3 {
        if let (Some((ch, fib, _)), Some((_, key))) = (prepared[j].take(), todo[j]) {
            let sl = &mut ws.slots[j][ws.newest[j]];
            crate::fast::unit_torque(&fib, &ch, &ws.lm[j], &mut sl.unit_torque);
            sl.stats = stats[j];
            sl.key = Some(key);
            ws.channels[j] = Some(ch);
        }
    }
    Ok(())
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
    let ta_active = needs_ta(effects);
    let ekey = (inputs.uid(), n, *effects);
    if ta_active || ws.effects_key != Some(ekey) {
        ws.effects_key = None;
        if ta_active {
            ws.ta.resize(n, 0.0);
            run_ta(inputs, params, effects, settings, &mut ws.ta)?;
        }
        ws.effects_torque.clear();
        ws.effects_torque.resize(n, 0.0);
        add_joint_effects(
            inputs,
            effects,
            if ta_active { &ws.ta } else { &[] },
            &mut ws.effects_torque,
        );
        if !ta_active {
            ws.effects_key = Some(ekey);
        }
    }
    let [f0, f1, f2] = ws.f0;
    let g0 = &ws.slots[0][ws.newest[0]].unit_torque[..n];
    let g1 = &ws.slots[1][ws.newest[1]].unit_torque[..n];
    let g2 = &ws.slots[2][ws.newest[2]].unit_torque[..n];
    let e = &ws.effects_torque[..n];
    // the operations of `simulate_into`: effects, then `+= F0₀g₀ + F0₁g₁ + F0₂g₂`
    for i in 0..n {
        out[i] = e[i] + (f0 * g0[i] + f1 * g1[i] + f2 * g2[i]);
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
