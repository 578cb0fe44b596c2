//! Activation dynamics (dissertation eq. 3) and the Manal–Buchanan (2003) A-model nonlinearity.

use crate::params::ActivationParams;

/// `u0 = 0.3085 − A/√2` and `a0 = 0.3085 + A/√2` are centred on this value.
pub const MB_CENTRE: f64 = 0.3085;
/// Shapes below this are treated as the identity (`A = 0`).
pub const MB_IDENTITY_BELOW: f64 = 1e-12;

thread_local! {
    /// The last curve built on this thread ([`ManalBuchanan::new`]).
    static MB_MEMO: std::cell::Cell<Option<ManalBuchanan>> = const { std::cell::Cell::new(None) };
}

/// The Manal–Buchanan A-model `â = f_A(a)`: logarithmic below `u0`, linear above, value and
/// slope continuous at `u0`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ManalBuchanan {
    /// Shape `A` (0 = identity).
    pub shape: f64,
    /// Break point `u0 = 0.3085 − A/√2`.
    pub u0: f64,
    /// Value at the break point `a0 = 0.3085 + A/√2`.
    pub a0: f64,
    /// Slope of the linear part `m = (1 − a0)/(1 − u0)`.
    pub m: f64,
    /// Scale `α` of the logarithmic part `α·ln(β·a + 1)`.
    pub alpha: f64,
    /// Rate `β` of the logarithmic part.
    pub beta: f64,
}

impl ManalBuchanan {
    /// Builds the curve for shape `A` (expected in `[0, 0.12]`).
    ///
    /// Continuity of value and slope at `u0` gives, with `x = β·u0`,
    /// `x/((1 + x)·ln(1 + x)) = m·u0/a0`, a strictly decreasing function of `x > 0` solved here
    /// by bisection to machine precision; then `β = x/u0`, `α = a0/ln(1 + x)`.
    pub fn new(shape: f64) -> Self {
        // The bisection below costs microseconds and every `MuscleUnit` builds the curve, so the
        // last result of this thread is kept (same bits: the computation is deterministic).
        if let Some(mb) = MB_MEMO
            .with(|c| c.get())
            .filter(|mb| mb.shape.to_bits() == shape.to_bits())
        {
            return mb;
        }
        let mb = Self::compute(shape);
        MB_MEMO.with(|c| c.set(Some(mb)));
        mb
    }

    fn compute(shape: f64) -> Self {
        let s = shape / std::f64::consts::SQRT_2;
        let u0 = MB_CENTRE - s;
        let a0 = MB_CENTRE + s;
        let m = (1.0 - a0) / (1.0 - u0);
        if shape < MB_IDENTITY_BELOW {
            return ManalBuchanan {
                shape,
                u0,
                a0,
                m,
                alpha: f64::INFINITY,
                beta: 0.0,
            };
        }
        let target = m * u0 / a0;
        let g = |x: f64| x / ((1.0 + x) * x.ln_1p());
        // g decreases from 1 (x → 0) to 0 (x → ∞): bisection in log x.
        let (mut lo, mut hi) = (-40.0_f64, 40.0_f64);
        for _ in 0..200 {
            let mid = 0.5 * (lo + hi);
            if g(mid.exp()) > target {
                lo = mid;
            } else {
                hi = mid;
            }
            if hi - lo < 1e-15 {
                break;
            }
        }
        let x = (0.5 * (lo + hi)).exp();
        ManalBuchanan {
            shape,
            u0,
            a0,
            m,
            alpha: a0 / x.ln_1p(),
            beta: x / u0,
        }
    }

    /// `true` when the curve is the identity (`A = 0`).
    #[inline]
    pub fn is_identity(&self) -> bool {
        self.shape < MB_IDENTITY_BELOW
    }

    /// `â = f_A(a)` for `a` clamped to `[0, 1]`.
    #[inline]
    pub fn apply(&self, a: f64) -> f64 {
        let a = a.clamp(0.0, 1.0);
        if self.is_identity() {
            a
        } else if a >= self.u0 {
            self.m * a + (1.0 - self.m)
        } else {
            self.alpha * (self.beta * a).ln_1p()
        }
    }

    /// `d²â/da²` at `a` (clamped): 0 on the linear part.
    #[inline]
    pub fn curvature(&self, a: f64) -> f64 {
        let a = a.clamp(0.0, 1.0);
        if self.is_identity() || a >= self.u0 {
            0.0
        } else {
            let d = self.beta * a + 1.0;
            -self.alpha * self.beta * self.beta / (d * d)
        }
    }

    /// `(∂â/∂A, ∂(dâ/da)/∂A)` at `a` (clamped): the curve's derivatives with respect to its
    /// shape at fixed `a`, in dual numbers through the constants. The bisection's root
    /// `x = β·u0` solves `g(x) = m·u0/a0`, so `dx/dA = (d(m·u0/a0)/dA)/g′(x)` (the implicit
    /// function's derivative, exact at the root whatever the bisection's path). Both
    /// derivatives are continuous across the break point, where value and slope of the two
    /// pieces agree for every `A`. Below [`MB_IDENTITY_BELOW`] they are taken at that shape
    /// (the limit as `A → 0⁺`).
    pub fn shape_derivatives(&self, a: f64) -> [f64; 2] {
        use num_dual::{Dual64, DualNum};
        let mb = if self.is_identity() {
            Self::compute(MB_IDENTITY_BELOW)
        } else {
            *self
        };
        let shape = Dual64::new(mb.shape, 1.0);
        let s = shape / std::f64::consts::SQRT_2;
        let u0 = -s + MB_CENTRE;
        let a0 = s + MB_CENTRE;
        let m = (-a0 + 1.0) / (-u0 + 1.0);
        let target = m * u0 / a0;
        let g = |x: Dual64| x / ((x + 1.0) * x.ln_1p());
        let x_re = mb.beta * mb.u0;
        let slope = g(Dual64::new(x_re, 1.0)).eps;
        let x = Dual64::new(x_re, target.eps / slope);
        let beta = x / u0;
        let alpha = a0 / x.ln_1p();
        let a = a.clamp(0.0, 1.0);
        if a >= mb.u0 {
            [(m * a - m + 1.0).eps, m.eps]
        } else {
            let d = beta * a + 1.0;
            [(alpha * d.ln()).eps, (alpha * beta / d).eps]
        }
    }

    /// Derivative `dâ/da` (for tests and linearisations).
    #[inline]
    pub fn slope(&self, a: f64) -> f64 {
        let a = a.clamp(0.0, 1.0);
        if self.is_identity() {
            1.0
        } else if a >= self.u0 {
            self.m
        } else {
            self.alpha * self.beta / (self.beta * a + 1.0)
        }
    }
}

/// Activation dynamics `ȧ = (u − a)(k1·u + k2)` with `k2 = 1/τdeact`, `k1 = 1/τact − 1/τdeact`,
/// plus the nonlinearity `â = f_A(a)`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Activation {
    /// `k1 = 1/τact − 1/τdeact`.
    pub k1: f64,
    /// `k2 = 1/τdeact`.
    pub k2: f64,
    /// The A-model.
    pub nonlinearity: ManalBuchanan,
}

impl Activation {
    /// Precomputes the constants of `p`.
    pub fn new(p: &ActivationParams) -> Self {
        Activation {
            k1: 1.0 / p.tau_act_s - 1.0 / p.tau_deact_s,
            k2: 1.0 / p.tau_deact_s,
            nonlinearity: ManalBuchanan::new(p.shape_a),
        }
    }

    /// `ȧ` for excitation `u` (clamped to `[0, 1]`) and activation `a`.
    #[inline]
    pub fn rate(&self, u: f64, a: f64) -> f64 {
        let u = u.clamp(0.0, 1.0);
        (u - a) * (self.k1 * u + self.k2)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn shape_derivatives_are_those_of_the_curve_rebuilt_at_a_moved_shape() {
        // central differences of the closed form in A (smooth away from the break point; the
        // bisection is exact to rounding, so a step of 1e-6 leaves about 1e-9 of error)
        for shape in [0.01, 0.05, 0.11] {
            let mb = ManalBuchanan::new(shape);
            let h = 1e-6;
            let (up, down) = (ManalBuchanan::new(shape + h), ManalBuchanan::new(shape - h));
            for a in [0.02, 0.1, 0.25, 0.5, 0.9] {
                if (a - mb.u0).abs() < 1e-3 {
                    continue;
                }
                let [df, dslope] = mb.shape_derivatives(a);
                let fd = (up.apply(a) - down.apply(a)) / (2.0 * h);
                let fd_slope = (up.slope(a) - down.slope(a)) / (2.0 * h);
                assert!(
                    (df - fd).abs() < 1e-6 * fd.abs().max(1.0),
                    "A {shape} a {a}: {df} {fd}"
                );
                assert!(
                    (dslope - fd_slope).abs() < 1e-6 * fd_slope.abs().max(1.0),
                    "A {shape} a {a}: {dslope} {fd_slope}"
                );
                let fd_curv = (mb.slope(a + h) - mb.slope(a - h)) / (2.0 * h);
                assert!((mb.curvature(a) - fd_curv).abs() < 1e-5 * fd_curv.abs().max(1.0));
            }
        }
    }
}
