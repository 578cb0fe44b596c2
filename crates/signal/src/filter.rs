//! Second-order-section filtering: `sosfilt`, `sosfilt_zi`, `sosfiltfilt` as scipy.

use crate::design::Sos;
use crate::error::{check_finite, SignalError};

/// Run the cascade over `x` in place (transposed direct form II, scipy's `_sosfilt`
/// operation order), updating the per-section state `zi`. `reverse` walks the samples
/// from last to first, which equals filtering the time-reversed signal.
fn run_in_place(sections: &[[f64; 6]], zi: &mut [[f64; 2]], x: &mut [f64], reverse: bool) {
    let mut step = |v: &mut f64| {
        let mut cur = *v;
        for (s, z) in sections.iter().zip(zi.iter_mut()) {
            let new = s[0] * cur + z[0];
            z[0] = s[1] * cur - s[4] * new + z[1];
            z[1] = s[2] * cur - s[5] * new;
            cur = new;
        }
        *v = cur;
    };
    if reverse {
        x.iter_mut().rev().for_each(&mut step);
    } else {
        x.iter_mut().for_each(&mut step);
    }
}

fn check_state(sos: &Sos, zi: &[[f64; 2]]) -> Result<(), SignalError> {
    if zi.len() != sos.len() {
        return Err(SignalError::LengthMismatch {
            what: "filter state zi (one [f64; 2] per section)",
            expected: sos.len(),
            got: zi.len(),
        });
    }
    for row in zi {
        check_finite(row)?;
    }
    Ok(())
}

/// Filter `x` in place through `sos`, starting from state `zi` (one `[z0, z1]` per
/// section, `scipy.signal.sosfilt(..., zi=zi)`); on return `zi` holds the final state `zf`.
/// No allocation.
///
/// # Errors
/// [`SignalError::LengthMismatch`] if `zi.len() != sos.len()`,
/// [`SignalError::NonFiniteSample`] for a NaN/inf sample (or state entry).
pub fn sosfilt_inplace(sos: &Sos, x: &mut [f64], zi: &mut [[f64; 2]]) -> Result<(), SignalError> {
    check_state(sos, zi)?;
    check_finite(x)?;
    run_in_place(sos.sections(), zi, x, false);
    Ok(())
}

/// Filter `x` into the caller's buffer `y` (same length) starting from state `zi`,
/// which is updated to the final state. No allocation.
///
/// # Errors
/// As [`sosfilt_inplace`], plus [`SignalError::LengthMismatch`] if `y.len() != x.len()`.
pub fn sosfilt_into(
    sos: &Sos,
    x: &[f64],
    zi: &mut [[f64; 2]],
    y: &mut [f64],
) -> Result<(), SignalError> {
    if y.len() != x.len() {
        return Err(SignalError::LengthMismatch {
            what: "output buffer",
            expected: x.len(),
            got: y.len(),
        });
    }
    check_state(sos, zi)?;
    check_finite(x)?;
    y.copy_from_slice(x);
    run_in_place(sos.sections(), zi, y, false);
    Ok(())
}

/// `scipy.signal.sosfilt(sos, x)`: causal filtering from rest (zero initial state).
///
/// # Errors
/// [`SignalError::NonFiniteSample`] for a NaN/inf sample.
pub fn sosfilt(sos: &Sos, x: &[f64]) -> Result<Vec<f64>, SignalError> {
    check_finite(x)?;
    let mut y = x.to_vec();
    let mut zi = vec![[0.0; 2]; sos.len()];
    run_in_place(sos.sections(), &mut zi, &mut y, false);
    Ok(y)
}

/// `scipy.signal.lfilter_zi` for one section `[b0, b1, b2, 1, a1, a2]`: the state of the
/// step response's steady state, solving `(I − Aᵀ) zi = b[1:] − a[1:]·b0` with the
/// companion matrix `A`, by LU with partial pivoting in LAPACK's operation order.
fn lfilter_zi_section(s: &[f64; 6]) -> [f64; 2] {
    let (b0, b1, b2, a1, a2) = (s[0], s[1], s[2], s[4], s[5]);
    // I − companion(a)ᵀ = [[1 + a1, −1], [a2, 1]]
    let mut m = [[1.0 + a1, -1.0], [a2, 1.0]];
    let mut r = [b1 - a1 * b0, b2 - a2 * b0];
    if m[1][0].abs() > m[0][0].abs() {
        m.swap(0, 1);
        r.swap(0, 1);
    }
    if m[0][0] == 0.0 {
        // Singular (pole at z = 1): no steady state; scipy would raise. Use zero state.
        return [0.0, 0.0];
    }
    let l10 = m[1][0] * (1.0 / m[0][0]);
    let u11 = m[1][1] - l10 * m[0][1];
    let y1 = r[1] - l10 * r[0];
    if u11 == 0.0 {
        return [0.0, 0.0];
    }
    let x1 = y1 / u11;
    let x0 = (r[0] - x1 * m[0][1]) / m[0][0];
    [x0, x1]
}

/// `scipy.signal.sosfilt_zi(sos)`: initial state for a step response at steady state
/// (unit input), section `s` scaled by the DC gain of sections `0..s`.
pub fn sosfilt_zi(sos: &Sos) -> Vec<[f64; 2]> {
    let mut scale = 1.0;
    sos.sections()
        .iter()
        .map(|s| {
            let z = lfilter_zi_section(s);
            let out = [scale * z[0], scale * z[1]];
            // numpy's reduction order for a 3-element sum: x0 + (x1 + x2).
            scale *= (s[0] + (s[1] + s[2])) / (s[3] + (s[4] + s[5]));
            out
        })
        .collect()
}

/// scipy's default pad length for `sosfiltfilt`:
/// `3 · (2·n_sections + 1 − min(#{b2 = 0}, #{a2 = 0}))`.
pub fn sosfiltfilt_padlen(sos: &Sos) -> usize {
    let nb = sos.sections().iter().filter(|s| s[2] == 0.0).count();
    let na = sos.sections().iter().filter(|s| s[5] == 0.0).count();
    3 * (2 * sos.len() + 1 - nb.min(na))
}

/// Forward-backward pass over the odd extension of `x`, built in `scratch`; on success
/// the zero-phase output is `scratch[padlen..padlen + x.len()]` and `padlen` is returned.
fn filtfilt_core(sos: &Sos, x: &[f64], scratch: &mut Vec<f64>) -> Result<usize, SignalError> {
    let n = x.len();
    let edge = sosfiltfilt_padlen(sos);
    if n <= edge {
        return Err(SignalError::SignalTooShort {
            len: n,
            padlen: edge,
        });
    }
    check_finite(x)?;
    // Odd extension: 2·x[0] − x[edge..0 step −1], x, 2·x[n−1] − x[n−2 .. n−2−edge step −1].
    scratch.clear();
    scratch.extend((1..=edge).rev().map(|i| 2.0 * x[0] - x[i]));
    scratch.extend_from_slice(x);
    scratch.extend((1..=edge).map(|i| 2.0 * x[n - 1] - x[n - 1 - i]));

    let zi0 = sosfilt_zi(sos);
    let mut zi = zi0.clone();
    let x0 = scratch[0];
    for z in &mut zi {
        z[0] *= x0;
        z[1] *= x0;
    }
    run_in_place(sos.sections(), &mut zi, scratch, false);
    let y0 = scratch[scratch.len() - 1];
    for (z, z0) in zi.iter_mut().zip(&zi0) {
        z[0] = z0[0] * y0;
        z[1] = z0[1] * y0;
    }
    run_in_place(sos.sections(), &mut zi, scratch, true);
    Ok(edge)
}

/// Zero-phase filtering into the caller's buffer `y`, reusing `scratch` for the padded
/// signal (grown as needed, never shrunk). See [`sosfiltfilt`].
///
/// # Errors
/// As [`sosfiltfilt`], plus [`SignalError::LengthMismatch`] if `y.len() != x.len()`.
pub fn sosfiltfilt_into(
    sos: &Sos,
    x: &[f64],
    y: &mut [f64],
    scratch: &mut Vec<f64>,
) -> Result<(), SignalError> {
    if y.len() != x.len() {
        return Err(SignalError::LengthMismatch {
            what: "output buffer",
            expected: x.len(),
            got: y.len(),
        });
    }
    let edge = filtfilt_core(sos, x, scratch)?;
    y.copy_from_slice(&scratch[edge..edge + x.len()]);
    Ok(())
}

/// Zero-phase filtering of `x` in place, reusing `scratch` for the padded signal.
/// See [`sosfiltfilt`]. On error `x` is left unchanged.
///
/// # Errors
/// As [`sosfiltfilt`].
pub fn sosfiltfilt_inplace(
    sos: &Sos,
    x: &mut [f64],
    scratch: &mut Vec<f64>,
) -> Result<(), SignalError> {
    let edge = filtfilt_core(sos, x, scratch)?;
    let n = x.len();
    x.copy_from_slice(&scratch[edge..edge + n]);
    Ok(())
}

/// `scipy.signal.sosfiltfilt(sos, x)` with its defaults: forward-backward filtering
/// (zero phase, squared magnitude response) of the odd extension of `x` by
/// `padlen = `[`sosfiltfilt_padlen`] samples per side, with initial states
/// `sosfilt_zi · ext[0]` forward and `sosfilt_zi · y_fwd[last]` backward.
///
/// # Errors
/// [`SignalError::SignalTooShort`] unless `x.len() > padlen`,
/// [`SignalError::NonFiniteSample`] for a NaN/inf sample.
pub fn sosfiltfilt(sos: &Sos, x: &[f64]) -> Result<Vec<f64>, SignalError> {
    let mut y = vec![0.0; x.len()];
    let mut scratch = Vec::with_capacity(x.len() + 2 * sosfiltfilt_padlen(sos));
    sosfiltfilt_into(sos, x, &mut y, &mut scratch)?;
    Ok(y)
}
