//! The per-muscle inputs of the fibre ODE at the points of a trial's [`TableGrid`] (its
//! samples, or several points per sample interval in a low-rate trial) ([`Channel`]).
//!
//! With the muscle's activation table (`a`, `ȧ`, `∫â`), the fatigue rate `k` and the
//! muscle's path on the trial ([`crate::path`]), each point holds
//!
//! ```text
//! act = â·φ,  φ = exp(−k∫â),  d(act)/dt = f_A'(a)·ȧ·φ − k·â²·φ,
//! LMT = P(q) − r_knee·k,  dLMT/dt = r(q)·q̇ − r_knee·k̇     (or a series and its rate)
//! ```
//!
//! (rates scaled by the grid's interval, as the cubic Hermite interpolation between points
//! reads them), and each sample `LMT`, `r` alone for the torque. On the samples' grid the rates
//! of the knee angle and of a series are central differences; between the samples of a
//! low-rate trial `LMT(t)` and its rate are the path's own (`q(t)` and the trial's cubics of
//! the knee angle or series), the curves the other formulations integrate.

use super::activation_table::{ActTable, TableKey};
use super::grid::TableGrid;
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

/// Per-trial, per-muscle inputs of the fibre ODE at the grid's points.
#[derive(Clone, Debug)]
pub(crate) struct Channel {
    pub(super) key: ChannelKey,
    /// Per point of `grid` `[act, dt·d(act)/dt, LMT, dt·dLMT/dt]`, `act = â·exp(−k∫â)`, `dt`
    /// the grid's interval.
    pub(super) drive: Vec<[f64; 4]>,
    /// The points `drive` is tabulated at.
    pub(super) grid: TableGrid,
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
        let grid = TableGrid::of(inputs);
        let dt = 1.0 / grid.rate;
        let nl = unit.activation.nonlinearity;
        let kf = unit.fatigue_rate;
        let z = if kf > 0.0 { table.z(env, inputs) } else { &[] };
        // `[act, dt·d(act)/dt]` at point `j`
        let act_at = |j: usize| {
            let (a, adot) = (table.a[j], table.adot[j]);
            let ah = nl.apply(a);
            let dah = nl.slope(a) * adot;
            let (phi, dphi) = if kf > 0.0 {
                let phi = (-kf * z[j]).exp();
                (phi, -kf * ah * phi)
            } else {
                (1.0, 0.0)
            };
            [ah * phi, dt * (dah * phi + ah * dphi)]
        };
        let mut drive = Vec::with_capacity(grid.len);
        let mut lmt_v = Vec::with_capacity(n);
        let mut r_v = Vec::with_capacity(n);
        for (i, &qdi) in qd.iter().enumerate().take(n) {
            let lmt = path.lmt_sample(inputs, i);
            let r = path.moment_arm_sample(inputs, i);
            if grid.per_sample == 1 {
                let dlmt = match path {
                    // the ankle polynomial alone: `dt·r·q̇` in this order
                    MusclePath::Poly { knee: None, .. } => dt * r * qdi,
                    _ => dt * path.vmt_sample(inputs, i),
                };
                let [act, dact] = act_at(i);
                drive.push([act, dact, lmt, dlmt]);
            }
            lmt_v.push(lmt);
            r_v.push(r);
        }
        if grid.per_sample > 1 {
            for j in 0..grid.len {
                let t = grid.time(j);
                let [act, dact] = act_at(j);
                let lmt = path.lmt_at(inputs, t);
                drive.push([act, dact, lmt, dt * path.vmt_at(inputs, t)]);
            }
        }
        Channel {
            key,
            drive,
            grid,
            lmt: lmt_v,
            r: r_v,
            table,
        }
    }

    /// The activation `a` and `∫â` at the grid's points (the integral computed on first use;
    /// `env` is the muscle's envelope) and the points per sample interval: sample `i` is point
    /// `i·per_sample`.
    pub(crate) fn activation<'a>(
        &'a self,
        env: &[f64],
        inputs: &TrialInputs,
    ) -> (&'a [f64], &'a [f64], usize) {
        (
            &self.table.a,
            self.table.z(env, inputs),
            self.grid.per_sample,
        )
    }
}
