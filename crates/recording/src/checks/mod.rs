//! The checks a lab needs before trusting a trial. [`check_trial`] first decides what the
//! trial is ([`TrialKind`]: a dynamometer trial or gait, given by the caller or inferred:
//! `trial_kind`), then runs the checks that apply to it:
//!
//! | check | dynamometer | gait |
//! |---|---|---|
//! | angle range | yes | yes |
//! | velocity plateaus (is the isokinetic test isokinetic?), speeds | yes | no |
//! | per-stride moment against the other strides and the foot's ground force | no | yes |
//! | saturation of torque and EMG | yes | yes |
//! | flat EMG | yes | yes |
//! | sampling rate against the EMG band, power-line interference | raw EMG only | raw EMG only |
//! | torque sign against an EMG-driven prediction | yes | yes |
//!
//! The rate and power-line checks are left out for EMG that is an envelope already
//! ([`TrialContext::emg_is_envelope`]): an envelope is low-passed, its rate is not the raw
//! band's and the mains frequency is not in it. Every finding is a field of [`TrialChecks`]
//! (serialisable to JSON; a check that did not apply is `null`, and `kind`, `kind_reason`
//! and `applied` say why) and, when something is wrong, a one-line warning naming the channel;
//! nothing panics and nothing is an error: an empty, single-sample or NaN-holding trial yields
//! `null` fields and warnings. Long lists are summarised in the text (more than four
//! plateaus by their count and speed range; more than five flagged strides by their count),
//! never on one line; the JSON keeps every entry.
//!
//! Across the trials of a session, [`check_envelope_scales`] compares each EMG channel's scale
//! with the moment's (`envelope_scale`).
//!
//! All thresholds live in [`CheckSettings`] (its `Default` holds the documented values); the
//! result repeats them under `settings`, so a JSON report says what it was judged against.
//!
//! Each check is a stage in a file of its own, whose documentation gives its method and its
//! thresholds: `angle` ([`AngleCheck`]), `motion` ([`MotionCheck`], [`Plateau`]), `gait`
//! ([`GaitCheck`], [`StrideFlag`]), `saturation` ([`SaturationCheck`]), `emg` ([`EmgCheck`])
//! and `sign` ([`SignCheck`]). This module runs them in that order and gathers their findings
//! and warnings.
//!
//! # Also reported
//!
//! Columns whose length differs from `time_s`, non-finite samples in any channel, and fewer
//! than two time samples (no sampling rate: no velocity and no spectrum).

mod angle;
mod emg;
mod envelope_scale;
mod gait;
mod motion;
mod saturation;
mod settings;
mod sign;
mod trial_kind;
mod values;

use experiment::Trial;
use serde::Serialize;

pub use angle::AngleCheck;
pub use emg::EmgCheck;
pub use envelope_scale::{
    check_envelope_scales, ChannelPeak, EnvelopeScaleCheck, ScaleFlag, ScaleTrial, TrialScale,
};
pub use gait::{GaitCheck, StrideFlag, StrideMeasures, StrideReason};
pub use motion::{MotionCheck, Plateau, SweepDirection};
pub use saturation::{ClipSide, SaturationCheck};
pub use settings::CheckSettings;
pub use sign::SignCheck;
pub use trial_kind::TrialKind;

use angle::angle_check;
use emg::{emg_check, Welch};
use gait::{gait_check, GaitInputs};
use motion::motion_check;
use saturation::saturation_check;
use sign::sign_check;
use trial_kind::infer_kind;
use values::{num, signed};

/// What the caller knows about a trial beyond its samples (the tested foot's ground force is
/// one of them: [`Trial::grf_vertical_n`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct TrialContext {
    /// What the trial is, when the caller knows (a session manifest's or a command's word);
    /// `None`: inferred (module `trial_kind`).
    pub kind: Option<TrialKind>,
    /// The EMG columns are envelopes already (a recording map's `emg_is_envelope`): no rate
    /// or power-line check.
    pub emg_is_envelope: bool,
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
    /// What the trial is: `dynamometer` or `gait`.
    pub kind: TrialKind,
    /// Why: `given by the caller`, or what it was inferred from.
    pub kind_reason: String,
    /// The EMG was taken as envelopes (no rate or power-line check).
    pub emg_is_envelope: bool,
    /// The names of the checks that ran, in order.
    pub applied: Vec<&'static str>,
    /// The angle range.
    pub angle: AngleCheck,
    /// Velocity, sweeps and plateaus (`null` for a gait trial).
    pub motion: Option<MotionCheck>,
    /// The per-stride checks (`null` for a dynamometer trial).
    pub strides: Option<GaitCheck>,
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

    /// The checks that ran, in words, for a one-line verdict ("recording checks: clean (…)"):
    /// the EMG checks of raw EMG (flat, rate, power line) are "EMG", of envelopes "flat EMG".
    #[must_use]
    pub fn applied_text(&self) -> String {
        let raw = self.applied.contains(&"power_line");
        self.applied
            .iter()
            .filter_map(|a| match *a {
                "angle" => Some("angle range"),
                "isokinetic" => Some("isokinetic plateaus"),
                "strides" => Some("strides"),
                "saturation" => Some("saturation"),
                "emg_flat" if raw => Some("EMG"),
                "emg_flat" => Some("flat EMG"),
                "sign" => Some("torque sign"),
                _ => None,
            })
            .collect::<Vec<_>>()
            .join(", ")
    }

    /// The summary for a terminal: one line per check (samples, trial kind, angle, isokinetic
    /// or strides, saturation, EMG, sign), then one `warning: …` line per warning.
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
        out.push(format!(
            "trial: {} ({})",
            self.kind.name(),
            self.kind_reason
        ));
        out.push(
            match (self.angle.min_deg, self.angle.max_deg, self.angle.range_deg) {
                (Some(lo), Some(hi), Some(r)) => {
                    format!("angle: {} … {}° ({}°)", num(lo, 1), num(hi, 1), num(r, 1))
                }
                _ => "angle: no finite samples".to_string(),
            },
        );
        match (&self.motion, &self.strides) {
            (Some(m), _) => out.push(motion_line(m)),
            (None, Some(g)) => out.push(strides_line(g)),
            (None, None) => out.push(format!(
                "isokinetic: not checked ({} trial); strides: not checked (no ground force)",
                self.kind.name()
            )),
        }
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

    fn emg_line(&self) -> String {
        if self.emg.is_empty() {
            return "emg: no channels".to_string();
        }
        if self.emg_is_envelope {
            let flat: Vec<&str> = self
                .emg
                .iter()
                .filter(|e| e.flat)
                .map(|e| e.channel.as_str())
                .collect();
            return format!(
                "emg: {} envelope channel{} ({}; rate and power line not checked)",
                self.emg.len(),
                if self.emg.len() == 1 { "" } else { "s" },
                if flat.is_empty() {
                    "none flat".to_string()
                } else {
                    format!("{} flat", flat.join(", "))
                }
            );
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

/// The plateaus' line: their speeds listed up to four, else their count and speed range.
fn motion_line(m: &MotionCheck) -> String {
    let Some(frac) = m.plateau_fraction else {
        return "isokinetic: no motion".to_string();
    };
    let speeds: Vec<f64> = m.plateaus.iter().map(|p| p.mean_velocity_deg_s).collect();
    let list = match speeds.len() {
        0 => String::new(),
        1 => format!(" at {} °/s", signed(speeds[0], 1)),
        2..=4 => {
            let s: Vec<String> = speeds.iter().map(|v| signed(*v, 1)).collect();
            format!(
                " at {} and {} °/s",
                s[..s.len() - 1].join(", "),
                s[s.len() - 1]
            )
        }
        _ => {
            let lo = speeds.iter().copied().fold(f64::INFINITY, f64::min);
            let hi = speeds.iter().copied().fold(f64::NEG_INFINITY, f64::max);
            format!(" from {} to {} °/s", signed(lo, 1), signed(hi, 1))
        }
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

/// The strides' line: their count, median durations and the flagged strides (up to eight
/// named).
fn strides_line(g: &GaitCheck) -> String {
    if let Some(e) = &g.error {
        return format!("strides: none ({e})");
    }
    let medians = match (g.median_stride_s, g.median_stance_s) {
        (Some(a), Some(b)) => format!(": median stride {} s, stance {} s", num(a, 2), num(b, 2)),
        _ => String::new(),
    };
    let flagged = match g.flagged.len() {
        0 if g.compared => "; none flagged".to_string(),
        0 => format!("; too few to compare (at least {} needed)", g.min_strides),
        n => {
            let mut ids: Vec<String> = g
                .flagged
                .iter()
                .take(8)
                .map(|f| f.stride.to_string())
                .collect();
            if n > 8 {
                ids.push(format!("… ({} more)", n - 8));
            }
            format!("; {n} flagged: {}", ids.join(", "))
        }
    };
    format!(
        "strides: {} from the ground force (stance above {} N){medians}{flagged}",
        g.strides,
        num(g.threshold_n, 0)
    )
}

/// [`check_trial_with`] with the default [`CheckSettings`].
#[must_use]
pub fn check_trial(trial: &Trial, prediction_nm: Option<&[f64]>) -> TrialChecks {
    check_trial_with(trial, prediction_nm, &CheckSettings::default())
}

/// [`check_trial_in_context`] with the default (empty) [`TrialContext`]: the kind inferred,
/// the EMG taken as raw.
#[must_use]
pub fn check_trial_with(
    trial: &Trial,
    prediction_nm: Option<&[f64]>,
    settings: &CheckSettings,
) -> TrialChecks {
    check_trial_in_context(trial, prediction_nm, &TrialContext::default(), settings)
}

/// The most flagged strides named one warning each; the rest in one line.
const STRIDE_WARNINGS: usize = 5;

/// Runs the checks of the module documentation that apply to `trial`. `prediction_nm` is the
/// model's EMG-driven torque on the same samples (N·m, plantarflexion > 0); without it the
/// sign check is skipped. Never panics; what cannot be computed is `None` (JSON `null`).
#[must_use]
pub fn check_trial_in_context(
    trial: &Trial,
    prediction_nm: Option<&[f64]>,
    context: &TrialContext,
    settings: &CheckSettings,
) -> TrialChecks {
    let mut warnings = Vec::new();
    let mut applied = Vec::new();
    let n = trial.time_s.len();
    let dt = sample_interval(trial, &mut warnings);
    let fs = dt.map(|d| 1.0 / d);
    let t0 = trial.time_s.first().copied().filter(|t| t.is_finite());
    let grf = trial.grf_vertical_n.as_deref();
    let (kind, kind_reason) = infer_kind(
        context.kind,
        grf.is_some(),
        &trial.ankle_angle_deg,
        dt,
        settings,
    );
    column_warnings(trial, &mut warnings);

    applied.push("angle");
    let angle = angle_check(&trial.ankle_angle_deg, settings, &mut warnings);
    let motion = (kind == TrialKind::Dynamometer).then(|| {
        applied.push("isokinetic");
        motion_check(
            &trial.ankle_angle_deg,
            dt,
            t0.unwrap_or(0.0),
            settings,
            &mut warnings,
        )
    });
    let strides = if kind == TrialKind::Gait {
        gait_stage(trial, dt, context, settings, &mut applied, &mut warnings)
    } else {
        None
    };

    applied.push("saturation");
    let saturation = saturation_checks(trial, settings);
    let emg = emg_stage(trial, fs, context, settings, &mut applied, &mut warnings);

    // Warnings in check order: saturation, then EMG, then sign.
    saturation_warnings(&saturation, &emg, settings, &mut warnings);
    emg_warnings(&emg, settings, &mut warnings);
    let sign = prediction_nm.map(|p| sign_check(&trial.torque_nm, p, settings, &mut warnings));
    if sign.is_some() {
        applied.push("sign");
    }

    TrialChecks {
        samples: n,
        sample_rate_hz: fs,
        duration_s: dt.map(|d| d * (n - 1) as f64),
        kind,
        kind_reason,
        emg_is_envelope: context.emg_is_envelope,
        applied,
        angle,
        motion,
        strides,
        saturation,
        emg,
        sign,
        warnings,
        settings: *settings,
    }
}

/// The sampling interval of `time_s` (`None`, with a warning, when there is none: fewer than
/// two samples or a non-increasing or non-finite span).
fn sample_interval(trial: &Trial, warnings: &mut Vec<String>) -> Option<f64> {
    let n = trial.time_s.len();
    let dt = trial.dt();
    let dt = (dt.is_finite() && dt > 0.0).then_some(dt);
    if dt.is_none() {
        warnings.push(format!(
            "time_s: {n} samples{}: no sampling rate, so no velocity, stride or spectrum checks",
            if n < 2 {
                ""
            } else {
                " with a non-increasing or non-finite span"
            }
        ));
    }
    dt
}

/// Warns of each column whose length differs from `time_s` or that holds non-finite samples.
fn column_warnings(trial: &Trial, warnings: &mut Vec<String>) {
    let n = trial.time_s.len();
    let mut columns: Vec<(String, &[f64])> = vec![
        ("ankle_angle_deg".into(), &trial.ankle_angle_deg),
        ("torque_nm".into(), &trial.torque_nm),
    ];
    columns.extend(trial.emg_channels());
    if let Some(knee) = &trial.knee_angle_deg {
        columns.push(("knee_angle_deg".into(), knee));
    }
    if let Some(f) = trial.grf_vertical_n.as_deref() {
        columns.push(("grf_vertical_n".into(), f));
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
}

/// The per-stride checks of a gait trial and their warnings; `None` (not applied) without a
/// ground force or a sampling interval.
fn gait_stage(
    trial: &Trial,
    dt: Option<f64>,
    context: &TrialContext,
    settings: &CheckSettings,
    applied: &mut Vec<&'static str>,
    warnings: &mut Vec<String>,
) -> Option<GaitCheck> {
    let (Some(grf_n), Some(dt)) = (trial.grf_vertical_n.as_deref(), dt) else {
        return None;
    };
    applied.push("strides");
    let emg_channels = trial.emg_channels();
    let g = gait_check(
        &GaitInputs {
            time_s: &trial.time_s,
            dt,
            torque_nm: &trial.torque_nm,
            grf_n,
            emg: emg_channels.iter().map(|(_, x)| *x).collect(),
            emg_is_envelope: context.emg_is_envelope,
        },
        settings,
    );
    stride_warnings(&g, warnings);
    Some(g)
}

/// Saturation of `torque_nm` and each EMG channel, in that order.
fn saturation_checks(trial: &Trial, settings: &CheckSettings) -> Vec<SaturationCheck> {
    let mut saturation = vec![saturation_check("torque_nm", &trial.torque_nm, settings)];
    for (name, x) in &trial.emg_channels() {
        saturation.push(saturation_check(name, x, settings));
    }
    saturation
}

/// The EMG checks: flat channels always; the sampling rate and power-line interference only
/// for raw EMG, since an envelope is low-passed and holds neither the band nor the mains.
fn emg_stage(
    trial: &Trial,
    fs: Option<f64>,
    context: &TrialContext,
    settings: &CheckSettings,
    applied: &mut Vec<&'static str>,
    warnings: &mut Vec<String>,
) -> Vec<EmgCheck> {
    let raw_emg = !context.emg_is_envelope;
    applied.push("emg_flat");
    if raw_emg {
        applied.push("emg_rate");
        applied.push("power_line");
    }
    let fs_raw = fs.filter(|_| raw_emg);
    if let Some(f) = fs_raw {
        emg_rate_warning(f, settings, warnings);
    }
    let n = trial.time_s.len();
    let spectrum = fs_raw.and_then(|f| Welch::new(f, n, settings));
    trial
        .emg_channels()
        .iter()
        .map(|(name, x)| emg_check(name, x, spectrum.as_ref(), settings))
        .collect()
}

/// Warns when the sampling rate `fs` is below the Nyquist rate of the raw EMG band.
fn emg_rate_warning(fs: f64, settings: &CheckSettings, warnings: &mut Vec<String>) {
    if fs < 2.0 * settings.emg_band_hz[1] {
        warnings.push(format!(
            "time_s: sampled at {} Hz, below the {} Hz the {}–{} Hz EMG band needs (if the EMG columns are envelopes already, say so: emg_is_envelope)",
            num(fs, 0),
            num(2.0 * settings.emg_band_hz[1], 0),
            num(settings.emg_band_hz[0], 0),
            num(settings.emg_band_hz[1], 0)
        ));
    }
}

/// The saturation warnings: a constant torque and each clipped side. A flat EMG channel is
/// left to its flat warning, which says more.
fn saturation_warnings(
    saturation: &[SaturationCheck],
    emg: &[EmgCheck],
    settings: &CheckSettings,
    warnings: &mut Vec<String>,
) {
    for s in saturation {
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
}

/// The EMG warnings: a flat channel, else its power-line interference.
fn emg_warnings(emg: &[EmgCheck], settings: &CheckSettings, warnings: &mut Vec<String>) {
    for e in emg {
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
}

/// The gait check's warnings: why there are no strides, or the flagged strides, each on its
/// own line up to [`STRIDE_WARNINGS`], the rest counted on one.
fn stride_warnings(g: &GaitCheck, warnings: &mut Vec<String>) {
    if let Some(e) = &g.error {
        warnings.push(format!("{e}: no per-stride checks"));
        return;
    }
    if !g.compared {
        warnings.push(format!(
            "grf_vertical_n: {} stride(s): too few to compare the strides with each other",
            g.strides
        ));
    }
    for f in g.flagged.iter().take(STRIDE_WARNINGS) {
        let why: Vec<&str> = f.reasons.iter().map(|r| r.text.as_str()).collect();
        warnings.push(format!(
            "stride {} ({}–{} s): {}",
            f.stride,
            num(f.start_s, 2),
            num(f.end_s, 2),
            why.join("; ")
        ));
    }
    if g.flagged.len() > STRIDE_WARNINGS {
        warnings.push(format!(
            "and {} more of the {} strides flagged (checks.strides.flagged in the JSON)",
            g.flagged.len() - STRIDE_WARNINGS,
            g.strides
        ));
    }
}
