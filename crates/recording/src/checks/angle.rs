//! The angle check.
//!
//! The finite minimum, maximum and range of `ankle_angle_deg`. Two warnings catch a wrong
//! convention rather than a bad recording: a range below **5°** (no sweep at all, or an angle
//! in radians: a 35° sweep is 0.61 rad), and a value beyond **±60°** (beyond the ankle's
//! range of motion from neutral: an angle with 90° at neutral, or another convention).

use serde::Serialize;

use super::settings::CheckSettings;
use super::values::{finite_min_max, num};

/// The angle range.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct AngleCheck {
    /// Smallest finite angle, degrees.
    pub min_deg: Option<f64>,
    /// Largest finite angle, degrees.
    pub max_deg: Option<f64>,
    /// `max − min`, degrees.
    pub range_deg: Option<f64>,
    /// Number of non-finite angle samples.
    pub non_finite: usize,
}

pub(super) fn angle_check(x: &[f64], s: &CheckSettings, warnings: &mut Vec<String>) -> AngleCheck {
    let (lo, hi) = finite_min_max(x);
    let range = lo.zip(hi).map(|(a, b)| b - a);
    if let (Some(lo), Some(hi), Some(r)) = (lo, hi, range) {
        if r < s.angle_min_range_deg {
            warnings.push(format!(
                "ankle_angle_deg: range only {}°, below {}°: no sweep (or an angle in radians?)",
                num(r, 2),
                num(s.angle_min_range_deg, 0)
            ));
        }
        let far = if hi.abs() >= lo.abs() { hi } else { lo };
        if far.abs() > s.angle_max_abs_deg {
            warnings.push(format!(
                "ankle_angle_deg: reaches {}°, beyond ±{}° of neutral: another angle convention (90° at neutral?)",
                num(far, 1),
                num(s.angle_max_abs_deg, 0)
            ));
        }
    } else {
        warnings.push("ankle_angle_deg: no finite samples".to_string());
    }
    AngleCheck {
        min_deg: lo,
        max_deg: hi,
        range_deg: range,
        non_finite: x.iter().filter(|v| !v.is_finite()).count(),
    }
}
