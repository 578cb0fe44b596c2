//! Linear resampling of a time series onto other times.
//!
//! For samples `(t_i, y_i)` with `t_0 < t_1 < … < t_{n−1}`, the value at `s` is
//!
//! ```text
//! y(s) = y_i + (s − t_i)·(y_{i+1} − y_i)/(t_{i+1} − t_i)     for t_i ≤ s ≤ t_{i+1},
//! y(s) = y_0 for s < t_0,   y(s) = y_{n−1} for s > t_{n−1}   (the end values are held).
//! ```
//!
//! Holding the ends is deliberate: recordings of one trial from different systems start and
//! stop at slightly different times, and the caller decides (and documents) what a held value
//! means for its data rather than getting an error on the first sample outside. Callers that
//! must not extrapolate check the span themselves.
//!
//! # Errors
//! [`NumericsError::BadTimes`] when the sample times are empty, not finite or not strictly
//! increasing, or a requested time is not finite (naming which times and the index);
//! [`NumericsError::DimensionMismatch`] when `values` and `times` differ in length.
//!
//! ```
//! use numerics::interpolate::resample_linear;
//! let y = resample_linear(&[0.0, 1.0, 3.0], &[0.0, 2.0, 0.0], &[-1.0, 0.5, 2.0, 9.0]).unwrap();
//! assert_eq!(y, vec![0.0, 1.0, 1.0, 0.0]);
//! assert!(resample_linear(&[0.0, 0.0], &[1.0, 2.0], &[0.0]).is_err());
//! ```

use crate::NumericsError;

/// The series `values` sampled at `times`, linearly interpolated at each of `at` (any order),
/// the end values held outside `[times[0], times[n−1]]`.
///
/// # Errors
/// See the module documentation.
pub fn resample_linear(
    times: &[f64],
    values: &[f64],
    at: &[f64],
) -> Result<Vec<f64>, NumericsError> {
    check_times(times)?;
    if values.len() != times.len() {
        return Err(NumericsError::DimensionMismatch {
            expected: times.len(),
            found: values.len(),
        });
    }
    let n = times.len();
    at.iter()
        .enumerate()
        .map(|(k, &s)| {
            if !s.is_finite() {
                return Err(NumericsError::BadTimes {
                    which: "requested times",
                    index: k,
                    reason: "not finite",
                });
            }
            if s <= times[0] {
                return Ok(values[0]);
            }
            if s >= times[n - 1] {
                return Ok(values[n - 1]);
            }
            // first sample strictly after s; 1 ≤ j ≤ n − 1 here
            let j = times.partition_point(|&t| t <= s);
            let (t0, t1) = (times[j - 1], times[j]);
            let w = (s - t0) / (t1 - t0);
            Ok(values[j - 1] + w * (values[j] - values[j - 1]))
        })
        .collect()
}

/// Checks that `times` is non-empty, finite and strictly increasing.
///
/// # Errors
/// [`NumericsError::BadTimes`] naming the first offending index.
pub fn check_times(times: &[f64]) -> Result<(), NumericsError> {
    let bad = |index, reason| NumericsError::BadTimes {
        which: "sample times",
        index,
        reason,
    };
    if times.is_empty() {
        return Err(bad(0, "no samples"));
    }
    for (i, t) in times.iter().enumerate() {
        if !t.is_finite() {
            return Err(bad(i, "not finite"));
        }
        if i > 0 && *t <= times[i - 1] {
            return Err(bad(i, "not after the previous time"));
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reproduces_a_linear_function_and_holds_the_ends() {
        let t: Vec<f64> = (0..50)
            .map(|i| 0.004 * i as f64 + 0.001 * (i % 3) as f64)
            .collect();
        let y: Vec<f64> = t.iter().map(|&t| 3.0 - 2.0 * t).collect();
        let at: Vec<f64> = (0..500).map(|k| -0.01 + 0.0005 * k as f64).collect();
        let r = resample_linear(&t, &y, &at).unwrap();
        for (s, v) in at.iter().zip(&r) {
            let want = 3.0 - 2.0 * s.clamp(t[0], t[49]);
            assert!((v - want).abs() < 1e-12, "{s}: {v} vs {want}");
        }
        // at the samples themselves the values come back exactly
        assert_eq!(resample_linear(&t, &y, &t).unwrap(), y);
        // a single sample is a constant
        assert_eq!(
            resample_linear(&[1.0], &[7.0], &[0.0, 2.0]).unwrap(),
            vec![7.0, 7.0]
        );
    }

    #[test]
    fn error_of_a_sine_is_second_order() {
        // halving the step quarters the largest error (h²·max|y''|/8)
        let err = |h: f64| {
            let t: Vec<f64> = (0..=(1.0 / h) as usize).map(|i| i as f64 * h).collect();
            let y: Vec<f64> = t.iter().map(|t| (7.0 * t).sin()).collect();
            let at: Vec<f64> = (0..1000).map(|k| k as f64 / 1000.0).collect();
            let r = resample_linear(&t, &y, &at).unwrap();
            at.iter()
                .zip(&r)
                .map(|(s, v)| (v - (7.0 * s).sin()).abs())
                .fold(0.0, f64::max)
        };
        let (e1, e2) = (err(0.02), err(0.01));
        assert!(e1 <= 0.02f64.powi(2) * 49.0 / 8.0 * 1.0001, "{e1}");
        assert!((e1 / e2 - 4.0).abs() < 0.5, "{e1} {e2}");
    }

    #[test]
    fn bad_times_are_named() {
        let e = resample_linear(&[0.0, 1.0, 1.0], &[0.0; 3], &[0.5]).unwrap_err();
        assert_eq!(
            e.to_string(),
            "sample times[2]: not after the previous time"
        );
        let e = resample_linear(&[0.0, f64::NAN], &[0.0; 2], &[0.5]).unwrap_err();
        assert_eq!(e.to_string(), "sample times[1]: not finite");
        let e = resample_linear(&[], &[], &[0.5]).unwrap_err();
        assert_eq!(e.to_string(), "sample times[0]: no samples");
        let e = resample_linear(&[0.0, 1.0], &[0.0; 2], &[0.5, f64::INFINITY]).unwrap_err();
        assert_eq!(e.to_string(), "requested times[1]: not finite");
        let e = resample_linear(&[0.0, 1.0], &[0.0; 3], &[0.5]).unwrap_err();
        assert!(matches!(
            e,
            NumericsError::DimensionMismatch {
                expected: 2,
                found: 3
            }
        ));
    }
}
