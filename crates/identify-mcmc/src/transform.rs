//! The logistic map from unconstrained coordinates onto a box, its log-Jacobian and the chain
//! rule for gradients.
//!
//! For a bound `(lo, hi)` and `u ∈ ℝ`:
//!
//! * `x = lo + (hi − lo)·σ(u)`, `σ(u) = 1/(1 + e^{−u})`;
//! * `u = logit((x − lo)/(hi − lo))`;
//! * `dx/du = (hi − lo)·σ(u)·(1 − σ(u))`, so
//!   `log J(u) = log(hi − lo) + log σ(u) + log(1 − σ(u))`, with
//!   `log σ(u) = −softplus(−u)` and `log(1 − σ(u)) = −softplus(u)` (no cancellation for large
//!   `|u|`);
//! * `d log J/du = 1 − 2σ(u)`.
//!
//! A density `π(x)` on the box becomes `p(u) = π(x(u))·Π J_i(u_i)` on `ℝᵈ`, and
//! `∂ log p/∂u_i = ∂ log π/∂x_i · dx_i/du_i + 1 − 2σ(u_i)`.

/// The logistic transform of every coordinate of a box onto `ℝᵈ`: `x = lo + (hi − lo)·σ(u)`,
/// `log J(u) = Σ log(hiᵢ − loᵢ) + log σ(uᵢ) + log(1 − σ(uᵢ))`, and the chain rule that turns
/// `∂ log π/∂x` into `∂/∂u [log π(x(u)) + log J(u)]`.
///
/// ```
/// use identify_mcmc::LogisticBox;
/// let t = LogisticBox::new(&[(0.0, 4.0)]);
/// let mut x = [0.0];
/// t.to_box(&[0.0], &mut x);
/// assert_eq!(x, [2.0]);
/// // dx/du = 4·σ(0)·(1 − σ(0)) = 1 at u = 0.
/// assert!(t.log_jacobian(&[0.0]).abs() < 1e-15);
/// let mut g = [0.5]; // ∂ log π/∂x
/// t.chain_rule(&[0.0], &mut g);
/// assert!((g[0] - 0.5).abs() < 1e-15); // 0.5·1 + (1 − 2σ(0))
/// ```
#[derive(Clone, Debug, PartialEq)]
pub struct LogisticBox {
    lower: Vec<f64>,
    upper: Vec<f64>,
    width: Vec<f64>,
}

/// `log(1 + eᵗ)` without overflow or loss of precision.
pub(crate) fn softplus(t: f64) -> f64 {
    t.max(0.0) + (-t.abs()).exp().ln_1p()
}

/// `lo + w·σ(u)`, computed as `lo + w/(1 + e^{−u})` (no overflow: `e^{−u} = ∞` gives `lo`).
pub(crate) fn logistic_map(lo: f64, w: f64, u: f64) -> f64 {
    lo + w / (1.0 + (-u).exp())
}

/// `log(dx/du) = log w + log σ(u) + log(1 − σ(u)) = log w − softplus(−u) − softplus(u)`.
pub(crate) fn logistic_log_jacobian(w: f64, u: f64) -> f64 {
    w.ln() - softplus(-u) - softplus(u)
}

impl LogisticBox {
    /// The transform of the box `bounds` (each `lo < hi`, finite; checked by the sampler).
    pub fn new(bounds: &[(f64, f64)]) -> Self {
        Self {
            lower: bounds.iter().map(|b| b.0).collect(),
            upper: bounds.iter().map(|b| b.1).collect(),
            width: bounds.iter().map(|b| b.1 - b.0).collect(),
        }
    }

    /// Number of coordinates.
    pub fn dim(&self) -> usize {
        self.lower.len()
    }

    /// `x = lo + (hi − lo)·σ(u)`, written into `x`; clamped into the box so that rounding
    /// never leaves it.
    pub fn to_box(&self, u: &[f64], x: &mut [f64]) {
        for i in 0..self.dim() {
            let v = logistic_map(self.lower[i], self.width[i], u[i]);
            x[i] = v.clamp(self.lower[i], self.upper[i]);
        }
    }

    /// `u = logit((x − lo)/(hi − lo))`, written into `u` (`±∞` on the bounds).
    pub fn to_unconstrained(&self, x: &[f64], u: &mut [f64]) {
        for i in 0..self.dim() {
            let t = (x[i] - self.lower[i]) / self.width[i];
            u[i] = t.ln() - (1.0 - t).ln();
        }
    }

    /// `Σ log J_i(u_i)` (module documentation).
    pub fn log_jacobian(&self, u: &[f64]) -> f64 {
        u.iter()
            .zip(&self.width)
            .map(|(&ui, &w)| logistic_log_jacobian(w, ui))
            .sum()
    }

    /// Turns `grad`, on entry `∂ log π/∂x` at `x(u)`, into `∂/∂u [log π(x(u)) + log J(u)]`.
    pub fn chain_rule(&self, u: &[f64], grad: &mut [f64]) {
        for i in 0..self.dim() {
            // σ(u) and 1 − σ(u) = σ(−u), each to full relative precision.
            let s = 1.0 / (1.0 + (-u[i]).exp());
            let c = 1.0 / (1.0 + u[i].exp());
            grad[i] = grad[i] * self.width[i] * s * c + (c - s);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn bounds() -> Vec<(f64, f64)> {
        vec![(-3.0, 5.0), (0.0, 1.0), (1e-3, 2e-3)]
    }

    #[test]
    fn round_trip() {
        let t = LogisticBox::new(&bounds());
        let u = [-4.0, 0.3, 7.5];
        let mut x = [0.0; 3];
        let mut v = [0.0; 3];
        t.to_box(&u, &mut x);
        t.to_unconstrained(&x, &mut v);
        for i in 0..3 {
            assert!((u[i] - v[i]).abs() < 1e-8 * (1.0 + u[i].abs()), "{i}");
        }
    }

    #[test]
    fn jacobian_matches_finite_differences_of_the_map() {
        let t = LogisticBox::new(&bounds());
        let u = [-2.5, 0.1, 3.0];
        let h = 1e-6;
        for i in 0..3 {
            let (mut up, mut dn) = (u, u);
            up[i] += h;
            dn[i] -= h;
            let (mut xp, mut xd) = ([0.0; 3], [0.0; 3]);
            t.to_box(&up, &mut xp);
            t.to_box(&dn, &mut xd);
            let dxdu = (xp[i] - xd[i]) / (2.0 * h);
            let one = LogisticBox::new(&bounds()[i..=i]);
            let lj = one.log_jacobian(&u[i..=i]);
            assert!(
                (lj.exp() / dxdu - 1.0).abs() < 1e-7,
                "{i}: {} {dxdu}",
                lj.exp()
            );
        }
    }

    #[test]
    fn log_jacobian_is_finite_far_out() {
        let t = LogisticBox::new(&[(0.0, 1.0)]);
        assert!((t.log_jacobian(&[800.0]) + 800.0).abs() < 1e-9);
        assert!((t.log_jacobian(&[-800.0]) + 800.0).abs() < 1e-9);
    }

    #[test]
    fn chain_rule_matches_finite_differences() {
        // log π(x) = −½ Σ c_i x_i², smooth and non-separable enough for the check.
        let b = bounds();
        let t = LogisticBox::new(&b);
        let c = [0.7, 3.0, 1e5];
        let logp = |u: &[f64]| {
            let mut x = [0.0; 3];
            t.to_box(u, &mut x);
            let lp: f64 = (0..3).map(|i| -0.5 * c[i] * x[i] * x[i]).sum::<f64>() + x[0] * x[1];
            lp + t.log_jacobian(u)
        };
        let u = [0.4, -1.2, 2.2];
        let mut x = [0.0; 3];
        t.to_box(&u, &mut x);
        let mut g = [-c[0] * x[0] + x[1], -c[1] * x[1] + x[0], -c[2] * x[2]];
        t.chain_rule(&u, &mut g);
        let h = 1e-5;
        for i in 0..3 {
            let (mut up, mut dn) = (u, u);
            up[i] += h;
            dn[i] -= h;
            let fd = (logp(&up) - logp(&dn)) / (2.0 * h);
            assert!(
                (fd - g[i]).abs() < 1e-6 * (1.0 + g[i].abs()),
                "{i}: {fd} {}",
                g[i]
            );
        }
    }
}
