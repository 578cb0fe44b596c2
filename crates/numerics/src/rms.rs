//! Root mean squares of slices.

/// Root mean square of `v`: `sqrt((Σ vᵢ²) / n)`, the squares summed in order from the first
/// element; 0 for an empty slice.
///
/// ```
/// assert_eq!(numerics::rms(&[3.0, -3.0]), 3.0);
/// assert_eq!(numerics::rms(&[]), 0.0);
/// ```
pub fn rms(v: &[f64]) -> f64 {
    if v.is_empty() {
        return 0.0;
    }
    (v.iter().map(|x| x * x).sum::<f64>() / v.len() as f64).sqrt()
}

/// Root mean square of `a − b`: `sqrt((Σ (aᵢ − bᵢ)²) / n)`, the squares summed in order from
/// the first element; 0 for empty slices.
///
/// # Panics
/// If `a` and `b` differ in length.
///
/// ```
/// assert_eq!(numerics::rms_diff(&[1.0, 5.0], &[-2.0, 8.0]), 3.0);
/// assert_eq!(numerics::rms_diff(&[], &[]), 0.0);
/// ```
pub fn rms_diff(a: &[f64], b: &[f64]) -> f64 {
    assert_eq!(a.len(), b.len(), "rms_diff of slices of different lengths");
    if a.is_empty() {
        return 0.0;
    }
    (a.iter().zip(b).map(|(x, y)| (x - y) * (x - y)).sum::<f64>() / a.len() as f64).sqrt()
}
