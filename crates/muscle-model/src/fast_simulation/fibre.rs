//! The fibre-length right-hand side of one muscle with its constants folded ([`Fibre`]), and
//! the tendon force and unit torque read from the fibre lengths.
//!
//! ```text
//! cos α = sqrt(LM² − h²)/LM              (α capped at 84°, h = LOM·sin α0)
//! ε     = (LMT − LM·cos α − LST)/LST
//! F̃T    = fT(ε)
//! act·fl(LM/LOM)·fv(ṽ) + fpe(LM/LOM) + β·ṽ = F̃T/cos α   → ṽ,   L̇M = ṽ·vmax
//! ```
//!
//! The curves are the Thelen curves of [`crate::curves`] with their constants precomputed, and
//! `exp(x) − 1` in place of `exp_m1` (absolute error ~1e-17, cheaper).

use super::channel::Channel;
use crate::curves::Curves;
use crate::musculotendon::{MuscleUnit, IX_A, IX_FATIGUE, IX_FT, IX_LM, IX_LMT, STATE_DIM};

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
    pub(super) fn velocity(&self, act: f64, lmt: f64, lm: f64) -> f64 {
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
///
/// The same numbers as `fib.tendon_force(lmt, lm) * r` sample by sample, computed in passes
/// without branches where possible so that the compiler can use vector instructions: the
/// strain of every sample, then the force in the linear region and zero below slack, then the
/// exponential toe only at the samples in it.
pub(crate) fn unit_torque(fib: &Fibre, ch: &Channel, lm: &[f64], out: &mut [f64]) {
    let n = out.len();
    let (lm, lmt, r) = (&lm[..n], &ch.lmt[..n], &ch.r[..n]);
    for i in 0..n {
        // `Fibre::cos(lm).1` as a select: for lm > lm_cap > h the root's argument is positive
        let l = lm[i];
        let w = (l * l - fib.h2).max(0.0).sqrt();
        let lmcos = if l <= fib.lm_cap { l * fib.cos_cap } else { w };
        out[i] = (lmt[i] - lmcos - fib.lst) * fib.inv_lst;
    }
    for (out, r) in out.chunks_mut(64).zip(r.chunks(64)) {
        let toe = out
            .iter()
            .fold(false, |t, &eps| t | (eps > 0.0 && eps <= fib.eps_toe));
        if toe {
            for (o, &r) in out.iter_mut().zip(r) {
                *o = fib.ft(*o) * r;
            }
        } else {
            for (o, &r) in out.iter_mut().zip(r) {
                let eps = *o;
                let lin = fib.klin * (eps - fib.eps_toe) + crate::curves::TOE_FORCE;
                *o = if eps <= 0.0 { 0.0 } else { lin } * r;
            }
        }
    }
}

/// The recorded state `[a, F̃T, LM, LMT, ∫â]` at one sample from its activation `a`, `∫â`,
/// fibre length, musculotendon length and tendon force.
pub(crate) fn state(a: f64, z: f64, lm: f64, lmt: f64, ft: f64) -> [f64; STATE_DIM] {
    let mut y = [0.0; STATE_DIM];
    y[IX_A] = a;
    y[IX_FT] = ft;
    y[IX_LM] = lm;
    y[IX_LMT] = lmt;
    y[IX_FATIGUE] = z;
    y
}
