//! The right-hand side of `y' = f(t, y)` ([`OdeSystem`]).

/// Right-hand side of `y' = f(t, y)` with a fixed-size state.
///
/// Closures `FnMut(f64, &[f64; N], &mut [f64; N])` implement it.
pub trait OdeSystem<const N: usize> {
    /// Writes `f(t, y)` into `dydt`. Writing a non-finite value signals that
    /// the system cannot be evaluated there; the integrator then fails with
    /// [`crate::OdeError::NonFinite`] (or rejects and shrinks the step first).
    fn rhs(&mut self, t: f64, y: &[f64; N], dydt: &mut [f64; N]);
}

impl<F, const N: usize> OdeSystem<N> for F
where
    F: FnMut(f64, &[f64; N], &mut [f64; N]),
{
    #[inline]
    fn rhs(&mut self, t: f64, y: &[f64; N], dydt: &mut [f64; N]) {
        self(t, y, dydt)
    }
}
