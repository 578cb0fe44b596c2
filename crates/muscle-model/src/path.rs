//! A muscle's musculotendon length `LMT`, its rate `vMT` and its ankle moment arm `r` on one
//! trial ([`MusclePath`]), from one of two sources:
//!
//! ```text
//! polynomial:  LMT(t) = P(q(t)) − r_knee·k(t),   vMT = r(q)·q̇ − r_knee·k̇,   r = P'(q)
//! series:      LMT(t), r(t) linear in time between the samples of the trial's series
//! ```
//!
//! `q(t)` is the trial's cubic Hermite angle, `k(t)` its knee angle linear in time between
//! samples (0 without a knee series); in a low-rate trial ([`TrialInputs::is_low_rate`]) the
//! knee angle and the series' length are cubics through the samples with central-difference
//! slopes instead ([`TrialInputs::series_at`]). Where a formulation integrates `LMT` from `vMT`
//! ([`crate::Formulation::FourState`]), `k̇` and the series' rate are the derivatives of those
//! interpolants (on the current sample interval for the linear ones): their integral is then
//! the interpolant itself, so the integrated `LMT` stays on the path. The fast formulation
//! reads `LMT` by cubic Hermite from its values and rates at its table's points; on the
//! samples' grid the rates are central differences (one-sided at the ends), the same rule as
//! the ankle velocity, so that curve passes through every sample and departs from the linear
//! interpolant by `O(Δt²·L̈)` between them; in a low-rate trial its points, several per
//! sample interval, lie on the path's own `LMT(t)` above.
//! Without a knee series, or for a muscle with no knee moment arm, the polynomial path is the
//! ankle polynomial alone, evaluated with exactly the operations of the knee-extended model.

use crate::error::ModelError;
use crate::inputs::{GeometrySeries, TrialInputs};
use crate::musculotendon::MuscleUnit;

/// Where a muscle's geometry comes from on a trial.
#[derive(Clone, Copy, Debug)]
pub(crate) enum MusclePath<'a> {
    /// The length polynomial, with the knee term when the trial has a knee angle and the
    /// muscle a knee moment arm.
    Poly {
        c: [f64; 4],
        knee: Option<(f64, &'a [f64])>,
    },
    /// The trial's series.
    Series(&'a GeometrySeries),
}

impl<'a> MusclePath<'a> {
    /// The path of `unit` on `inputs`: the trial's series for the muscle when there is one,
    /// else its polynomial; an error when the muscle has neither.
    pub(crate) fn new(unit: &MuscleUnit, inputs: &'a TrialInputs) -> Result<Self, ModelError> {
        if let Some(g) = inputs.geometry(unit.name) {
            return Ok(MusclePath::Series(g));
        }
        if unit.geometry_from_trial {
            return Err(ModelError::input(
                format!("geometry of {}", unit.name),
                format!(
                    "muscle `{}` has no length polynomial and the trial gives no musculotendon \
                     length and moment-arm series for it",
                    unit.name
                ),
            ));
        }
        let knee = match inputs.knee_angle() {
            Some(k) if unit.knee_moment_arm != 0.0 => Some((unit.knee_moment_arm, k)),
            _ => None,
        };
        Ok(MusclePath::Poly { c: unit.poly, knee })
    }

    /// `LMT` at sample `i` (m).
    #[inline]
    pub(crate) fn lmt_sample(&self, inputs: &TrialInputs, i: usize) -> f64 {
        match self {
            MusclePath::Poly { c, knee } => {
                let l = crate::geometry::lmt(c, inputs.angle()[i]);
                match knee {
                    Some((rk, k)) => l - rk * k[i],
                    None => l,
                }
            }
            MusclePath::Series(g) => g.lmt_m[i],
        }
    }

    /// Ankle moment arm at sample `i` (m).
    #[inline]
    pub(crate) fn moment_arm_sample(&self, inputs: &TrialInputs, i: usize) -> f64 {
        match self {
            MusclePath::Poly { c, .. } => crate::geometry::moment_arm(c, inputs.angle()[i]),
            MusclePath::Series(g) => g.moment_arm_m[i],
        }
    }

    /// `vMT` at sample `i` for the Hermite reading of the fast formulation (m/s; central
    /// differences of the knee angle and of a series).
    #[inline]
    pub(crate) fn vmt_sample(&self, inputs: &TrialInputs, i: usize) -> f64 {
        match self {
            MusclePath::Poly { c, knee } => {
                let v = crate::geometry::moment_arm(c, inputs.angle()[i]) * inputs.velocity()[i];
                match knee {
                    Some((rk, k)) => v - rk * central_rate(k, i, inputs.fs()),
                    None => v,
                }
            }
            MusclePath::Series(g) => central_rate(&g.lmt_m, i, inputs.fs()),
        }
    }

    /// `LMT` at time `t` (m).
    #[inline]
    pub(crate) fn lmt_at(&self, inputs: &TrialInputs, t: f64) -> f64 {
        match self {
            MusclePath::Poly { c, knee } => {
                let l = crate::geometry::lmt(c, inputs.angle_value_at(t));
                match knee {
                    Some((rk, k)) => l - rk * inputs.series_at(k, t),
                    None => l,
                }
            }
            MusclePath::Series(g) => inputs.series_at(&g.lmt_m, t),
        }
    }

    /// `vMT` at time `t` (m/s; slopes of the linear interpolants).
    #[inline]
    pub(crate) fn vmt_at(&self, inputs: &TrialInputs, t: f64) -> f64 {
        match self {
            MusclePath::Poly { c, knee } => {
                let (q, qd) = inputs.angle_at(t);
                let v = crate::geometry::moment_arm(c, q) * qd;
                match knee {
                    Some((rk, k)) => v - rk * inputs.series_rate_at(k, t),
                    None => v,
                }
            }
            MusclePath::Series(g) => inputs.series_rate_at(&g.lmt_m, t),
        }
    }
}

/// Central difference of `v` at sample `i` (one-sided at the ends), per second.
#[inline]
fn central_rate(v: &[f64], i: usize, fs: f64) -> f64 {
    let n = v.len();
    if i == 0 {
        (v[1] - v[0]) * fs
    } else if i == n - 1 {
        (v[n - 1] - v[n - 2]) * fs
    } else {
        0.5 * (v[i + 1] - v[i - 1]) * fs
    }
}
