//! Standard test functions with known minima (Rosenbrock, Rastrigin, Ackley, sphere).

use std::f64::consts::PI;

use crate::Objective;

/// Which standard function a [`TestFunction`] evaluates.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Kind {
    /// `Σ 100(x_{i+1} − x_i²)² + (1 − x_i)²` on `[−5, 10]ⁿ`; minimum 0 at `(1, …, 1)`.
    Rosenbrock,
    /// `10n + Σ (x_i² − 10 cos 2πx_i)` on `[−5.12, 5.12]ⁿ`; minimum 0 at 0.
    Rastrigin,
    /// `−20 exp(−0.2 √(Σx_i²/n)) − exp(Σ cos(2πx_i)/n) + 20 + e` on
    /// `[−32.768, 32.768]ⁿ`; minimum 0 at 0.
    Ackley,
    /// `Σ x_i²` on `[−5, 5]ⁿ`; minimum 0 at 0.
    Sphere,
}

/// A standard function on its standard box, counting its evaluations.
#[derive(Debug, Clone, PartialEq)]
pub struct TestFunction {
    kind: Kind,
    bounds: Vec<(f64, f64)>,
    /// Evaluations so far.
    pub evaluations: u64,
}

impl TestFunction {
    /// `kind` in `dim` dimensions on its standard box.
    #[must_use]
    pub fn new(kind: Kind, dim: usize) -> Self {
        let b = match kind {
            Kind::Rosenbrock => (-5.0, 10.0),
            Kind::Rastrigin => (-5.12, 5.12),
            Kind::Ackley => (-32.768, 32.768),
            Kind::Sphere => (-5.0, 5.0),
        };
        Self {
            kind,
            bounds: vec![b; dim],
            evaluations: 0,
        }
    }

    /// The global minimiser.
    #[must_use]
    pub fn minimiser(&self) -> Vec<f64> {
        let v = if self.kind == Kind::Rosenbrock {
            1.0
        } else {
            0.0
        };
        vec![v; self.bounds.len()]
    }

    /// The function value (no counting).
    #[must_use]
    pub fn value(&self, x: &[f64]) -> f64 {
        match self.kind {
            Kind::Rosenbrock => x
                .windows(2)
                .map(|w| 100.0 * (w[1] - w[0] * w[0]).powi(2) + (1.0 - w[0]).powi(2))
                .sum(),
            Kind::Rastrigin => x
                .iter()
                .map(|&v| v * v - 10.0 * (2.0 * PI * v).cos() + 10.0)
                .sum(),
            Kind::Ackley => {
                let n = x.len() as f64;
                let s2 = x.iter().map(|v| v * v).sum::<f64>() / n;
                let sc = x.iter().map(|v| (2.0 * PI * v).cos()).sum::<f64>() / n;
                (-20.0 * (-0.2 * s2.sqrt()).exp() - sc.exp() + 20.0 + std::f64::consts::E).max(0.0)
            }
            Kind::Sphere => x.iter().map(|v| v * v).sum(),
        }
    }
}

impl Objective for TestFunction {
    fn dim(&self) -> usize {
        self.bounds.len()
    }
    fn bounds(&self) -> &[(f64, f64)] {
        &self.bounds
    }
    fn cost(&mut self, x: &[f64]) -> Option<f64> {
        self.evaluations += 1;
        Some(self.value(x))
    }
}
