//! Numbers as a reader meets them in summaries, warnings and report pages: a fixed number of
//! decimals and the typographic minus sign (U+2212, which a proportional font sets as wide
//! as the plus), with or without an explicit sign.
//!
//! ```
//! use numerics::text::{fixed, signed};
//! assert_eq!(fixed(-2.345, 2), "−2.35");
//! assert_eq!(signed(2.2, 1), "+2.2");
//! assert_eq!(signed(-14.8, 1), "−14.8");
//! ```

/// `x` with `decimals` decimals and a typographic minus.
pub fn fixed(x: f64, decimals: usize) -> String {
    format!("{x:.decimals$}").replace('-', "−")
}

/// `x` with `decimals` decimals, an explicit sign and a typographic minus: a change, a fall
/// shown with its minus.
pub fn signed(x: f64, decimals: usize) -> String {
    format!("{x:+.decimals$}").replace('-', "−")
}

#[cfg(test)]
mod tests {
    use super::{fixed, signed};

    #[test]
    fn signs_are_typographic_and_explicit_only_when_asked() {
        assert_eq!(fixed(3.0, 1), "3.0");
        assert_eq!(fixed(-0.04, 1), "−0.0");
        assert_eq!(signed(0.0, 2), "+0.00");
        assert_eq!(signed(-1.25e3, 0), "−1250");
        assert!(!signed(-7.5, 1).contains('-'));
    }
}
