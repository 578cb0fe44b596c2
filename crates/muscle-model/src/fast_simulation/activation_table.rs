//! The activation of one muscle tabulated at the points of a trial's [`TableGrid`] (its
//! samples, or several points per sample interval in a low-rate trial) ([`ActTable`]): `a`,
//! `ȧ` and, when asked for, `∫₀ᵗ â dt`.
//!
//! With `u(t) = env(t − d)` clamped to `[0, 1]`, the activation follows
//!
//! ```text
//! ȧ = (u − a)(k1·u + k2),     â = f_A(a)
//! ```
//!
//! integrated with classical RK4, [`ACT_SUBSTEPS`] substeps per grid interval (the envelope is
//! a polynomial inside one: linear, or the low-rate trial's monotone cubic). A table with a
//! delay `d > 0` is the undelayed one read at `tⱼ − d` by cubic Hermite interpolation
//! (`a₀(t₀)` before `t₀ + d`), with `∫₀ᵗ â_d = â(a₀(t₀))·min(t − t₀, d) + ∫₀^{t−d} â₀`.

use super::grid::TableGrid;
use super::kept::KeptList;
use crate::activation::Activation;
use crate::inputs::TrialInputs;
use crate::musculotendon::MuscleUnit;
use crate::params::Muscle;
use std::sync::{Arc, OnceLock};

/// RK4 substeps per grid interval when the activation is precomputed.
pub(super) const ACT_SUBSTEPS: usize = 4;

/// What an [`ActTable`] was computed from: everything the activation `a(t)` depends on.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct TableKey {
    uid: u64,
    n: usize,
    /// The muscle, whose envelope drives the activation.
    pub(super) name: &'static str,
    k1: f64,
    k2: f64,
    shape: f64,
    pub(super) delay: f64,
}

impl TableKey {
    /// The key of `unit`'s activation on `inputs` with electromechanical delay `delay` (s).
    pub(super) fn new(inputs: &TrialInputs, unit: &MuscleUnit, delay: f64) -> Self {
        let act = unit.activation;
        TableKey {
            uid: inputs.uid(),
            n: inputs.len(),
            name: unit.name,
            k1: act.k1,
            k2: act.k2,
            shape: act.nonlinearity.shape,
            delay,
        }
    }

    /// The same key without a delay.
    pub(super) fn undelayed(self) -> TableKey {
        TableKey { delay: 0.0, ..self }
    }

    /// Whether a table of `self` has the same `a` and `ȧ` as one of `other`: every field but
    /// the A-model's shape, which only `∫â` reads.
    pub(super) fn same_dynamics(&self, other: &TableKey) -> bool {
        TableKey {
            shape: other.shape,
            ..*self
        } == *other
    }
}

/// The activation of one muscle at the grid's points: `a`, `ȧ` and (on first use) `∫₀ᵗ â dt`.
///
/// It depends on the activation parameters and the delay but not on the fatigue rate or the
/// muscle's identified parameters, so the channels of every fatigue rate share one table (a
/// fatigue fit rebuilds only the cheap per-sample drive), and `∫â`, which only the fatigue
/// factor and the recorded state read, is integrated only when one of them asks for it.
#[derive(Debug)]
pub(super) struct ActTable {
    pub(super) key: TableKey,
    pub(super) act: Activation,
    /// `a` at the grid's points.
    pub(super) a: Vec<f64>,
    /// `ȧ = rate(u(tⱼ), aⱼ)` at the grid's points.
    pub(super) adot: Vec<f64>,
    /// `∫₀ᵗ â dt` at the grid's points, computed on first use.
    z: OnceLock<Vec<f64>>,
    /// For a delayed table, the undelayed one it was shifted from.
    pub(super) base: Option<Arc<ActTable>>,
}

impl ActTable {
    /// The tables of sol, gm and gl with `key`'s activation and delay (a delay or an
    /// activation parameter changes all three at once): integrated without a delay, else the
    /// undelayed tables (from `undelayed`, the trial's list of them) shifted by the delay.
    pub(super) fn build_all(
        key: TableKey,
        inputs: &TrialInputs,
        act: Activation,
        undelayed: &KeptList<ActTable>,
    ) -> [ActTable; 3] {
        let envs = Muscle::ALL.map(|m| inputs.envelope(m));
        if key.delay > 0.0 {
            let base = Self::undelayed(key, inputs, act, undelayed);
            return std::array::from_fn(|j| {
                let name = Muscle::ALL[j].name();
                Self::shifted(&base[j], TableKey { name, ..key }, envs[j], inputs)
            });
        }
        let keys: [TableKey; 3] = std::array::from_fn(|j| TableKey {
            name: Muscle::ALL[j].name(),
            ..key
        });
        let mut j = 0;
        integrate_activation(&keys, &envs, inputs, act).map(|(a, adot)| {
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

    /// The three undelayed tables with `key`'s activation, from the trial's own `list` or
    /// integrated (and kept there).
    pub(super) fn undelayed(
        key: TableKey,
        inputs: &TrialInputs,
        act: Activation,
        list: &KeptList<ActTable>,
    ) -> [Arc<ActTable>; 3] {
        let keys: [TableKey; 3] = std::array::from_fn(|j| TableKey {
            name: Muscle::ALL[j].name(),
            delay: 0.0,
            ..key
        });
        let found: Vec<Arc<ActTable>> = keys
            .iter()
            .filter_map(|k| list.find(k, |t| &t.key))
            .collect();
        if let Ok(all) = <[Arc<ActTable>; 3]>::try_from(found) {
            return all;
        }
        let other_shape: Vec<Arc<ActTable>> = keys
            .iter()
            .filter_map(|k| list.find_where(|t| t.key.same_dynamics(k)))
            .collect();
        if let Ok(all) = <[Arc<ActTable>; 3]>::try_from(other_shape) {
            return std::array::from_fn(|j| {
                list.keep(Arc::new(all[j].reshaped(keys[j], act, None)), |t| &t.key)
            });
        }
        Self::build_all(keys[0], inputs, act, list).map(|t| list.keep(Arc::new(t), |t| &t.key))
    }

    /// The table of one further muscle (driven by envelope `env`) with `key`'s activation and
    /// delay: integrated alone without a delay, else its undelayed table (from `undelayed` or
    /// integrated and kept there) shifted by the delay.
    pub(super) fn build_one(
        key: TableKey,
        env: &[f64],
        inputs: &TrialInputs,
        act: Activation,
        undelayed: &KeptList<ActTable>,
    ) -> ActTable {
        let alone = |key: TableKey| {
            let [(a, adot)] = integrate_activation(&[key], &[env], inputs, act);
            ActTable {
                key,
                act,
                a,
                adot,
                z: OnceLock::new(),
                base: None,
            }
        };
        if key.delay > 0.0 {
            let k0 = TableKey { delay: 0.0, ..key };
            let base = match undelayed.find(&k0, |t| &t.key) {
                Some(b) => b,
                None => undelayed.keep(Arc::new(alone(k0)), |t| &t.key),
            };
            return Self::shifted(&base, key, env, inputs);
        }
        alone(key)
    }

    /// This table under `key`, which differs from its own key at most in the A-model's shape
    /// (activation `act`): `a` and `ȧ` are copied, since the shape acts only on `â = f_A(a)`,
    /// so an activation-shape fit does not integrate the activation again. A delayed table
    /// takes `base`, the undelayed table of the new shape, from which its `∫â` is read.
    pub(super) fn reshaped(
        &self,
        key: TableKey,
        act: Activation,
        base: Option<Arc<ActTable>>,
    ) -> ActTable {
        debug_assert!(self.key.same_dynamics(&key));
        ActTable {
            key,
            act,
            a: self.a.clone(),
            adot: self.adot.clone(),
            z: OnceLock::new(),
            base,
        }
    }

    /// `base` (undelayed) delayed by `key.delay > 0`: `a(tⱼ) = a₀(tⱼ − d)` by cubic Hermite
    /// interpolation of `a₀` and `ȧ₀` (`a₀(t₀)` before `t₀ + d`), `ȧ(tⱼ)` from the activation
    /// equation at `u(tⱼ − d)`.
    fn shifted(base: &Arc<ActTable>, key: TableKey, env: &[f64], inputs: &TrialInputs) -> ActTable {
        let act = base.act;
        let (a0, adot0) = (&base.a, &base.adot);
        let g = TableGrid::of(inputs);
        let mut a = Vec::with_capacity(g.len);
        let mut adot = Vec::with_capacity(g.len);
        for j in 0..g.len {
            let ti = g.time(j);
            // `a₀(t₀)` at and before the first sample: the rest before `t₀ + d`
            let ai = g.hermite_at(a0, adot0, ti - key.delay);
            a.push(ai);
            let u = inputs.envelope_value_at(env, ti - key.delay);
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

    /// `∫₀ᵗ â dt` at the grid's points, on the first call: integrated together with `a` (with the
    /// same arithmetic for `a`), or for a delayed table `â(a₀(t₀))·min(t − t₀, d)` plus the
    /// undelayed integral at `t − d` (cubic Hermite, slopes `â₀`).
    pub(super) fn z(&self, env: &[f64], inputs: &TrialInputs) -> &[f64] {
        self.z.get_or_init(|| {
            let g = TableGrid::of(inputs);
            let mut z = Vec::with_capacity(g.len);
            match &self.base {
                None => {
                    integrate_activation_and_integral(&self.key, env, inputs, self.act, |zi| {
                        z.push(zi)
                    });
                }
                Some(b) => {
                    let (z0, nl, d) = (b.z(env, inputs), self.act.nonlinearity, self.key.delay);
                    let ah0: Vec<f64> = b.a.iter().map(|&a| nl.apply(a)).collect();
                    let rest = ah0[0];
                    let t0 = inputs.t0();
                    for j in 0..g.len {
                        let ti = g.time(j);
                        let s = ti - d;
                        let zi = if s > t0 {
                            rest * d + g.hermite_at(z0, &ah0, s)
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

/// Classical RK4 on `ȧ = rate(u_l(t − d), a)` for the muscles `keys[l]` (envelopes `envs[l]`) together (their
/// independent recurrences interleaved, which keeps the processor busy: each alone is one
/// long dependency chain), [`ACT_SUBSTEPS`] substeps per interval of the trial's
/// [`TableGrid`] (`u` clamped to [0, 1]). Returns `a` and `ȧ` at the grid's points per
/// muscle; each muscle's numbers are the same whatever it is integrated with.
///
/// `u` is read once per distinct time: the two midpoint stages share one, and a substep's
/// last stage time is the next substep's first (the same `tt + hs` rounding).
fn integrate_activation<const L: usize>(
    keys: &[TableKey; L],
    envs: &[&[f64]; L],
    inputs: &TrialInputs,
    act: Activation,
) -> [(Vec<f64>, Vec<f64>); L] {
    let g = TableGrid::of(inputs);
    let n = g.len;
    let hs = 1.0 / g.rate / ACT_SUBSTEPS as f64;
    let u_at = |l: usize, tt: f64| {
        inputs
            .envelope_value_at(envs[l], tt - keys[l].delay)
            .clamp(0.0, 1.0)
    };
    let mut out: [(Vec<f64>, Vec<f64>); L] =
        std::array::from_fn(|_| (Vec::with_capacity(n), Vec::with_capacity(n)));
    let mut y: [f64; L] = std::array::from_fn(|l| u_at(l, g.time(0)));
    for i in 0..n {
        let ti = g.time(i);
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
/// identically: it does not read `∫â`); calls `out(∫â)` at every point of the grid.
fn integrate_activation_and_integral(
    key: &TableKey,
    env: &[f64],
    inputs: &TrialInputs,
    act: Activation,
    mut out: impl FnMut(f64),
) {
    let g = TableGrid::of(inputs);
    let n = g.len;
    let delay = key.delay;
    let hs = 1.0 / g.rate / ACT_SUBSTEPS as f64;
    let nl = act.nonlinearity;
    let u_at = |tt: f64| inputs.envelope_value_at(env, tt - delay).clamp(0.0, 1.0);
    let f = |tt: f64, y: [f64; 2]| -> [f64; 2] { [act.rate(u_at(tt), y[0]), nl.apply(y[0])] };
    let mut y = [u_at(g.time(0)), 0.0];
    for i in 0..n {
        let ti = g.time(i);
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

#[cfg(test)]
mod tests {
    use super::super::test_support::test_units as units;
    use super::*;
    use crate::effects::Effects;
    use crate::params::ModelParams;

    #[test]
    fn muscles_integrated_together_equal_each_alone_bit_for_bit() {
        let (tr, u, d) = units(None, 37.0);
        let keys: [TableKey; 3] = std::array::from_fn(|j| TableKey::new(&tr, &u[j], d));
        let envs = Muscle::ALL.map(|m| tr.envelope(m));
        let together = integrate_activation(&keys, &envs, &tr, u[0].activation);
        for j in 0..3 {
            let [alone] = integrate_activation(&[keys[j]], &[envs[j]], &tr, u[0].activation);
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
                let key = TableKey::new(&tr, &u[1], d);
                let env = tr.envelope(Muscle::Gm);
                let [(a, adot)] = integrate_activation(&[key], &[env], &tr, act);
                let mut z = Vec::new();
                integrate_activation_and_integral(&key, env, &tr, act, |zi| z.push(zi));
                let shifted = &ActTable::build_all(key, &tr, act, &KeptList::default())[1];
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
                    err(shifted.z(env, &tr), &z),
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
}
