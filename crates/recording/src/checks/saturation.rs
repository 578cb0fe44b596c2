//! The saturation check.
//!
//! For `torque_nm` and every EMG channel (not the angles: a hold at the end of the range is a
//! run of the extreme value by design). A clipped channel sits on its extreme ADC code, so for
//! each side (maximum and minimum of the finite samples) the check counts the samples that
//! equal the extreme in runs of at least **3** consecutive samples, as a fraction of the
//! channel's samples. A rounded peak of a smooth, coarsely quantised signal also dwells on its
//! top code, so a side is **clipped** only when that fraction exceeds **0.5 %** *and* the
//! extreme level holds at least **3×** as many samples as the next level inward (a flat top:
//! for a parabolic peak that ratio is `1/(√2 − 1) ≈ 2.4`; a clipped signal passes the level
//! below the rail in a sample or two and then stays on the rail). A constant channel is not
//! "clipped" (the flat EMG check, or a constant-torque warning, reports it).

use serde::Serialize;

use super::settings::CheckSettings;

/// One side (maximum or minimum) of a channel's saturation check.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct ClipSide {
    /// The extreme value.
    pub value: f64,
    /// Share of the channel's samples equal to it in runs of at least `clip_min_run`.
    pub fraction: f64,
    /// Samples at the extreme level over samples at the next level inward (`null` when the
    /// channel has a single level).
    pub level_ratio: Option<f64>,
    /// Whether this side looks clipped.
    pub clipped: bool,
}

/// Saturation of one channel.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct SaturationCheck {
    /// Column name (`torque_nm`, `emg_sol`, …).
    pub channel: String,
    /// Number of samples.
    pub samples: usize,
    /// Number of non-finite samples.
    pub non_finite: usize,
    /// The maximum side (`null` without finite samples).
    pub high: Option<ClipSide>,
    /// The minimum side (`null` without finite samples).
    pub low: Option<ClipSide>,
    /// Either side clipped.
    pub clipped: bool,
}

pub(super) fn saturation_check(name: &str, x: &[f64], s: &CheckSettings) -> SaturationCheck {
    let non_finite = x.iter().filter(|v| !v.is_finite()).count();
    let mut sorted: Vec<f64> = x.iter().copied().filter(|v| v.is_finite()).collect();
    sorted.sort_by(f64::total_cmp);
    let mut out = SaturationCheck {
        channel: name.to_string(),
        samples: x.len(),
        non_finite,
        high: None,
        low: None,
        clipped: false,
    };
    let (Some(&lo), Some(&hi)) = (sorted.first(), sorted.last()) else {
        return out;
    };
    let n = x.len() as f64;
    // Occupancy of the extreme level and of the next level inward, from the sorted values.
    let level_counts = |from_top: bool| -> (usize, Option<usize>) {
        let it: Box<dyn Iterator<Item = &f64>> = if from_top {
            Box::new(sorted.iter().rev())
        } else {
            Box::new(sorted.iter())
        };
        let mut first = 0usize;
        let mut second = 0usize;
        let mut levels: Option<(f64, Option<f64>)> = None;
        for &v in it {
            match levels {
                None => {
                    levels = Some((v, None));
                    first = 1;
                }
                Some((l1, None)) if v == l1 => first += 1,
                Some((l1, None)) => {
                    levels = Some((l1, Some(v)));
                    second = 1;
                }
                Some((_, Some(l2))) if v == l2 => second += 1,
                Some(_) => break,
            }
        }
        (first, (second > 0).then_some(second))
    };
    let side = |value: f64, from_top: bool| -> ClipSide {
        let in_runs = runs_at(x, value, s.clip_min_run.max(1));
        let fraction = in_runs as f64 / n;
        let (at, next) = level_counts(from_top);
        let level_ratio = next.map(|nx| at as f64 / nx as f64);
        let clipped = hi > lo
            && fraction > s.clip_max_fraction
            && level_ratio.is_some_and(|r| r >= s.clip_min_level_ratio);
        ClipSide {
            value,
            fraction,
            level_ratio,
            clipped,
        }
    };
    let high = side(hi, true);
    let low = side(lo, false);
    out.clipped = high.clipped || low.clipped;
    out.high = Some(high);
    out.low = Some(low);
    out
}

/// Number of samples equal to `value` in runs of at least `min_run` consecutive samples.
fn runs_at(x: &[f64], value: f64, min_run: usize) -> usize {
    let mut total = 0;
    let mut run = 0;
    for &v in x {
        if v == value {
            run += 1;
        } else {
            if run >= min_run {
                total += run;
            }
            run = 0;
        }
    }
    if run >= min_run {
        total += run;
    }
    total
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn runs_count_only_long_runs() {
        let x = [5.0, 5.0, 1.0, 5.0, 5.0, 5.0, 2.0, 5.0];
        assert_eq!(runs_at(&x, 5.0, 3), 3);
        assert_eq!(runs_at(&x, 5.0, 1), 6);
    }
}
