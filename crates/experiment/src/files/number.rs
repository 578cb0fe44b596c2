//! The number format of the files: shortest round-trip decimals.

use std::fmt::Write as _;

/// Appends `x` in the crate's file format: the shortest decimal string that parses back to
/// exactly `x` (Rust's round-trip `Display`/`LowerExp` digits). Plain notation for
/// `1e-5 ≤ |x| < 1e15` and for zero, scientific (`4.2e-7`) otherwise. `-0.0` is written `-0`.
pub fn write_f64(out: &mut String, x: f64) {
    let a = x.abs();
    // Writing into a String cannot fail.
    if a == 0.0 || ((1e-5..1e15).contains(&a)) || !x.is_finite() {
        let _ = write!(out, "{x}");
    } else {
        let _ = write!(out, "{x:e}");
    }
}

/// [`write_f64`] into a new string.
#[must_use]
pub fn format_f64(x: f64) -> String {
    let mut s = String::new();
    write_f64(&mut s, x);
    s
}
