//! What a trial is: a dynamometer trial (the isokinetic experiment) or gait, which decides
//! the checks that apply.
//!
//! The caller may say ([`super::TrialContext::kind`]: a session manifest's or a command's
//! word). Otherwise it is inferred from the data, in this order:
//!
//! 1. a vertical ground reaction force of the tested foot (`grf_vertical_n`) → **gait**: a
//!    dynamometer has no force plate;
//! 2. the sweeps of the ankle angle (the moving runs of the plateau check, `motion`): a
//!    dynamometer turns the ankle between two set limits, so each of its sweeps spans the
//!    trial's range of motion (a trapezoidal, sinusoidal or triangular profile alike: the
//!    moving part of a sinusoid's sweep, `|v| > 0.2·v_max`, spans 98 % of it), while a
//!    walking ankle makes three to four sweeps of different sizes per stride (loading,
//!    push-off, swing). Runs shorter than the velocity's 50 ms window are not sweeps (a speed
//!    flickering about the threshold). With at least **4** sweeps, fewer than **half** of which span at least
//!    **70 %** of the angle's range (1st to 99th percentile) → **gait**;
//! 3. anything else → **dynamometer** (the experiment surae was built for), with the reason.

use serde::{Deserialize, Serialize};

use super::motion::sweeps;
use super::settings::CheckSettings;
use super::values::num;

/// What a trial is.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum TrialKind {
    /// An isokinetic dynamometer trial: the isokinetic checks apply.
    Dynamometer,
    /// Gait (walking or running with inverse dynamics): the per-stride checks apply.
    Gait,
}

impl TrialKind {
    /// `dynamometer` or `gait`.
    #[must_use]
    pub fn name(self) -> &'static str {
        match self {
            Self::Dynamometer => "dynamometer",
            Self::Gait => "gait",
        }
    }
}

/// The share of sweeps spanning `span_fraction` of the angle's 1–99 % range, and the number
/// of sweeps (`None` without a velocity or a range).
pub(super) fn spanning_share(
    angle: &[f64],
    dt: f64,
    s: &CheckSettings,
) -> Option<(f64, usize, f64)> {
    let sw = sweeps(angle, dt, s).ok()?;
    let mut finite: Vec<f64> = angle.iter().copied().filter(|v| v.is_finite()).collect();
    if finite.len() < 2 || sw.runs.is_empty() {
        return None;
    }
    finite.sort_by(f64::total_cmp);
    let q = |p: f64| finite[((finite.len() - 1) as f64 * p).round() as usize];
    let range = q(0.99) - q(0.01);
    if range.is_nan() || range <= 0.0 {
        return None;
    }
    // A run shorter than the velocity's own window is the flicker of a speed near the
    // threshold, not a sweep.
    let min_len = (sw.window_s / dt).round() as usize;
    let excursions: Vec<f64> = sw
        .runs
        .iter()
        .filter(|&&(a, b, _)| b - a >= min_len)
        .filter_map(|&(a, b, _)| {
            let d = (angle[b - 1] - angle[a]).abs();
            d.is_finite().then_some(d)
        })
        .collect();
    if excursions.is_empty() {
        return None;
    }
    let spanning = excursions
        .iter()
        .filter(|&&d| d >= s.kind_sweep_span_fraction * range)
        .count();
    Some((
        spanning as f64 / excursions.len() as f64,
        excursions.len(),
        range,
    ))
}

/// The kind of a trial and why (module documentation).
pub(super) fn infer_kind(
    given: Option<TrialKind>,
    has_ground_force: bool,
    angle: &[f64],
    dt: Option<f64>,
    s: &CheckSettings,
) -> (TrialKind, String) {
    if let Some(k) = given {
        return (k, "given by the caller".into());
    }
    if has_ground_force {
        return (
            TrialKind::Gait,
            "a ground reaction force channel (grf_vertical_n)".into(),
        );
    }
    let Some(dt) = dt else {
        return (
            TrialKind::Dynamometer,
            "no sampling rate to tell; taken as a dynamometer trial".into(),
        );
    };
    match spanning_share(angle, dt, s) {
        Some((share, n, range)) if n >= s.kind_min_sweeps && share < s.kind_min_spanning_share => (
            TrialKind::Gait,
            format!(
                "no ground force, but only {} % of the ankle's {n} sweeps span {} % of its {}° range (a dynamometer's sweep its whole range)",
                num(100.0 * share, 0),
                num(100.0 * s.kind_sweep_span_fraction, 0),
                num(range, 1)
            ),
        ),
        Some((share, n, range)) => (
            TrialKind::Dynamometer,
            format!(
                "no ground force; {} % of the ankle's {n} sweep{} span {} % of its {}° range",
                num(100.0 * share, 0),
                if n == 1 { "" } else { "s" },
                num(100.0 * s.kind_sweep_span_fraction, 0),
                num(range, 1)
            ),
        ),
        None => (
            TrialKind::Dynamometer,
            "no ground force and no ankle motion to tell; taken as a dynamometer trial".into(),
        ),
    }
}
