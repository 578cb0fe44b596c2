//! The fast forward model ([`crate::Formulation::Fast`]): activation and musculotendon length
//! precomputed once per trial, then each fibre length integrated alone ([`ode::DoPri5`] with
//! dense output at the samples; the activation's error estimate joins the step-size control).
//!
//! Activation `a(t)`, `â = f_A(a)`, the fatigue factor `exp(−k∫â)` and `LMT(q(t))` do not
//! depend on the identified parameters (LST, F0, α0), so a [`Channel`] holds them at every
//! sample (value and time derivative) and the integrator reads them by cubic Hermite
//! interpolation. The activation is integrated once with classical RK4, [`ACT_SUBSTEPS`]
//! substeps per sample interval (the envelope is linear inside an interval). The only state
//! left per muscle is the fibre length `LM`; `F̃T = fT(ε(LMT, LM))` at the samples.
//!
//! A delay `d` only shifts the activation in time: the input `u(t) = env(t − d)` is held at
//! `env(t₀)` before `t₀ + d`, where the activation rests at equilibrium, so
//! `a_d(t) = a₀(t − d)` (and `a₀(t₀)` before `t₀ + d`) and
//! `∫₀ᵗ â_d = â(a₀(t₀))·d + ∫₀^{t−d} â₀` after it. A delayed table is therefore the undelayed
//! one read at `tᵢ − d` by cubic Hermite interpolation from its values and rates at the
//! samples (the envelope's kinks at the samples make the error O(Δt²): 1.2·10⁻⁸ of the
//! activation against an RK4 of the delayed input at 2048 Hz), with `ȧ` from the
//! activation equation at the delayed input: a delay fit costs one read per sample instead of
//! an RK4 integration of the three muscles.
//!
//! Two levels are kept per trial: an [`ActTable`] (`a`, `ȧ` and, when asked for, `∫â`)
//! depends on the activation parameters and the delay only, so fits that move the fatigue
//! rate reuse it and only rebuild the per-sample drive; the three muscles' tables are
//! integrated together (a new delay needs all three). When several muscles need integrating
//! (a delay, fatigue or activation change, or a move of every muscle's parameters),
//! [`run_lanes`] advances their fibre integrations together with [`ode::attempt_lanes`].
//! Both interleave independent recurrences for the processor's sake only: every muscle's
//! numbers are the same bits as when it is computed alone.

use crate::activation::Activation;
use crate::curves::Curves;
use crate::inputs::TrialInputs;
use crate::simulate::{SimSettings, SimStats};
use crate::unit::{MuscleUnit, IX_A, IX_FATIGUE, IX_FT, IX_LM, IX_LMT, STATE_DIM};
use ode::{DoPri5, OdeError, OdeSystem};
use std::sync::{Arc, Mutex, OnceLock};

/// RK4 substeps per sample interval when the activation is precomputed.
pub const ACT_SUBSTEPS: usize = 4;

/// What an [`ActTable`] was computed from: everything the activation `a(t)` depends on.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct TableKey {
    uid: u64,
    n: usize,
    j: usize,
    k1: f64,
    k2: f64,
    shape: f64,
    delay: f64,
}

/// What a [`Channel`] was computed from: its activation table's key, the fatigue rate and the
/// musculotendon-length polynomial.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct ChannelKey {
    table: TableKey,
    fatigue: f64,
    poly: [f64; 4],
}

impl ChannelKey {
    /// The key of `unit`'s channel on `inputs` with electromechanical delay `delay` (s).
    pub(crate) fn new(inputs: &TrialInputs, unit: &MuscleUnit, delay: f64) -> Self {
        let act = unit.activation;
        ChannelKey {
            table: TableKey {
                uid: inputs.uid(),
                n: inputs.len(),
                j: unit.muscle.index(),
                k1: act.k1,
                k2: act.k2,
                shape: act.nonlinearity.shape,
                delay,
            },
            fatigue: unit.fatigue_rate,
            poly: unit.poly,
        }
    }
}

/// Activation tables and channels kept per [`TrialInputs`] (each; shared by its clones and by
/// every thread).
pub(crate) const SHARED_CHANNELS: usize = 12;

/// The activation of one muscle at the samples: `a`, `ȧ` and (on first use) `∫₀ᵗ â dt`.
///
/// It depends on the activation parameters and the delay but not on the fatigue rate or the
/// muscle's identified parameters, so the channels of every fatigue rate share one table (a
/// fatigue fit rebuilds only the cheap per-sample drive), and `∫â`, which only the fatigue
/// factor and the recorded state read, is integrated only when one of them asks for it.
#[derive(Debug)]
pub(crate) struct ActTable {
    key: TableKey,
    act: Activation,
    /// `a` at the samples.
    a: Vec<f64>,
    /// `ȧ = rate(u(tᵢ), aᵢ)` at the samples.
    adot: Vec<f64>,
    /// `∫₀ᵗ â dt` at the samples, computed on first use.
    z: OnceLock<Vec<f64>>,
    /// For a delayed table, the undelayed one it was shifted from.
    base: Option<Arc<ActTable>>,
}

impl ActTable {
    /// The tables of all three muscles with `key`'s activation and delay (a delay or an
    /// activation parameter changes all three at once): integrated without a delay, else the
    /// undelayed tables (kept apart per trial) shifted by the delay.
    fn build_all(key: TableKey, inputs: &TrialInputs, act: Activation) -> [ActTable; 3] {
        if key.delay > 0.0 {
            let base = Self::undelayed(key, inputs, act);
            return std::array::from_fn(|j| Self::shifted(&base[j], TableKey { j, ..key }, inputs));
        }
        let keys: [TableKey; 3] = std::array::from_fn(|j| TableKey { j, ..key });
        let mut j = 0;
        integrate_activation(&keys, inputs, act).map(|(a, adot)| {
            j += 1;
            ActTable {
                key: keys[j - 1],
                act,
                a,
                adot,
                z: OnceLock::new(),
                base: None,
            }
        })
    }

    /// The three undelayed tables with `key`'s activation, from the trial's own list or
    /// integrated (and kept there).
    fn undelayed(key: TableKey, inputs: &TrialInputs, act: Activation) -> [Arc<ActTable>; 3] {
        let list = &inputs.channel_cache().undelayed;
        let keys: [TableKey; 3] = std::array::from_fn(|j| TableKey {
            j,
            delay: 0.0,
            ..key
        });
        let found: Vec<Arc<ActTable>> = keys
            .iter()
            .filter_map(|k| find(list, k, |t| &t.key))
            .collect();
        if let Ok(all) = <[Arc<ActTable>; 3]>::try_from(found) {
            return all;
        }
        Self::build_all(keys[0], inputs, act).map(|t| keep(list, Arc::new(t), |t| &t.key))
    }

    /// `base` (undelayed) delayed by `key.delay > 0`: `a(tᵢ) = a₀(tᵢ − d)` by cubic Hermite
    /// interpolation of `a₀` and `ȧ₀` (`a₀(t₀)` before `t₀ + d`), `ȧ(tᵢ)` from the activation
    /// equation at `u(tᵢ − d)`.
    fn shifted(base: &Arc<ActTable>, key: TableKey, inputs: &TrialInputs) -> ActTable {
        let act = base.act;
        let (a0, adot0) = (&base.a, &base.adot);
        let mut a = Vec::with_capacity(key.n);
        let mut adot = Vec::with_capacity(key.n);
        for &ti in inputs.times() {
            // `a₀(t₀)` at and before the first sample: the rest before `t₀ + d`
            let ai = inputs.hermite_at(a0, adot0, ti - key.delay);
            a.push(ai);
            let u = inputs.envelope_at(key.j, ti - key.delay);
            adot.push(act.rate(u.clamp(0.0, 1.0), ai));
        }
        ActTable {
            key,
            act,
            a,
            adot,
            z: OnceLock::new(),
            base: Some(Arc::clone(base)),
        }
    }

    /// `∫₀ᵗ â dt` at the samples, on the first call: integrated together with `a` (with the
    /// same arithmetic for `a`), or for a delayed table `â(a₀(t₀))·min(t − t₀, d)` plus the
    /// undelayed integral at `t − d` (cubic Hermite, slopes `â₀`).
    fn z(&self, inputs: &TrialInputs) -> &[f64] {
        self.z.get_or_init(|| {
            let mut z = Vec::with_capacity(self.key.n);
            match &self.base {
                None => {
                    integrate_activation_and_integral(&self.key, inputs, self.act, |zi| z.push(zi));
                }
                Some(b) => {
                    let (z0, nl, d) = (b.z(inputs), self.act.nonlinearity, self.key.delay);
                    let ah0: Vec<f64> = b.a.iter().map(|&a| nl.apply(a)).collect();
                    let rest = ah0[0];
                    let t0 = inputs.t0();
                    for &ti in inputs.times() {
                        let s = ti - d;
                        let zi = if s > t0 {
                            rest * d + inputs.hermite_at(z0, &ah0, s)
                        } else {
                            rest * (ti - t0)
                        };
                        z.push(zi);
                    }
                }
            }
            z
        })
    }
}

/// Classical RK4 on `ȧ = rate(u_l(t − d), a)` for the muscles `keys[l].j` together (their
/// independent recurrences interleaved, which keeps the processor busy: each alone is one
/// long dependency chain), [`ACT_SUBSTEPS`] substeps per sample interval (`u` clamped to
/// [0, 1]). Returns `a` and `ȧ` at the samples per muscle; each muscle's numbers are the same
/// whatever it is integrated with.
///
/// `u` is read once per distinct time: the two midpoint stages share one, and a substep's
/// last stage time is the next substep's first (the same `tt + hs` rounding).
fn integrate_activation<const L: usize>(
    keys: &[TableKey; L],
    inputs: &TrialInputs,
    act: Activation,
) -> [(Vec<f64>, Vec<f64>); L] {
    let n = inputs.len();
    let t = inputs.times();
    let hs = 1.0 / inputs.fs() / ACT_SUBSTEPS as f64;
    let u_at = |l: usize, tt: f64| {
        inputs
            .envelope_at(keys[l].j, tt - keys[l].delay)
            .clamp(0.0, 1.0)
    };
    let mut out: [(Vec<f64>, Vec<f64>); L] =
        std::array::from_fn(|_| (Vec::with_capacity(n), Vec::with_capacity(n)));
    let mut y: [f64; L] = std::array::from_fn(|l| u_at(l, t[0]));
    for (i, &ti) in t.iter().enumerate() {
        let mut u0: [f64; L] = std::array::from_fn(|l| u_at(l, ti));
        for l in 0..L {
            out[l].0.push(y[l]);
            out[l].1.push(act.rate(u0[l], y[l]));
        }
        if i + 1 < n {
            let mut tt = ti;
            for _ in 0..ACT_SUBSTEPS {
                let t1 = tt + hs;
                for l in 0..L {
                    let um = u_at(l, tt + 0.5 * hs);
                    let u1 = u_at(l, t1);
                    let yl = y[l];
                    let k1 = act.rate(u0[l], yl);
                    let k2 = act.rate(um, yl + 0.5 * hs * k1);
                    let k3 = act.rate(um, yl + 0.5 * hs * k2);
                    let k4 = act.rate(u1, yl + hs * k3);
                    y[l] = yl + hs / 6.0 * (k1 + 2.0 * k2 + 2.0 * k3 + k4);
                    u0[l] = u1;
                }
                tt = t1;
            }
        }
    }
    out
}

/// The same RK4 as [`integrate_activation`] on `[a, ∫â]` (the `a` component is computed
/// identically: it does not read `∫â`); calls `out(∫â)` at every sample.
fn integrate_activation_and_integral(
    key: &TableKey,
    inputs: &TrialInputs,
    act: Activation,
    mut out: impl FnMut(f64),
) {
    let n = key.n;
    let (j, delay) = (key.j, key.delay);
    let t = inputs.times();
    let hs = 1.0 / inputs.fs() / ACT_SUBSTEPS as f64;
    let nl = act.nonlinearity;
    let u_at = |tt: f64| inputs.envelope_at(j, tt - delay).clamp(0.0, 1.0);
    let f = |tt: f64, y: [f64; 2]| -> [f64; 2] { [act.rate(u_at(tt), y[0]), nl.apply(y[0])] };
    let mut y = [u_at(t[0]), 0.0];
    for (i, &ti) in t.iter().enumerate() {
        out(y[1]);
        if i + 1 < n {
            let mut tt = ti;
            for _ in 0..ACT_SUBSTEPS {
                let k1 = f(tt, y);
                let k2 = f(
                    tt + 0.5 * hs,
                    [y[0] + 0.5 * hs * k1[0], y[1] + 0.5 * hs * k1[1]],
                );
                let k3 = f(
                    tt + 0.5 * hs,
                    [y[0] + 0.5 * hs * k2[0], y[1] + 0.5 * hs * k2[1]],
                );
                let k4 = f(tt + hs, [y[0] + hs * k3[0], y[1] + hs * k3[1]]);
                for c in 0..2 {
                    y[c] += hs / 6.0 * (k1[c] + 2.0 * k2[c] + 2.0 * k3[c] + k4[c]);
                }
                tt += hs;
            }
        }
    }
}

/// Per-trial, per-muscle inputs of the fibre ODE at the samples.
#[derive(Clone, Debug)]
pub(crate) struct Channel {
    pub(crate) key: ChannelKey,
    /// Per sample `[act, dt·d(act)/dt, LMT, dt·dLMT/dt]`, `act = â·exp(−k∫â)`.
    drive: Vec<[f64; 4]>,
    /// `LMT(q)` at the samples (m).
    pub(crate) lmt: Vec<f64>,
    /// Moment arm `r(q)` at the samples (m).
    pub(crate) r: Vec<f64>,
    /// The activation it was built from.
    table: Arc<ActTable>,
}

/// Finds `key` in `list`.
fn find<T, K: PartialEq>(
    list: &Mutex<Vec<Arc<T>>>,
    key: &K,
    key_of: impl Fn(&T) -> &K,
) -> Option<Arc<T>> {
    let list = list.lock().unwrap_or_else(|e| e.into_inner());
    list.iter().find(|c| key_of(c) == key).map(Arc::clone)
}

/// Keeps `item` in `list` (unless an equal one arrived meanwhile, which is returned instead),
/// dropping the oldest beyond [`SHARED_CHANNELS`].
fn keep<T, K: PartialEq>(
    list: &Mutex<Vec<Arc<T>>>,
    item: Arc<T>,
    key_of: impl Fn(&T) -> &K,
) -> Arc<T> {
    let mut list = list.lock().unwrap_or_else(|e| e.into_inner());
    if let Some(c) = list.iter().find(|c| key_of(c) == key_of(&item)) {
        return Arc::clone(c);
    }
    if list.len() >= SHARED_CHANNELS {
        list.remove(0);
    }
    list.push(Arc::clone(&item));
    item
}

/// The channel of `unit` on `inputs`: `current` when its key matches, else one kept with the
/// inputs (shared across threads), else a new one (then kept), built from the kept activation
/// table when there is one. Channels and tables are deterministic functions of their keys, so
/// where one comes from does not change any result.
pub(crate) fn channel_for(
    current: Option<&Arc<Channel>>,
    inputs: &TrialInputs,
    unit: &MuscleUnit,
    delay: f64,
) -> Arc<Channel> {
    let key = ChannelKey::new(inputs, unit, delay);
    if let Some(c) = current.filter(|c| c.key == key) {
        return Arc::clone(c);
    }
    let cache = inputs.channel_cache();
    if let Some(c) = find(&cache.channels, &key, |c| &c.key) {
        return c;
    }
    let j = key.table.j;
    let table = if key.table.delay > 0.0 {
        match find(&cache.tables, &key.table, |t| &t.key) {
            Some(t) => t,
            None => {
                let all = ActTable::build_all(key.table, inputs, unit.activation)
                    .map(|t| keep(&cache.tables, Arc::new(t), |t| &t.key));
                Arc::clone(&all[j])
            }
        }
    } else {
        Arc::clone(&ActTable::undelayed(key.table, inputs, unit.activation)[j])
    };
    let c = Arc::new(Channel::build(key, inputs, unit, table));
    keep(&cache.channels, c, |c| &c.key)
}

impl Channel {
    /// Tabulates the drive of `unit` on `inputs` from its activation table.
    fn build(
        key: ChannelKey,
        inputs: &TrialInputs,
        unit: &MuscleUnit,
        table: Arc<ActTable>,
    ) -> Self {
        let n = inputs.len();
        let q = inputs.angle();
        let qd = inputs.velocity();
        let dt = 1.0 / inputs.fs();
        let nl = unit.activation.nonlinearity;
        let kf = unit.fatigue_rate;
        let z = if kf > 0.0 { table.z(inputs) } else { &[] };
        let c = unit.poly;
        let mut drive = Vec::with_capacity(n);
        let mut lmt_v = Vec::with_capacity(n);
        let mut r_v = Vec::with_capacity(n);
        for i in 0..n {
            let (a, adot) = (table.a[i], table.adot[i]);
            let ah = nl.apply(a);
            let dah = nl.slope(a) * adot;
            let (phi, dphi) = if kf > 0.0 {
                let phi = (-kf * z[i]).exp();
                (phi, -kf * ah * phi)
            } else {
                (1.0, 0.0)
            };
            let lmt = crate::geometry::lmt(&c, q[i]);
            let r = crate::geometry::moment_arm(&c, q[i]);
            drive.push([ah * phi, dt * (dah * phi + ah * dphi), lmt, dt * r * qd[i]]);
            lmt_v.push(lmt);
            r_v.push(r);
        }
        Channel {
            key,
            drive,
            lmt: lmt_v,
            r: r_v,
            table,
        }
    }
}

/// Constants of the fibre-length right-hand side of one muscle.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Fibre {
    h2: f64,
    lm_cap: f64,
    cos_cap: f64,
    lst: f64,
    inv_lst: f64,
    inv_lom: f64,
    inv_gamma: f64,
    vmax: f64,
    lm_min: f64,
    eps_toe: f64,
    toe_rate: f64,
    toe_scale: f64,
    klin: f64,
    pe_rate: f64,
    pe_scale: f64,
    curves: Curves,
}

impl Fibre {
    pub(crate) fn new(u: &MuscleUnit) -> Self {
        let cap = crate::geometry::MAX_PENNATION_DEG.to_radians();
        let c = &u.curves;
        Fibre {
            h2: u.pennation.h * u.pennation.h,
            lm_cap: u.pennation.lm_cap,
            cos_cap: cap.cos(),
            lst: u.lst,
            inv_lst: 1.0 / u.lst,
            inv_lom: 1.0 / u.lom,
            inv_gamma: 1.0 / u.curves.gamma,
            vmax: u.vmax,
            lm_min: u.lm_min,
            eps_toe: crate::curves::TOE_STRAIN_FRACTION * c.e0t,
            toe_rate: crate::curves::TOE_SHAPE / (crate::curves::TOE_STRAIN_FRACTION * c.e0t),
            toe_scale: crate::curves::TOE_FORCE / crate::curves::TOE_SHAPE.exp_m1(),
            klin: crate::curves::LINEAR_STIFFNESS_X_E0 / c.e0t,
            pe_rate: c.kpe / c.e0m,
            pe_scale: 1.0 / c.kpe.exp_m1(),
            curves: u.curves,
        }
    }

    /// `(cos α, LM·cos α)`.
    #[inline(always)]
    fn cos(&self, lm: f64) -> (f64, f64) {
        if lm <= self.lm_cap {
            (self.cos_cap, lm * self.cos_cap)
        } else {
            let w = (lm * lm - self.h2).sqrt();
            (w / lm, w)
        }
    }

    /// Normalised tendon force `fT(ε(LMT, LM))` (the same function serves every caller, so
    /// results agree bit for bit).
    #[inline(always)]
    pub(crate) fn tendon_force(&self, lmt: f64, lm: f64) -> f64 {
        let (_, lmcos) = self.cos(lm);
        self.ft((lmt - lmcos - self.lst) * self.inv_lst)
    }

    /// `fT(ε)`; the toe uses `exp(x) − 1` (absolute error ~1e-17, cheaper than `exp_m1`).
    #[inline(always)]
    fn ft(&self, eps: f64) -> f64 {
        if eps <= 0.0 {
            0.0
        } else if eps <= self.eps_toe {
            self.toe_scale * ((eps * self.toe_rate).exp() - 1.0)
        } else {
            self.klin * (eps - self.eps_toe) + crate::curves::TOE_FORCE
        }
    }

    /// `fpe(l̃)` with `exp(x) − 1`.
    #[inline(always)]
    fn fpe(&self, l: f64) -> f64 {
        if l > 1.0 {
            ((l - 1.0) * self.pe_rate).exp() * self.pe_scale - self.pe_scale
        } else {
            0.0
        }
    }

    /// Fibre velocity `vM` (m/s) for input `act = â·φ`, `LMT` and `LM`.
    #[inline(always)]
    fn velocity(&self, act: f64, lmt: f64, lm: f64) -> f64 {
        let (cos, lmcos) = self.cos(lm);
        let ft = self.ft((lmt - lmcos - self.lst) * self.inv_lst);
        let l = lm * self.inv_lom;
        let d = l - 1.0;
        let fl = (-d * d * self.inv_gamma).exp();
        let v = self.curves.solve_velocity(act * fl, ft / cos - self.fpe(l));
        let vm = v * self.vmax;
        if lm <= self.lm_min && vm < 0.0 {
            0.0
        } else {
            vm
        }
    }
}

/// Unit-`F0` torque `F̃T·r(q)` at every sample from the fibre lengths `lm` (one pass over the
/// samples, separate from the integration so that the integrator's loop stays small).
///
/// The same numbers as `fib.tendon_force(lmt, lm) * r` sample by sample, computed in passes
/// without branches where possible so that the compiler can use vector instructions: the
/// strain of every sample, then the force in the linear region and zero below slack, then the
/// exponential toe only at the samples in it.
pub(crate) fn unit_torque(fib: &Fibre, ch: &Channel, lm: &[f64], out: &mut [f64]) {
    let n = out.len();
    let (lm, lmt, r) = (&lm[..n], &ch.lmt[..n], &ch.r[..n]);
    for i in 0..n {
        // `Fibre::cos(lm).1` as a select: for lm > lm_cap > h the root's argument is positive
        let l = lm[i];
        let w = (l * l - fib.h2).max(0.0).sqrt();
        let lmcos = if l <= fib.lm_cap { l * fib.cos_cap } else { w };
        out[i] = (lmt[i] - lmcos - fib.lst) * fib.inv_lst;
    }
    for (out, r) in out.chunks_mut(64).zip(r.chunks(64)) {
        let toe = out
            .iter()
            .fold(false, |t, &eps| t | (eps > 0.0 && eps <= fib.eps_toe));
        if toe {
            for (o, &r) in out.iter_mut().zip(r) {
                *o = fib.ft(*o) * r;
            }
        } else {
            for (o, &r) in out.iter_mut().zip(r) {
                let eps = *o;
                let lin = fib.klin * (eps - fib.eps_toe) + crate::curves::TOE_FORCE;
                *o = if eps <= 0.0 { 0.0 } else { lin } * r;
            }
        }
    }
}

/// Cubic Hermite interpolation of the drive at time `t`: `(act, d(act)/dt, LMT)`.
#[inline(always)]
fn drive_at(drive: &[[f64; 4]], t0: f64, fs: f64, t: f64) -> (f64, f64, f64) {
    let n = drive.len();
    let x = ((t - t0) * fs).clamp(0.0, (n - 1) as f64);
    let i = (x as usize).min(n - 2);
    let s = x - i as f64;
    let (d0, d1) = (drive[i], drive[i + 1]);
    let s1 = 1.0 - s;
    let s12 = s1 * s1;
    let s2 = s * s;
    let h00 = (1.0 + 2.0 * s) * s12;
    let h10 = s * s12;
    let h01 = s2 * (3.0 - 2.0 * s);
    let h11 = -s2 * s1;
    // derivatives of the basis with respect to s
    let g00 = -6.0 * s * s1;
    let g10 = s1 * (1.0 - 3.0 * s);
    let g11 = s * (3.0 * s - 2.0);
    (
        h00 * d0[0] + h10 * d0[1] + h01 * d1[0] + h11 * d1[1],
        fs * (g00 * (d0[0] - d1[0]) + g10 * d0[1] + g11 * d1[1]),
        h00 * d0[2] + h10 * d0[3] + h01 * d1[2] + h11 * d1[3],
    )
}

/// The fibre ODE on `[LM, act]`: `(L̇M, d(act)/dt)` with the drive interpolated at `t`.
#[derive(Clone, Copy)]
struct FibreSystem<'a> {
    drive: &'a [[f64; 4]],
    t0: f64,
    fs: f64,
    fib: &'a Fibre,
}

impl OdeSystem<2> for FibreSystem<'_> {
    #[inline(always)]
    fn rhs(&mut self, t: f64, y: &[f64; 2], dy: &mut [f64; 2]) {
        let (act, dact, lmt) = drive_at(self.drive, self.t0, self.fs, t);
        dy[0] = self.fib.velocity(act, lmt, y[0]);
        dy[1] = dact;
    }
}

/// Integrates the fibre length of `fib` over the samples of `inputs` (channel prepared) and
/// writes `LM` at every sample into `lm_out` (length = samples).
///
/// The integrator is [`ode::DoPri5`] on the two-component state `[LM, act]` with
/// `d(act)/dt` read from the drive: the activation input itself needs no integration (it is
/// tabulated), but its embedded error estimate enters the step-size control, which shrinks
/// steps that straddle a fast change of the input (an onset), whose effect on `LM` the `LM`
/// estimate alone misses in the dense output.
pub(crate) fn run(
    ch: &Channel,
    inputs: &TrialInputs,
    fib: &Fibre,
    lm0: f64,
    settings: &SimSettings,
    lm_out: &mut [f64],
) -> Result<SimStats, OdeError> {
    run_lanes([Some((ch, fib, lm0, lm_out))], inputs, settings)
        .map(|[stats]| stats)
        .map_err(|(_, e)| e)
}

/// One muscle of [`run_lanes`]: its channel, fibre constants, initial `LM` and the buffer for
/// `LM` at the samples.
pub(crate) type Lane<'a> = (&'a Channel, &'a Fibre, f64, &'a mut [f64]);

/// [`run`] for several muscles together (their integrations interleaved by
/// [`ode::attempt_lanes`]; each muscle's `LM` is the same bits as from [`run`]). Lanes whose
/// `lm_out` is `None` are skipped. On failure returns the failing lane and its error.
pub(crate) fn run_lanes<const L: usize>(
    lanes: [Option<Lane<'_>>; L],
    inputs: &TrialInputs,
    settings: &SimSettings,
) -> Result<[SimStats; L], (usize, OdeError)> {
    let times = inputs.times();
    let n = times.len();
    let t0 = times[0];
    let fs = inputs.fs();
    let t_end = times[n - 1];
    let mut stats = [SimStats::default(); L];
    let mut outs: [Option<&mut [f64]>; L] = std::array::from_fn(|_| None);
    let mut systems: [Option<FibreSystem<'_>>; L] = [None; L];
    let mut y0 = [[0.0; 2]; L];
    for (l, lane) in lanes.into_iter().enumerate() {
        if let Some((ch, fib, lm0, out)) = lane {
            if !lm0.is_finite() {
                return Err((l, OdeError::NonFinite { t: t0 }));
            }
            out[0] = lm0;
            y0[l] = [lm0, ch.drive[0][0]];
            systems[l] = Some(FibreSystem {
                drive: &ch.drive,
                t0,
                fs,
                fib,
            });
            outs[l] = Some(out);
        }
    }
    if n < 2 {
        return Ok(stats);
    }
    // lanes without a muscle hold a copy of an active one's system (never stepped)
    let Some(first) = systems.iter().flatten().next().copied() else {
        return Ok(stats);
    };
    let mut active = [false; L];
    let mut sys: [FibreSystem<'_>; L] = std::array::from_fn(|l| {
        active[l] = systems[l].is_some();
        systems[l].take().unwrap_or(first)
    });
    let stepper = DoPri5::<2>::new(settings.adaptive())
        .map_err(|e| (0, e))?
        .with_log_controller();
    let mut steppers: [DoPri5<2>; L] = std::array::from_fn(|_| stepper.clone());
    for l in 0..L {
        if active[l] {
            steppers[l]
                .init(&mut sys[l], t0, y0[l], t_end)
                .map_err(|e| (l, e))?;
        }
    }
    let mut next = [1usize; L];
    loop {
        for l in 0..L {
            active[l] = active[l] && next[l] < n;
        }
        if !active.iter().any(|a| *a) {
            break;
        }
        let accepted = ode::attempt_lanes(&mut steppers, &mut sys, active)?;
        for l in 0..L {
            if !accepted[l] {
                continue;
            }
            if let Some(out) = outs[l].as_deref_mut() {
                let dense = steppers[l].dense();
                let t = dense.t();
                let (from, to) = (
                    next[l],
                    next[l] + times[next[l]..].partition_point(|&x| x <= t),
                );
                dense.component_into(&times[from..to], 0, &mut out[from..to]);
                next[l] = to;
            }
        }
    }
    for l in 0..L {
        if outs[l].is_some() {
            stats[l] = steppers[l].stats().into();
        }
    }
    Ok(stats)
}

impl Channel {
    /// The activation `a` and `∫â` at the samples (the integral computed on first use).
    pub(crate) fn activation<'a>(&'a self, inputs: &TrialInputs) -> (&'a [f64], &'a [f64]) {
        (&self.table.a, self.table.z(inputs))
    }
}

/// The recorded state `[a, F̃T, LM, LMT, ∫â]` at one sample from its activation `a`, `∫â`,
/// fibre length, musculotendon length and tendon force.
pub(crate) fn state(a: f64, z: f64, lm: f64, lmt: f64, ft: f64) -> [f64; STATE_DIM] {
    let mut y = [0.0; STATE_DIM];
    y[IX_A] = a;
    y[IX_FT] = ft;
    y[IX_LM] = lm;
    y[IX_LMT] = lmt;
    y[IX_FATIGUE] = z;
    y
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{Effects, ModelParams, Muscle};

    fn units(fatigue: Option<f64>, delay_ms: f64) -> (TrialInputs, [MuscleUnit; 3], f64) {
        let tr = crate::synthetic::seed_like_trial(512.0).unwrap();
        let mut json = format!(r#"{{"electromechanical_delay": {{"delay_ms": {delay_ms}}}"#);
        if let Some(k) = fatigue {
            json += &format!(r#", "fatigue": {{"rate_per_s": {k}}}"#);
        }
        json += "}";
        let e = Effects::from_json_str(&json).unwrap();
        let p = ModelParams::nominal();
        let u = Muscle::ALL.map(|m| MuscleUnit::new(&p, m, &e));
        (tr, u, delay_ms * 1e-3)
    }

    #[test]
    fn muscles_integrated_together_equal_each_alone_bit_for_bit() {
        let (tr, u, d) = units(None, 37.0);
        let keys: [TableKey; 3] = std::array::from_fn(|j| ChannelKey::new(&tr, &u[j], d).table);
        let together = integrate_activation(&keys, &tr, u[0].activation);
        for j in 0..3 {
            let [alone] = integrate_activation(&[keys[j]], &tr, u[0].activation);
            assert_eq!(alone, together[j], "muscle {j}");
        }
        // the activation follows a step of the envelope towards it and stays in [0, 1]
        assert!(together[0].0.iter().all(|a| (0.0..=1.0).contains(a)));
    }

    #[test]
    fn a_delayed_table_is_the_undelayed_one_shifted() {
        for (fs, tol) in [(2048.0, [3e-8, 2e-6, 4e-9]), (512.0, [5e-7, 3e-5, 6e-8])] {
            let tr = crate::synthetic::seed_like_trial(fs).unwrap();
            let e = Effects::from_json_str(r#"{"fatigue": {"rate_per_s": 0.03}}"#).unwrap();
            let u = Muscle::ALL.map(|m| MuscleUnit::new(&ModelParams::nominal(), m, &e));
            let act = u[0].activation;
            // 0.3 samples, 37.4 ms, and the largest delay allowed (150 ms)
            for d in [0.3 / fs, 0.0374, 0.150] {
                let key = ChannelKey::new(&tr, &u[1], d).table;
                let [(a, adot)] = integrate_activation(&[key], &tr, act);
                let mut z = Vec::new();
                integrate_activation_and_integral(&key, &tr, act, |zi| z.push(zi));
                let shifted = &ActTable::build_all(key, &tr, act)[1];
                assert!(shifted.base.is_some() && shifted.key == key);
                let err = |x: &[f64], y: &[f64]| {
                    x.iter()
                        .zip(y)
                        .map(|(p, q)| (p - q).abs())
                        .fold(0.0, f64::max)
                };
                // both are approximations of the same activation (RK4 across the envelope's
                // kinks, Hermite between samples); they differ by O(Δt²)
                let (ea, ed, ez) = (
                    err(&shifted.a, &a),
                    err(&shifted.adot, &adot),
                    err(shifted.z(&tr), &z),
                );
                assert!(
                    ea < tol[0] && ed < tol[1] && ez < tol[2],
                    "fs {fs} d {d}: {ea:e} {ed:e} {ez:e}"
                );
                // before t₀ + d the activation rests where it started
                let rest = (d * fs).floor() as usize;
                assert!(shifted.a[..=rest].iter().all(|&v| v == a[0]));
            }
        }
    }

    #[test]
    fn delay_fits_reuse_the_undelayed_tables() {
        let (tr, u, _) = units(None, 0.0);
        let c0 = channel_for(None, &tr, &u[2], 0.0);
        let c1 = channel_for(None, &tr, &u[2], 0.021);
        let c2 = channel_for(None, &tr, &u[2], 0.0213);
        for c in [&c1, &c2] {
            let base = c.table.base.as_ref().expect("a delayed table has a base");
            assert!(Arc::ptr_eq(base, &c0.table));
        }
        assert!(c0.table.base.is_none());
        assert!(Arc::ptr_eq(&c1, &channel_for(None, &tr, &u[2], 0.021)));
    }

    #[test]
    fn fatigue_rates_share_one_table_and_scale_the_drive() {
        let (tr, u0, d) = units(None, 20.0);
        let (_, u1, _) = units(Some(0.03), 20.0);
        // the same inputs (one cache): rebuild the fatigued units on `tr`
        let c0 = channel_for(None, &tr, &u0[1], d);
        let c1 = channel_for(None, &tr, &u1[1], d);
        assert!(Arc::ptr_eq(&c0.table, &c1.table));
        assert!(Arc::ptr_eq(&c0, &channel_for(None, &tr, &u0[1], d)));
        let (a, z) = c1.activation(&tr);
        let nl = u1[1].activation.nonlinearity;
        for i in (0..tr.len()).step_by(97) {
            assert_eq!(c0.drive[i][0], nl.apply(a[i]));
            let want = nl.apply(a[i]) * (-0.03 * z[i]).exp();
            assert_eq!(c1.drive[i][0], want, "sample {i}");
        }
        // ∫â is non-decreasing from 0
        assert_eq!(z[0], 0.0);
        assert!(z.windows(2).all(|w| w[1] >= w[0]));
    }
}
