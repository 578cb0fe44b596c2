//! Normalised Thelen (2003) curves, the force–velocity relation and its closed-form inversion.
//!
//! All functions take normalised quantities: fibre length `l̃ = LM/LOM`, tendon strain
//! `ε = (LT − LST)/LST`, fibre velocity `ṽ = vM/vmax` (negative when shortening).

use crate::params::CurveParams;

/// Tendon toe-region strain as a fraction of `ε0` (Thelen 2003).
pub const TOE_STRAIN_FRACTION: f64 = 0.609;
/// Normalised tendon force at the end of the toe region.
pub const TOE_FORCE: f64 = 0.33;
/// Exponential shape factor of the toe region.
pub const TOE_SHAPE: f64 = 3.0;
/// Linear tendon stiffness times `ε0` (`klin = 1.712/ε0`).
pub const LINEAR_STIFFNESS_X_E0: f64 = 1.712;

/// Active force–length `fl(l̃) = exp(−(l̃ − 1)²/γ)`.
#[inline]
pub fn active_force_length(l: f64, gamma: f64) -> f64 {
    let d = l - 1.0;
    (-d * d / gamma).exp()
}

/// Passive fibre force `fpe(l̃) = (exp(kPE(l̃ − 1)/e0M) − 1)/(exp(kPE) − 1)` for `l̃ > 1`, else 0.
#[inline]
pub fn passive_force_length(l: f64, kpe: f64, e0m: f64) -> f64 {
    if l > 1.0 {
        (kpe * (l - 1.0) / e0m).exp_m1() / kpe.exp_m1()
    } else {
        0.0
    }
}

/// Tendon force–strain `fT(ε)` (toe exponential then linear, Thelen 2003), strain `ε0 = e0t` at
/// `F̃T = 1` nominally.
#[inline]
pub fn tendon_force(eps: f64, e0t: f64) -> f64 {
    let eps_toe = TOE_STRAIN_FRACTION * e0t;
    if eps <= 0.0 {
        0.0
    } else if eps <= eps_toe {
        TOE_FORCE * (TOE_SHAPE * eps / eps_toe).exp_m1() / TOE_SHAPE.exp_m1()
    } else {
        LINEAR_STIFFNESS_X_E0 / e0t * (eps - eps_toe) + TOE_FORCE
    }
}

/// Derivative `dfT/dε` of [`tendon_force`].
#[inline]
pub fn tendon_stiffness(eps: f64, e0t: f64) -> f64 {
    let eps_toe = TOE_STRAIN_FRACTION * e0t;
    if eps <= 0.0 {
        0.0
    } else if eps <= eps_toe {
        TOE_FORCE * TOE_SHAPE / eps_toe * (TOE_SHAPE * eps / eps_toe).exp() / TOE_SHAPE.exp_m1()
    } else {
        LINEAR_STIFFNESS_X_E0 / e0t
    }
}

/// Eccentric constant `c = (Flen − 1)·Af/(2(1 + Af))`, which makes the eccentric slope at
/// `ṽ = 0` twice the concentric one.
#[inline]
pub fn eccentric_constant(af: f64, flen: f64) -> f64 {
    (flen - 1.0) * af / (2.0 * (1.0 + af))
}

/// Force–velocity `fv(ṽ)`: 0 for `ṽ < −1`, `(1 + ṽ)/(1 − ṽ/Af)` for `−1 ≤ ṽ ≤ 0`
/// (dissertation eq. 2), `(Flen·ṽ + c)/(ṽ + c)` for `ṽ > 0`.
#[inline]
pub fn force_velocity(v: f64, af: f64, flen: f64) -> f64 {
    if v < -1.0 {
        0.0
    } else if v <= 0.0 {
        (1.0 + v) / (1.0 - v / af)
    } else {
        let c = eccentric_constant(af, flen);
        if c == 0.0 {
            flen
        } else {
            (flen * v + c) / (v + c)
        }
    }
}

/// The curve constants of one parameter set, precomputed for the right-hand side.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Curves {
    /// Width `γ` of the active force–length Gaussian.
    pub gamma: f64,
    /// Passive exponential shape `kPE`.
    pub kpe: f64,
    /// Passive strain at `F̃ = 1`, `e0M`.
    pub e0m: f64,
    /// Tendon strain at `F̃T = 1`, `ε0`.
    pub e0t: f64,
    /// Concentric curvature `Af`.
    pub af: f64,
    /// Eccentric plateau `Flen`.
    pub flen: f64,
    /// Eccentric constant `c`.
    pub c_ecc: f64,
    /// Fibre damping `β`.
    pub damping: f64,
    inv_pe_denom: f64,
    eps_toe: f64,
    klin: f64,
    toe_scale: f64,
}

impl Curves {
    /// Precomputes the constants of `p` (with `Flen` possibly overridden by the
    /// `eccentric_enhancement` effect).
    pub fn new(p: &CurveParams, flen: f64) -> Self {
        let eps_toe = TOE_STRAIN_FRACTION * p.e0t;
        Curves {
            gamma: p.gamma,
            kpe: p.kpe,
            e0m: p.e0m,
            e0t: p.e0t,
            af: p.af,
            flen,
            c_ecc: eccentric_constant(p.af, flen),
            damping: p.damping,
            inv_pe_denom: 1.0 / p.kpe.exp_m1(),
            eps_toe,
            klin: LINEAR_STIFFNESS_X_E0 / p.e0t,
            toe_scale: TOE_FORCE / TOE_SHAPE.exp_m1(),
        }
    }

    /// Active force–length at `l̃`.
    #[inline]
    pub fn fl(&self, l: f64) -> f64 {
        let d = l - 1.0;
        (-d * d / self.gamma).exp()
    }

    /// Passive fibre force at `l̃`.
    #[inline]
    pub fn fpe(&self, l: f64) -> f64 {
        if l > 1.0 {
            (self.kpe * (l - 1.0) / self.e0m).exp_m1() * self.inv_pe_denom
        } else {
            0.0
        }
    }

    /// Tendon force at strain `ε`.
    #[inline]
    pub fn ft(&self, eps: f64) -> f64 {
        if eps <= 0.0 {
            0.0
        } else if eps <= self.eps_toe {
            self.toe_scale * (TOE_SHAPE * eps / self.eps_toe).exp_m1()
        } else {
            self.klin * (eps - self.eps_toe) + TOE_FORCE
        }
    }

    /// Tendon stiffness `dfT/dε` at strain `ε`.
    #[inline]
    pub fn dft(&self, eps: f64) -> f64 {
        if eps <= 0.0 {
            0.0
        } else if eps <= self.eps_toe {
            self.toe_scale * TOE_SHAPE / self.eps_toe * (TOE_SHAPE * eps / self.eps_toe).exp()
        } else {
            self.klin
        }
    }

    /// Force–velocity at `ṽ`.
    #[inline]
    pub fn fv(&self, v: f64) -> f64 {
        if v < -1.0 {
            0.0
        } else if v <= 0.0 {
            (1.0 + v) / (1.0 - v / self.af)
        } else if self.c_ecc == 0.0 {
            self.flen
        } else {
            (self.flen * v + self.c_ecc) / (v + self.c_ecc)
        }
    }

    /// The unique `ṽ` with `act·fv(ṽ) + β·ṽ = r`, where `act = â·fl(l̃)·(fatigue factor) ≥ 0`
    /// and `r = F̃M − fpe(l̃)` ([`solve_velocity_of`] with this parameter set's constants).
    #[inline]
    pub fn solve_velocity(&self, act: f64, r: f64) -> f64 {
        solve_velocity_of(act, r, self.damping, self.af, self.flen, self.c_ecc)
    }
}

/// The scalar the model's right-hand side is written in: `f64`, or a dual number that carries
/// derivatives with respect to parameters along (forward sensitivities). Branches compare
/// real parts, so a dual number follows the branch its value takes.
pub trait Scalar: num_dual::DualNum<f64> + Copy {}
impl<T: num_dual::DualNum<f64> + Copy> Scalar for T {}

/// `max(x, lo)` by the real part (`lo` for NaN, as `f64::max`).
#[inline(always)]
pub(crate) fn at_least<D: Scalar>(x: D, lo: f64) -> D {
    if x.re() >= lo {
        x
    } else {
        D::from(lo)
    }
}

/// The unique `ṽ` with `act·fv(ṽ) + β·ṽ = r` for damping `β`, curvature `Af`, plateau `Flen`
/// and eccentric constant `c` (see [`eccentric_constant`]), where `act ≥ 0` is `â·fl(l̃)`
/// times the fatigue factor and `r = F̃M − fpe(l̃)`.
///
/// The left side is continuous and strictly increasing (slope ≥ β > 0), so the solution
/// exists and is unique; on each branch of `fv` the equation is a quadratic in `ṽ`, solved
/// here in closed form (numerically stable root formula). With dual numbers the derivative is
/// the implicit one, `dṽ = (dr − fv·d(act) − act·∂fv/∂(Af, Flen, c)) / (act·fv′ + β)`, because
/// the root formula is differentiated as written.
#[inline]
pub fn solve_velocity_of<D: Scalar>(act: D, r: D, beta: D, af: D, flen: D, c_ecc: D) -> D {
    let act = at_least(act, 0.0);
    if r.re() < -beta.re() {
        // fv = 0 below ṽ = −1: pure damping.
        r / beta
    } else if r.re() <= act.re() {
        // Concentric: β ṽ² − (act·Af + β·Af + r) ṽ − Af (act − r) = 0, root in [−1, 0].
        let b = -(act * af + beta * af + r);
        let c0 = -af * (act - r);
        let v = smaller_root(beta, b, c0);
        if v.re() < -1.0 {
            D::from(-1.0)
        } else if v.re() > 0.0 {
            D::from(0.0)
        } else {
            v
        }
    } else {
        // Eccentric: β ṽ² + (act·Flen + β c − r) ṽ + c (act − r) = 0, root > 0.
        let b = act * flen + beta * c_ecc - r;
        let c0 = c_ecc * (act - r);
        at_least(larger_root(beta, b, c0), 0.0)
    }
}

/// Smaller root of `a x² + b x + c = 0` with `a > 0`, `c ≤ 0` (so real roots of opposite sign).
#[inline]
fn smaller_root<D: Scalar>(a: D, b: D, c: D) -> D {
    let d = at_least(b * b - a * 4.0 * c, 0.0).sqrt();
    if b.re() <= 0.0 {
        let q = (-b + d) * 0.5;
        if q.re() == 0.0 {
            D::from(0.0)
        } else {
            c / q
        }
    } else {
        (b + d) * (-0.5) / a
    }
}

/// Larger root of `a x² + b x + c = 0` with `a > 0`, `c ≤ 0`.
#[inline]
fn larger_root<D: Scalar>(a: D, b: D, c: D) -> D {
    let d = at_least(b * b - a * 4.0 * c, 0.0).sqrt();
    if b.re() >= 0.0 {
        let q = (b + d) * (-0.5);
        if q.re() == 0.0 {
            D::from(0.0)
        } else {
            c / q
        }
    } else {
        (-b + d) * 0.5 / a
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::params::CurveParams;

    #[test]
    fn solve_velocity_inverts_the_force_velocity_relation() {
        let p = CurveParams::default();
        for &flen in &[1.0, 1.4, 2.0] {
            let c = Curves::new(&p, flen);
            for &act in &[0.0, 1e-6, 0.3, 1.0, 1.7] {
                for k in 0..=400 {
                    let v = -1.6 + 3.2 * k as f64 / 400.0;
                    let r = act * c.fv(v) + c.damping * v;
                    let got = c.solve_velocity(act, r);
                    let back = act * c.fv(got) + c.damping * got;
                    assert!(
                        (back - r).abs() < 1e-12 * (1.0 + r.abs()),
                        "flen {flen} act {act} v {v}: got {got}, residual {}",
                        back - r
                    );
                    // the function is strictly increasing, so the input is recovered
                    assert!(
                        (got - v).abs() < 1e-9,
                        "flen {flen} act {act} v {v} got {got}"
                    );
                }
            }
        }
    }
}
