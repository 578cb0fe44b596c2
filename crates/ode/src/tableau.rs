//! Fixed-step explicit Runge–Kutta methods given by their Butcher tableau.

use crate::error::OdeError;
use crate::stats::Stats;
use crate::system::OdeSystem;

/// An explicit Butcher tableau with `S` stages: `c_i`, the strictly lower
/// triangular `a_ij` and the weights `b_i`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Tableau<const S: usize> {
    /// Stage matrix (only the strictly lower triangle is used).
    pub a: [[f64; S]; S],
    /// Weights of the propagated solution.
    pub b: [f64; S],
    /// Nodes.
    pub c: [f64; S],
    /// Classical order of the weights `b`.
    pub order: u32,
}

/// The classic 4th-order Runge–Kutta method.
pub const RK4: Tableau<4> = Tableau {
    a: [
        [0.0, 0.0, 0.0, 0.0],
        [0.5, 0.0, 0.0, 0.0],
        [0.0, 0.5, 0.0, 0.0],
        [0.0, 0.0, 1.0, 0.0],
    ],
    b: [1.0 / 6.0, 1.0 / 3.0, 1.0 / 3.0, 1.0 / 6.0],
    c: [0.0, 0.5, 0.5, 1.0],
    order: 4,
};

/// The 5th-order solution of the Dormand–Prince pair used with a fixed step
/// (the 7th, FSAL stage has weight zero and is left out).
pub const DP5: Tableau<6> = Tableau {
    a: [
        [0.0; 6],
        [1.0 / 5.0, 0.0, 0.0, 0.0, 0.0, 0.0],
        [3.0 / 40.0, 9.0 / 40.0, 0.0, 0.0, 0.0, 0.0],
        [44.0 / 45.0, -56.0 / 15.0, 32.0 / 9.0, 0.0, 0.0, 0.0],
        [
            19372.0 / 6561.0,
            -25360.0 / 2187.0,
            64448.0 / 6561.0,
            -212.0 / 729.0,
            0.0,
            0.0,
        ],
        [
            9017.0 / 3168.0,
            -355.0 / 33.0,
            46732.0 / 5247.0,
            49.0 / 176.0,
            -5103.0 / 18656.0,
            0.0,
        ],
    ],
    b: [
        35.0 / 384.0,
        0.0,
        500.0 / 1113.0,
        125.0 / 192.0,
        -2187.0 / 6784.0,
        11.0 / 84.0,
    ],
    c: [0.0, 1.0 / 5.0, 3.0 / 10.0, 4.0 / 5.0, 8.0 / 9.0, 1.0],
    order: 5,
};

/// One step of size `h` of the method `tab`, in place.
pub fn rk_step<S: OdeSystem<N>, const N: usize, const ST: usize>(
    tab: &Tableau<ST>,
    sys: &mut S,
    t: f64,
    y: &mut [f64; N],
    h: f64,
) {
    let mut k = [[0.0; N]; ST];
    let mut ytmp = [0.0; N];
    for s in 0..ST {
        for i in 0..N {
            let mut acc = 0.0;
            for (j, kj) in k.iter().enumerate().take(s) {
                acc += tab.a[s][j] * kj[i];
            }
            ytmp[i] = y[i] + h * acc;
        }
        let (_, rest) = k.split_at_mut(s);
        sys.rhs(t + tab.c[s] * h, &ytmp, &mut rest[0]);
    }
    for i in 0..N {
        let mut acc = 0.0;
        for (s, ks) in k.iter().enumerate() {
            acc += tab.b[s] * ks[i];
        }
        y[i] += h * acc;
    }
}

/// One classic RK4 step of size `h`, in place.
pub fn rk4_step<S: OdeSystem<N>, const N: usize>(sys: &mut S, t: f64, y: &mut [f64; N], h: f64) {
    rk_step(&RK4, sys, t, y, h);
}

/// `n_steps` fixed steps of size `h` from `(t0, y0)`; calls
/// `out(i, t_i, &y_i)` for `i = 0..=n_steps`.
pub fn rk_fixed<S: OdeSystem<N>, const N: usize, const ST: usize>(
    tab: &Tableau<ST>,
    sys: &mut S,
    t0: f64,
    y0: [f64; N],
    h: f64,
    n_steps: usize,
    mut out: impl FnMut(usize, f64, &[f64; N]),
) -> Result<Stats, OdeError> {
    if !(h.is_finite() && h > 0.0 && t0.is_finite()) {
        return Err(OdeError::InvalidInput {
            what: "fixed step needs a finite t0 and a positive finite h",
        });
    }
    let mut y = y0;
    if !y.iter().all(|v| v.is_finite()) {
        return Err(OdeError::NonFinite { t: t0 });
    }
    out(0, t0, &y);
    for n in 0..n_steps {
        let t = t0 + n as f64 * h;
        rk_step(tab, sys, t, &mut y, h);
        let t1 = t0 + (n + 1) as f64 * h;
        if !y.iter().all(|v| v.is_finite()) {
            return Err(OdeError::NonFinite { t: t1 });
        }
        out(n + 1, t1, &y);
    }
    Ok(Stats {
        accepted: n_steps,
        rejected: 0,
        rhs_calls: n_steps * ST,
    })
}

/// [`rk_fixed`] with the classic RK4 tableau.
pub fn rk4_fixed<S: OdeSystem<N>, const N: usize>(
    sys: &mut S,
    t0: f64,
    y0: [f64; N],
    h: f64,
    n_steps: usize,
    out: impl FnMut(usize, f64, &[f64; N]),
) -> Result<Stats, OdeError> {
    rk_fixed(&RK4, sys, t0, y0, h, n_steps, out)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn check_consistency<const S: usize>(tab: &Tableau<S>) {
        let sb: f64 = tab.b.iter().sum();
        assert!((sb - 1.0).abs() < 1e-14);
        for i in 0..S {
            let row: f64 = tab.a[i].iter().sum();
            assert!((row - tab.c[i]).abs() < 1e-14, "row {i}");
            for j in i..S {
                assert_eq!(tab.a[i][j], 0.0);
            }
        }
    }

    #[test]
    fn tableaus_are_consistent() {
        check_consistency(&RK4);
        check_consistency(&DP5);
    }
}
