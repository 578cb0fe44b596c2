//! Where activation tables and channels are kept: per [`TrialInputs`], shared by its clones and
//! by every thread and [`crate::Workspace`], so that a parameter set met before (on any thread)
//! reuses its channel, and a fit that moves the delay, fatigue rate or activation rebuilds only
//! what depends on it.
//!
//! The lists live in the inputs' [`crate::inputs::TrialMemo`], which holds them without knowing
//! their type. Channels and tables are deterministic functions of their keys, so whether one is
//! found or built does not change any number.

use super::activation_table::ActTable;
use super::channel::{Channel, ChannelKey};
use super::kept::KeptList;
use crate::inputs::TrialInputs;
use crate::musculotendon::MuscleUnit;
use crate::params::Muscle;
use crate::path::MusclePath;
use std::sync::Arc;

/// The kept activation tables and channels of one trial.
#[derive(Default)]
struct ChannelCache {
    /// Tables with a delay.
    tables: KeptList<ActTable>,
    /// Tables without a delay, kept apart: a delayed table is one of them shifted in time, and
    /// a delay fit makes new delayed tables at every step.
    undelayed: KeptList<ActTable>,
    channels: KeptList<Channel>,
}

/// The channel of `unit` (envelope `env`, geometry `path`) on `inputs`: `current` when its
/// key matches, else one kept with the inputs (shared across threads), else a new one (then
/// kept), built from the kept activation table when there is one. Channels and tables are
/// deterministic functions of their keys, so where one comes from does not change any result.
pub(crate) fn channel_for(
    current: Option<&Arc<Channel>>,
    inputs: &TrialInputs,
    unit: &MuscleUnit,
    env: &[f64],
    path: &MusclePath<'_>,
    delay: f64,
) -> Arc<Channel> {
    let key = ChannelKey::new(inputs, unit, delay);
    if let Some(c) = current.filter(|c| c.key == key) {
        return Arc::clone(c);
    }
    let own;
    let cache = match inputs.memo().get_or_default::<ChannelCache>() {
        Some(c) => c,
        // the memo holds something else: build without keeping (the same numbers)
        None => {
            own = ChannelCache::default();
            &own
        }
    };
    if let Some(c) = cache.channels.find(&key, |c| &c.key) {
        return c;
    }
    let table = match Muscle::from_name(key.table.name) {
        Some(m) => triceps_table(key, inputs, unit, cache, m.index()),
        // a further muscle: its table alone (kept in the same lists, keyed by its name)
        None => {
            let list = if key.table.delay > 0.0 {
                &cache.tables
            } else {
                &cache.undelayed
            };
            match list.find(&key.table, |t| &t.key) {
                Some(t) => t,
                None => {
                    let t = ActTable::build_one(
                        key.table,
                        env,
                        inputs,
                        unit.activation,
                        &cache.undelayed,
                    );
                    list.keep(Arc::new(t), |t| &t.key)
                }
            }
        }
    };
    let c = Arc::new(Channel::build(key, inputs, unit, env, path, table));
    cache.channels.keep(c, |c| &c.key)
}

/// The activation table of sol, gm or gl (index `j`) for `key`: kept, or the three built
/// together (a new delay or activation needs all three).
fn triceps_table(
    key: ChannelKey,
    inputs: &TrialInputs,
    unit: &MuscleUnit,
    cache: &ChannelCache,
    j: usize,
) -> Arc<ActTable> {
    if key.table.delay > 0.0 {
        if let Some(t) = cache.tables.find(&key.table, |t| &t.key) {
            return t;
        }
        // the same delay under another activation shape: its `a` and `ȧ` hold
        if let Some(t) = cache.tables.find_where(|t| t.key.same_dynamics(&key.table)) {
            let base = ActTable::undelayed(
                key.table.undelayed(),
                inputs,
                unit.activation,
                &cache.undelayed,
            );
            let t = t.reshaped(key.table, unit.activation, Some(Arc::clone(&base[j])));
            return cache.tables.keep(Arc::new(t), |t| &t.key);
        }
        match cache.tables.find(&key.table, |t| &t.key) {
            Some(t) => t,
            None => {
                let all = ActTable::build_all(key.table, inputs, unit.activation, &cache.undelayed)
                    .map(|t| cache.tables.keep(Arc::new(t), |t| &t.key));
                Arc::clone(&all[j])
            }
        }
    } else {
        Arc::clone(&ActTable::undelayed(key.table, inputs, unit.activation, &cache.undelayed)[j])
    }
}

#[cfg(test)]
mod tests {
    use super::super::test_support::{test_channel as chan, test_units as units};
    use super::*;

    #[test]
    fn delay_fits_reuse_the_undelayed_tables() {
        let (tr, u, _) = units(None, 0.0);
        let c0 = chan(&tr, &u[2], 0.0);
        let c1 = chan(&tr, &u[2], 0.021);
        let c2 = chan(&tr, &u[2], 0.0213);
        for c in [&c1, &c2] {
            let base = c.table.base.as_ref().expect("a delayed table has a base");
            assert!(Arc::ptr_eq(base, &c0.table));
        }
        assert!(c0.table.base.is_none());
        assert!(Arc::ptr_eq(&c1, &chan(&tr, &u[2], 0.021)));
    }

    #[test]
    fn a_new_activation_shape_reuses_the_activation_and_changes_nothing_else() {
        use crate::activation::ManalBuchanan;
        let reshape = |u: &MuscleUnit| {
            let mut v = *u;
            v.activation.nonlinearity = ManalBuchanan::new(0.05);
            v
        };
        for (fatigue, delay_ms) in [
            (None, 0.0),
            (None, 20.0),
            (Some(0.03), 0.0),
            (Some(0.03), 20.0),
        ] {
            let (tr, u, d) = units(fatigue, delay_ms);
            let first = chan(&tr, &u[1], d);
            let reused = chan(&tr, &reshape(&u[1]), d);
            // a fresh trial (its own cache) builds the new shape's table from nothing
            let (fresh_tr, fresh_u, _) = units(fatigue, delay_ms);
            let built = chan(&fresh_tr, &reshape(&fresh_u[1]), d);
            assert!(!Arc::ptr_eq(&first.table, &reused.table));
            assert_eq!(reused.table.a, built.table.a, "{fatigue:?} {delay_ms}");
            assert_eq!(reused.table.adot, built.table.adot);
            assert_eq!(reused.drive, built.drive);
            let env = tr.envelope(crate::params::Muscle::Gm);
            let (_, z_reused, _) = reused.activation(env, &tr);
            let (_, z_built, _) = built.activation(env, &fresh_tr);
            assert_eq!(z_reused, z_built);
            assert_ne!(first.drive, reused.drive, "the shape changes the drive");
        }
    }

    #[test]
    fn fatigue_rates_share_one_table_and_scale_the_drive() {
        let (tr, u0, d) = units(None, 20.0);
        let (_, u1, _) = units(Some(0.03), 20.0);
        // the same inputs (one cache): rebuild the fatigued units on `tr`
        let c0 = chan(&tr, &u0[1], d);
        let c1 = chan(&tr, &u1[1], d);
        assert!(Arc::ptr_eq(&c0.table, &c1.table));
        assert!(Arc::ptr_eq(&c0, &chan(&tr, &u0[1], d)));
        let (a, z, m) = c1.activation(tr.envelope(crate::params::Muscle::Gm), &tr);
        assert_eq!(m, 1);
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
