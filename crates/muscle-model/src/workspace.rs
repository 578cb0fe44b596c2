//! Reusable scratch memory of the hot-loop simulation ([`Workspace`]) and its cache of
//! per-muscle results.
//!
//! With [`Formulation::Fast`] the torque of muscle `j` is `F0_j·g_j(t)`, where the unit torque
//! `g_j = F̃T_j·r_j(q)` depends on every muscle constant but `F0`. Each muscle keeps `g_j` for
//! its two latest parameter sets (two slots, the newer one marked), so a move of one muscle's
//! parameters integrates one muscle and a move of `F0` alone integrates none; the muscles are
//! independent given the inputs, so a reused result is the same bits as a new one.
//!
//! The fixed muscles of a model (`ModelParams::fixed`) are not identified: with any
//! formulation each one's torque, and their sum, is kept for the trial, parameters, effects
//! and settings it was computed with, so that an identification's evaluations integrate them
//! once (again only when the activation, curves, delay or another of their inputs moves).

use crate::effects::Effects;
use crate::error::ModelError;
use crate::fast_simulation::{self, Channel, Fibre};
use crate::inputs::TrialInputs;
use crate::joint_effects::{add_joint_effects, delay_s, needs_ta, run_ta};
use crate::muscle_torque::{
    fast_prepare, fast_unit_torque, integration_error, run_muscle, sum_torques, MuscleOutput,
};
use crate::musculotendon::MuscleUnit;
use crate::params::{ModelParams, Muscle};
use crate::settings::{Formulation, SimSettings};
use crate::stats::SimStats;
use std::sync::Arc;

/// Reusable scratch memory for [`crate::simulate_into`] (one per thread).
#[derive(Clone, Debug, Default)]
pub struct Workspace {
    /// sol, gm, gl, then the fixed muscles (torques and statistics; no states).
    torque_muscle: Vec<MuscleOutput>,
    /// The fixed muscles' kept torques.
    fixed: Vec<FixedSlot>,
    /// `Σ` of the fixed muscles' torques, valid for `fixed_sum_len` muscles (`None`: stale).
    fixed_sum: Vec<f64>,
    fixed_sum_len: Option<usize>,
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

/// What a fixed muscle's kept torque was computed from.
#[derive(Clone, Copy, Debug, PartialEq)]
struct FixedKey {
    uid: u64,
    n: usize,
    unit: MuscleUnit,
    delay: f64,
    settings: SimSettings,
}

/// One fixed muscle's kept torque `F̃T·F0·r` at the samples.
#[derive(Clone, Debug, Default)]
struct FixedSlot {
    key: Option<FixedKey>,
    torque: Vec<f64>,
    stats: SimStats,
    channel: Option<Arc<Channel>>,
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

    /// Per-muscle torques and statistics of the last [`crate::simulate_into`] call: sol, gm,
    /// gl (at [`Muscle::index`]), then the fixed muscles in order (empty before the first
    /// call).
    pub fn torque_muscle(&self) -> &[MuscleOutput] {
        &self.torque_muscle
    }

    /// The per-muscle outputs sized and named for `params` (sol, gm, gl, then the fixed
    /// muscles).
    fn name_outputs(&mut self, params: &ModelParams) {
        let names = Muscle::ALL
            .iter()
            .map(|m| m.name())
            .chain(params.fixed.iter().map(|f| f.name));
        let mut k = 0;
        for name in names {
            if k == self.torque_muscle.len() {
                self.torque_muscle.push(MuscleOutput {
                    name,
                    torque: Vec::new(),
                    states: None,
                    stats: SimStats::default(),
                });
            }
            self.torque_muscle[k].name = name;
            k += 1;
        }
        self.torque_muscle.truncate(k);
    }

    /// The fixed muscles' summed torque at the samples (`n`), `None` when the model has none.
    pub(crate) fn fixed_torque(&self, n: usize) -> Option<&[f64]> {
        match self.fixed_sum_len {
            Some(k) if k > 0 => Some(&self.fixed_sum[..n]),
            _ => None,
        }
    }

    /// Copies the fixed muscles' kept torques and statistics into [`Workspace::torque_muscle`].
    pub(crate) fn copy_fixed_outputs(&mut self) {
        for (k, slot) in self.fixed.iter().enumerate() {
            let out = &mut self.torque_muscle[3 + k];
            out.torque.clone_from(&slot.torque);
            out.stats = slot.stats;
        }
    }

    /// `(reused, integrated)`: how many per-muscle results [`crate::simulate_into`] took from this
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

    /// With [`Formulation::Fast`], the per-muscle torques `F0·g` of the newest slots into
    /// [`Workspace::torque_muscle`] (`n` samples).
    pub(crate) fn scale_unit_torques(&mut self, n: usize) {
        for j in 0..3 {
            let f0 = self.f0[j];
            let g = &self.slots[j][self.newest[j]].unit_torque;
            self.torque_muscle[j].stats = self.slots[j][self.newest[j]].stats;
            let buf = &mut self.torque_muscle[j].torque;
            buf.resize(n, 0.0);
            for (b, g) in buf.iter_mut().zip(g) {
                *b = f0 * g;
            }
        }
    }

    /// The TA activation at the samples when the antagonist term is active (integrated into
    /// this workspace's buffer), else an empty slice.
    pub(crate) fn ta_activation(
        &mut self,
        inputs: &TrialInputs,
        params: &ModelParams,
        effects: &Effects,
        settings: &SimSettings,
    ) -> Result<&[f64], ModelError> {
        if !needs_ta(effects) {
            return Ok(&[]);
        }
        self.ta.resize(inputs.len(), 0.0);
        run_ta(inputs, params, effects, settings, &mut self.ta)?;
        Ok(&self.ta)
    }

    /// Brings the kept joint-level effect torque up to date for `effects` on `inputs`: kept
    /// while the trial and the effects stay the same, recomputed every time with the
    /// antagonist term (it depends on the activation parameters too).
    pub(crate) fn update_effects_torque(
        &mut self,
        inputs: &TrialInputs,
        params: &ModelParams,
        effects: &Effects,
        settings: &SimSettings,
    ) -> Result<(), ModelError> {
        let n = inputs.len();
        let ta_active = needs_ta(effects);
        let ekey = (inputs.uid(), n, *effects);
        if ta_active || self.effects_key != Some(ekey) {
            self.effects_key = None;
            if ta_active {
                self.ta.resize(n, 0.0);
                run_ta(inputs, params, effects, settings, &mut self.ta)?;
            }
            self.effects_torque.clear();
            self.effects_torque.resize(n, 0.0);
            add_joint_effects(
                inputs,
                effects,
                if ta_active { &self.ta } else { &[] },
                &mut self.effects_torque,
            );
            if !ta_active {
                self.effects_key = Some(ekey);
            }
        }
        Ok(())
    }

    /// With [`Formulation::Fast`], after [`update_muscles`] and
    /// [`Workspace::update_effects_torque`]: each muscle's `F0`, its newest unit torque and
    /// the effect torque, `n` samples each.
    pub(crate) fn fast_terms(&self, n: usize) -> ([f64; 3], [&[f64]; 3], &[f64]) {
        let g = |j: usize| &self.slots[j][self.newest[j]].unit_torque[..n];
        (self.f0, [g(0), g(1), g(2)], &self.effects_torque[..n])
    }
}

/// Brings the per-muscle results of `ws` up to date: with [`Formulation::Fast`] the cache slots
/// (`ws.newest`, `ws.f0`), otherwise `ws.torque_muscle`. Returns the summed statistics.
pub(crate) fn update_muscles(
    ws: &mut Workspace,
    inputs: &TrialInputs,
    params: &ModelParams,
    effects: &Effects,
    settings: &SimSettings,
) -> Result<SimStats, ModelError> {
    let n = inputs.len();
    let mut total = SimStats::default();
    let delay = delay_s(effects);
    ws.name_outputs(params);
    if settings.formulation == Formulation::Fast {
        update_fast(ws, inputs, params, effects, settings, delay)?;
        for j in 0..3 {
            total.add(ws.slots[j][ws.newest[j]].stats);
        }
    } else {
        for m in Muscle::ALL {
            let j = m.index();
            let out = &mut ws.torque_muscle[j];
            out.torque.resize(n, 0.0);
            let unit = MuscleUnit::new(params, m, effects);
            let s = run_muscle(
                &mut ws.channels[j],
                inputs,
                &unit,
                effects,
                settings,
                &mut out.torque,
                None,
            )?;
            out.stats = s;
            total.add(s);
        }
    }
    total.add(update_fixed(ws, inputs, params, effects, settings, delay)?);
    Ok(total)
}

/// Brings the fixed muscles' kept torques and their sum up to date (each integrated only when
/// what it depends on changed). Returns their summed statistics.
fn update_fixed(
    ws: &mut Workspace,
    inputs: &TrialInputs,
    params: &ModelParams,
    effects: &Effects,
    settings: &SimSettings,
    delay: f64,
) -> Result<SimStats, ModelError> {
    let n = inputs.len();
    let count = params.fixed.len();
    let mut total = SimStats::default();
    let mut changed = ws.fixed_sum_len != Some(count);
    ws.fixed.resize_with(count, FixedSlot::default);
    // the settings that change the result (recording states does not)
    let settings_key = SimSettings {
        record_states: false,
        ..*settings
    };
    for (slot, f) in ws.fixed.iter_mut().zip(params.fixed.iter()) {
        let unit = MuscleUnit::of(f.name, &f.params, params, effects);
        let key = FixedKey {
            uid: inputs.uid(),
            n,
            unit,
            delay,
            settings: settings_key,
        };
        if slot.key == Some(key) {
            ws.hits += 1;
        } else {
            ws.misses += 1;
            changed = true;
            slot.key = None;
            slot.torque.resize(n, 0.0);
            slot.stats = run_muscle(
                &mut slot.channel,
                inputs,
                &unit,
                effects,
                settings,
                &mut slot.torque,
                None,
            )?;
            slot.key = Some(key);
        }
        total.add(slot.stats);
    }
    if changed {
        ws.fixed_sum_len = None;
        sum_torques(ws.fixed.iter().map(|s| &s.torque[..]), n, &mut ws.fixed_sum);
        ws.fixed_sum_len = Some(count);
    }
    Ok(total)
}

/// [`update_muscles`] with [`Formulation::Fast`]: muscles whose slot matches are reused; the
/// others are integrated, together when there are several ([`fast_simulation::run_lanes`], the
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
    let mut prepared: [Option<(Arc<Channel>, Fibre, f64)>; 3] = [None, None, None];
    for j in 0..3 {
        if let Some((unit, _)) = &todo[j] {
            prepared[j] = Some(fast_prepare(ws.channels[j].as_ref(), inputs, unit, delay)?);
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
    let stats = fast_simulation::run_lanes(lanes, inputs, settings)
        .map_err(|(j, e)| integration_error(Muscle::ALL[j].name())(e))?;
    for j in 0..3 {
        if let (Some((ch, fib, _)), Some((_, key))) = (prepared[j].take(), todo[j]) {
            let sl = &mut ws.slots[j][ws.newest[j]];
            fast_simulation::unit_torque(&fib, &ch, &ws.lm[j], &mut sl.unit_torque);
            sl.stats = stats[j];
            sl.key = Some(key);
            ws.channels[j] = Some(ch);
        }
    }
    Ok(())
}
