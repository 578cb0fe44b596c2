//! The fast Fourier transform shared by the MCMC's autocorrelations (effective sample size)
//! and the recording checks' power spectra: iterative radix-2 Cooley–Tukey, in place.
//!
//! ```
//! use numerics::fft::fft_in_place;
//! // a pure cosine of 2 cycles over 8 samples puts n/2 into bins 2 and 6
//! let mut re: Vec<f64> = (0..8)
//!     .map(|j| (2.0 * std::f64::consts::TAU * j as f64 / 8.0).cos())
//!     .collect();
//! let mut im = vec![0.0; 8];
//! fft_in_place(&mut re, &mut im, false);
//! assert!((re[2] - 4.0).abs() < 1e-12 && (re[6] - 4.0).abs() < 1e-12);
//! assert!(re[0].abs() < 1e-12 && im[2].abs() < 1e-12);
//! ```

/// In-place iterative radix-2 complex FFT of a power-of-two length `n`, unnormalised:
/// `X_k = Σ_j x_j·e^{∓2πijk/n}` (`−` forward, `+` with `inverse`).
///
/// # Panics
/// In debug builds, when the length is not a power of two or `im` is shorter than `re`.
pub fn fft_in_place(re: &mut [f64], im: &mut [f64], inverse: bool) {
    let n = re.len();
    debug_assert!(n.is_power_of_two() && im.len() >= n);
    // Bit-reversal permutation.
    let mut j = 0;
    for i in 1..n {
        let mut bit = n >> 1;
        while j & bit != 0 {
            j ^= bit;
            bit >>= 1;
        }
        j |= bit;
        if i < j {
            re.swap(i, j);
            im.swap(i, j);
        }
    }
    let sign = if inverse { 1.0 } else { -1.0 };
    let mut len = 2;
    while len <= n {
        let half = len / 2;
        let step = std::f64::consts::TAU / len as f64;
        for k in 0..half {
            let (s, c) = (sign * step * k as f64).sin_cos();
            for start in (0..n).step_by(len) {
                let a = start + k;
                let b = a + half;
                let tr = re[b] * c - im[b] * s;
                let ti = re[b] * s + im[b] * c;
                re[b] = re[a] - tr;
                im[b] = im[a] - ti;
                re[a] += tr;
                im[a] += ti;
            }
        }
        len <<= 1;
    }
}

#[cfg(test)]
mod tests {
    use super::fft_in_place;

    /// Forward against a direct DFT, and the inverse brings the signal back (times n).
    #[test]
    fn matches_a_direct_dft_and_inverts() {
        let n = 64;
        let x: Vec<f64> = (0..n)
            .map(|j| ((j * 7 % 13) as f64).sin() + 0.1 * j as f64)
            .collect();
        let (mut re, mut im) = (x.clone(), vec![0.0; n]);
        fft_in_place(&mut re, &mut im, false);
        let tau = std::f64::consts::TAU;
        for k in 0..n {
            let (mut r, mut i) = (0.0, 0.0);
            for (j, v) in x.iter().enumerate() {
                let a = -tau * (j * k) as f64 / n as f64;
                r += v * a.cos();
                i += v * a.sin();
            }
            assert!((re[k] - r).abs() < 1e-9, "re {k}");
            assert!((im[k] - i).abs() < 1e-9, "im {k}");
        }
        fft_in_place(&mut re, &mut im, true);
        for (k, v) in x.iter().enumerate() {
            assert!((re[k] / n as f64 - v).abs() < 1e-12, "{k}");
        }
    }
}
