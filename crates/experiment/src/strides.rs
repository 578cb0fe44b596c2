//! Strides as units: the cycles of a trial, found from the foot's ground force, from a
//! dynamometer's motion or from given event times, and the masks, weights and normalised
//! curves a fit, a hold-out test or an ensemble figure takes per stride.
//!
//! # Definitions
//!
//! * A [`Stride`] is a run of samples `start..end` (`end` exclusive). For gait it is one gait
//!   cycle of the tested foot, its **stance** the samples `start..stance_end`.
//! * **From the ground force** ([`strides_from_ground_force`]): the foot is in **stance**
//!   while its vertical ground reaction force `F_i > F_thr` (default
//!   [`STANCE_THRESHOLD_N`] = 20 N: above the noise of an unloaded force plate or treadmill
//!   belt, a few per cent of body weight, far below a stance's 500–900 N). A **foot strike**
//!   is a sample `i ≥ 1` with `F_{i−1} ≤ F_thr < F_i` (the force rising through the
//!   threshold); a stride runs from one strike to the next, its `stance_end` the first sample
//!   after the strike with `F ≤ F_thr` (toe-off). The partial cycles before the first and after
//!   the last strike are not strides (a trial that begins in stance has no strike there).
//! * **From the motion** ([`strides_from_motion`]): the events of [`crate::detect_events`]
//!   on a dynamometer trial's angle. A bout of motion runs from a start through its reversals
//!   to its stop; each cycle is two sweeps of it (there and back): from the start to the
//!   second boundary after it, then on every second reversal, the last cycle ending at the
//!   stop; a bout with an odd number of sweeps ends with a one-sweep cycle. The holds between
//!   bouts are in no stride. The seed protocol (start, reversal, stop) is one stride.
//! * **From events** ([`strides_from_events`]): one stride between each two consecutive
//!   event times (e.g. the foot strikes of a lab's event file), a stride holding the samples
//!   with `e_k ≤ t < e_{k+1}`.
//! * Every stride must last at least [`MIN_STRIDE_S`] = 0.2 s (at 3.6 km/h a stride lasts
//!   about 1.1 s and a stance 0.7 s; the fastest running strides last about 0.6 s): anything
//!   shorter is a blip of the force or a doubled event, and is refused rather than counted.
//!   [`ground_force_cycles`] gives every cycle, short ones included, for the checks that flag
//!   them one by one.
//! * **Normalised** curves ([`Strides::normalised`]): each stride (or its stance, when
//!   `stance_end` is known) resampled linearly onto `points` equally spaced points from 0 to
//!   100 %: 0 % at the stride's first sample, 100 % at its closing sample (the next stride's
//!   first sample, or toe-off's first sample below the threshold; the stride's last sample
//!   when the series ends there).
//!
//! Errors are one line naming the series (`grf_vertical_n`, `ankle_angle_deg`, `events`) and,
//! for a stride shorter than 0.2 s, its time span.
//!
//! ```
//! use experiment::{strides_from_ground_force, StridePart, STANCE_THRESHOLD_N};
//!
//! // 100 Hz: 0.7 s stances every 1.1 s, starting in swing
//! let grf: Vec<f64> = (0..600)
//!     .map(|i| if (i + 100) % 110 < 70 && i >= 10 { 600.0 } else { 0.0 })
//!     .collect();
//! let s = strides_from_ground_force(&grf, 100.0, STANCE_THRESHOLD_N)?;
//! assert_eq!(s.strides.len(), 5);
//! assert_eq!((s.strides[0].start, s.strides[0].end, s.strides[0].stance_end), (10, 120, Some(80)));
//! let keep = s.keep_first(2);
//! let train = s.mask_of(&keep, grf.len());
//! assert!(train[10] && train[229] && !train[230]);
//! let stance = s.normalised_part(&grf, 101, StridePart::Stance);
//! assert_eq!(stance.len(), 5);
//! assert_eq!(stance[0][50], 600.0);
//! # Ok::<(), experiment::ExperimentError>(())
//! ```

use serde::{Deserialize, Serialize};

use crate::error::{ErrorKind, ExperimentError, Result};
use crate::events::detect_events;

/// The default stance threshold of the vertical ground reaction force, N.
pub const STANCE_THRESHOLD_N: f64 = 20.0;
/// The shortest stride accepted, s.
pub const MIN_STRIDE_S: f64 = 0.2;

/// One cycle of a trial: samples `start..end` (`end` exclusive); for gait, stance
/// `start..stance_end`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct Stride {
    /// First sample of the cycle (the foot strike).
    pub start: usize,
    /// One past the last sample (the next cycle's first sample).
    pub end: usize,
    /// One past the last stance sample (toe-off's first sample below the threshold), when
    /// known.
    pub stance_end: Option<usize>,
}

impl Stride {
    /// Number of samples of the cycle.
    #[must_use]
    pub fn len(&self) -> usize {
        self.end.saturating_sub(self.start)
    }

    /// True for a cycle without samples.
    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// The samples `first..end` of one part of the cycle; the stance of a cycle without a
    /// known stance is the whole cycle.
    #[must_use]
    pub fn part(&self, part: StridePart) -> (usize, usize) {
        match (part, self.stance_end) {
            (StridePart::Stance, Some(e)) => (self.start, e),
            _ => (self.start, self.end),
        }
    }
}

/// Where the strides came from.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum StrideSource {
    /// Foot strikes of the vertical ground reaction force rising through `threshold_n`.
    GroundForce {
        /// The stance threshold, N.
        threshold_n: f64,
    },
    /// A dynamometer's motion events.
    Motion,
    /// Given event times.
    Events,
}

/// Which part of a stride a normalised curve spans.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum StridePart {
    /// The whole cycle (% of the gait cycle).
    Cycle,
    /// The stance (% of stance), or the whole cycle when the stance is not known.
    Stance,
}

/// The strides of one trial, in time order, and where they came from.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Strides {
    /// The strides, in time order, not overlapping.
    pub strides: Vec<Stride>,
    /// How they were found.
    pub source: StrideSource,
}

fn bad(what: &str, kind: ErrorKind, reason: impl Into<String>) -> ExperimentError {
    ExperimentError::invalid(what, kind, reason)
}

/// `x` seconds with two decimals (the stride times of messages).
fn secs(x: f64) -> String {
    format!("{x:.2} s")
}

const GRF: &str = "grf_vertical_n";

fn check_rate(what: &str, fs_hz: f64) -> Result<()> {
    if fs_hz.is_finite() && fs_hz > 0.0 {
        Ok(())
    } else {
        Err(bad(
            what,
            ErrorKind::InvalidSettings,
            format!("the sampling rate must be a positive number of Hz, got {fs_hz}"),
        ))
    }
}

/// Every cycle of a vertical ground reaction force sampled at `fs_hz`, from one foot strike to
/// the next (module documentation), short ones included; [`strides_from_ground_force`] is
/// this with the cycles shorter than [`MIN_STRIDE_S`] refused.
///
/// # Errors
/// A non-positive rate, a threshold that is not a finite number ≥ 0, a sample that is NaN or
/// infinite, or fewer than two foot strikes (no complete stride).
pub fn ground_force_cycles(grf_n: &[f64], fs_hz: f64, threshold_n: f64) -> Result<Vec<Stride>> {
    check_rate(GRF, fs_hz)?;
    if !(threshold_n.is_finite() && threshold_n >= 0.0) {
        return Err(bad(
            GRF,
            ErrorKind::InvalidSettings,
            format!("the stance threshold must be a finite force ≥ 0 N, got {threshold_n}"),
        ));
    }
    if let Some((i, v)) = grf_n.iter().enumerate().find(|(_, v)| !v.is_finite()) {
        return Err(bad(
            GRF,
            ErrorKind::NotFinite,
            format!(
                "sample {i} ({}) is {v}: a gap in the force cannot be split into strides",
                secs(i as f64 / fs_hz)
            ),
        ));
    }
    let above = |i: usize| grf_n[i] > threshold_n;
    let strikes: Vec<usize> = (1..grf_n.len())
        .filter(|&i| above(i) && !above(i - 1))
        .collect();
    if strikes.len() < 2 {
        let reason = match strikes.first() {
            None => format!(
                "no foot strike: the force never rises through {threshold_n} N over its {} samples",
                grf_n.len()
            ),
            Some(&i) => format!(
                "only one foot strike (at {}): no complete stride",
                secs(i as f64 / fs_hz)
            ),
        };
        return Err(bad(GRF, ErrorKind::TooShort, reason));
    }
    Ok(strikes
        .windows(2)
        .map(|w| {
            // A next strike needs the force at or below the threshold first, so toe-off
            // always lies inside the cycle.
            let toe_off = (w[0]..w[1]).find(|&j| !above(j)).unwrap_or(w[1]);
            Stride {
                start: w[0],
                end: w[1],
                stance_end: Some(toe_off),
            }
        })
        .collect())
}

/// Stance = vertical force above `threshold_n` (default [`STANCE_THRESHOLD_N`]); a stride
/// from one foot strike (force rising through the threshold) to the next; the partial cycles
/// before the first and after the last strike are not strides. Times in messages count from
/// the series' first sample.
///
/// # Errors
/// Those of [`ground_force_cycles`], and a stride shorter than [`MIN_STRIDE_S`] (naming its
/// time span).
pub fn strides_from_ground_force(grf_n: &[f64], fs_hz: f64, threshold_n: f64) -> Result<Strides> {
    let strides = ground_force_cycles(grf_n, fs_hz, threshold_n)?;
    for (k, s) in strides.iter().enumerate() {
        let (a, b) = (s.start as f64 / fs_hz, s.end as f64 / fs_hz);
        refuse_short(GRF, k, a, b)?;
    }
    Ok(Strides {
        strides,
        source: StrideSource::GroundForce { threshold_n },
    })
}

fn refuse_short(what: &str, k: usize, a: f64, b: f64) -> Result<()> {
    if b - a < MIN_STRIDE_S - 1e-9 {
        return Err(bad(
            what,
            ErrorKind::TooShort,
            format!(
                "stride {k} from {} to {} lasts {}, shorter than the {MIN_STRIDE_S} s a stride needs",
                secs(a),
                secs(b),
                secs(b - a)
            ),
        ));
    }
    Ok(())
}

/// The first sample at or after `t` (`time_s` increasing).
fn sample_at(time_s: &[f64], t: f64) -> usize {
    time_s.partition_point(|&x| x < t)
}

/// A dynamometer trial's motion cycles, from [`crate::detect_events`] on its angle (module
/// documentation: two sweeps per cycle, within each bout from a start to its stop).
///
/// # Errors
/// Those of [`crate::detect_events`] (no motion, bad samples), no complete sweep, or a cycle
/// shorter than [`MIN_STRIDE_S`].
pub fn strides_from_motion(time_s: &[f64], ankle_angle_deg: &[f64]) -> Result<Strides> {
    const WHAT: &str = "ankle_angle_deg";
    let ev = detect_events(time_s, ankle_angle_deg)?;
    // Every boundary in time order: 0 start, 1 reversal, 2 stop.
    let mut marks: Vec<(f64, u8)> = ev
        .starts
        .iter()
        .map(|&t| (t, 0))
        .chain(ev.reversals.iter().map(|&t| (t, 1)))
        .chain(ev.stops.iter().map(|&t| (t, 2)))
        .collect();
    marks.sort_by(|a, b| a.0.total_cmp(&b.0));
    let mut cycles: Vec<(f64, f64)> = Vec::new();
    let mut bout: Vec<f64> = Vec::new();
    for (t, kind) in marks {
        match kind {
            0 => bout = vec![t],
            1 if !bout.is_empty() => bout.push(t),
            2 if !bout.is_empty() => {
                bout.push(t);
                let last = bout.len() - 1;
                let mut i = 0;
                while i < last {
                    let j = (i + 2).min(last);
                    cycles.push((bout[i], bout[j]));
                    i = j;
                }
                bout.clear();
            }
            _ => {}
        }
    }
    if cycles.is_empty() {
        return Err(bad(
            WHAT,
            ErrorKind::TooShort,
            "no motion cycle: no sweep from a start to a stop",
        ));
    }
    let t0 = time_s[0];
    let mut strides = Vec::with_capacity(cycles.len());
    for (k, &(a, b)) in cycles.iter().enumerate() {
        refuse_short(WHAT, k, a - t0, b - t0)?;
        strides.push(Stride {
            start: sample_at(time_s, a),
            end: sample_at(time_s, b),
            stance_end: None,
        });
    }
    Ok(Strides {
        strides,
        source: StrideSource::Motion,
    })
}

/// Cycles between given event times (s), e.g. foot strikes from a lab's event file: stride
/// `k` holds the samples with `e_k ≤ t < e_{k+1}`.
///
/// # Errors
/// A time axis that is empty, not finite or not increasing; fewer than two events; an event
/// that is not finite, not after the previous one, or outside `time_s`'s span; a stride
/// shorter than [`MIN_STRIDE_S`] or holding fewer than two samples.
pub fn strides_from_events(event_times_s: &[f64], time_s: &[f64]) -> Result<Strides> {
    const WHAT: &str = "events";
    if let Err(e) = numerics::interpolate::check_times(time_s) {
        return Err(bad(
            "time_s",
            ErrorKind::TimeNotIncreasing,
            format!("{e}: no time axis to place the events on"),
        ));
    }
    let (t0, t1) = (time_s[0], time_s[time_s.len() - 1]);
    if event_times_s.len() < 2 {
        return Err(bad(
            WHAT,
            ErrorKind::TooShort,
            format!("{} event time(s): a stride needs two", event_times_s.len()),
        ));
    }
    for (k, &e) in event_times_s.iter().enumerate() {
        if !e.is_finite() {
            return Err(bad(WHAT, ErrorKind::NotFinite, format!("event {k} is {e}")));
        }
        if e < t0 || e > t1 {
            return Err(bad(
                WHAT,
                ErrorKind::OutOfRange,
                format!(
                    "event {k} at {} is outside the trial's time, {} to {}",
                    secs(e),
                    secs(t0),
                    secs(t1)
                ),
            ));
        }
        if k > 0 && e <= event_times_s[k - 1] {
            return Err(bad(
                WHAT,
                ErrorKind::TimeNotIncreasing,
                format!(
                    "event {k} at {} is not after event {} at {}",
                    secs(e),
                    k - 1,
                    secs(event_times_s[k - 1])
                ),
            ));
        }
    }
    let mut strides = Vec::with_capacity(event_times_s.len() - 1);
    for (k, w) in event_times_s.windows(2).enumerate() {
        refuse_short(WHAT, k, w[0], w[1])?;
        let s = Stride {
            start: sample_at(time_s, w[0]),
            end: sample_at(time_s, w[1]),
            stance_end: None,
        };
        if s.len() < 2 {
            return Err(bad(
                WHAT,
                ErrorKind::TooShort,
                format!(
                    "stride {k} from {} to {} holds {} sample(s): the trial is sampled too sparsely",
                    secs(w[0]),
                    secs(w[1]),
                    s.len()
                ),
            ));
        }
        strides.push(s);
    }
    Ok(Strides {
        strides,
        source: StrideSource::Events,
    })
}

impl Strides {
    /// Number of strides.
    #[must_use]
    pub fn len(&self) -> usize {
        self.strides.len()
    }

    /// True without strides.
    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.strides.is_empty()
    }

    /// The samples of the kept strides: `true` at every sample `i < n` inside a stride `k`
    /// with `keep[k]`. A stride without an entry in `keep` is not kept; the samples outside
    /// every stride (before the first strike, holds, after the last) are never in the mask.
    #[must_use]
    pub fn mask_of(&self, keep: &[bool], n: usize) -> Vec<bool> {
        let mut mask = vec![false; n];
        for (s, _) in self.strides.iter().zip(keep).filter(|(_, &k)| k) {
            for m in &mut mask[s.start.min(n)..s.end.min(n)] {
                *m = true;
            }
        }
        mask
    }

    /// A `keep` vector for [`Strides::mask_of`] holding the first `count` strides (hold out
    /// the later strides of a trial: train on `mask_of(&keep_first(k))`, test on
    /// `mask_of` of its negation).
    #[must_use]
    pub fn keep_first(&self, count: usize) -> Vec<bool> {
        (0..self.len()).map(|k| k < count).collect()
    }

    /// Split at time `t_s`: `(before, after)` keep vectors of the strides that end by `t_s`
    /// and those that start at or after it (`time_s` the trial's times). A stride spanning
    /// `t_s` is in neither, so the two sets never share a cycle.
    #[must_use]
    pub fn split_at_time(&self, time_s: &[f64], t_s: f64) -> (Vec<bool>, Vec<bool>) {
        let at = |i: usize| time_s.get(i).copied();
        let before = self
            .strides
            .iter()
            .map(|s| {
                // the stride's last sample is end − 1
                s.end.checked_sub(1).and_then(at).is_some_and(|t| t < t_s)
            })
            .collect();
        let after = self
            .strides
            .iter()
            .map(|s| at(s.start).is_some_and(|t| t >= t_s))
            .collect();
        (before, after)
    }

    /// The stride index of every sample `i < n` (`None` outside every stride): per-stride
    /// errors are sums over the samples of one label.
    #[must_use]
    pub fn labels(&self, n: usize) -> Vec<Option<usize>> {
        let mut out = vec![None; n];
        for (k, s) in self.strides.iter().enumerate() {
            for l in &mut out[s.start.min(n)..s.end.min(n)] {
                *l = Some(k);
            }
        }
        out
    }

    /// Per-sample weights from per-stride ones: sample `i < n` of stride `k` weighs
    /// `stride_weights[k]`; samples outside every stride, or of a stride without a weight,
    /// weigh 0.
    #[must_use]
    pub fn sample_weights(&self, stride_weights: &[f64], n: usize) -> Vec<f64> {
        let mut out = vec![0.0; n];
        for (s, &w) in self.strides.iter().zip(stride_weights) {
            for x in &mut out[s.start.min(n)..s.end.min(n)] {
                *x = w;
            }
        }
        out
    }

    /// Per-stride weights `L̄ / L_k` (`L_k` stride `k`'s samples, `L̄` their mean) for
    /// [`Strides::sample_weights`]: each stride then weighs as much in a sum over samples,
    /// a long (slow) stride no more than a short one, and the total weight stays the number
    /// of samples in strides.
    #[must_use]
    pub fn equal_stride_weights(&self) -> Vec<f64> {
        let total: usize = self.strides.iter().map(Stride::len).sum();
        if self.is_empty() || total == 0 {
            return vec![0.0; self.len()];
        }
        let mean = total as f64 / self.len() as f64;
        self.strides
            .iter()
            .map(|s| {
                if s.is_empty() {
                    0.0
                } else {
                    mean / s.len() as f64
                }
            })
            .collect()
    }

    /// Each stride's duration, s, at `fs_hz`.
    #[must_use]
    pub fn durations_s(&self, fs_hz: f64) -> Vec<f64> {
        self.strides
            .iter()
            .map(|s| s.len() as f64 / fs_hz)
            .collect()
    }

    /// Each stride's stance duration, s, at `fs_hz` (`None` when not known).
    #[must_use]
    pub fn stance_durations_s(&self, fs_hz: f64) -> Vec<Option<f64>> {
        self.strides
            .iter()
            .map(|s| {
                s.stance_end
                    .map(|e| e.saturating_sub(s.start) as f64 / fs_hz)
            })
            .collect()
    }

    /// Each stride (or its stance, when `stance_end` is known) resampled to `points` points
    /// over 0..100 % ([`Strides::normalised_part`] with [`StridePart::Stance`]).
    #[must_use]
    pub fn normalised(&self, series: &[f64], points: usize) -> Vec<Vec<f64>> {
        self.normalised_part(series, points, StridePart::Stance)
    }

    /// Each stride's `part` of `series` resampled linearly to `points` points, the `j`-th at
    /// `100·j/(points − 1)` % (module documentation: 0 % at the first sample, 100 % at the
    /// closing one). One curve per stride, in order; the curve of a stride that does not lie
    /// within `series` (or a series with a non-finite sample in it) is empty, so index `k`
    /// stays stride `k`. `points = 1` gives the 0 % value alone.
    #[must_use]
    pub fn normalised_part(
        &self,
        series: &[f64],
        points: usize,
        part: StridePart,
    ) -> Vec<Vec<f64>> {
        self.strides
            .iter()
            .map(|s| {
                let (a, b) = s.part(part);
                // 100 % is the closing sample when the series has it, else the part's last.
                let last = if b < series.len() {
                    b
                } else {
                    b.saturating_sub(1)
                };
                if points == 0 || last <= a || last >= series.len() {
                    return Vec::new();
                }
                let seg = &series[a..=last];
                if seg.iter().any(|v| !v.is_finite()) {
                    return Vec::new();
                }
                let idx: Vec<f64> = (0..seg.len()).map(|i| i as f64).collect();
                let span = (seg.len() - 1) as f64;
                let at: Vec<f64> = (0..points)
                    .map(|j| {
                        if points == 1 {
                            0.0
                        } else {
                            span * j as f64 / (points - 1) as f64
                        }
                    })
                    .collect();
                numerics::interpolate::resample_linear(&idx, seg, &at).unwrap_or_default()
            })
            .collect()
    }
}

/// The percentages `100·j/(points − 1)`, `j = 0..points`, of [`Strides::normalised`]'s
/// points (`[0]` for one point).
#[must_use]
pub fn stride_percent(points: usize) -> Vec<f64> {
    (0..points)
        .map(|j| {
            if points <= 1 {
                0.0
            } else {
                100.0 * j as f64 / (points - 1) as f64
            }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A force that is `on` in `[a, b)` for each pair and 0 elsewhere.
    fn pattern(n: usize, stances: &[(usize, usize)], on: f64) -> Vec<f64> {
        let mut f = vec![0.0; n];
        for &(a, b) in stances {
            for x in &mut f[a..b] {
                *x = on;
            }
        }
        f
    }

    #[test]
    fn strikes_are_the_rising_crossings() {
        // starts in stance (partial cycle), three strikes, ends in stance
        let f = pattern(
            500,
            &[(0, 40), (100, 170), (210, 280), (320, 390), (430, 500)],
            500.0,
        );
        let s = strides_from_ground_force(&f, 100.0, 20.0).unwrap();
        let got: Vec<_> = s
            .strides
            .iter()
            .map(|s| (s.start, s.end, s.stance_end))
            .collect();
        assert_eq!(
            got,
            vec![
                (100, 210, Some(170)),
                (210, 320, Some(280)),
                (320, 430, Some(390))
            ]
        );
        assert_eq!(s.source, StrideSource::GroundForce { threshold_n: 20.0 });
        assert_eq!(s.durations_s(100.0), vec![1.1, 1.1, 1.1]);
        assert_eq!(s.stance_durations_s(100.0)[0], Some(0.7));
        // exactly at the threshold is not stance
        let mut g = f.clone();
        g[99] = 20.0;
        g[100] = 20.0;
        let s2 = strides_from_ground_force(&g, 100.0, 20.0).unwrap();
        assert_eq!(s2.strides[0].start, 101);
    }

    #[test]
    fn bad_force_series_are_one_line_errors() {
        let mut f = pattern(300, &[(10, 80), (120, 190), (230, 290)], 500.0);
        f[57] = f64::NAN;
        let e = strides_from_ground_force(&f, 100.0, 20.0)
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("grf_vertical_n") && e.contains("sample 57 (0.57 s)"),
            "{e}"
        );
        assert_eq!(e.lines().count(), 1);
        let e = strides_from_ground_force(&[0.0; 50], 100.0, 20.0).unwrap_err();
        assert_eq!(e.kind(), ErrorKind::TooShort);
        assert!(e.to_string().contains("no foot strike"), "{e}");
        let one = pattern(300, &[(10, 80)], 500.0);
        let e = strides_from_ground_force(&one, 100.0, 20.0)
            .unwrap_err()
            .to_string();
        assert!(e.contains("only one foot strike (at 0.10 s)"), "{e}");
        // a blip 0.15 s after a strike
        let blip = pattern(400, &[(10, 80), (120, 122), (135, 200), (250, 320)], 500.0);
        let e = strides_from_ground_force(&blip, 100.0, 20.0)
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("stride 1 from 1.20 s to 1.35 s lasts 0.15 s, shorter than the 0.2 s"),
            "{e}"
        );
        // the cycles themselves are still there for the checks
        assert_eq!(ground_force_cycles(&blip, 100.0, 20.0).unwrap().len(), 3);
        assert!(strides_from_ground_force(&blip, 0.0, 20.0).is_err());
        assert!(strides_from_ground_force(&blip, 100.0, f64::NAN).is_err());
    }

    #[test]
    fn events_place_strides_on_the_time_axis() {
        let t: Vec<f64> = (0..300).map(|i| i as f64 * 0.01).collect();
        let s = strides_from_events(&[0.5, 1.6, 2.7], &t).unwrap();
        let got: Vec<_> = s.strides.iter().map(|s| (s.start, s.end)).collect();
        assert_eq!(got, vec![(50, 160), (160, 270)]);
        let msg = |ev: &[f64]| strides_from_events(ev, &t).unwrap_err().to_string();
        assert!(msg(&[0.5, 3.5])
            .contains("event 1 at 3.50 s is outside the trial's time, 0.00 s to 2.99 s"));
        assert!(msg(&[0.5, 1.5, 1.2]).contains("event 2 at 1.20 s is not after event 1 at 1.50 s"));
        assert!(msg(&[0.5, 0.6]).contains("stride 0 from 0.50 s to 0.60 s lasts 0.10 s"));
        assert!(msg(&[0.5]).contains("a stride needs two"));
        assert!(msg(&[0.5, f64::NAN]).contains("event 1 is NaN"));
        assert!(strides_from_events(&[0.0, 1.0], &[0.0, 0.0, 1.0]).is_err());
    }

    #[test]
    fn masks_weights_and_labels() {
        let f = pattern(
            500,
            &[(100, 170), (210, 280), (320, 390), (430, 500)],
            500.0,
        );
        let s = strides_from_ground_force(&f, 100.0, 20.0).unwrap();
        let keep = s.keep_first(2);
        assert_eq!(keep, vec![true, true, false]);
        let m = s.mask_of(&keep, 500);
        assert_eq!(m.iter().filter(|&&x| x).count(), 220);
        assert!(!m[99] && m[100] && m[319] && !m[320]);
        let held: Vec<bool> = keep.iter().map(|k| !k).collect();
        let m2 = s.mask_of(&held, 500);
        assert_eq!(m2.iter().filter(|&&x| x).count(), 110);
        // a short keep vector keeps nothing beyond it; n shorter than the strides is cut
        assert_eq!(s.mask_of(&[true], 150).iter().filter(|&&x| x).count(), 50);
        let t: Vec<f64> = (0..500).map(|i| i as f64 * 0.01).collect();
        let (before, after) = s.split_at_time(&t, 3.0);
        assert_eq!(before, vec![true, false, false]);
        assert_eq!(after, vec![false, false, true]);
        let l = s.labels(500);
        assert_eq!(
            (l[99], l[100], l[320], l[430]),
            (None, Some(0), Some(2), None)
        );
        let w = s.sample_weights(&[1.0, 0.0, 2.0], 500);
        assert_eq!((w[150], w[250], w[400], w[450]), (1.0, 0.0, 2.0, 0.0));
        assert_eq!(s.equal_stride_weights(), vec![1.0; 3]);
    }

    #[test]
    fn normalised_curves_span_0_to_100_percent() {
        // a ramp: the curve at j is the index it lands on
        let f = pattern(
            500,
            &[(100, 170), (210, 280), (320, 390), (430, 500)],
            500.0,
        );
        let s = strides_from_ground_force(&f, 100.0, 20.0).unwrap();
        let ramp: Vec<f64> = (0..500).map(|i| i as f64).collect();
        let stance = s.normalised(&ramp, 11);
        assert_eq!(stance.len(), 3);
        assert_eq!(stance[0][0], 100.0);
        assert_eq!(stance[0][10], 170.0);
        assert!((stance[0][5] - 135.0).abs() < 1e-12);
        let cycle = s.normalised_part(&ramp, 3, StridePart::Cycle);
        assert_eq!(cycle[1], vec![210.0, 265.0, 320.0]);
        assert_eq!(stride_percent(3), vec![0.0, 50.0, 100.0]);
        // a series too short for the last stride: its curve is empty, the others kept
        let short = s.normalised(&ramp[..350], 5);
        assert_eq!((short[1].len(), short[2].len()), (5, 0));
        assert!(s.normalised(&ramp, 0).iter().all(Vec::is_empty));
        assert_eq!(s.normalised(&ramp, 1)[0], vec![100.0]);
    }

    #[test]
    fn motion_cycles_of_the_protocols() {
        let seed = crate::Protocol::Seed.trace().unwrap();
        let s = strides_from_motion(&seed.time_s, &seed.angle_deg).unwrap();
        assert_eq!(s.len(), 1);
        let d = s.durations_s(seed.sample_rate_hz)[0];
        // two sweeps of 35°/(30 °/s) + 50 ms ramp each
        assert!((d - 2.0 * (35.0 / 30.0 + 0.05)).abs() < 2e-3, "{d}");
        let three = crate::Protocol::Cycles { cycles: 3 }.trace().unwrap();
        let s3 = strides_from_motion(&three.time_s, &three.angle_deg).unwrap();
        assert_eq!(s3.len(), 3);
        for w in s3.strides.windows(2) {
            assert_eq!(w[0].end, w[1].start);
        }
        let relaxed = crate::Protocol::Relaxed { cycles: 2 }.trace().unwrap();
        let sr = strides_from_motion(&relaxed.time_s, &relaxed.angle_deg).unwrap();
        assert_eq!(sr.len(), 3, "the relaxed cycle and two maximal ones");
        assert!(
            sr.strides[0].end < sr.strides[1].start,
            "the hold is in no stride"
        );
        let still = vec![1.0; 100];
        let t: Vec<f64> = (0..100).map(|i| i as f64 * 0.01).collect();
        assert!(strides_from_motion(&t, &still).is_err());
    }
}
