//! Systems the tests of the integrators share.

use crate::system::OdeSystem;

/// A stiff-ish forced oscillator whose rate differs per lane (so lanes take different
/// steps, with rejections).
pub(crate) struct Forced {
    pub(crate) k: f64,
}

impl OdeSystem<2> for Forced {
    fn rhs(&mut self, t: f64, y: &[f64; 2], dy: &mut [f64; 2]) {
        dy[0] = y[1];
        dy[1] = -self.k * y[0] - 0.5 * y[1] + (7.0 * t).sin() * (1.0 + (3.0 * t).cos().abs());
    }
}

/// Harmonic oscillator `y'' = −y` as `[y, y']`, exact solution `[cos t, −sin t]`.
pub(crate) fn oscillator(_t: f64, y: &[f64; 2], d: &mut [f64; 2]) {
    d[0] = y[1];
    d[1] = -y[0];
}
