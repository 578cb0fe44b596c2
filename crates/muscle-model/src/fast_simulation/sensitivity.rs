//! Forward sensitivities of one muscle's fibre length, integrated with it.
//!
//! For parameters `θ` of the fibre's constants (`LOM`, `LST`, `α0`, `vmax`, the curves), the
//! sensitivity `s = ∂LM/∂θ` obeys the variational equation of `L̇M = vM(act, LMT, LM; θ)`,
//!
//! ```text
//! ṡ = (∂vM/∂LM)·s + ∂vM/∂θ,     s(t₀) = −(∂g/∂θ)/(∂g/∂LM)
//! ```
//!
//! where `g(LM; θ) = F̃T/cos α − fpe − act·fl` is the static-equilibrium residual whose root is
//! the initial fibre length (at the fibre-length floor, `s(t₀) = ∂LM_min/∂θ`; at rest with the
//! tendon just slack, where `g` is flat, the root is the slack length and `s(t₀)` follows from
//! `ε(LM; θ) = 0`). The partial
//! derivatives are those of the right-hand side as written: it is evaluated in dual numbers
//! ([`crate::curves::Scalar`]) seeded in `θ` and in `s`. The state `[LM, act, s₁ … s_K]` is
//! integrated by one [`ode::DoPri5`] whose error norm measures every component, so that the
//! steps resolve the sensitivities as well as the fibre length: `s` is integrated, not a
//! difference of two adaptive integrations, so it has none of their jitter. (Controlling the
//! steps by `[LM, act]` alone, the simulation's own steps, leaves the α0 columns 0.1–0.5 % from
//! the tight reference at the default tolerances; controlled by all, 0.02–0.05 %.) The torque's
//! derivative follows at every sample from `∂(F0·fT(ε(LMT, LM; θ))·r)/∂θ` with `LM` carrying
//! `s`.
//!
//! The activation's shape `A` and the electromechanical delay `d` move the drive instead: the
//! tabulated `act = f_A(a)` and its rate, which the fibre reads by cubic Hermite interpolation.
//! The interpolation is linear in the table, so `∂act(t)/∂θ` is the same interpolation of the
//! table's derivatives ([`drive_derivative`]), and it enters the variational equation through
//! `∂vM/∂act`. With the table's `a` and `ȧ` (no fatigue),
//!
//! ```text
//! ∂act/∂A = ∂f_A/∂A(a),               ∂(d act/dt)/∂A = ∂f_A′/∂A(a)·ȧ
//! a_d(tⱼ) = H(a₀, ȧ₀)(tⱼ − d):         ∂a/∂d = −Ḣ(tⱼ − d),   ∂ȧ/∂d = −∂ȧ/∂u·u̇(tⱼ − d) + ∂ȧ/∂a·∂a/∂d
//! ∂act/∂d = f_A′(a)·∂a/∂d,            ∂(d act/dt)/∂d = f_A″(a)·∂a/∂d·ȧ + f_A′(a)·∂ȧ/∂d
//! ```
//!
//! (`H` the undelayed table's Hermite interpolant; 0 where the delayed input is held at its
//! first value, and the derivative with respect to `d` is the right one at `d = 0`).

use super::channel::Channel;
use super::fibre::Fibre;
use super::integrate::{drive_at, hermite_weights};
use crate::inputs::TrialInputs;
use crate::settings::SimSettings;
use crate::stats::SimStats;
use nalgebra::SVector;
use num_dual::{Derivative, Dual64, DualSVec64};
use ode::{DoPri5, OdeError, OdeSystem};

/// The sensitivities are integrated at this share of the simulation's tolerances.
const SENSITIVITY_TOLERANCE: f64 = 0.1;

/// A dual number of value `re` and derivative `eps`.
pub(crate) fn dual<const K: usize>(re: f64, eps: [f64; K]) -> DualSVec64<K> {
    DualSVec64::new(re, Derivative::some(SVector::from(eps)))
}

/// The derivative part of `x` (zeros when it carries none).
pub(crate) fn eps_of<const K: usize>(x: &DualSVec64<K>) -> [f64; K] {
    let m = x.eps.unwrap_generic(nalgebra::Const::<K>, nalgebra::U1);
    std::array::from_fn(|k| m[k])
}

/// What moves a fibre's drive: the activation's shape or the electromechanical delay.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum DriveSeat {
    /// The A-model's shape `A`.
    Shape,
    /// The delay `d` (the derivative per second).
    Delay,
}

/// The derivative of a channel's drive `[act, Δt·d(act)/dt]` at every grid point in one
/// sensitivity direction.
#[derive(Clone, Debug)]
pub(crate) struct DriveSensitivity {
    /// The sensitivity direction it seeds.
    pub(crate) direction: usize,
    pub(crate) table: Vec<[f64; 2]>,
}

/// The derivative of `ch`'s drive with respect to `seat`, times `scale`, at every point of its
/// grid (`env` the muscle's envelope; the channel has no fatigue: the caller refuses it).
pub(crate) fn drive_derivative(
    ch: &Channel,
    inputs: &TrialInputs,
    env: &[f64],
    seat: DriveSeat,
    scale: f64,
    direction: usize,
) -> DriveSensitivity {
    let table = &ch.table;
    let nl = table.act.nonlinearity;
    let dt = 1.0 / ch.grid.rate;
    let points = table.a.iter().zip(&table.adot);
    let table_of = match seat {
        DriveSeat::Shape => points
            .map(|(&a, &adot)| {
                let [df, dslope] = nl.shape_derivatives(a);
                [scale * df, scale * dt * dslope * adot]
            })
            .collect(),
        DriveSeat::Delay => {
            let base = table.base.as_deref().unwrap_or(table);
            let (k1, k2) = (table.act.k1, table.act.k2);
            let d = table.key.delay;
            let g = ch.grid;
            points
                .enumerate()
                .map(|(j, (&a, &adot))| {
                    let s = g.time(j) - d;
                    let x = (s - g.t0) * g.rate;
                    let da = if x > 0.0 && x < (g.len - 1) as f64 {
                        let i = (x as usize).min(g.len - 2);
                        let (_, dv) = crate::interp::hermite(
                            base.a[i],
                            base.a[i + 1],
                            dt * base.adot[i],
                            dt * base.adot[i + 1],
                            x - i as f64,
                        );
                        -dv * g.rate
                    } else {
                        0.0
                    };
                    let u = inputs.envelope_value_at(env, s);
                    let du = if (0.0..=1.0).contains(&u) {
                        inputs.envelope_rate_at(env, s)
                    } else {
                        0.0
                    };
                    let u = u.clamp(0.0, 1.0);
                    let rate_u = (k1 * u + k2) + (u - a) * k1;
                    let rate_a = -(k1 * u + k2);
                    let dadot = -rate_u * du + rate_a * da;
                    let slope = nl.slope(a);
                    [
                        scale * slope * da,
                        scale * dt * (nl.curvature(a) * da * adot + slope * dadot),
                    ]
                })
                .collect()
        }
    };
    DriveSensitivity {
        direction,
        table: table_of,
    }
}

/// The fibre ODE with its `K` sensitivities on `[LM, act, s₁ … s_K]` (`N = K + 2`).
struct SensitivitySystem<'a, const K: usize> {
    drive: &'a [[f64; 4]],
    t0: f64,
    fs: f64,
    fib: &'a Fibre<DualSVec64<K>>,
    /// The drive's derivatives by direction ([`DriveSensitivity`]).
    moved: &'a [DriveSensitivity],
}

impl<const K: usize> SensitivitySystem<'_, K> {
    /// The activation at `t` with its derivatives in the directions that move the drive.
    #[inline]
    fn activation(&self, act: f64, t: f64) -> DualSVec64<K> {
        if self.moved.is_empty() {
            return DualSVec64::from(act);
        }
        let (i, h, _) = hermite_weights(self.drive.len(), self.t0, self.fs, t);
        let mut eps = [0.0; K];
        for m in self.moved {
            let (d0, d1) = (m.table[i], m.table[i + 1]);
            eps[m.direction] = h[0] * d0[0] + h[1] * d0[1] + h[2] * d1[0] + h[3] * d1[1];
        }
        dual(act, eps)
    }
}

impl<const N: usize, const K: usize> OdeSystem<N> for SensitivitySystem<'_, K> {
    #[inline]
    fn rhs(&mut self, t: f64, y: &[f64; N], dy: &mut [f64; N]) {
        let (act, dact, lmt) = drive_at(self.drive, self.t0, self.fs, t);
        let lm = dual(y[0], std::array::from_fn(|k| y[2 + k]));
        let v = self.fib.velocity(self.activation(act, t), lmt, lm);
        dy[0] = v.re;
        dy[1] = dact;
        let e = eps_of(&v);
        dy[2..K + 2].copy_from_slice(&e);
    }
}

/// The initial fibre length `lm0` (the equilibrium's root, found by the caller) with its
/// derivative with respect to the seeds of `fib` and of the drive (`moved`; `real` the same
/// constants in `f64`).
pub(crate) fn initial_length<const K: usize>(
    ch: &Channel,
    fib: &Fibre<DualSVec64<K>>,
    real: &Fibre<Dual64>,
    moved: &[DriveSensitivity],
    lm0: f64,
) -> DualSVec64<K> {
    if lm0 <= fib.lm_min.re {
        // at the floor the fibre length is the floor's
        return fib.lm_min;
    }
    let mut act_eps = [0.0; K];
    for m in moved {
        act_eps[m.direction] = m.table[0][0];
    }
    let act = dual(ch.drive[0][0], act_eps);
    let lmt = ch.drive[0][2];
    let g_theta = fib.equilibrium_residual(act, lmt, DualSVec64::from(lm0));
    let g_lm = real
        .equilibrium_residual(Dual64::from(act.re), lmt, Dual64::new(lm0, 1.0))
        .eps;
    if g_lm != 0.0 && g_lm.is_finite() {
        let gt = eps_of(&g_theta);
        return dual(lm0, std::array::from_fn(|k| -gt[k] / g_lm));
    }
    // At rest with the tendon just slack the residual is flat (no active force, no tendon
    // force below slack): the root the bisection finds is the slack length, ε(LM; θ) = 0.
    let e_theta = eps_of(&fib.strain(lmt, DualSVec64::from(lm0)));
    let e_lm = real.strain(lmt, Dual64::new(lm0, 1.0)).eps;
    dual(
        lm0,
        std::array::from_fn(|k| {
            let s = -e_theta[k] / e_lm;
            if s.is_finite() {
                s
            } else {
                0.0
            }
        }),
    )
}

/// A fibre length and its sensitivities at every sample, as [`run_sensitivities`] writes them.
#[derive(Clone, Debug, Default)]
pub(crate) struct SensitivityTrace {
    /// `LM` at every sample.
    pub(crate) lm: Vec<f64>,
    /// `∂LM/∂θ_k` at every sample, by direction `k`.
    pub(crate) sens: Vec<Vec<f64>>,
}

/// Integrates `LM` and its `K` sensitivities over the samples of `inputs` (`N = K + 2`) into
/// `out`.
pub(crate) fn run_sensitivities<const N: usize, const K: usize>(
    ch: &Channel,
    inputs: &TrialInputs,
    fib: &Fibre<DualSVec64<K>>,
    moved: &[DriveSensitivity],
    lm0: DualSVec64<K>,
    settings: &SimSettings,
    out: &mut SensitivityTrace,
) -> Result<SimStats, OdeError> {
    assert_eq!(N, K + 2, "the state is [LM, act] and K sensitivities");
    let times = inputs.times();
    let n = times.len();
    let s0 = eps_of(&lm0);
    out.lm.clear();
    out.lm.resize(n, 0.0);
    out.sens.resize(K, Vec::new());
    let (lm_out, sens_out) = (&mut out.lm, &mut out.sens);
    lm_out[0] = lm0.re;
    for k in 0..K {
        sens_out[k].clear();
        sens_out[k].resize(n, 0.0);
        sens_out[k][0] = s0[k];
    }
    if n < 2 {
        return Ok(SimStats::default());
    }
    let mut sys = SensitivitySystem {
        drive: &ch.drive,
        t0: ch.grid.t0,
        fs: ch.grid.rate,
        fib,
        moved,
    };
    let mut y0 = [0.0; N];
    y0[0] = lm0.re;
    y0[1] = ch.drive[0][0];
    y0[2..].copy_from_slice(&s0);
    let mut adaptive = settings.adaptive(inputs);
    adaptive.rtol *= SENSITIVITY_TOLERANCE;
    adaptive.atol *= SENSITIVITY_TOLERANCE;
    let mut stepper = DoPri5::<N>::new(adaptive)?.with_log_controller();
    stepper.init(&mut sys, times[0], y0, times[n - 1])?;
    let mut next = 1;
    while next < n {
        stepper.step(&mut sys)?;
        let dense = stepper.dense();
        let to = next + times[next..].partition_point(|&x| x <= dense.t());
        dense.component_into(&times[next..to], 0, &mut lm_out[next..to]);
        for (k, out) in sens_out.iter_mut().enumerate().take(K) {
            dense.component_into(&times[next..to], 2 + k, &mut out[next..to]);
        }
        next = to;
        floor_jump(&mut stepper, &mut sys, fib);
    }
    Ok(stepper.stats().into())
}

/// The sensitivities' jump where the fibre reaches its floor.
///
/// At `LM = lm_min(θ)` with a shortening velocity the velocity is held at zero: the
/// right-hand side switches at a time `t*(θ)` where `LM(t*; θ) = lm_min(θ)`. Continuity of
/// `LM` across the switch, differentiated in `θ`, gives `s⁺ + f⁺·∂t*/∂θ = s⁻ + f⁻·∂t*/∂θ`
/// with `∂t*/∂θ = −(s⁻ − ∂lm_min/∂θ)/f⁻`, and with `f⁺ = 0`:
///
/// ```text
/// s⁺ = ∂lm_min/∂θ
/// ```
///
/// (the clamped fibre's length is the floor's, so is its derivative), after which `ṡ = 0`
/// while the clamp holds. The velocity leaves the floor through zero, continuously, so the
/// exit needs no jump. Without this the sensitivity kept its value from before the clamp,
/// harmless while the tendon is slack (`∂τ/∂θ ∝ fT′ = 0`) and wrong by a spike where it
/// tightens again (a gastrocnemius on a knee-flexed trial). Applied at the end of the step
/// in which the clamp holds; that step's samples keep the values from before.
fn floor_jump<const N: usize, const K: usize>(
    stepper: &mut DoPri5<N>,
    sys: &mut SensitivitySystem<'_, K>,
    fib: &Fibre<DualSVec64<K>>,
) {
    let y = *stepper.y();
    if y[0] > fib.lm_min.re {
        return;
    }
    let mut dy = [0.0; N];
    sys.rhs(stepper.t(), &y, &mut dy);
    if dy[0] != 0.0 {
        return;
    }
    let floor = eps_of(&fib.lm_min);
    for (k, v) in floor.iter().enumerate() {
        if y[2 + k] != *v {
            stepper.set_component(2 + k, *v);
        }
    }
}
