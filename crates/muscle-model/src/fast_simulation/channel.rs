//! The per-muscle inputs of the fibre ODE at the samples of a trial ([`Channel`]).
//!
//! With the muscle's activation table (`a`, `ȧ`, `∫â`), the fatigue rate `k` and the
//! musculotendon-length polynomial, each sample holds
//!
//! ```text
//! act = â·φ,  φ = exp(−k∫â),  d(act)/dt = f_A'(a)·ȧ·φ − k·â²·φ,
//! LMT = LMT(q),  dLMT/dt = r(q)·q̇
//! ```
//!
//! (rates scaled by the sample interval, as the cubic Hermite interpolation between samples
//! reads them), and `LMT`, `r` alone for the torque.

use super::activation_table::{ActTable, TableKey};
use crate::inputs::TrialInputs;
use crate::musculotendon::MuscleUnit;
use std::sync::Arc;

/// What a [`Channel`] was computed from: its activation table's key, the fatigue rate and the
/// musculotendon-length polynomial.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct ChannelKey {
    pub(super) table: TableKey,
    fatigue: f64,
    poly: [f64; 4],
}

impl ChannelKey {
    /// The key of `unit`'s channel on `inputs` with electromechanical delay `delay` (s).
    pub(super) fn new(inputs: &TrialInputs, unit: &MuscleUnit, delay: f64) -> Self {
        ChannelKey {
            table: TableKey::new(inputs, unit, delay),
            fatigue: unit.fatigue_rate,
            poly: unit.poly,
        }
    }
}

/// Per-trial, per-muscle inputs of the fibre ODE at the samples.
#[derive(Clone, Debug)]
pub(crate) struct Channel {
    pub(super) key: ChannelKey,
    /// Per sample `[act, dt·d(act)/dt, LMT, dt·dLMT/dt]`, `act = â·exp(−k∫â)`.
    pub(super) drive: Vec<[f64; 4]>,
    /// `LMT(q)` at the samples (m).
    pub(crate) lmt: Vec<f64>,
    /// Moment arm `r(q)` at the samples (m).
    pub(crate) r: Vec<f64>,
    /// The activation it was built from.
    pub(super) table: Arc<ActTable>,
}

impl Channel {
    /// Tabulates the drive of `unit` on `inputs` from its activation table.
    pub(super) fn build(
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

    /// The activation `a` and `∫â` at the samples (the integral computed on first use).
    pub(crate) fn activation<'a>(&'a self, inputs: &TrialInputs) -> (&'a [f64], &'a [f64]) {
        (&self.table.a, self.table.z(inputs))
    }
}
