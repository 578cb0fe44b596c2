//! The per-stride checks of a gait trial: strides whose inverse-dynamics ankle moment is
//! implausible against the other strides and the foot's ground force.
//!
//! The strides are the cycles of [`experiment::ground_force_cycles`] (stance while the
//! vertical force exceeds **20 N**, a stride from one foot strike to the next). A stride
//! shorter than [`experiment::MIN_STRIDE_S`] (0.2 s) is flagged outright (a force blip) and
//! left out of the comparison. For every other stride `k` the check measures
//!
//! | measure | definition | flagged when |
//! |---|---|---|
//! | `duration_s` | strike to strike | `|z| > 3.5`, floor 3 % |
//! | `stance_s` | strike to the first sample at or below the threshold | `|z| > 3.5`, floor 3 % |
//! | `peak_force_n` | largest vertical force in stance | `|z| > 3.5`, floor 5 % |
//! | `peak_moment_nm` | largest plantarflexion moment in stance | `|z| > 3.5`, floor 8 % |
//! | `moment_per_force_m` | `peak_moment_nm / peak_force_n` | `|z| > 3.5`, floor 8 % |
//! | `swing_moment_nm` | largest `|moment|` in swing (the foot off the ground) | `z > 3.5`, floor 5 % of the median peak moment |
//! | `moment_jump_nm_s` | largest `|Δmoment|/dt` between two samples | `z > 3.5`, floor 10 %, and no envelope jump (below) |
//!
//! with the robust score `z = (x_k − m)/σ` over the compared strides: `m` the median,
//! `σ = max(1.4826·MAD, floor·|m|)`, MAD the median absolute deviation (1.4826·MAD estimates
//! the sd of normal data and, like the median, ignores up to half the strides being bad).
//! `|z| > 3.5` is Iglewicz and Hoaglin's outlier rule for the modified z-score; for normal
//! data it flags one stride in about 2 000 per measure. The floors are the stride-to-stride
//! variability of healthy walking (coefficient of variation of stride and stance time about
//! 2–3 %, of the vertical force's peak about 3–5 %, of the peak ankle moment about 5–8 %):
//! a very regular subject's tiny MAD must not turn normal variation into flags. The
//! comparison needs at least **5** strides.
//!
//! What the measures catch: a foot on both belts of an instrumented treadmill (the other
//! foot's force is added to this one's: a stance or stride far longer than the others, a
//! force that never falls below the threshold in swing, a higher peak); a force assigned to
//! the wrong foot (a moment in swing); an impact spike: a jump of the moment that no muscle
//! explains. For the last, each EMG channel's envelope (the channel itself when it is an
//! envelope already, else a 50 ms moving mean of `|x|`) is divided by its 95th percentile
//! over the trial and its largest `|Δe|/dt` taken per stride (`envelope_jump_per_s`, the
//! largest over the channels); a moment jump is flagged only when that stride's envelope
//! jump is not itself an outlier (`z ≤ 3.5`, floor 10 %).

use experiment::{ground_force_cycles, Stride, StrideSource, Strides, MIN_STRIDE_S};
use serde::Serialize;

use super::settings::CheckSettings;
use super::values::{median_of, num};

/// What one stride measures (module documentation); `null` where it cannot be computed.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct StrideMeasures {
    /// Index of the stride.
    pub stride: usize,
    /// Time of the foot strike, s.
    pub start_s: f64,
    /// Time of the next foot strike, s.
    pub end_s: f64,
    /// Strike to strike, s.
    pub duration_s: f64,
    /// Strike to toe-off, s.
    pub stance_s: Option<f64>,
    /// Largest vertical force in stance, N.
    pub peak_force_n: Option<f64>,
    /// Largest plantarflexion moment in stance, N·m.
    pub peak_moment_nm: Option<f64>,
    /// `peak_moment_nm / peak_force_n`, m.
    pub moment_per_force_m: Option<f64>,
    /// Largest |moment| in swing, N·m.
    pub swing_moment_nm: Option<f64>,
    /// Largest |Δmoment|/dt, N·m/s.
    pub moment_jump_nm_s: Option<f64>,
    /// Largest |Δe|/dt of the normalised envelopes, 1/s.
    pub envelope_jump_per_s: Option<f64>,
}

/// One reason a stride is flagged.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct StrideReason {
    /// The measure (`stance_s`, `moment_jump_nm_s`, …; `too_short` for a force blip).
    pub measure: &'static str,
    /// Its value in this stride.
    pub value: f64,
    /// Its median over the compared strides (`null` for `too_short`).
    pub median: Option<f64>,
    /// The robust score `z` (`null` for `too_short`).
    pub robust_z: Option<f64>,
    /// The reason in words.
    pub text: String,
}

/// A stride flagged as implausible.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct StrideFlag {
    /// Index of the stride.
    pub stride: usize,
    /// Time of its foot strike, s.
    pub start_s: f64,
    /// Time of the next foot strike, s.
    pub end_s: f64,
    /// Why, one entry per measure out of line.
    pub reasons: Vec<StrideReason>,
}

/// The per-stride checks of a gait trial.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct GaitCheck {
    /// The stance threshold of the ground force, N.
    pub threshold_n: f64,
    /// Why no strides could be found (`null` when they were).
    pub error: Option<String>,
    /// Number of strides (cycles between foot strikes, short ones included).
    pub strides: usize,
    /// Fewest strides the comparison needs.
    pub min_strides: usize,
    /// Whether there were enough strides to compare them (at least `min_strides`).
    pub compared: bool,
    /// Median stride duration over the compared strides, s.
    pub median_stride_s: Option<f64>,
    /// Median stance duration over the compared strides, s.
    pub median_stance_s: Option<f64>,
    /// Every stride's measures, in order.
    pub measures: Vec<StrideMeasures>,
    /// The flagged strides, in order.
    pub flagged: Vec<StrideFlag>,
    /// The strides' samples (for [`GaitCheck::strides_kept`]).
    #[serde(skip)]
    pub cycles: Vec<Stride>,
}

impl GaitCheck {
    /// The strides with a keep vector leaving the flagged ones out: a fit or a validation that
    /// excludes them on request takes `strides.mask_of(&keep, n)`.
    #[must_use]
    pub fn strides_kept(&self) -> (Strides, Vec<bool>) {
        let keep = (0..self.cycles.len())
            .map(|k| !self.flagged.iter().any(|f| f.stride == k))
            .collect();
        (
            Strides {
                strides: self.cycles.clone(),
                source: StrideSource::GroundForce {
                    threshold_n: self.threshold_n,
                },
            },
            keep,
        )
    }
}

/// Largest of the finite values of `it` (`None` without any).
fn finite_max(it: impl Iterator<Item = f64>) -> Option<f64> {
    it.filter(|v| v.is_finite())
        .fold(None, |m: Option<f64>, v| Some(m.map_or(v, |m| m.max(v))))
}

/// Each channel divided by its 95th percentile; raw EMG first as a 50 ms moving mean of |x|.
fn normalised_envelopes(emg: &[&[f64]], raw: bool, dt: f64) -> Vec<Vec<f64>> {
    emg.iter()
        .filter_map(|x| {
            let env: Vec<f64> = if raw {
                let half = ((0.025 / dt).round() as usize).max(1);
                let abs: Vec<f64> = x.iter().map(|v| v.abs()).collect();
                moving_mean(&abs, half)
            } else {
                x.to_vec()
            };
            let mut f: Vec<f64> = env.iter().copied().filter(|v| v.is_finite()).collect();
            if f.is_empty() {
                return None;
            }
            f.sort_by(f64::total_cmp);
            let p95 = f[((f.len() - 1) as f64 * 0.95).round() as usize];
            (p95 > 0.0).then(|| env.iter().map(|v| v / p95).collect())
        })
        .collect()
}

/// Centred moving mean over `2·half + 1` samples (shrunk at the ends; NaN where the window
/// holds a non-finite sample).
fn moving_mean(x: &[f64], half: usize) -> Vec<f64> {
    let n = x.len();
    // prefix sums of the values and of the count of non-finite samples
    let mut sum = vec![0.0; n + 1];
    let mut bad = vec![0usize; n + 1];
    for i in 0..n {
        let ok = x[i].is_finite();
        sum[i + 1] = sum[i] + if ok { x[i] } else { 0.0 };
        bad[i + 1] = bad[i] + usize::from(!ok);
    }
    (0..n)
        .map(|i| {
            let (a, b) = (i.saturating_sub(half), (i + half + 1).min(n));
            if bad[b] > bad[a] {
                f64::NAN
            } else {
                (sum[b] - sum[a]) / (b - a) as f64
            }
        })
        .collect()
}

/// Largest `|x_{i+1} − x_i|/dt` over pairs within `a..b`.
fn max_jump(x: &[f64], a: usize, b: usize, dt: f64) -> Option<f64> {
    let b = b.min(x.len());
    if b < a + 2 {
        return None;
    }
    finite_max(x[a..b].windows(2).map(|w| (w[1] - w[0]).abs() / dt))
}

/// The robust score of each value against the others: `(z, median)` per value (`None` where
/// the value is `None`), or `None` with fewer than `min_count` values.
fn robust_scores(
    values: &[Option<f64>],
    floor: f64,
    min_count: usize,
) -> Option<(Vec<Option<f64>>, f64)> {
    let present: Vec<f64> = values.iter().flatten().copied().collect();
    if present.len() < min_count.max(1) {
        return None;
    }
    let m = median_of(&present)?;
    let dev: Vec<f64> = present.iter().map(|v| (v - m).abs()).collect();
    let mad = median_of(&dev)?;
    let sigma = (1.4826 * mad).max(floor);
    if !(sigma > 0.0 && sigma.is_finite()) {
        return None;
    }
    Some((
        values.iter().map(|v| v.map(|x| (x - m) / sigma)).collect(),
        m,
    ))
}

/// The inputs of the gait checks.
pub(super) struct GaitInputs<'a> {
    pub time_s: &'a [f64],
    pub dt: f64,
    pub torque_nm: &'a [f64],
    pub grf_n: &'a [f64],
    pub emg: Vec<&'a [f64]>,
    pub emg_is_envelope: bool,
}

/// One measure's flagging rule.
struct Rule {
    measure: &'static str,
    two_sided: bool,
    floor: f64,
    get: fn(&StrideMeasures) -> Option<f64>,
    text: fn(f64, f64) -> String,
}

/// Every stride's measures with the too short strides left out of the comparison.
struct Compared<'a> {
    measures: &'a [StrideMeasures],
    short: &'a [bool],
}

impl Compared<'_> {
    /// One measure of each stride, `None` for a too short one.
    fn values(&self, get: fn(&StrideMeasures) -> Option<f64>) -> Vec<Option<f64>> {
        self.measures
            .iter()
            .zip(self.short)
            .map(|(m, &sh)| if sh { None } else { get(m) })
            .collect()
    }

    /// The median of one measure over the compared strides.
    fn median(&self, get: fn(&StrideMeasures) -> Option<f64>) -> Option<f64> {
        median_present(&self.values(get))
    }
}

/// The median of the values that are present.
fn median_present(values: &[Option<f64>]) -> Option<f64> {
    median_of(&values.iter().flatten().copied().collect::<Vec<_>>())
}

/// The per-stride checks of the module documentation: find the strides, measure each, flag
/// the short ones and, with enough strides, those out of line.
pub(super) fn gait_check(g: &GaitInputs<'_>, s: &CheckSettings) -> GaitCheck {
    let mut out = GaitCheck {
        threshold_n: s.stance_threshold_n,
        error: None,
        strides: 0,
        min_strides: s.stride_min_count,
        compared: false,
        median_stride_s: None,
        median_stance_s: None,
        measures: Vec::new(),
        flagged: Vec::new(),
        cycles: Vec::new(),
    };
    let cycles = match find_cycles(g, s) {
        Ok(c) => c,
        Err(e) => {
            out.error = Some(e);
            return out;
        }
    };
    out.measures = measure_strides(g, &cycles);
    out.strides = cycles.len();
    out.cycles = cycles;

    let short: Vec<bool> = out.measures.iter().map(is_too_short).collect();
    let mut flags = too_short_reasons(&out.measures, s);
    let compared = Compared {
        measures: &out.measures,
        short: &short,
    };
    out.compared = short.iter().filter(|s| !**s).count() >= s.stride_min_count;
    out.median_stride_s = compared.median(|m| Some(m.duration_s));
    out.median_stance_s = compared.median(|m| m.stance_s);
    if out.compared {
        flag_rule_outliers(&compared, &stride_rules(s), s, &mut flags);
        flag_swing_moments(&compared, s, &mut flags);
        flag_moment_jumps(&compared, s, &mut flags);
    }
    out.flagged = flagged_strides(&out.measures, flags);
    out
}

/// The strides of the ground force, or why there are none (columns of unequal length, or
/// no foot strike).
fn find_cycles(g: &GaitInputs<'_>, s: &CheckSettings) -> Result<Vec<Stride>, String> {
    let n = g.time_s.len();
    if g.grf_n.len() != n || g.torque_nm.len() != n {
        return Err(format!(
            "grf_vertical_n has {} samples and torque_nm {} but time_s {n}",
            g.grf_n.len(),
            g.torque_nm.len()
        ));
    }
    ground_force_cycles(g.grf_n, 1.0 / g.dt, s.stance_threshold_n).map_err(|e| e.to_string())
}

/// Every stride's measures (module documentation), in order.
fn measure_strides(g: &GaitInputs<'_>, cycles: &[Stride]) -> Vec<StrideMeasures> {
    let n = g.time_s.len();
    let dt = g.dt;
    // A stride may end one sample past the last: its time is extrapolated.
    let time_at = |i: usize| -> f64 {
        g.time_s
            .get(i)
            .copied()
            .unwrap_or_else(|| g.time_s[n - 1] + (i + 1 - n) as f64 * dt)
    };
    let env = normalised_envelopes(&g.emg, !g.emg_is_envelope, dt);
    let tq = g.torque_nm;
    cycles
        .iter()
        .enumerate()
        .map(|(k, c)| {
            let stance_end = c.stance_end.unwrap_or(c.end);
            let peak_force = finite_max(g.grf_n[c.start..stance_end].iter().copied());
            let peak_moment = finite_max(tq[c.start..stance_end].iter().copied());
            let swing = finite_max(tq[stance_end..c.end].iter().map(|v| v.abs()));
            let env_jump = finite_max(env.iter().filter_map(|e| max_jump(e, c.start, c.end, dt)));
            StrideMeasures {
                stride: k,
                start_s: time_at(c.start),
                end_s: time_at(c.end),
                duration_s: c.len() as f64 * dt,
                stance_s: c.stance_end.map(|e| (e - c.start) as f64 * dt),
                peak_force_n: peak_force,
                peak_moment_nm: peak_moment,
                moment_per_force_m: peak_moment
                    .zip(peak_force)
                    .and_then(|(m, f)| (f > 0.0).then(|| m / f)),
                swing_moment_nm: swing,
                moment_jump_nm_s: max_jump(tq, c.start, c.end, dt),
                envelope_jump_per_s: env_jump,
            }
        })
        .collect()
}

/// Whether a stride is shorter than a stride can be (a blip of the force).
fn is_too_short(m: &StrideMeasures) -> bool {
    m.duration_s < MIN_STRIDE_S - 1e-9
}

/// Each stride's reasons so far: `too_short` for a force blip, else none.
fn too_short_reasons(measures: &[StrideMeasures], s: &CheckSettings) -> Vec<Vec<StrideReason>> {
    measures
        .iter()
        .map(|m| {
            if !is_too_short(m) {
                return Vec::new();
            }
            vec![StrideReason {
                measure: "too_short",
                value: m.duration_s,
                median: None,
                robust_z: None,
                text: format!(
                    "lasts {} s, shorter than the {MIN_STRIDE_S} s a stride needs (a blip of the force above {} N?)",
                    num(m.duration_s, 2),
                    num(s.stance_threshold_n, 0)
                ),
            }]
        })
        .collect()
}

/// The rules of the measures compared against their own median (module documentation).
fn stride_rules(s: &CheckSettings) -> [Rule; 5] {
    [
        Rule {
            measure: "duration_s",
            two_sided: true,
            floor: s.stride_time_floor,
            get: |m| Some(m.duration_s),
            text: duration_text,
        },
        Rule {
            measure: "stance_s",
            two_sided: true,
            floor: s.stride_time_floor,
            get: |m| m.stance_s,
            text: stance_text,
        },
        Rule {
            measure: "peak_force_n",
            two_sided: true,
            floor: s.peak_force_floor,
            get: |m| m.peak_force_n,
            text: peak_force_text,
        },
        Rule {
            measure: "peak_moment_nm",
            two_sided: true,
            floor: s.peak_moment_floor,
            get: |m| m.peak_moment_nm,
            text: peak_moment_text,
        },
        Rule {
            measure: "moment_per_force_m",
            two_sided: true,
            floor: s.peak_moment_floor,
            get: |m| m.moment_per_force_m,
            text: moment_per_force_text,
        },
    ]
}

fn duration_text(v: f64, md: f64) -> String {
    format!(
        "stride {} s (median {} s{})",
        num(v, 2),
        num(md, 2),
        if v > md {
            ": a missed strike?"
        } else {
            ": an extra strike?"
        }
    )
}

fn stance_text(v: f64, md: f64) -> String {
    format!(
        "stance {} s (median {} s{})",
        num(v, 2),
        num(md, 2),
        if v > md {
            ": the other foot on this belt?"
        } else {
            ""
        }
    )
}

fn peak_force_text(v: f64, md: f64) -> String {
    format!(
        "peak vertical force {} N (median {} N{})",
        num(v, 0),
        num(md, 0),
        if v > md {
            ": the other foot on this belt?"
        } else {
            ""
        }
    )
}

fn peak_moment_text(v: f64, md: f64) -> String {
    format!(
        "peak plantarflexion moment {} N·m (median {} N·m)",
        num(v, 1),
        num(md, 1)
    )
}

fn moment_per_force_text(v: f64, md: f64) -> String {
    format!(
        "peak moment per peak force {} m (median {} m: the moment does not follow the foot's force)",
        num(v, 3),
        num(md, 3)
    )
}

/// Adds a reason to each stride whose measure is out of line by one of `rules`, rule by rule.
fn flag_rule_outliers(
    compared: &Compared<'_>,
    rules: &[Rule],
    s: &CheckSettings,
    flags: &mut [Vec<StrideReason>],
) {
    for r in rules {
        let values = compared.values(r.get);
        let floor = r.floor * median_present(&values).map_or(0.0, f64::abs);
        let Some((z, md)) = robust_scores(&values, floor, s.stride_min_count) else {
            continue;
        };
        for (k, zk) in z.iter().enumerate() {
            if let Some(zk) = *zk {
                let out_of_line = if r.two_sided { zk.abs() } else { zk };
                if out_of_line > s.stride_outlier_z {
                    let v = values[k].unwrap_or(f64::NAN);
                    flags[k].push(StrideReason {
                        measure: r.measure,
                        value: v,
                        median: Some(md),
                        robust_z: Some(zk),
                        text: (r.text)(v, md),
                    });
                }
            }
        }
    }
}

/// Adds a reason to each stride with a moment in swing: one-sided, its floor a share of the
/// median peak moment in stance, since a regular swing's moment is near zero.
fn flag_swing_moments(compared: &Compared<'_>, s: &CheckSettings, flags: &mut [Vec<StrideReason>]) {
    let median_peak = compared.median(|m| m.peak_moment_nm).filter(|p| *p > 0.0);
    let swing = compared.values(|m| m.swing_moment_nm);
    let floor = s.swing_moment_floor_of_peak * median_peak.unwrap_or(0.0);
    let Some((z, md)) = robust_scores(&swing, floor, s.stride_min_count) else {
        return;
    };
    for (k, zk) in z.iter().enumerate() {
        if zk.is_some_and(|z| z > s.stride_outlier_z) {
            let v = swing[k].unwrap_or(f64::NAN);
            flags[k].push(StrideReason {
                measure: "swing_moment_nm",
                value: v,
                median: Some(md),
                robust_z: *zk,
                text: format!(
                    "a moment of {} N·m in swing, the foot off the ground (median {} N·m: a force on the wrong foot?)",
                    num(v, 1),
                    num(md, 1)
                ),
            });
        }
    }
}

/// Adds a reason to each stride whose moment jumps where no EMG envelope jumps: a jump the
/// muscles explain is no impact spike.
fn flag_moment_jumps(compared: &Compared<'_>, s: &CheckSettings, flags: &mut [Vec<StrideReason>]) {
    let jumps = compared.values(|m| m.moment_jump_nm_s);
    let env_jumps = compared.values(|m| m.envelope_jump_per_s);
    let jump_floor = |v: &[Option<f64>]| s.moment_jump_floor * median_present(v).unwrap_or(0.0);
    let env_z = robust_scores(&env_jumps, jump_floor(&env_jumps), s.stride_min_count);
    let Some((z, md)) = robust_scores(&jumps, jump_floor(&jumps), s.stride_min_count) else {
        return;
    };
    for (k, zk) in z.iter().enumerate() {
        let explained = env_z
            .as_ref()
            .and_then(|(ez, _)| ez[k])
            .is_some_and(|e| e > s.stride_outlier_z);
        if zk.is_some_and(|z| z > s.stride_outlier_z) && !explained {
            let v = jumps[k].unwrap_or(f64::NAN);
            flags[k].push(StrideReason {
                measure: "moment_jump_nm_s",
                value: v,
                median: Some(md),
                robust_z: *zk,
                text: format!(
                    "the moment jumps at {} N·m/s (median {} N·m/s) where no EMG envelope jumps: an impact spike?",
                    num(v, 0),
                    num(md, 0)
                ),
            });
        }
    }
}

/// The strides with at least one reason, in order.
fn flagged_strides(measures: &[StrideMeasures], flags: Vec<Vec<StrideReason>>) -> Vec<StrideFlag> {
    flags
        .into_iter()
        .enumerate()
        .filter(|(_, reasons)| !reasons.is_empty())
        .map(|(k, reasons)| StrideFlag {
            stride: k,
            start_s: measures[k].start_s,
            end_s: measures[k].end_s,
            reasons,
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn robust_scores_ignore_the_outlier() {
        let v: Vec<Option<f64>> = [1.0, 1.1, 0.9, 1.0, 1.05, 0.95, 5.0]
            .iter()
            .map(|x| Some(*x))
            .collect();
        let (z, m) = robust_scores(&v, 0.0, 5).unwrap();
        assert_eq!(m, 1.0);
        assert!(z[6].unwrap() > 30.0, "{z:?}");
        assert!(z[..6].iter().all(|z| z.unwrap().abs() < 1.5), "{z:?}");
        // the floor caps the score of a very regular series
        let (z, _) = robust_scores(&v, 0.5, 5).unwrap();
        assert!((z[6].unwrap() - 8.0).abs() < 1e-12);
        assert!(robust_scores(&v[..3], 0.0, 5).is_none());
    }

    #[test]
    fn moving_mean_and_jumps() {
        let x = [0.0, 3.0, 6.0, f64::NAN, 1.0];
        let m = moving_mean(&x, 1);
        assert_eq!(m[0], 1.5);
        assert_eq!(m[1], 3.0);
        assert!(m[2].is_nan() && m[4].is_nan());
        assert_eq!(max_jump(&[0.0, 1.0, 5.0, 4.0], 0, 4, 0.5), Some(8.0));
        assert_eq!(max_jump(&[0.0, 1.0], 0, 1, 0.5), None);
    }
}
