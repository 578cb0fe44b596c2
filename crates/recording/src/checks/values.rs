//! The small numeric and formatting helpers that several checks share.

pub(super) use numerics::text::{fixed as num, signed};

pub(super) fn finite_min_max(x: &[f64]) -> (Option<f64>, Option<f64>) {
    let mut it = x.iter().copied().filter(|v| v.is_finite());
    let Some(first) = it.next() else {
        return (None, None);
    };
    let (lo, hi) = it.fold((first, first), |(l, h), v| (l.min(v), h.max(v)));
    (Some(lo), Some(hi))
}

/// Median of the values (`None` when empty); NaN-free input expected.
pub(super) fn median_of(x: &[f64]) -> Option<f64> {
    if x.is_empty() {
        return None;
    }
    let mut v = x.to_vec();
    v.sort_by(f64::total_cmp);
    let n = v.len();
    Some(0.5 * (v[(n - 1) / 2] + v[n / 2]))
}

/// The `p`-quantile (0…1) of the finite values, the sample at rank `round(p·(n − 1))` of
/// the sorted values (`None` without finite values).
pub(super) fn finite_quantile(x: &[f64], p: f64) -> Option<f64> {
    let mut v: Vec<f64> = x.iter().copied().filter(|v| v.is_finite()).collect();
    if v.is_empty() {
        return None;
    }
    v.sort_by(f64::total_cmp);
    Some(v[((v.len() - 1) as f64 * p.clamp(0.0, 1.0)).round() as usize])
}
