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
use crate::curves::{solve_velocity_of, Scalar};
use crate::musculotendon::{MuscleUnit, IX_A, IX_FATIGUE, IX_FT, IX_LM, IX_LMT, STATE_DIM};
use crate::params::CurveParams;

/// Constants of the fibre-length right-hand side of one muscle, in `f64` for the simulation
/// or in dual numbers that carry their derivatives with respect to parameters
/// ([`Fibre::of_values`]) for the forward sensitivities.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Fibre<D: Scalar = f64> {
    pub(crate) h2: D,
    lm_cap: D,
    cos_cap: f64,
    pub(crate) lst: D,
    inv_lst: D,
    inv_lom: D,
    inv_gamma: D,
    vmax: D,
    pub(crate) lm_min: D,
    eps_toe: D,
    toe_rate: D,
    toe_scale: f64,
    klin: D,
    pe_rate: D,
    pe_scale: D,
    damping: D,
    af: D,
    flen: D,
    c_ecc: D,
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
            damping: c.damping,
            af: c.af,
            flen: c.flen,
            c_ecc: c.c_ecc,
        }
    }
}

/// The values a muscle's fibre constants are computed from, in any [`Scalar`]: a dual number
/// seeded in one of them carries the derivative with respect to that parameter.
#[derive(Clone, Copy, Debug)]
pub(crate) struct FibreValues<D: Scalar> {
    /// `LOM` (m).
    pub(crate) lom: D,
    /// `LST` (m).
    pub(crate) lst: D,
    /// `α0` (degrees).
    pub(crate) alpha_deg: D,
    /// `vmax` (LOM/s).
    pub(crate) vmax_lom_per_s: D,
    /// The curves `af, flen, gamma, kpe, e0m, e0t, damping` (`flen` the effective one).
    pub(crate) curves: [D; 7],
}

impl FibreValues<f64> {
    /// The values of muscle parameters `p` under curves `c` with effective plateau `flen`.
    pub(crate) fn of(p: &crate::params::MuscleParams, c: &CurveParams, flen: f64) -> Self {
        FibreValues {
            lom: p.lom_m,
            lst: p.lst_m,
            alpha_deg: p.alpha_deg,
            vmax_lom_per_s: p.vmax_lom_per_s,
            curves: [c.af, flen, c.gamma, c.kpe, c.e0m, c.e0t, c.damping],
        }
    }
}

impl<D: Scalar> Fibre<D> {
    /// The constants from their values, by the same operations as [`MuscleUnit::of`] and
    /// [`Fibre::new`] (so that an `f64` one is the same bits).
    pub(crate) fn of_values(v: &FibreValues<D>) -> Self {
        let cap = crate::geometry::MAX_PENNATION_DEG.to_radians();
        let [af, flen, gamma, kpe, e0m, e0t, damping] = v.curves;
        // `f64::to_radians` multiplies by this constant
        let h = v.lom * (v.alpha_deg * (std::f64::consts::PI / 180.0)).sin();
        let lm_cap = h / cap.sin();
        let floor = v.lom * crate::musculotendon::MIN_FIBRE_FRACTION;
        let toe = e0t * crate::curves::TOE_STRAIN_FRACTION;
        let one = D::from(1.0);
        Fibre {
            h2: h * h,
            lm_cap,
            cos_cap: cap.cos(),
            lst: v.lst,
            inv_lst: one / v.lst,
            inv_lom: one / v.lom,
            inv_gamma: one / gamma,
            vmax: v.vmax_lom_per_s * v.lom,
            lm_min: if lm_cap.re() >= floor.re() {
                lm_cap
            } else {
                floor
            },
            eps_toe: toe,
            toe_rate: D::from(crate::curves::TOE_SHAPE) / toe,
            toe_scale: crate::curves::TOE_FORCE / crate::curves::TOE_SHAPE.exp_m1(),
            klin: D::from(crate::curves::LINEAR_STIFFNESS_X_E0) / e0t,
            pe_rate: kpe / e0m,
            pe_scale: one / kpe.exp_m1(),
            damping,
            af,
            flen,
            c_ecc: eccentric_constant_of(af, flen),
        }
    }

    /// `(cos α, LM·cos α)`.
    #[inline(always)]
    fn cos(&self, lm: D) -> (D, D) {
        if lm.re() <= self.lm_cap.re() {
            (D::from(self.cos_cap), lm * self.cos_cap)
        } else {
            let w = (lm * lm - self.h2).sqrt();
            (w / lm, w)
        }
    }

    /// Normalised tendon force `fT(ε(LMT, LM))` (the same function serves every caller, so
    /// results agree bit for bit).
    #[inline(always)]
    pub(crate) fn tendon_force(&self, lmt: f64, lm: D) -> D {
        self.ft(self.strain(lmt, lm))
    }

    /// Tendon strain `ε = (LMT − LM·cos α − LST)/LST`.
    #[inline(always)]
    pub(crate) fn strain(&self, lmt: f64, lm: D) -> D {
        let (_, lmcos) = self.cos(lm);
        (-lmcos + lmt - self.lst) * self.inv_lst
    }

    /// `fT(ε)`; the toe uses `exp(x) − 1` (absolute error ~1e-17, cheaper than `exp_m1`).
    #[inline(always)]
    fn ft(&self, eps: D) -> D {
        if eps.re() <= 0.0 {
            D::from(0.0)
        } else if eps.re() <= self.eps_toe.re() {
            ((eps * self.toe_rate).exp() - 1.0) * self.toe_scale
        } else {
            self.klin * (eps - self.eps_toe) + crate::curves::TOE_FORCE
        }
    }

    /// `fpe(l̃)` with `exp(x) − 1`.
    #[inline(always)]
    fn fpe(&self, l: D) -> D {
        if l.re() > 1.0 {
            ((l - 1.0) * self.pe_rate).exp() * self.pe_scale - self.pe_scale
        } else {
            D::from(0.0)
        }
    }

    /// `(act·fl(l̃), F̃T/cos α − fpe(l̃))`: the two sides of the force balance
    /// `act·fl·fv(ṽ) + β·ṽ = F̃T/cos α − fpe` at input `act`, `LMT` and `LM`.
    #[inline(always)]
    fn balance(&self, act: D, lmt: f64, lm: D) -> (D, D) {
        let (cos, lmcos) = self.cos(lm);
        let ft = self.ft((-lmcos + lmt - self.lst) * self.inv_lst);
        let l = lm * self.inv_lom;
        let d = l - 1.0;
        let fl = (-d * d * self.inv_gamma).exp();
        (act * fl, ft / cos - self.fpe(l))
    }

    /// Fibre velocity `vM` (m/s) for input `act = â·φ`, `LMT` and `LM`.
    #[inline(always)]
    pub(crate) fn velocity(&self, act: D, lmt: f64, lm: D) -> D {
        let (a, r) = self.balance(act, lmt, lm);
        let v = solve_velocity_of(a, r, self.damping, self.af, self.flen, self.c_ecc);
        let vm = v * self.vmax;
        if lm.re() <= self.lm_min.re() && vm.re() < 0.0 {
            D::from(0.0)
        } else {
            vm
        }
    }

    /// The static-equilibrium residual `F̃T/cos α − fpe − act·fl` (zero at `ṽ = 0`), whose root
    /// in `LM` is a trial's initial fibre length.
    pub(crate) fn equilibrium_residual(&self, act: D, lmt: f64, lm: D) -> D {
        let (a, r) = self.balance(act, lmt, lm);
        r - a
    }
}

/// [`crate::curves::eccentric_constant`] in any [`Scalar`] (the same operations).
fn eccentric_constant_of<D: Scalar>(af: D, flen: D) -> D {
    (flen - 1.0) * af / ((af + 1.0) * 2.0)
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
