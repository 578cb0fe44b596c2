//! Dense Cholesky factorisation `A = L Lᵀ` of a symmetric positive-definite matrix, and the
//! triangular solves that use it.
//!
//! Matrices are row-major `n × n` slices; only the lower triangle of `A` is read. Column `j`
//! of `L` is
//!
//! ```text
//! L_jj = √(A_jj − Σ_{k<j} L_jk²),     L_ij = (A_ij − Σ_{k<j} L_ik L_jk) / L_jj   (i > j),
//! ```
//!
//! the sums taken in increasing `k`. A pivot `A_jj − Σ L_jk²` that is not positive and finite
//! ends the factorisation with [`NumericsError::NotPositiveDefinite`] naming `j`.
//!
//! The matrices here are small (the 9–12 parameters of the muscle model, the ≤ 3 linear
//! forces of the MCMC's conditional), so a plain loop is used rather than a library
//! factorisation: on 9×9 and 12×12 SPD matrices `faer` 0.22's one-call `Mat::llt` took
//! 1.5–3.2× the time of this loop with its copy (0.67–0.95 µs against 0.29–0.61 µs, two runs
//! on the shared two-core machine), and its factor differs from this one in the last bit
//! (largest difference 2.2·10⁻¹⁶), so the identification results would not stay as they are.
//!
//! ```
//! use numerics::cholesky::{cholesky, solve_lower_in_place, solve_lower_transpose_in_place};
//! // [[4, 2], [2, 3]] = L Lᵀ with L = [[2, 0], [1, √2]]
//! let l = cholesky(&[4.0, 2.0, 2.0, 3.0], 2).unwrap();
//! assert_eq!(&l[..3], &[2.0, 0.0, 1.0]);
//! // solve A x = b: L y = b, then Lᵀ x = y
//! let mut b = [2.0, 1.0];
//! solve_lower_in_place(&l, &mut b);
//! solve_lower_transpose_in_place(&l, &mut b);
//! assert!((b[0] - 0.5).abs() < 1e-15 && b[1].abs() < 1e-15);
//! ```

use crate::NumericsError;

/// Factor the lower triangle of `a` (row-major `n × n`) in place into `L`; the strict upper
/// triangle is set to zero.
///
/// # Errors
/// [`NumericsError::DimensionMismatch`] when `a.len() != n²`;
/// [`NumericsError::NotPositiveDefinite`] at the first pivot that is not positive and finite
/// (`a` is then partly overwritten).
pub fn cholesky_in_place(a: &mut [f64], n: usize) -> Result<(), NumericsError> {
    if a.len() != n * n {
        return Err(NumericsError::DimensionMismatch {
            expected: n * n,
            found: a.len(),
        });
    }
    for j in 0..n {
        let mut s = a[j * n + j];
        for k in 0..j {
            s -= a[j * n + k] * a[j * n + k];
        }
        if !(s > 0.0 && s.is_finite()) {
            return Err(NumericsError::NotPositiveDefinite { pivot: j });
        }
        let ljj = s.sqrt();
        a[j * n + j] = ljj;
        for i in j + 1..n {
            let mut s = a[i * n + j];
            for k in 0..j {
                s -= a[i * n + k] * a[j * n + k];
            }
            a[i * n + j] = s / ljj;
        }
        for k in j + 1..n {
            a[j * n + k] = 0.0;
        }
    }
    Ok(())
}

/// The lower Cholesky factor of `a` (row-major `n × n`) as a new matrix; see
/// [`cholesky_in_place`].
///
/// # Errors
/// As [`cholesky_in_place`].
pub fn cholesky(a: &[f64], n: usize) -> Result<Vec<f64>, NumericsError> {
    let mut l = a.to_vec();
    cholesky_in_place(&mut l, n)?;
    Ok(l)
}

/// Solve `L x = b` in place by forward substitution, `L` lower triangular (row-major `n × n`,
/// `n = b.len()`).
pub fn solve_lower_in_place(l: &[f64], b: &mut [f64]) {
    let n = b.len();
    for i in 0..n {
        let mut v = b[i];
        for (p, bp) in b[..i].iter().enumerate() {
            v -= l[i * n + p] * bp;
        }
        b[i] = v / l[i * n + i];
    }
}

/// Solve `Lᵀ x = b` in place by back substitution, `L` lower triangular (row-major `n × n`,
/// `n = b.len()`).
pub fn solve_lower_transpose_in_place(l: &[f64], b: &mut [f64]) {
    let n = b.len();
    for i in (0..n).rev() {
        let mut v = b[i];
        for p in i + 1..n {
            v -= l[p * n + i] * b[p];
        }
        b[i] = v / l[i * n + i];
    }
}

/// Solve `A x = b` for a symmetric positive-definite `A` (row-major `n × n`, `n = b.len()`):
/// `A` is overwritten by its factor `L`, `b` by `x`.
///
/// # Errors
/// As [`cholesky_in_place`] (`b` is then unchanged).
pub fn cholesky_solve_in_place(a: &mut [f64], b: &mut [f64]) -> Result<(), NumericsError> {
    cholesky_in_place(a, b.len())?;
    solve_lower_in_place(a, b);
    solve_lower_transpose_in_place(a, b);
    Ok(())
}

/// The inverse of the symmetric positive-definite `a` (row-major `n × n`), column by column
/// from its Cholesky factor.
///
/// # Errors
/// As [`cholesky_in_place`].
pub fn spd_inverse(a: &[f64], n: usize) -> Result<Vec<f64>, NumericsError> {
    let l = cholesky(a, n)?;
    let mut inv = vec![0.0; n * n];
    let mut col = vec![0.0; n];
    for c in 0..n {
        col.iter_mut().enumerate().for_each(|(i, v)| {
            *v = if i == c { 1.0 } else { 0.0 };
        });
        solve_lower_in_place(&l, &mut col);
        solve_lower_transpose_in_place(&l, &mut col);
        for (i, v) in col.iter().enumerate() {
            inv[i * n + c] = *v;
        }
    }
    Ok(inv)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn factor_of_a_known_matrix() {
        // [[4, 2], [2, 3]] = L Lᵀ with L = [[2, 0], [1, √2]]; the upper entry is ignored
        let mut a = vec![4.0, 99.0, 2.0, 3.0];
        cholesky_in_place(&mut a, 2).unwrap();
        let want = [2.0, 0.0, 1.0, 2f64.sqrt()];
        for (g, w) in a.iter().zip(want) {
            assert!((g - w).abs() < 1e-15);
        }
    }

    #[test]
    fn indefinite_matrices_name_the_failing_pivot() {
        assert_eq!(
            cholesky(&[1.0, 2.0, 2.0, 1.0], 2),
            Err(NumericsError::NotPositiveDefinite { pivot: 1 })
        );
        assert_eq!(
            cholesky(&[-1.0, 0.0, 0.0, 1.0], 2),
            Err(NumericsError::NotPositiveDefinite { pivot: 0 })
        );
        assert_eq!(
            cholesky(&[f64::NAN, 0.0, 0.0, 1.0], 2),
            Err(NumericsError::NotPositiveDefinite { pivot: 0 })
        );
        assert!(matches!(
            cholesky(&[1.0, 0.0, 0.0], 2),
            Err(NumericsError::DimensionMismatch { .. })
        ));
    }

    #[test]
    fn inverse_of_a_known_matrix() {
        let inv = spd_inverse(&[4.0, 2.0, 2.0, 3.0], 2).unwrap();
        let want = [3.0 / 8.0, -2.0 / 8.0, -2.0 / 8.0, 4.0 / 8.0];
        for (g, w) in inv.iter().zip(want) {
            assert!((g - w).abs() < 1e-14);
        }
    }

    #[test]
    fn solves_a_larger_system() {
        // A = B Bᵀ + n·I for a fixed B; check A x = b by multiplying back
        let n = 9;
        let b: Vec<f64> = (0..n * n)
            .map(|k| ((k * 37 % 17) as f64 - 8.0) / 8.0)
            .collect();
        let mut a = vec![0.0; n * n];
        for i in 0..n {
            for j in 0..n {
                a[i * n + j] = (0..n).map(|k| b[i * n + k] * b[j * n + k]).sum::<f64>()
                    + if i == j { n as f64 } else { 0.0 };
            }
        }
        let rhs: Vec<f64> = (0..n).map(|i| i as f64 - 3.0).collect();
        let mut x = rhs.clone();
        let mut f = a.clone();
        cholesky_solve_in_place(&mut f, &mut x).unwrap();
        for i in 0..n {
            let ax: f64 = (0..n).map(|j| a[i * n + j] * x[j]).sum();
            assert!((ax - rhs[i]).abs() < 1e-12, "row {i}: {ax} vs {}", rhs[i]);
        }
    }
}
