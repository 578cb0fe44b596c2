//! The per-muscle inputs of the fibre ODE at the samples of a trial ([`Channel`]).
//!
//! With the muscle's activation table (`a`, `ȧ`, `∫â`), the fatigue rate `k` and the
//! muscle's path on the trial ([`crate::path`]), each sample holds
//!
//! ```text
//! act = â·φ,  φ = exp(−k∫â),  d(act)/dt = f_A'(a)·ȧ·φ − k·â²·φ,
//! LMT = P(q) − r_knee·k,  dLMT/dt = r(q)·q̇ − r_knee·k̇     (or a series and its rate)
//! ```
//!
//! (rates scaled by the sample interval, as the cubic Hermite interpolation between samples
//! reads them), and `LMT`, `r` alone for the torque.

use super::activation_table::{ActTable, TableKey};
use crate::inputs::TrialInputs;
use crate::musculotendon::MuscleUnit;
use crate::path::MusclePath;
use std::sync::Arc;

/// What a [`Channel`] was computed from: its activation table's key (with the trial and the
/// muscle's name, which select its envelope and geometry series), the fatigue rate, the
/// musculotendon-length polynomial and the knee moment arm.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct ChannelKey {
    pub(super) table: TableKey,
    fatigue: f64,
    poly: [f64; 4],
    knee: f64,
}

impl ChannelKey {
    /// The key of `unit`'s channel on `inputs` with electromechanical delay `delay` (s).
    pub(super) fn new(inputs: &TrialInputs, unit: &MuscleUnit, delay: f64) -> Self {
        ChannelKey {
            table: TableKey::new(inputs, unit, delay),
            fatigue: unit.fatigue_rate,
            poly: unit.poly,
            knee: unit.knee_moment_arm,
        }
    }
}

/// Per-trial, per-muscle inputs of the fibre ODE at the samples.
#[derive(Clone, Debug)]
pub(crate) struct Channel {
    pub(super) key: ChannelKey,
    /// Per sample `[act, dt·d(act)/dt, LMT, dt·dLMT/dt]`, `act = â·exp(−k∫â)`.
    pub(super) drive: Vec<[f64; 4]>,
    /// `LMT` at the samples (m).
    pub(crate) lmt: Vec<f64>,
    /// Ankle moment arm at the samples (m).
    pub(crate) r: Vec<f64>,
    /// The activation it was built from.
    pub(super) table: Arc<ActTable>,
}

impl Channel {
    /// Tabulates the drive of `unit` (envelope `env`, geometry `path`) on `inputs` from its
    /// activation table.
    pub(super) fn build(
        key: ChannelKey,
        inputs: &TrialInputs,
        unit: &MuscleUnit,
        env: &[f64],
        path: &MusclePath<'_>,
        table: Arc<ActTable>,
    ) -> Self {
        let n = inputs.len();
        let qd = inputs.velocity();
        let dt = 1.0 / inputs.fs();
        let nl = unit.activation.nonlinearity;
        let kf = unit.fatigue_rate;
        let z = if kf > 0.0 { table.z(env, inputs) } else { &[] };
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
            let lmt = path.lmt_sample(inputs, i);
            let r = path.moment_arm_sample(inputs, i);
            let dlmt = match path {
                // the ankle polynomial alone: `dt·r·q̇` in this order
                MusclePath::Poly { knee: None, .. } => dt * r * qd[i],
                _ => dt * path.vmt_sample(inputs, i),
            };
            drive.push([ah * phi, dt * (dah * phi + ah * dphi), lmt, dlmt]);
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

    /// The activation `a` and `∫â` at the samples (the integral computed on first use; `env`
    /// is the muscle's envelope).
    pub(crate) fn activation<'a>(
        &'a self,
        env: &[f64],
        inputs: &TrialInputs,
    ) -> (&'a [f64], &'a [f64]) {
        (&self.table.a, self.table.z(env, inputs))
    }
}
