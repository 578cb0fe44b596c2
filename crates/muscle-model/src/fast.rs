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

use crate::curves::Curves;
use crate::inputs::TrialInputs;
use crate::simulate::{SimSettings, SimStats};
use crate::unit::{MuscleUnit, IX_A, IX_FATIGUE, IX_FT, IX_LM, IX_LMT, STATE_DIM};
use ode::{DoPri5, OdeError, OdeSystem};
use std::sync::Arc;

/// RK4 substeps per sample interval when the activation is precomputed.
pub const ACT_SUBSTEPS: usize = 4;

/// What a [`Channel`] was computed from.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct ChannelKey {
    uid: u64,
    n: usize,
    j: usize,
    k1: f64,
    k2: f64,
    shape: f64,
    delay: f64,
    fatigue: f64,
    poly: [f64; 4],
}

impl ChannelKey {
    /// The key of `unit`'s channel on `inputs` with electromechanical delay `delay` (s).
    pub(crate) fn new(inputs: &TrialInputs, unit: &MuscleUnit, delay: f64) -> Self {
        let act = unit.activation;
        ChannelKey {
            uid: inputs.uid(),
            n: inputs.len(),
            j: unit.muscle.index(),
            k1: act.k1,
            k2: act.k2,
            shape: act.nonlinearity.shape,
            delay,
            fatigue: unit.fatigue_rate,
            poly: unit.poly,
        }
    }
}

/// Channels kept per [`TrialInputs`] (shared by its clones and by every thread).
pub(crate) const SHARED_CHANNELS: usize = 12;

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
    /// Activation `a` at the samples.
    a: Vec<f64>,
    /// `∫₀ᵗ â dt` at the samples.
    z: Vec<f64>,
}

/// The channel of `unit` on `inputs`: `current` when its key matches, else one kept with the
/// inputs (shared across threads), else a new one (then kept). Channels are deterministic
/// functions of their key, so where one comes from does not change any result.
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
    let shared = inputs.channel_cache();
    {
        let list = shared.lock().unwrap_or_else(|e| e.into_inner());
        if let Some(c) = list.iter().find(|c| c.key == key) {
            return Arc::clone(c);
        }
    }
    let c = Arc::new(Channel::build(key, inputs, unit, delay));
    let mut list = shared.lock().unwrap_or_else(|e| e.into_inner());
    if let Some(c) = list.iter().find(|c| c.key == key) {
        return Arc::clone(c);
    }
    if list.len() >= SHARED_CHANNELS {
        list.remove(0);
    }
    list.push(Arc::clone(&c));
    c
}

impl Channel {
    /// Integrates the activation of `unit` on `inputs` and tabulates the drive.
    fn build(key: ChannelKey, inputs: &TrialInputs, unit: &MuscleUnit, delay: f64) -> Self {
        let act = unit.activation;
        let n = inputs.len();
        let j = key.j;
        let t = inputs.times();
        let q = inputs.angle();
        let qd = inputs.velocity();
        let dt = 1.0 / inputs.fs();
        let nl = act.nonlinearity;
        let kf = unit.fatigue_rate;
        let mut ch = Channel {
            key,
            drive: Vec::with_capacity(n),
            lmt: Vec::with_capacity(n),
            r: Vec::with_capacity(n),
            a: Vec::with_capacity(n),
            z: Vec::with_capacity(n),
        };
        let u_at = |tt: f64| inputs.envelope_at(j, tt - delay).clamp(0.0, 1.0);
        let f = |tt: f64, y: [f64; 2]| -> [f64; 2] { [act.rate(u_at(tt), y[0]), nl.apply(y[0])] };
        let mut y = [u_at(t[0]), 0.0];
        let hs = dt / ACT_SUBSTEPS as f64;
        for i in 0..n {
            let (a, z) = (y[0], y[1]);
            let adot = act.rate(u_at(t[i]), a);
            let ah = nl.apply(a);
            let dah = nl.slope(a) * adot;
            let (phi, dphi) = if kf > 0.0 {
                let phi = (-kf * z).exp();
                (phi, -kf * ah * phi)
            } else {
                (1.0, 0.0)
            };
            let c = unit.poly;
            let lmt = crate::geometry::lmt(&c, q[i]);
            let r = crate::geometry::moment_arm(&c, q[i]);
            ch.drive
                .push([ah * phi, dt * (dah * phi + ah * dphi), lmt, dt * r * qd[i]]);
            ch.lmt.push(lmt);
            ch.r.push(r);
            ch.a.push(a);
            ch.z.push(z);
            if i + 1 < n {
                let mut tt = t[i];
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
        ch
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
pub(crate) fn unit_torque(fib: &Fibre, ch: &Channel, lm: &[f64], out: &mut [f64]) {
    let n = out.len();
    let (lm, lmt, r) = (&lm[..n], &ch.lmt[..n], &ch.r[..n]);
    for i in 0..n {
        out[i] = fib.tendon_force(lmt[i], lm[i]) * r[i];
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
    let drive = &ch.drive[..];
    let times = inputs.times();
    let n = times.len();
    let t0 = times[0];
    let fs = inputs.fs();
    let t_end = times[n - 1];
    let mut sys = FibreSystem { drive, t0, fs, fib };
    if !lm0.is_finite() {
        return Err(OdeError::NonFinite { t: t0 });
    }
    lm_out[0] = lm0;
    if n < 2 {
        return Ok(SimStats::default());
    }
    let mut stepper = DoPri5::<2>::new(settings.adaptive())?.with_log_controller();
    stepper.init(&mut sys, t0, [lm0, drive[0][0]], t_end)?;
    let mut next = 1;
    while next < n {
        stepper.step(&mut sys)?;
        let dense = stepper.dense();
        let t = dense.t();
        while next < n && times[next] <= t {
            lm_out[next] = dense.component(times[next], 0);
            next += 1;
        }
    }
    Ok(stepper.stats().into())
}

/// The recorded state `[a, F̃T, LM, LMT, ∫â]` at sample `i`.
pub(crate) fn state(ch: &Channel, i: usize, lm: f64, lmt: f64, ft: f64) -> [f64; STATE_DIM] {
    let mut y = [0.0; STATE_DIM];
    y[IX_A] = ch.a[i];
    y[IX_FT] = ft;
    y[IX_LM] = lm;
    y[IX_LMT] = lmt;
    y[IX_FATIGUE] = ch.z[i];
    y
}
