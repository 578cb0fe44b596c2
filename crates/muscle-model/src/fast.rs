//! The fast forward model ([`crate::Formulation::Fast`]): activation and musculotendon length
//! precomputed once per trial, then each fibre length integrated alone (scalar Dormand–Prince
//! 5(4) with dense output at the samples).
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
use ode::OdeError;
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

// Dormand–Prince 5(4) coefficients (Hairer, Nørsett & Wanner, table 5.2) and the
// 4th-order dense-output weights.
const C2: f64 = 1.0 / 5.0;
const C3: f64 = 3.0 / 10.0;
const C4: f64 = 4.0 / 5.0;
const C5: f64 = 8.0 / 9.0;
const A21: f64 = 1.0 / 5.0;
const A31: f64 = 3.0 / 40.0;
const A32: f64 = 9.0 / 40.0;
const A41: f64 = 44.0 / 45.0;
const A42: f64 = -56.0 / 15.0;
const A43: f64 = 32.0 / 9.0;
const A51: f64 = 19372.0 / 6561.0;
const A52: f64 = -25360.0 / 2187.0;
const A53: f64 = 64448.0 / 6561.0;
const A54: f64 = -212.0 / 729.0;
const A61: f64 = 9017.0 / 3168.0;
const A62: f64 = -355.0 / 33.0;
const A63: f64 = 46732.0 / 5247.0;
const A64: f64 = 49.0 / 176.0;
const A65: f64 = -5103.0 / 18656.0;
const A71: f64 = 35.0 / 384.0;
const A73: f64 = 500.0 / 1113.0;
const A74: f64 = 125.0 / 192.0;
const A75: f64 = -2187.0 / 6784.0;
const A76: f64 = 11.0 / 84.0;
const E1: f64 = 71.0 / 57600.0;
const E3: f64 = -71.0 / 16695.0;
const E4: f64 = 71.0 / 1920.0;
const E5: f64 = -17253.0 / 339200.0;
const E6: f64 = 22.0 / 525.0;
const E7: f64 = -1.0 / 40.0;
const D1: f64 = -12715105075.0 / 11282082432.0;
const D3: f64 = 87487479700.0 / 32700410799.0;
const D4: f64 = -10690763975.0 / 1880347072.0;
const D5: f64 = 701980252875.0 / 199316789632.0;
const D6: f64 = -1453857185.0 / 822651844.0;
const D7: f64 = 69997945.0 / 29380423.0;
const SAFETY: f64 = 0.9;
const BETA: f64 = 0.04;
const FAC_MIN: f64 = 0.2;
const FAC_MAX: f64 = 10.0;
const H_MIN: f64 = 1e-14;
const LN_1E_4: f64 = -9.210_340_371_976_184;

/// Integrates the fibre length of `fib` over the samples of `inputs` (channel prepared) and
/// writes `LM` at every sample into `lm_out` (length = samples).
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
    // returns (L̇M, d(act)/dt): the activation input feeds the step-size control too
    let f = |t: f64, lm: f64| -> (f64, f64) {
        let (act, dact, lmt) = drive_at(drive, t0, fs, t);
        (fib.velocity(act, lmt, lm), dact)
    };
    let (rtol, atol, h_max) = (settings.rtol, settings.atol, settings.h_max);
    let mut stats = SimStats::default();
    if !lm0.is_finite() {
        return Err(OdeError::NonFinite { t: t0 });
    }
    lm_out[0] = lm0;
    let mut t = t0;
    let mut y = lm0;
    let (mut k1, mut a1) = f(t, y);
    stats.rhs_calls += 1;
    if !k1.is_finite() {
        return Err(OdeError::NonFinite { t });
    }
    // initial step (Hairer & Wanner's heuristic, one component)
    let sc = atol + rtol * y.abs();
    let (d0, d1) = ((y / sc).abs(), (k1 / sc).abs());
    let mut h0 = if d0 < 1e-5 || d1 < 1e-5 {
        1e-6
    } else {
        0.01 * d0 / d1
    };
    h0 = h0.min(h_max).min(t_end - t);
    let k2 = f(t + h0, y + h0 * k1).0;
    stats.rhs_calls += 1;
    let mut h = if k2.is_finite() {
        let d2 = ((k2 - k1) / sc).abs() / h0;
        let dmax = d1.max(d2);
        let h1 = if dmax <= 1e-15 {
            (h0 * 1e-3).max(1e-6)
        } else {
            (0.01 / dmax).powf(0.2)
        };
        (100.0 * h0).min(h1)
    } else {
        h0 * 1e-3
    }
    .min(h_max)
    .min(t_end - t);
    let mut err_prev_pow = (BETA * LN_1E_4).exp();
    let mut rejected_last = false;
    let expo1 = 0.2 - BETA * 0.75;
    let mut next = 1;
    while next < n {
        if stats.accepted + stats.rejected >= settings.max_steps {
            return Err(OdeError::MaxSteps {
                t,
                steps: settings.max_steps,
            });
        }
        let remaining = t_end - t;
        let mut hh = h.min(h_max);
        if hh >= remaining || remaining - hh < 1e-12 * remaining.abs().max(1.0) {
            hh = remaining;
        }
        if hh < H_MIN || t + hh == t {
            return Err(OdeError::StepSizeUnderflow { t, h: hh });
        }
        let (k2, _) = f(t + C2 * hh, y + hh * A21 * k1);
        let (k3, a3) = f(t + C3 * hh, y + hh * (A31 * k1 + A32 * k2));
        let (k4, a4) = f(t + C4 * hh, y + hh * (A41 * k1 + A42 * k2 + A43 * k3));
        let (k5, a5) = f(
            t + C5 * hh,
            y + hh * (A51 * k1 + A52 * k2 + A53 * k3 + A54 * k4),
        );
        let (k6, a6) = f(
            t + hh,
            y + hh * (A61 * k1 + A62 * k2 + A63 * k3 + A64 * k4 + A65 * k5),
        );
        let ynew = y + hh * (A71 * k1 + A73 * k3 + A74 * k4 + A75 * k5 + A76 * k6);
        let (k7, a7) = f(t + hh, ynew);
        stats.rhs_calls += 6;
        let e = hh * (E1 * k1 + E3 * k3 + E4 * k4 + E5 * k5 + E6 * k6 + E7 * k7);
        let e_lm = e / (atol + rtol * y.abs().max(ynew.abs()));
        // Error estimate of the activation over the step (the embedded estimate of
        // ∫ d(act)/dt dt), scaled like the activation state of the two-state system: it
        // shrinks steps that straddle a fast change of the input (an onset), whose effect on
        // LM the LM estimate alone misses in the dense output.
        let ea = hh * (E1 * a1 + E3 * a3 + E4 * a4 + E5 * a5 + E6 * a6 + E7 * a7);
        let act_end = drive_at(drive, t0, fs, t + hh).0;
        let e_a = ea / (atol + rtol * act_end.abs());
        let err = (0.5 * (e_lm * e_lm + e_a * e_a)).sqrt();
        if !(err.is_finite() && ynew.is_finite() && k7.is_finite()) {
            stats.rejected += 1;
            rejected_last = true;
            h = hh * 0.25;
            if h < H_MIN {
                return Err(OdeError::NonFinite { t });
            }
            continue;
        }
        // err^expo1 and err^BETA from one logarithm (cheaper than two powf)
        let ln_err = err.max(1e-300).ln();
        let fac11 = (expo1 * ln_err).exp();
        if err > 1.0 {
            stats.rejected += 1;
            rejected_last = true;
            h = hh / (1.0 / FAC_MIN).min(fac11 / SAFETY);
            continue;
        }
        let fac = (fac11 / err_prev_pow / SAFETY).clamp(1.0 / FAC_MAX, 1.0 / FAC_MIN);
        let mut h_new = hh / fac;
        if rejected_last {
            h_new = h_new.min(hh);
        }
        err_prev_pow = (BETA * ln_err.max(LN_1E_4)).exp();
        rejected_last = false;
        // dense output on [t, t + hh]
        let ydiff = ynew - y;
        let bspl = hh * k1 - ydiff;
        let r3 = bspl;
        let r4 = ydiff - hh * k7 - bspl;
        let r5 = hh * (D1 * k1 + D3 * k3 + D4 * k4 + D5 * k5 + D6 * k6 + D7 * k7);
        let t_new = if hh == remaining { t_end } else { t + hh };
        let inv_h = 1.0 / hh;
        while next < n && times[next] <= t_new {
            let lm = if times[next] == t_new {
                ynew
            } else {
                let th = (times[next] - t) * inv_h;
                let th1 = 1.0 - th;
                y + th * (ydiff + th1 * (r3 + th * (r4 + th1 * r5)))
            };
            lm_out[next] = lm;
            next += 1;
        }
        t = t_new;
        y = ynew;
        k1 = k7;
        a1 = a7;
        h = h_new;
        stats.accepted += 1;
    }
    Ok(stats)
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
