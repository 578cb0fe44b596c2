//! The small numeric and formatting helpers that several checks share.

pub(super) fn finite_min_max(x: &[f64]) -> (Option<f64>, Option<f64>) {
    let mut it = x.iter().copied().filter(|v| v.is_finite());
    let Some(first) = it.next() else {
        return (None, None);
    };
    let (lo, hi) = it.fold((first, first), |(l, h), v| (l.min(v), h.max(v)));
    (Some(lo), Some(hi))
}

/// `x` with `d` decimals and a typographic minus.
pub(super) fn num(x: f64, d: usize) -> String {
    format!("{x:.d$}").replace('-', "−")
}

/// `x` with `d` decimals, an explicit sign and a typographic minus.
pub(super) fn signed(x: f64, d: usize) -> String {
    format!("{x:+.d$}").replace('-', "−")
}
