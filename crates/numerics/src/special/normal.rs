//! The standard normal distribution: CDF `Φ`, quantile `Φ⁻¹` and the complementary error
//! function.
//!
//! `Φ(x) = erfc(−x/√2)/2`. [`erfc`] is evaluated from the positive power series
//! `erf(x) = (2/√π) e^{−x²} Σₙ 2ⁿ x^{2n+1} / (1·3·…·(2n+1))` for `|x| < 0.5` and from Laplace's
//! continued fraction `erfc(x) = e^{−x²}/√π · 1/(x + (1/2)/(x + 1/(x + (3/2)/(x + …))))` above,
//! which need no fitted constants and are exact to a few ulps. [`normal_quantile`] is
//! Wichura's AS 241 (`PPND16`), about 1e-16 relative accuracy: the algorithm R's `qnorm`
//! uses, so rank-normalised diagnostics agree with R's `posterior` package to the last bits.

/// Φ⁻¹(p), the standard normal quantile (Wichura 1988, AS 241, `PPND16`).
///
/// Returns `-∞` at `p = 0`, `+∞` at `p = 1` and NaN for `p` outside `[0, 1]`
/// or NaN.
///
/// ```
/// use numerics::special::normal_quantile;
/// assert!((normal_quantile(0.975) - 1.959_963_984_540_054).abs() < 1e-15);
/// assert_eq!(normal_quantile(0.5), 0.0);
/// ```
#[allow(clippy::excessive_precision)]
pub fn normal_quantile(p: f64) -> f64 {
    // Coefficients of AS 241 (Wichura 1988), lowest degree first.
    const A: [f64; 8] = [
        3.3871328727963666080e0,
        1.3314166789178437745e+2,
        1.9715909503065514427e+3,
        1.3731693765509461125e+4,
        4.5921953931549871457e+4,
        6.7265770927008700853e+4,
        3.3430575583588128105e+4,
        2.5090809287301226727e+3,
    ];
    const B: [f64; 8] = [
        1.0,
        4.2313330701600911252e+1,
        6.8718700749205790830e+2,
        5.3941960214247511077e+3,
        2.1213794301586595867e+4,
        3.9307895800092710610e+4,
        2.8729085735721942674e+4,
        5.2264952788528545610e+3,
    ];
    const C: [f64; 8] = [
        1.42343711074968357734e0,
        4.63033784615654529590e0,
        5.76949722146069140550e0,
        3.64784832476320460504e0,
        1.27045825245236838258e0,
        2.41780725177450611770e-1,
        2.27238449892691845833e-2,
        7.74545014278341407640e-4,
    ];
    const D: [f64; 8] = [
        1.0,
        2.05319162663775882187e0,
        1.67638483018380384940e0,
        6.89767334985100004550e-1,
        1.48103976427480074590e-1,
        1.51986665636164571966e-2,
        5.47593808499534494600e-4,
        1.05075007164441684324e-9,
    ];
    const E: [f64; 8] = [
        6.65790464350110377720e0,
        5.46378491116411436990e0,
        1.78482653991729133580e0,
        2.96560571828504891230e-1,
        2.65321895265761230930e-2,
        1.24266094738807843860e-3,
        2.71155556874348757815e-5,
        2.01033439929228813265e-7,
    ];
    const F: [f64; 8] = [
        1.0,
        5.99832206555887937690e-1,
        1.36929880922735805310e-1,
        1.48753612908506148525e-2,
        7.86869131145613259100e-4,
        1.84631831751005468180e-5,
        1.42151175831644588870e-7,
        2.04426310338993978564e-15,
    ];
    if p.is_nan() || !(0.0..=1.0).contains(&p) {
        return f64::NAN;
    }
    if p == 0.0 {
        return f64::NEG_INFINITY;
    }
    if p == 1.0 {
        return f64::INFINITY;
    }
    let q = p - 0.5;
    if q.abs() <= 0.425 {
        let r = 0.180625 - q * q;
        return q * horner(&A, r) / horner(&B, r);
    }
    let tail = if q < 0.0 { p } else { 1.0 - p };
    let r = (-tail.ln()).sqrt();
    let value = if r <= 5.0 {
        let r = r - 1.6;
        horner(&C, r) / horner(&D, r)
    } else {
        let r = r - 5.0;
        horner(&E, r) / horner(&F, r)
    };
    if q < 0.0 {
        -value
    } else {
        value
    }
}

/// `c[0] + c[1]·x + … + c[7]·x⁷` by Horner's rule.
fn horner(c: &[f64; 8], x: f64) -> f64 {
    c.iter().rev().fold(0.0, |acc, &ci| acc * x + ci)
}

/// The complementary error function `erfc(x) = 1 − erf(x)`.
///
/// For `|x| < 0.5` the positive series
/// `erf(x) = (2/√π) e^{−x²} Σₙ 2ⁿ x^{2n+1} / (1·3·…·(2n+1))`; for `x ≥ 0.5`
/// Laplace's continued fraction
/// `erfc(x) = e^{−x²}/√π · 1/(x + (1/2)/(x + 1/(x + (3/2)/(x + …))))`
/// (modified Lentz); `erfc(−x) = 2 − erfc(x)`.
pub fn erfc(x: f64) -> f64 {
    if x.is_nan() {
        return f64::NAN;
    }
    if x < 0.0 {
        return 2.0 - erfc(-x);
    }
    let two_over_sqrt_pi = std::f64::consts::FRAC_2_SQRT_PI;
    if x < 0.5 {
        let x2 = x * x;
        let mut term = x;
        let mut sum = x;
        let mut n = 0.0;
        loop {
            n += 1.0;
            term *= 2.0 * x2 / (2.0 * n + 1.0);
            sum += term;
            if term.abs() <= 1e-17 * sum.abs() {
                break;
            }
        }
        return 1.0 - two_over_sqrt_pi * (-x2).exp() * sum;
    }
    if x > 27.3 {
        return 0.0;
    }
    let tiny = 1e-300;
    let mut f = x;
    let mut c = f;
    let mut d = 0.0;
    for n in 1..20_000 {
        let a = 0.5 * n as f64;
        d = x + a * d;
        if d.abs() < tiny {
            d = tiny;
        }
        d = 1.0 / d;
        c = x + a / c;
        if c.abs() < tiny {
            c = tiny;
        }
        let delta = c * d;
        f *= delta;
        if (delta - 1.0).abs() < 1e-16 {
            break;
        }
    }
    0.5 * two_over_sqrt_pi * (-x * x).exp() / f
}

/// Φ(x), the standard normal CDF, `erfc(−x/√2)/2`.
///
/// ```
/// use numerics::special::normal_cdf;
/// assert!((normal_cdf(1.959_963_984_540_054) - 0.975).abs() < 1e-15);
/// ```
pub fn normal_cdf(x: f64) -> f64 {
    0.5 * erfc(-x / std::f64::consts::SQRT_2)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn erfc_known_values() {
        let cases = [
            (0.0, 1.0),
            (0.25, 0.723_673_609_831_763_3),
            (0.5, 0.479_500_122_186_953_5),
            (1.0, 0.157_299_207_050_285_13),
            (2.0, 0.004_677_734_981_047_266),
            (3.0, 2.209_049_699_858_544e-5),
            (-1.0, 1.842_700_792_949_715),
        ];
        for (x, want) in cases {
            let got = erfc(x);
            assert!(
                ((got - want) / want).abs() < 4e-15,
                "erfc({x}) = {got}, want {want}"
            );
        }
    }

    #[test]
    fn quantile_inverts_cdf() {
        // Relative residual of Φ(Φ⁻¹(p)) = p over the central range and both tails.
        let mut p = 1e-12;
        while p < 1.0 {
            let z = normal_quantile(p);
            let back = if p < 0.5 {
                normal_cdf(z)
            } else {
                1.0 - normal_cdf(z)
            };
            let target = if p < 0.5 { p } else { 1.0 - p };
            // dΦ/dz·δz: the z error is what matters; scale by the density.
            let dens = (-0.5 * z * z).exp() / (2.0 * std::f64::consts::PI).sqrt();
            let dz = (back - target) / dens;
            // The series/continued-fraction Φ used as a check is itself exact
            // only to ~4e-15 relative; the mpmath table below is the tight test.
            assert!(
                dz.abs() <= 1e-14 * z.abs().max(1e-3) + 1e-16,
                "p = {p}: z = {z}, dz = {dz}"
            );
            p = if p < 0.01 { p * 3.7 } else { p + 0.0137 };
        }
    }

    #[test]
    fn quantile_matches_high_precision_values() {
        // Φ⁻¹ of the f64 nearest each p, from mpmath at 40 digits.
        let table = [
            (1e-300, -37.047_096_299_361_2),
            (1e-50, -14.933_337_534_788_489),
            (1e-12, -7.034_483_825_301_132),
            (0.0001, -3.719_016_485_455_680_6),
            (0.01, -2.326_347_874_040_841),
            (0.05, -1.644_853_626_951_472_7),
            (0.2, -0.841_621_233_572_914_2),
            (0.3, -0.524_400_512_708_040_8),
            (0.45, -0.125_661_346_855_074),
            (0.55, 0.125_661_346_855_074_15),
            (0.75, 0.674_489_750_196_081_7),
            (0.9, 1.281_551_565_544_600_6),
            (0.99, 2.326_347_874_040_840_8),
            (0.999_999, 4.753_424_308_817_088),
        ];
        for (p, z) in table {
            let got = normal_quantile(p);
            assert!(
                ((got - z) / z).abs() < 1e-15,
                "normal_quantile({p}) = {got}, want {z}"
            );
        }
        assert_eq!(normal_quantile(0.5), 0.0);
    }

    #[test]
    fn quantile_known_values_and_edges() {
        assert!((normal_quantile(0.975) - 1.959_963_984_540_054).abs() < 1e-15);
        assert!((normal_quantile(0.025) + 1.959_963_984_540_054).abs() < 1e-15);
        assert!((normal_quantile(0.841_344_746_068_542_9) - 1.0).abs() < 1e-14);
        assert!((normal_quantile(1e-20) + 9.262_340_089_798_408).abs() < 1e-13);
        assert_eq!(normal_quantile(0.0), f64::NEG_INFINITY);
        assert_eq!(normal_quantile(1.0), f64::INFINITY);
        assert!(normal_quantile(-0.1).is_nan());
        assert!(normal_quantile(f64::NAN).is_nan());
        // Symmetry (1 − p is exact for these p).
        for p in [0.015625, 0.125, 0.3125, 0.4375] {
            assert_eq!(normal_quantile(p), -normal_quantile(1.0 - p));
        }
    }
}
