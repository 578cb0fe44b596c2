//! The checks a lab needs before trusting a trial: [`check_trial`] looks at the angle range,
//! the velocity plateaus (is the isokinetic test isokinetic?), saturation of every channel,
//! flat or power-line-dominated EMG and the sign of the torque against an EMG-driven
//! prediction. Every finding is a field of [`TrialChecks`] (serialisable to JSON) and,
//! when something is wrong, a one-line warning naming the channel; nothing panics and nothing
//! is an error: an empty, single-sample or NaN-holding trial yields `null` fields and
//! warnings.
//!
//! All thresholds live in [`CheckSettings`] (its `Default` holds the values below); the
//! result repeats them under `settings`, so a JSON report says what it was judged against.
//!
//! # Angle
//!
//! The finite minimum, maximum and range of `ankle_angle_deg`. Two warnings catch a wrong
//! convention rather than a bad recording: a range below **5°** (no sweep at all, or an angle
//! in radians: a 35° sweep is 0.61 rad), and a value beyond **±60°** (beyond the ankle's
//! range of motion from neutral: an angle with 90° at neutral, or another convention).
//!
//! # Velocity and plateaus
//!
//! The velocity is the slope of a local least-squares line through the angle over a centred
//! window of **50 ms** (half-width `k = round(0.025·fs)` samples, shrunk near the ends):
//!
//! `v_i = Σ_{j=1..k} j·(θ_{i+j} − θ_{i−j}) / (dt · 2Σ_{j=1..k} j²)`
//!
//! This is a Savitzky–Golay first derivative of order 1. A plain two-point difference of a
//! quantised encoder is useless (a 0.1° step over one 0.5 ms sample is 200 °/s); over the
//! window, a quantisation error of step `q` (sd `q/√12`) leaves a velocity sd of
//! `q/√12 / (dt·√(2Σj²)) ≈ 2q` per second at 2048 Hz, i.e. 0.2 °/s for `q = 0.1°`, an order
//! below the ±10 % tolerance at 30 °/s. The window smears each 50 ms speed ramp over about
//! 100 ms, which costs a few percent of the moving time, not the verdict.
//!
//! The ankle **moves** where `|v| > max(2 °/s, 0.2·v₉₉)`, `v₉₉` the 99th percentile of `|v|`
//! (the cruise speed of any test that moves for more than 1 % of its duration). A **sweep**
//! is a maximal run of moving samples of one sign: `v < 0` (plantarflexing) is
//! [`SweepDirection::Concentric`] for the triceps surae, `v > 0` is
//! [`SweepDirection::Eccentric`].
//!
//! A sweep's **plateau velocity** is the speed `c` that the most samples of the sweep lie
//! within `tol(c) = max(10 %·c, 1 °/s)` of (found exactly over the sorted speeds with two
//! pointers); those samples are "on the plateau". A sweep has a [`Plateau`] when they add up
//! to at least **50 ms**. The plateau's span runs from its first to its last on-plateau
//! sample; its mean velocity and relative sd (`sd/|mean|`) are taken over the whole span.
//!
//! The test is **isokinetic** when it has a plateau and at least **60 %** of the moving time
//! is on a plateau. A trapezoidal ±30 °/s protocol with 50 ms ramps (the seed fixture) scores 94 %; a
//! sinusoidal motion scores at most 45 % (`cos θ ∈ [0.82, 1]` over `|θ| < acos 0.2`), a
//! triangular (constant-acceleration) one about 23 %. No motion at all is a warning too (an
//! isokinetic test that does not move is not one).
//!
//! # Saturation
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
//!
//! # EMG
//!
//! **Flat**: fewer than **8** distinct finite values (constant, or toggling over a few ADC
//! codes: an electrode or amplifier that records nothing).
//!
//! **Power-line interference** from a Welch periodogram: segments of `L` samples, `L` the
//! power of two reaching `fs·1 s` (bins `Δf = fs/L ≤ 1 Hz`; a shorter trial uses the largest
//! power of two that fits, and no ratio is computed with `Δf > 2.5 Hz`), 50 % overlap,
//! periodic Hann window, mean removed per segment; segments holding a non-finite sample are
//! skipped. With `P_k` the averaged `|X_k|²` and `f_k = k·Δf`, the EMG (envelope) band is
//! `B = {k : 10 ≤ f_k ≤ 350 Hz}` (the upper edge capped at `fs/2`), and for mains frequency
//! `f₀ ∈ {50, 60}` the line bands are `{k ∈ B : |f_k − h·f₀| ≤ max(1 Hz, Δf), h = 1, 2, 3}`.
//! The ratio
//!
//! `ρ(f₀) = Σ_{line bands of f₀} P_k / Σ_{B} P_k`
//!
//! is the share of the envelope band's power in the mains bands; the check reports the larger
//! of `ρ(50)`, `ρ(60)` and its `f₀`. Broadband EMG puts about 9 of 341 one-hertz bins, i.e.
//! **≈ 3 %**, of its power there; the warning is above **0.3** (30 %), where the mains
//! amplitude is comparable to the EMG's and biases the envelope, most visibly at rest.
//! (A Hann-windowed tone spreads over its bin and the two neighbours, all within ±1 Hz of a
//! bin-centred tone, so a pure tone scores ≈ 100 %.) The transform is a small radix-2 FFT of
//! this module. A sampling rate below `2·350 Hz` is a warning (the band is cut at `fs/2`).
//!
//! # Sign
//!
//! With a prediction (the model's EMG-driven torque on the same samples, nominal parameters),
//! the Pearson correlation `r` of measured and predicted torque over the samples where both are
//! finite, and the least-squares slope `cov/var(prediction)`. `r < −0.3` is the warning
//! "torque sign looks flipped" (a left leg on a right-leg setting, or a sign convention with
//! plantarflexion < 0): a good trial correlates at `r ≈ 0.9`, and an inverted one at about
//! `−r`; between −0.3 and 0.3 the relation is too weak to tell (a relaxed trial), so it is not
//! flagged. A prediction of another length is not compared (a warning).
//!
//! # Also reported
//!
//! Columns whose length differs from `time_s`, non-finite samples in any channel, and fewer
//! than two time samples (no sampling rate: no velocity and no spectrum).

use experiment::Trial;
use serde::{Deserialize, Serialize};

/// The thresholds of the checks (module documentation); `Default` holds the documented values.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct CheckSettings {
    /// Smallest plausible angle range of a sweep in degrees (5°).
    pub angle_min_range_deg: f64,
    /// Largest plausible |angle| in degrees from neutral (60°).
    pub angle_max_abs_deg: f64,
    /// Width of the centred least-squares window of the velocity, in seconds (0.05 s).
    pub velocity_window_s: f64,
    /// Speeds at or below this never count as moving, °/s (2 °/s).
    pub min_moving_speed_deg_s: f64,
    /// Moving threshold as a fraction of the 99th percentile of |velocity| (0.2).
    pub moving_fraction_of_peak: f64,
    /// Relative half-width of a plateau around its velocity (0.10 = ±10 %).
    pub plateau_tolerance: f64,
    /// Smallest half-width of a plateau in °/s (1 °/s), for slow tests.
    pub plateau_tolerance_min_deg_s: f64,
    /// Least on-plateau time for a sweep to have a plateau, in seconds (0.05 s).
    pub min_plateau_s: f64,
    /// Least share of the moving time on a plateau for an isokinetic test (0.6).
    pub min_plateau_fraction: f64,
    /// Least length of a run at the extreme value that counts as clipping, in samples (3).
    pub clip_min_run: usize,
    /// Largest share of samples in clipping runs on one side before the warning (0.005).
    pub clip_max_fraction: f64,
    /// Least ratio of samples at the extreme level to those at the next level inward (3).
    pub clip_min_level_ratio: f64,
    /// An EMG channel with fewer distinct finite values than this is flat (8).
    pub flat_min_distinct: usize,
    /// Length of a Welch segment in seconds; rounded up to a power of two of samples (1 s).
    pub welch_segment_s: f64,
    /// Largest usable frequency resolution of the periodogram, Hz (2.5 Hz).
    pub welch_max_resolution_hz: f64,
    /// The EMG (envelope) band, Hz ([10, 350]).
    pub emg_band_hz: [f64; 2],
    /// Half-width of each mains band, Hz (1 Hz; at least one bin).
    pub power_line_half_width_hz: f64,
    /// Harmonics of the mains frequency included (3: 50, 100, 150 Hz and 60, 120, 180 Hz).
    pub power_line_harmonics: usize,
    /// Largest share of the EMG band's power in the mains bands before the warning (0.3).
    pub power_line_max_ratio: f64,
    /// Correlation with the prediction below which the torque looks flipped (−0.3).
    pub flipped_max_correlation: f64,
}

impl Default for CheckSettings {
    fn default() -> Self {
        Self {
            angle_min_range_deg: 5.0,
            angle_max_abs_deg: 60.0,
            velocity_window_s: 0.05,
            min_moving_speed_deg_s: 2.0,
            moving_fraction_of_peak: 0.2,
            plateau_tolerance: 0.10,
            plateau_tolerance_min_deg_s: 1.0,
            min_plateau_s: 0.05,
            min_plateau_fraction: 0.6,
            clip_min_run: 3,
            clip_max_fraction: 0.005,
            clip_min_level_ratio: 3.0,
            flat_min_distinct: 8,
            welch_segment_s: 1.0,
            welch_max_resolution_hz: 2.5,
            emg_band_hz: [10.0, 350.0],
            power_line_half_width_hz: 1.0,
            power_line_harmonics: 3,
            power_line_max_ratio: 0.3,
            flipped_max_correlation: -0.3,
        }
    }
}

/// Everything [`check_trial`] found. Serialises to JSON with these (snake_case) field names;
/// a value that could not be computed is `null`.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct TrialChecks {
    /// Number of time samples.
    pub samples: usize,
    /// Sampling rate `1/dt` in Hz (`null` with fewer than 2 samples or a bad time axis).
    pub sample_rate_hz: Option<f64>,
    /// `t_last − t_first` in seconds (`null` without a time axis).
    pub duration_s: Option<f64>,
    /// The angle range.
    pub angle: AngleCheck,
    /// Velocity, sweeps and plateaus.
    pub motion: MotionCheck,
    /// Saturation of `torque_nm` and each EMG channel, in that order.
    pub saturation: Vec<SaturationCheck>,
    /// The EMG channels, in [`Trial::emg_channels`] order.
    pub emg: Vec<EmgCheck>,
    /// Torque against the prediction (`null` without a prediction).
    pub sign: Option<SignCheck>,
    /// One line per problem, each naming its channel; empty for a trial that passes.
    pub warnings: Vec<String>,
    /// The thresholds used.
    pub settings: CheckSettings,
}

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

/// Direction of a sweep, from the triceps surae's point of view.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum SweepDirection {
    /// Plantarflexing (velocity < 0): the triceps shortens.
    Concentric,
    /// Dorsiflexing (velocity > 0): the triceps lengthens.
    Eccentric,
}

/// A constant-velocity part of one sweep.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Plateau {
    /// Direction of the sweep.
    pub direction: SweepDirection,
    /// Time of the first on-plateau sample, s.
    pub start_s: f64,
    /// Time of the last on-plateau sample, s.
    pub end_s: f64,
    /// Length of the span, `end − start + dt`, s.
    pub duration_s: f64,
    /// Angle at the first on-plateau sample, degrees.
    pub start_angle_deg: f64,
    /// Angle at the last on-plateau sample, degrees.
    pub end_angle_deg: f64,
    /// Mean velocity over the span, °/s (negative for concentric).
    pub mean_velocity_deg_s: f64,
    /// Standard deviation of the velocity over the span divided by |mean|.
    pub relative_sd: f64,
    /// Share of the sweep's moving samples that are on the plateau.
    pub fraction_of_sweep: f64,
}

/// Velocity, sweeps and plateaus.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct MotionCheck {
    /// Width of the velocity window actually used, s (`null` without a sampling rate).
    pub velocity_window_s: Option<f64>,
    /// 99th percentile of |velocity|, °/s.
    pub peak_speed_deg_s: Option<f64>,
    /// Speed above which the ankle counts as moving, °/s.
    pub moving_threshold_deg_s: Option<f64>,
    /// Number of sweeps (runs of moving samples of one sign).
    pub sweeps: usize,
    /// Total moving time, s.
    pub moving_s: f64,
    /// Total on-plateau time of the plateaus, s.
    pub plateau_s: f64,
    /// `plateau_s / moving_s` (`null` when nothing moves).
    pub plateau_fraction: Option<f64>,
    /// The plateaus, in time order (at most one per sweep).
    pub plateaus: Vec<Plateau>,
    /// Whether the test is plateau-dominated (module documentation).
    pub isokinetic: bool,
}

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

/// One EMG channel.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct EmgCheck {
    /// Column name (`emg_sol`, …).
    pub channel: String,
    /// Number of samples.
    pub samples: usize,
    /// Number of non-finite samples.
    pub non_finite: usize,
    /// Standard deviation of the finite samples.
    pub sd: Option<f64>,
    /// Number of distinct finite values.
    pub distinct_values: usize,
    /// Fewer than `flat_min_distinct` distinct values.
    pub flat: bool,
    /// Share of the EMG band's power in the mains bands of `power_line_hz` (`null` when flat,
    /// too short or without a sampling rate).
    pub power_line_ratio: Option<f64>,
    /// The mains frequency (50 or 60 Hz) with the larger share.
    pub power_line_hz: Option<f64>,
    /// `power_line_ratio` above the threshold.
    pub power_line: bool,
}

/// Torque against the EMG-driven prediction.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct SignCheck {
    /// Number of sample pairs compared (both finite).
    pub samples: usize,
    /// Pearson correlation of measured and predicted torque (`null` when either is constant
    /// or the lengths differ).
    pub correlation: Option<f64>,
    /// Least-squares slope of measured on predicted torque.
    pub slope: Option<f64>,
    /// Correlation below `flipped_max_correlation`.
    pub flipped: bool,
}

impl TrialChecks {
    /// True when no check warned.
    #[must_use]
    pub fn is_clean(&self) -> bool {
        self.warnings.is_empty()
    }

    /// The summary for a terminal: one line per check (samples, angle, isokinetic,
    /// saturation, EMG, sign), then one `warning: …` line per warning.
    #[must_use]
    pub fn summary_lines(&self) -> Vec<String> {
        let mut out = Vec::new();
        out.push(match (self.sample_rate_hz, self.duration_s) {
            (Some(fs), Some(d)) => format!(
                "samples: {} at {} Hz ({} s)",
                self.samples,
                num(fs, 1),
                num(d, 2)
            ),
            _ => format!("samples: {} (no sampling rate)", self.samples),
        });
        out.push(
            match (self.angle.min_deg, self.angle.max_deg, self.angle.range_deg) {
                (Some(lo), Some(hi), Some(r)) => {
                    format!("angle: {} … {}° ({}°)", num(lo, 1), num(hi, 1), num(r, 1))
                }
                _ => "angle: no finite samples".to_string(),
            },
        );
        out.push(self.motion_line());
        let clipped: Vec<&str> = self
            .saturation
            .iter()
            .filter(|s| s.clipped)
            .map(|s| s.channel.as_str())
            .collect();
        out.push(if clipped.is_empty() {
            format!(
                "saturation: none of {} channels clipped",
                self.saturation.len()
            )
        } else {
            format!("saturation: {} clipped", clipped.join(", "))
        });
        out.push(self.emg_line());
        out.push(match &self.sign {
            None => "sign: not checked (no prediction)".to_string(),
            Some(sc) => match sc.correlation {
                Some(r) => format!(
                    "sign: torque vs EMG-driven prediction r = {}{}",
                    signed(r, 2),
                    if sc.flipped { " (flipped?)" } else { "" }
                ),
                None => {
                    "sign: no correlation (constant or mismatched torque or prediction)".to_string()
                }
            },
        });
        out.extend(self.warnings.iter().map(|w| format!("warning: {w}")));
        out
    }

    fn motion_line(&self) -> String {
        let m = &self.motion;
        let Some(frac) = m.plateau_fraction else {
            return "isokinetic: no motion".to_string();
        };
        let speeds: Vec<String> = m
            .plateaus
            .iter()
            .map(|p| signed(p.mean_velocity_deg_s, 1))
            .collect();
        let list = match speeds.len() {
            0 => String::new(),
            1 => format!(" at {} °/s", speeds[0]),
            n => format!(
                " at {} and {} °/s",
                speeds[..n - 1].join(", "),
                speeds[n - 1]
            ),
        };
        let count = match m.plateaus.len() {
            1 => "1 plateau".to_string(),
            n => format!("{n} plateaus"),
        };
        format!(
            "isokinetic: {}{count}{list} ({} % of {} s moving)",
            if m.isokinetic { "" } else { "no: " },
            num(100.0 * frac, 0),
            num(m.moving_s, 2)
        )
    }

    fn emg_line(&self) -> String {
        if self.emg.is_empty() {
            return "emg: no channels".to_string();
        }
        let parts: Vec<String> = self
            .emg
            .iter()
            .map(|e| {
                if e.flat {
                    format!("{} flat", e.channel)
                } else {
                    match (e.power_line_ratio, e.power_line_hz) {
                        (Some(r), Some(hz)) => {
                            format!("{} {} % at {} Hz", e.channel, num(100.0 * r, 0), num(hz, 0))
                        }
                        _ => format!("{} (no spectrum)", e.channel),
                    }
                }
            })
            .collect();
        format!("emg: power-line share {}", parts.join(", "))
    }
}

/// [`check_trial_with`] with the default [`CheckSettings`].
#[must_use]
pub fn check_trial(trial: &Trial, prediction_nm: Option<&[f64]>) -> TrialChecks {
    check_trial_with(trial, prediction_nm, &CheckSettings::default())
}

/// Runs every check of the module documentation on `trial`. `prediction_nm` is the model's
/// EMG-driven torque on the same samples (N·m, plantarflexion > 0); without it the sign check
/// is skipped. Never panics; what cannot be computed is `None` (JSON `null`).
#[must_use]
pub fn check_trial_with(
    trial: &Trial,
    prediction_nm: Option<&[f64]>,
    settings: &CheckSettings,
) -> TrialChecks {
    let mut warnings = Vec::new();
    let n = trial.time_s.len();
    let dt = trial.dt();
    let dt = (dt.is_finite() && dt > 0.0).then_some(dt);
    let fs = dt.map(|d| 1.0 / d);
    let t0 = trial.time_s.first().copied().filter(|t| t.is_finite());
    if dt.is_none() {
        warnings.push(format!(
            "time_s: {n} samples{}: no sampling rate, so no velocity or spectrum checks",
            if n < 2 {
                ""
            } else {
                " with a non-increasing or non-finite span"
            }
        ));
    }

    let mut columns: Vec<(String, &[f64])> = vec![
        ("ankle_angle_deg".into(), &trial.ankle_angle_deg),
        ("torque_nm".into(), &trial.torque_nm),
    ];
    columns.extend(trial.emg_channels());
    if let Some(knee) = &trial.knee_angle_deg {
        columns.push(("knee_angle_deg".into(), knee));
    }
    for (name, x) in &columns {
        if x.len() != n {
            warnings.push(format!("{name}: {} samples but time_s has {n}", x.len()));
        }
        let bad = x.iter().filter(|v| !v.is_finite()).count();
        if bad > 0 {
            warnings.push(format!("{name}: {bad} non-finite samples (NaN or ±inf)"));
        }
    }

    let angle = angle_check(&trial.ankle_angle_deg, settings, &mut warnings);
    let motion = motion_check(
        &trial.ankle_angle_deg,
        dt,
        t0.unwrap_or(0.0),
        settings,
        &mut warnings,
    );

    let mut saturation = Vec::new();
    saturation.push(saturation_check("torque_nm", &trial.torque_nm, settings));
    let emg_channels = trial.emg_channels();
    for (name, x) in &emg_channels {
        saturation.push(saturation_check(name, x, settings));
    }

    if let Some(f) = fs {
        if f < 2.0 * settings.emg_band_hz[1] {
            warnings.push(format!(
                "time_s: sampled at {} Hz, below the {} Hz the {}–{} Hz EMG band needs",
                num(f, 0),
                num(2.0 * settings.emg_band_hz[1], 0),
                num(settings.emg_band_hz[0], 0),
                num(settings.emg_band_hz[1], 0)
            ));
        }
    }
    let spectrum = fs.and_then(|f| Welch::new(f, n, settings));
    let mut emg = Vec::new();
    for (name, x) in &emg_channels {
        emg.push(emg_check(name, x, spectrum.as_ref(), settings));
    }

    // Warnings in check order: saturation, then EMG, then sign.
    for s in &saturation {
        let flat_emg = emg.iter().any(|e| e.channel == s.channel && e.flat);
        if flat_emg {
            continue;
        }
        if s.channel == "torque_nm" {
            if let (Some(h), Some(l)) = (&s.high, &s.low) {
                if h.value == l.value {
                    warnings.push(format!("torque_nm: constant at {} N·m", num(h.value, 3)));
                }
            }
        }
        for (side, word) in [(&s.high, "maximum"), (&s.low, "minimum")] {
            if let Some(c) = side.as_ref().filter(|c| c.clipped) {
                warnings.push(format!(
                    "{}: clipped at {} ({} % of samples in runs of ≥ {} at the channel's {word})",
                    s.channel,
                    num(c.value, 4),
                    num(100.0 * c.fraction, 1),
                    settings.clip_min_run
                ));
            }
        }
    }
    for e in &emg {
        if e.flat {
            warnings.push(format!(
                "{}: flat: {} distinct value{} (sd {})",
                e.channel,
                e.distinct_values,
                if e.distinct_values == 1 { "" } else { "s" },
                e.sd.map_or("n/a".to_string(), |s| format!("{s:.3e}"))
            ));
        } else if e.power_line {
            if let (Some(r), Some(hz)) = (e.power_line_ratio, e.power_line_hz) {
                warnings.push(format!(
                    "{}: {} Hz power-line interference: {} % of the EMG band's power in the {} Hz band{}",
                    e.channel,
                    num(hz, 0),
                    num(100.0 * r, 0),
                    num(hz, 0),
                    if settings.power_line_harmonics > 1 {
                        " and its harmonics"
                    } else {
                        ""
                    }
                ));
            }
        }
    }

    let sign = prediction_nm.map(|p| sign_check(&trial.torque_nm, p, settings, &mut warnings));

    TrialChecks {
        samples: n,
        sample_rate_hz: fs,
        duration_s: dt.map(|d| d * (n - 1) as f64),
        angle,
        motion,
        saturation,
        emg,
        sign,
        warnings,
        settings: *settings,
    }
}

// ---------------------------------------------------------------------------------------------
// Angle

fn angle_check(x: &[f64], s: &CheckSettings, warnings: &mut Vec<String>) -> AngleCheck {
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

// ---------------------------------------------------------------------------------------------
// Motion

/// Centred least-squares slope of `angle` over `2k + 1` samples (shrunk near the ends; NaN at
/// the first and last sample and wherever the window holds a non-finite value).
fn smoothed_velocity(angle: &[f64], dt: f64, k: usize) -> Vec<f64> {
    let n = angle.len();
    (0..n)
        .map(|i| {
            let kk = k.min(i).min(n - 1 - i);
            if kk == 0 {
                return f64::NAN;
            }
            let num: f64 = (1..=kk)
                .map(|j| j as f64 * (angle[i + j] - angle[i - j]))
                .sum();
            let kf = kk as f64;
            let den = kf * (kf + 1.0) * (2.0 * kf + 1.0) / 3.0; // 2 Σ j²
            num / (den * dt)
        })
        .collect()
}

fn motion_check(
    angle: &[f64],
    dt: Option<f64>,
    t0: f64,
    s: &CheckSettings,
    warnings: &mut Vec<String>,
) -> MotionCheck {
    let mut out = MotionCheck {
        velocity_window_s: None,
        peak_speed_deg_s: None,
        moving_threshold_deg_s: None,
        sweeps: 0,
        moving_s: 0.0,
        plateau_s: 0.0,
        plateau_fraction: None,
        plateaus: Vec::new(),
        isokinetic: false,
    };
    let Some(dt) = dt else {
        return out;
    };
    let half = 0.5 * s.velocity_window_s / dt;
    let k = if half.is_finite() {
        (half.round().max(1.0) as usize).min(1 << 14)
    } else {
        1
    };
    out.velocity_window_s = Some(2.0 * k as f64 * dt);
    let v = smoothed_velocity(angle, dt, k);
    let mut speeds: Vec<f64> = v
        .iter()
        .filter(|x| x.is_finite())
        .map(|x| x.abs())
        .collect();
    if speeds.is_empty() {
        warnings.push(
            "ankle_angle_deg: too few finite samples for a velocity: not an isokinetic test"
                .to_string(),
        );
        return out;
    }
    speeds.sort_by(f64::total_cmp);
    let p99 = speeds[((speeds.len() - 1) as f64 * 0.99).floor() as usize];
    let threshold = s
        .min_moving_speed_deg_s
        .max(s.moving_fraction_of_peak * p99);
    out.peak_speed_deg_s = Some(p99);
    out.moving_threshold_deg_s = Some(threshold);

    // Sweeps: maximal runs of moving samples of one sign.
    let moving_sign = |x: f64| -> i8 {
        if x.is_finite() && x.abs() > threshold {
            if x < 0.0 {
                -1
            } else {
                1
            }
        } else {
            0
        }
    };
    let mut sweeps: Vec<(usize, usize, i8)> = Vec::new();
    let mut i = 0;
    while i < v.len() {
        let sg = moving_sign(v[i]);
        if sg == 0 {
            i += 1;
            continue;
        }
        let start = i;
        while i < v.len() && moving_sign(v[i]) == sg {
            i += 1;
        }
        sweeps.push((start, i, sg));
    }
    out.sweeps = sweeps.len();
    let moving: usize = sweeps.iter().map(|(a, b, _)| b - a).sum();
    out.moving_s = moving as f64 * dt;
    if moving == 0 {
        warnings.push(format!(
            "ankle_angle_deg: no motion faster than {} °/s: not an isokinetic test",
            num(threshold, 1)
        ));
        return out;
    }

    let tol = |c: f64| (s.plateau_tolerance * c).max(s.plateau_tolerance_min_deg_s);
    let mut on_total = 0usize;
    for &(a, b, sg) in &sweeps {
        let seg = &v[a..b];
        let mut mags: Vec<f64> = seg.iter().map(|x| x.abs()).collect();
        mags.sort_by(f64::total_cmp);
        let c = plateau_speed(&mags, &tol);
        let on = |x: f64| (x.abs() - c).abs() <= tol(c);
        let count = seg.iter().filter(|x| on(**x)).count();
        if (count as f64) * dt < s.min_plateau_s || count == 0 {
            continue;
        }
        let first = a + seg.iter().position(|x| on(*x)).unwrap_or(0);
        let last = a + seg.iter().rposition(|x| on(*x)).unwrap_or(0);
        let span = &v[first..=last];
        let mean = span.iter().sum::<f64>() / span.len() as f64;
        let var = span.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / span.len() as f64;
        on_total += count;
        out.plateaus.push(Plateau {
            direction: if sg < 0 {
                SweepDirection::Concentric
            } else {
                SweepDirection::Eccentric
            },
            start_s: t0 + first as f64 * dt,
            end_s: t0 + last as f64 * dt,
            duration_s: (last - first + 1) as f64 * dt,
            start_angle_deg: angle[first],
            end_angle_deg: angle[last],
            mean_velocity_deg_s: mean,
            relative_sd: var.sqrt() / mean.abs(),
            fraction_of_sweep: count as f64 / (b - a) as f64,
        });
    }
    out.plateau_s = on_total as f64 * dt;
    let frac = on_total as f64 / moving as f64;
    out.plateau_fraction = Some(frac);
    out.isokinetic = !out.plateaus.is_empty() && frac >= s.min_plateau_fraction;
    if !out.isokinetic {
        warnings.push(format!(
            "ankle_angle_deg: not isokinetic: {} % of the moving time ({} s) within ±{} % of a plateau velocity (at least {} % expected)",
            num(100.0 * frac, 0),
            num(out.moving_s, 2),
            num(100.0 * s.plateau_tolerance, 0),
            num(100.0 * s.min_plateau_fraction, 0)
        ));
    }
    out
}

/// The speed `c` (one of the sorted speeds `a`) with the most speeds within `tol(c)` of it.
fn plateau_speed(a: &[f64], tol: &dyn Fn(f64) -> f64) -> f64 {
    let m = a.len();
    if m == 0 {
        return f64::NAN;
    }
    let (mut lo, mut hi) = (0usize, 0usize);
    let (mut best, mut best_count) = (a[0], 0usize);
    for (i, &c) in a.iter().enumerate() {
        let t = tol(c);
        while lo < i && a[lo] < c - t {
            lo += 1;
        }
        hi = hi.max(i);
        while hi + 1 < m && a[hi + 1] <= c + t {
            hi += 1;
        }
        let count = hi - lo + 1;
        if count > best_count {
            best_count = count;
            best = c;
        }
    }
    best
}

// ---------------------------------------------------------------------------------------------
// Saturation

fn saturation_check(name: &str, x: &[f64], s: &CheckSettings) -> SaturationCheck {
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

// ---------------------------------------------------------------------------------------------
// EMG

fn emg_check(name: &str, x: &[f64], welch: Option<&Welch>, s: &CheckSettings) -> EmgCheck {
    let finite: Vec<f64> = x.iter().copied().filter(|v| v.is_finite()).collect();
    let non_finite = x.len() - finite.len();
    let sd = (!finite.is_empty()).then(|| {
        let m = finite.iter().sum::<f64>() / finite.len() as f64;
        (finite.iter().map(|v| (v - m).powi(2)).sum::<f64>() / finite.len() as f64).sqrt()
    });
    let mut sorted = finite;
    sorted.sort_by(f64::total_cmp);
    sorted.dedup();
    let distinct = sorted.len();
    let flat = distinct < s.flat_min_distinct.max(1) || sd.is_some_and(|v| v == 0.0);
    let mut out = EmgCheck {
        channel: name.to_string(),
        samples: x.len(),
        non_finite,
        sd,
        distinct_values: distinct,
        flat,
        power_line_ratio: None,
        power_line_hz: None,
        power_line: false,
    };
    if flat {
        return out;
    }
    if let Some((ratio, hz)) = welch.and_then(|w| w.power_line(x, s)) {
        out.power_line_ratio = Some(ratio);
        out.power_line_hz = Some(hz);
        out.power_line = ratio > s.power_line_max_ratio;
    }
    out
}

/// A Welch periodogram of one segment length, with its window and FFT twiddles.
struct Welch {
    fs: f64,
    len: usize,
    window: Vec<f64>,
}

impl Welch {
    /// The segment length for `n` samples at `fs` (module documentation), or `None` when the
    /// resolution would exceed the limit.
    fn new(fs: f64, n: usize, s: &CheckSettings) -> Option<Self> {
        let want = (fs * s.welch_segment_s).ceil();
        if !(want.is_finite() && want >= 2.0) || n < 2 {
            return None;
        }
        let want = (want as usize).min(1 << 20).next_power_of_two();
        let fit = if n >= want {
            want
        } else {
            // The largest power of two not above n.
            1usize << (usize::BITS - 1 - n.leading_zeros())
        };
        if fit < 4 || fs / fit as f64 > s.welch_max_resolution_hz {
            return None;
        }
        let tau = 2.0 * std::f64::consts::PI;
        let window = (0..fit)
            .map(|j| 0.5 - 0.5 * (tau * j as f64 / fit as f64).cos())
            .collect();
        Some(Self {
            fs,
            len: fit,
            window,
        })
    }

    /// Averaged `|X_k|²`, `k = 0..=len/2`, over the finite 50 %-overlapping segments.
    fn psd(&self, x: &[f64]) -> Option<Vec<f64>> {
        let l = self.len;
        let mut acc = vec![0.0; l / 2 + 1];
        let mut segments = 0usize;
        let (mut re, mut im) = (vec![0.0; l], vec![0.0; l]);
        let hop = (l / 2).max(1);
        let mut start = 0;
        while start + l <= x.len() {
            let seg = &x[start..start + l];
            start += hop;
            if seg.iter().any(|v| !v.is_finite()) {
                continue;
            }
            let mean = seg.iter().sum::<f64>() / l as f64;
            for j in 0..l {
                re[j] = (seg[j] - mean) * self.window[j];
                im[j] = 0.0;
            }
            numerics::fft::fft_in_place(&mut re, &mut im, false);
            for (k, a) in acc.iter_mut().enumerate() {
                *a += re[k] * re[k] + im[k] * im[k];
            }
            segments += 1;
        }
        (segments > 0).then_some(acc)
    }

    /// `(ρ, f₀)`: the larger share of the EMG band's power in the mains bands, and its `f₀`.
    fn power_line(&self, x: &[f64], s: &CheckSettings) -> Option<(f64, f64)> {
        let p = self.psd(x)?;
        let df = self.fs / self.len as f64;
        let lo = s.emg_band_hz[0];
        let hi = s.emg_band_hz[1].min(0.5 * self.fs);
        let half = s.power_line_half_width_hz.max(df);
        let mut band = 0.0;
        let mut line = [0.0f64; 2];
        let mains = [50.0, 60.0];
        for (k, pk) in p.iter().enumerate() {
            let f = k as f64 * df;
            if f < lo || f > hi {
                continue;
            }
            band += pk;
            for (m, f0) in mains.iter().enumerate() {
                if (1..=s.power_line_harmonics).any(|h| (f - h as f64 * f0).abs() <= half) {
                    line[m] += pk;
                }
            }
        }
        if !(band > 0.0 && band.is_finite()) {
            return None;
        }
        let (m, &best) = line.iter().enumerate().max_by(|a, b| a.1.total_cmp(b.1))?;
        Some((best / band, mains[m]))
    }
}

// ---------------------------------------------------------------------------------------------
// Sign

fn sign_check(
    torque: &[f64],
    prediction: &[f64],
    s: &CheckSettings,
    warnings: &mut Vec<String>,
) -> SignCheck {
    if torque.len() != prediction.len() {
        warnings.push(format!(
            "torque_nm: the prediction has {} samples but the torque has {}: sign not checked",
            prediction.len(),
            torque.len()
        ));
        return SignCheck {
            samples: 0,
            correlation: None,
            slope: None,
            flipped: false,
        };
    }
    let pairs: Vec<(f64, f64)> = torque
        .iter()
        .zip(prediction)
        .filter(|(a, b)| a.is_finite() && b.is_finite())
        .map(|(a, b)| (*a, *b))
        .collect();
    let m = pairs.len();
    let mut out = SignCheck {
        samples: m,
        correlation: None,
        slope: None,
        flipped: false,
    };
    if m < 2 {
        return out;
    }
    let mx = pairs.iter().map(|p| p.0).sum::<f64>() / m as f64;
    let my = pairs.iter().map(|p| p.1).sum::<f64>() / m as f64;
    let (mut sxx, mut syy, mut sxy) = (0.0, 0.0, 0.0);
    for &(x, y) in &pairs {
        sxx += (x - mx) * (x - mx);
        syy += (y - my) * (y - my);
        sxy += (x - mx) * (y - my);
    }
    if syy > 0.0 {
        out.slope = Some(sxy / syy).filter(|v| v.is_finite());
    }
    if sxx > 0.0 && syy > 0.0 {
        let r = (sxy / (sxx.sqrt() * syy.sqrt())).clamp(-1.0, 1.0);
        if r.is_finite() {
            out.correlation = Some(r);
            out.flipped = r < s.flipped_max_correlation;
        }
    }
    if out.flipped {
        warnings.push(format!(
            "torque_nm: torque sign looks flipped: correlation with the EMG-driven prediction r = {} (a flipped leg, or plantarflexion < 0?)",
            signed(out.correlation.unwrap_or(f64::NAN), 2)
        ));
    }
    out
}

// ---------------------------------------------------------------------------------------------
// Helpers

fn finite_min_max(x: &[f64]) -> (Option<f64>, Option<f64>) {
    let mut it = x.iter().copied().filter(|v| v.is_finite());
    let Some(first) = it.next() else {
        return (None, None);
    };
    let (lo, hi) = it.fold((first, first), |(l, h), v| (l.min(v), h.max(v)));
    (Some(lo), Some(hi))
}

/// `x` with `d` decimals and a typographic minus.
fn num(x: f64, d: usize) -> String {
    format!("{x:.d$}").replace('-', "−")
}

/// `x` with `d` decimals, an explicit sign and a typographic minus.
fn signed(x: f64, d: usize) -> String {
    format!("{x:+.d$}").replace('-', "−")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn plateau_speed_finds_the_mode() {
        let mut a = vec![1.0, 2.0, 3.0, 29.0, 30.0, 30.0, 30.5, 31.0, 50.0];
        a.sort_by(f64::total_cmp);
        let tol = |c: f64| 0.1 * c;
        let c = plateau_speed(&a, &tol);
        assert!((c - 29.0).abs() < 2.5, "{c}");
    }

    #[test]
    fn runs_count_only_long_runs() {
        let x = [5.0, 5.0, 1.0, 5.0, 5.0, 5.0, 2.0, 5.0];
        assert_eq!(runs_at(&x, 5.0, 3), 3);
        assert_eq!(runs_at(&x, 5.0, 1), 6);
    }

    #[test]
    fn velocity_of_a_ramp() {
        let dt = 0.001;
        let x: Vec<f64> = (0..200).map(|i| -30.0 * i as f64 * dt).collect();
        let v = smoothed_velocity(&x, dt, 25);
        assert!(v[0].is_nan() && v[199].is_nan());
        for w in &v[1..199] {
            assert!((w + 30.0).abs() < 1e-9);
        }
    }
}
