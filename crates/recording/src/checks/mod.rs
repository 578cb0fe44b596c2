//! The checks a lab needs before trusting a trial: [`check_trial`] looks at the angle range,
//! the velocity plateaus (is the isokinetic test isokinetic?), saturation of every channel,
//! flat or power-line-dominated EMG and the sign of the torque against an EMG-driven
//! prediction. Every finding is a field of [`TrialChecks`] (serialisable to JSON) and,
//! when something is wrong, a one-line warning naming the channel; nothing panics and nothing
//! is an error: an empty, single-sample or NaN-holding trial yields `null` fields and
//! warnings.
//!
//! All thresholds live in [`CheckSettings`] (its `Default` holds the documented values); the
//! result repeats them under `settings`, so a JSON report says what it was judged against.
//!
//! Each check is a stage in a file of its own, whose documentation gives its method and its
//! thresholds: `angle` ([`AngleCheck`]), `motion` ([`MotionCheck`], [`Plateau`]), `saturation`
//! ([`SaturationCheck`]), `emg` ([`EmgCheck`]) and `sign` ([`SignCheck`]). This module runs
//! them in that order and gathers their findings and warnings.
//!
//! # Also reported
//!
//! Columns whose length differs from `time_s`, non-finite samples in any channel, and fewer
//! than two time samples (no sampling rate: no velocity and no spectrum).

mod angle;
mod emg;
mod motion;
mod saturation;
mod settings;
mod sign;
mod values;

use experiment::Trial;
use serde::Serialize;

pub use angle::AngleCheck;
pub use emg::EmgCheck;
pub use motion::{MotionCheck, Plateau, SweepDirection};
pub use saturation::{ClipSide, SaturationCheck};
pub use settings::CheckSettings;
pub use sign::SignCheck;

use angle::angle_check;
use emg::{emg_check, Welch};
use motion::motion_check;
use saturation::saturation_check;
use sign::sign_check;
use values::{num, signed};

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
