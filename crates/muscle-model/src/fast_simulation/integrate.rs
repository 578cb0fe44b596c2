//! The fibre-length integration of one or several muscles over a trial's samples.
//!
//! Each muscle integrates `[LM, act]` with [`ode::DoPri5`] (log-form PI controller) and dense
//! output at the samples:
//!
//! ```text
//! L̇M = vM(act(t), LMT(t), LM),     d(act)/dt read from the drive
//! ```
//!
//! with `act`, `d(act)/dt` and `LMT` interpolated between the drive's points by cubic Hermite from the
//! [`Channel`]'s drive. The activation input needs no integration (it is tabulated), but its
//! embedded error estimate enters the step-size control.

use super::channel::Channel;
use super::fibre::Fibre;
use crate::inputs::TrialInputs;
use crate::settings::SimSettings;
use crate::stats::SimStats;
use ode::{DoPri5, OdeError, OdeSystem};

/// The cubic Hermite weights at time `t` on a table of `n` points at `t0 + j/fs`: the first
/// point `i` of the interval holding `t`, the weights of `[vᵢ, Δt·v̇ᵢ, vᵢ₊₁, Δt·v̇ᵢ₊₁]` for the
/// value, and those of `vᵢ − vᵢ₊₁`, `Δt·v̇ᵢ`, `Δt·v̇ᵢ₊₁` for its derivative in `s`.
#[inline(always)]
pub(super) fn hermite_weights(n: usize, t0: f64, fs: f64, t: f64) -> (usize, [f64; 4], [f64; 3]) {
    let x = ((t - t0) * fs).clamp(0.0, (n - 1) as f64);
    let i = (x as usize).min(n - 2);
    let s = x - i as f64;
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
    (i, [h00, h10, h01, h11], [g00, g10, g11])
}

/// Cubic Hermite interpolation of the drive (tabulated at `t0 + j/fs`) at time `t`:
/// `(act, d(act)/dt, LMT)`.
#[inline(always)]
pub(super) fn drive_at(drive: &[[f64; 4]], t0: f64, fs: f64, t: f64) -> (f64, f64, f64) {
    let (i, [h00, h10, h01, h11], [g00, g10, g11]) = hermite_weights(drive.len(), t0, fs, t);
    let (d0, d1) = (drive[i], drive[i + 1]);
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
                t0: ch.grid.t0,
                fs: ch.grid.rate,
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
    let stepper = DoPri5::<2>::new(settings.adaptive(inputs))
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
