//! The smooth interpolants of a low-rate trial's inputs between samples (a trial sampled below
//! [`crate::inputs::LOW_RATE_BELOW_HZ`]; `docs/model.md`, section 1).
//!
//! On the sample interval `[tᵢ, tᵢ₊₁]` with `s = (t − tᵢ)·fs ∈ [0, 1]`, both are the cubic
//! Hermite curve through the samples `vᵢ`, `vᵢ₊₁` with node slopes `dᵢ`, `dᵢ₊₁` (per sample
//! interval, i.e. `Δt·dv/dt`):
//!
//! ```text
//! v(s) = (1 + 2s)(1 − s)²·vᵢ + s(1 − s)²·dᵢ + s²(3 − 2s)·vᵢ₊₁ − s²(1 − s)·dᵢ₊₁
//! ```
//!
//! The curve is C¹ (value and slope continuous at every sample) and passes through the
//! samples. The node slopes:
//!
//! * **monotone cubic** ([`pchip_slope`], Fritsch & Carlson 1980; scipy's
//!   `PchipInterpolator` on a uniform grid), for envelopes: with the differences
//!   `δₖ = vₖ₊₁ − vₖ`, `dᵢ = 2·δᵢ₋₁·δᵢ/(δᵢ₋₁ + δᵢ)` (the harmonic mean) when `δᵢ₋₁` and `δᵢ` have
//!   the same sign, else 0; at the ends the three-point formula `(3δ₀ − δ₁)/2` (mirrored at
//!   the last sample), set to 0 when its sign differs from `δ₀`'s and limited to `3δ₀` when
//!   `δ₀` and `δ₁` differ in sign. Between two samples the curve then stays between their
//!   values (no overshoot), so an envelope in `[0, 1]` stays in `[0, 1]` and is never negative;
//! * **central differences** ([`central_slope`]), for the knee angle and geometry series:
//!   `dᵢ = (vᵢ₊₁ − vᵢ₋₁)/2`, one-sided at the ends — the rule the ankle angle uses at every
//!   rate.

/// Cubic Hermite value and slope at `s ∈ [0, 1]` from the end values `v0`, `v1` and node
/// slopes `d0`, `d1` (per interval): `(v(s), dv/ds)`.
#[inline]
pub(crate) fn hermite(v0: f64, v1: f64, d0: f64, d1: f64, s: f64) -> (f64, f64) {
    let s1 = 1.0 - s;
    let s12 = s1 * s1;
    let s2 = s * s;
    let v = (1.0 + 2.0 * s) * s12 * v0 + s * s12 * d0 + s2 * (3.0 - 2.0 * s) * v1 - s2 * s1 * d1;
    let dv = -6.0 * s * s1 * (v0 - v1) + s1 * (1.0 - 3.0 * s) * d0 + s * (3.0 * s - 2.0) * d1;
    (v, dv)
}

/// Cubic Hermite value at `s ∈ [0, 1]` of an interval of length `dt` from the end values `v0`,
/// `v1` and time derivatives `d0`, `d1`: what the delayed activation tables and the inputs
/// read between their points (one expression, so both give the same numbers).
#[inline]
pub(crate) fn hermite_dt(v0: f64, d0: f64, v1: f64, d1: f64, s: f64, dt: f64) -> f64 {
    let s2 = s * s;
    let s3 = s2 * s;
    (2.0 * s3 - 3.0 * s2 + 1.0) * v0
        + (s3 - 2.0 * s2 + s) * dt * d0
        + (-2.0 * s3 + 3.0 * s2) * v1
        + (s3 - s2) * dt * d1
}

/// The monotone-cubic node slope of `v` at sample `i` (per sample interval).
#[inline]
pub(crate) fn pchip_slope(v: &[f64], i: usize) -> f64 {
    let n = v.len();
    if n < 3 {
        // two samples: the straight line
        return v[1] - v[0];
    }
    if i == 0 {
        return pchip_end(v[1] - v[0], v[2] - v[1]);
    }
    if i == n - 1 {
        return pchip_end(v[n - 1] - v[n - 2], v[n - 2] - v[n - 3]);
    }
    let (a, b) = (v[i] - v[i - 1], v[i + 1] - v[i]);
    if a * b > 0.0 {
        2.0 * a * b / (a + b)
    } else {
        0.0
    }
}

/// The end slope from the first difference `d0` and the next one `d1` (scipy's edge case).
#[inline]
fn pchip_end(d0: f64, d1: f64) -> f64 {
    let d = (3.0 * d0 - d1) / 2.0;
    if d * d0 <= 0.0 {
        0.0
    } else if d0 * d1 < 0.0 && d.abs() > 3.0 * d0.abs() {
        3.0 * d0
    } else {
        d
    }
}

/// The central-difference node slope of `v` at sample `i` (per sample interval; one-sided at
/// the ends).
#[inline]
pub(crate) fn central_slope(v: &[f64], i: usize) -> f64 {
    let n = v.len();
    if i == 0 {
        v[1] - v[0]
    } else if i == n - 1 {
        v[n - 1] - v[n - 2]
    } else {
        0.5 * (v[i + 1] - v[i - 1])
    }
}

/// The monotone cubic through `v` on interval `i` at fraction `s`: `(v, dv/ds)`.
#[inline]
pub(crate) fn pchip(v: &[f64], i: usize, s: f64) -> (f64, f64) {
    hermite(v[i], v[i + 1], pchip_slope(v, i), pchip_slope(v, i + 1), s)
}

/// The central-difference cubic through `v` on interval `i` at fraction `s`: `(v, dv/ds)`.
#[inline]
pub(crate) fn central(v: &[f64], i: usize, s: f64) -> (f64, f64) {
    hermite(
        v[i],
        v[i + 1],
        central_slope(v, i),
        central_slope(v, i + 1),
        s,
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `v` on a fine grid over every interval: `(value, slope per interval)` at `k/m`.
    fn sweep(v: &[f64], m: usize, f: impl Fn(&[f64], usize, f64) -> (f64, f64)) -> Vec<(f64, f64)> {
        let mut out = Vec::new();
        for i in 0..v.len() - 1 {
            for k in 0..m {
                out.push(f(v, i, k as f64 / m as f64));
            }
        }
        out.push(f(v, v.len() - 2, 1.0));
        out
    }

    #[test]
    fn both_pass_through_the_samples_with_continuous_slopes() {
        let v = [0.1, 0.4, 0.35, 0.9, 0.9, 0.2, 0.0, 0.05];
        for f in [pchip, central] {
            for i in 0..v.len() - 1 {
                let (a, da) = f(&v, i, 0.0);
                let (b, db) = f(&v, i, 1.0);
                assert_eq!((a, b), (v[i], v[i + 1]), "interval {i}");
                if i + 1 < v.len() - 1 {
                    // the slope at the right end equals the next interval's at its left end
                    assert_eq!(db, f(&v, i + 1, 0.0).1, "sample {}", i + 1);
                }
                if i > 0 {
                    assert_eq!(da, f(&v, i - 1, 1.0).1, "sample {i}");
                }
            }
        }
    }

    #[test]
    fn the_monotone_cubic_does_not_overshoot_and_the_central_one_can() {
        // a step with a flat top: the central cubic overshoots 1 and undershoots 0, the
        // monotone one stays inside each interval's two values
        let v = [0.0, 0.0, 0.0, 1.0, 1.0, 1.0, 0.0, 0.0];
        let m = 64;
        let p = sweep(&v, m, pchip);
        let c = sweep(&v, m, central);
        for (k, (val, _)) in p.iter().enumerate() {
            let i = (k / m).min(v.len() - 2);
            let (lo, hi) = (v[i].min(v[i + 1]), v[i].max(v[i + 1]));
            assert!(*val >= lo && *val <= hi, "pchip {val} at {k}");
        }
        assert!(c.iter().any(|(x, _)| *x > 1.0) && c.iter().any(|(x, _)| *x < 0.0));
        // a local extremum gets a zero slope
        assert_eq!(pchip_slope(&[0.0, 1.0, 0.5], 1), 0.0);
    }

    #[test]
    fn slopes_of_smooth_data_approach_the_derivative() {
        // sin sampled at Δt = 0.05: the interior node slopes are second-order accurate
        let dt = 0.05;
        let v: Vec<f64> = (0..40).map(|i| (i as f64 * dt).sin()).collect();
        for i in 1..39 {
            let exact = (i as f64 * dt).cos() * dt;
            assert!(
                (central_slope(&v, i) - exact).abs() < 1e-3 * dt,
                "central {i}"
            );
            // the harmonic mean is second order too where the slope is not near zero
            if exact.abs() > 0.3 * dt {
                assert!((pchip_slope(&v, i) - exact).abs() < 4e-3 * dt, "pchip {i}");
            }
        }
        // the value between samples is third-order accurate: far closer than the chord
        let (i, s) = (10, 0.5);
        let t = (i as f64 + s) * dt;
        let lin = 0.5 * (v[i] + v[i + 1]);
        assert!((central(&v, i, s).0 - t.sin()).abs() < 1e-2 * (lin - t.sin()).abs());
        assert!((pchip(&v, i, s).0 - t.sin()).abs() < 1e-1 * (lin - t.sin()).abs());
    }

    #[test]
    fn the_slope_is_the_derivative_of_the_value() {
        let v = [0.3, 0.1, 0.6, 0.65, 0.2, 0.25];
        for f in [pchip, central] {
            for i in 0..v.len() - 1 {
                for s in [0.1, 0.37, 0.8] {
                    let e = 1e-6;
                    let fd = (f(&v, i, s + e).0 - f(&v, i, s - e).0) / (2.0 * e);
                    assert!((fd - f(&v, i, s).1).abs() < 1e-8, "{i} {s}");
                }
            }
        }
    }

    #[test]
    fn two_samples_give_the_straight_line() {
        let v = [0.2, 0.6];
        for s in [0.0, 0.25, 0.5, 1.0] {
            let (x, dx) = pchip(&v, 0, s);
            assert!((x - (0.2 + 0.4 * s)).abs() < 1e-15 && (dx - 0.4).abs() < 1e-15);
        }
    }
}
