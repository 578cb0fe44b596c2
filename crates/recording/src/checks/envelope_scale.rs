//! Across the trials of one session: an EMG channel whose scale differs between trials far
//! more than the moment does (an electrode moved or re-applied, another gain, a trial
//! normalised to something else), which a model fitted to the session cannot absorb.
//!
//! For trial `i` and channel `c`, `E_ic` is the 95th percentile of `|x|` over the trial (of
//! the envelope, or of the raw EMG, which scales with the same amplitude), and `M_i` the 95th
//! percentile of the ankle moment (plantarflexion > 0; the same percentile, so that like is
//! compared with like: a peak that a few samples of an artefact do not set). The envelope per
//! moment is `r_ic = E_ic / M_i`. With three or more trials holding channel `c`, trial `i` is
//! flagged when `r_ic / median_j r_jc` lies outside `[1/F, F]`; with two, the pair is flagged
//! when `r_2c / r_1c` does. `F` = **3**: between four different tasks of one real subject
//! (CEINMS's test subject: walking, running and two cutting manoeuvres, whose peak moments
//! differ 2.4-fold) the ratio stays within a factor 1.7 of the median; a changed gain or
//! normalisation is usually a factor of 2 to 1000.

use serde::Serialize;

use super::settings::CheckSettings;
use super::values::{finite_quantile, median_of, num};

/// One trial of a session, for [`check_envelope_scales`].
#[derive(Clone, Debug)]
pub struct ScaleTrial<'a> {
    /// The trial's name (in messages).
    pub name: &'a str,
    /// The ankle moment, N·m (plantarflexion > 0).
    pub moment_nm: &'a [f64],
    /// `(channel, samples)` of each EMG channel (envelope or raw).
    pub emg: Vec<(String, &'a [f64])>,
}

/// One channel's peak in one trial.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct ChannelPeak {
    /// Channel name.
    pub channel: String,
    /// Percentile of `|x|` (`null` without finite samples or when 0).
    pub peak: Option<f64>,
}

/// One trial's peaks.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct TrialScale {
    /// The trial.
    pub trial: String,
    /// Percentile of the moment, N·m (`null` when not positive).
    pub moment_peak_nm: Option<f64>,
    /// Each channel's percentile.
    pub envelope_peaks: Vec<ChannelPeak>,
}

/// A channel of a trial whose scale is out of line with the moment.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct ScaleFlag {
    /// The trial.
    pub trial: String,
    /// The trial compared with (the other one of two; `null` against the session's median).
    pub against: Option<String>,
    /// The channel.
    pub channel: String,
    /// The envelope's peak over the reference's (the other trial's, or the median over the
    /// trials).
    pub envelope_ratio: f64,
    /// The moment's peak over the reference's.
    pub moment_ratio: f64,
    /// The envelope per moment over the reference's (`r_ic / median r_jc`, or `r_2c / r_1c`).
    pub factor: f64,
}

/// The envelope-scale check of a session.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct EnvelopeScaleCheck {
    /// The percentile of the peaks (0.95).
    pub percentile: f64,
    /// The factor `F`.
    pub max_factor: f64,
    /// Each trial's peaks.
    pub trials: Vec<TrialScale>,
    /// The flagged channels.
    pub flagged: Vec<ScaleFlag>,
    /// One line per flag (or per reason nothing could be compared).
    pub warnings: Vec<String>,
}

fn positive(x: Option<f64>) -> Option<f64> {
    x.filter(|v| *v > 0.0 && v.is_finite())
}

/// Compares the EMG scales of a session's trials (module documentation). Never panics: a
/// channel in fewer than two trials, or a trial without a positive moment, is left out.
#[must_use]
pub fn check_envelope_scales(trials: &[ScaleTrial<'_>], s: &CheckSettings) -> EnvelopeScaleCheck {
    let p = s.envelope_scale_percentile;
    let f = s.envelope_scale_max_factor;
    let scales: Vec<TrialScale> = trials
        .iter()
        .map(|t| TrialScale {
            trial: t.name.to_string(),
            moment_peak_nm: positive(finite_quantile(t.moment_nm, p)),
            envelope_peaks: t
                .emg
                .iter()
                .map(|(c, x)| ChannelPeak {
                    channel: c.clone(),
                    peak: positive(finite_quantile(
                        &x.iter().map(|v| v.abs()).collect::<Vec<_>>(),
                        p,
                    )),
                })
                .collect(),
        })
        .collect();
    let mut out = EnvelopeScaleCheck {
        percentile: p,
        max_factor: f,
        trials: scales,
        flagged: Vec::new(),
        warnings: Vec::new(),
    };
    for t in &out.trials {
        if t.moment_peak_nm.is_none() {
            out.warnings.push(format!(
                "{}: torque_nm: no positive (plantarflexion) moment at the {} th percentile: its EMG scale is not compared",
                t.trial,
                num(100.0 * p, 0)
            ));
        }
    }
    let mut channels: Vec<String> = Vec::new();
    for t in &out.trials {
        for c in &t.envelope_peaks {
            if !channels.contains(&c.channel) {
                channels.push(c.channel.clone());
            }
        }
    }
    let mut flagged = Vec::new();
    for c in &channels {
        // (trial index, E, M) of the trials holding both
        let rows: Vec<(usize, f64, f64)> = out
            .trials
            .iter()
            .enumerate()
            .filter_map(|(i, t)| {
                let e = t
                    .envelope_peaks
                    .iter()
                    .find(|x| &x.channel == c)
                    .and_then(|x| x.peak)?;
                Some((i, e, t.moment_peak_nm?))
            })
            .collect();
        if rows.len() == 2 {
            let ((a, ea, ma), (b, eb, mb)) = (rows[0], rows[1]);
            let factor = (eb / ea) / (mb / ma);
            if !(1.0 / f..=f).contains(&factor) {
                // name the trial with the larger envelope per moment
                let (hi, lo, er, mr) = if factor > 1.0 {
                    (b, a, eb / ea, mb / ma)
                } else {
                    (a, b, ea / eb, ma / mb)
                };
                flagged.push(ScaleFlag {
                    trial: out.trials[hi].trial.clone(),
                    against: Some(out.trials[lo].trial.clone()),
                    channel: c.clone(),
                    envelope_ratio: er,
                    moment_ratio: mr,
                    factor: er / mr,
                });
            }
        } else if rows.len() >= 3 {
            let r: Vec<f64> = rows.iter().map(|(_, e, m)| e / m).collect();
            let es: Vec<f64> = rows.iter().map(|x| x.1).collect();
            let ms: Vec<f64> = rows.iter().map(|x| x.2).collect();
            let (Some(rm), Some(em), Some(mm)) = (median_of(&r), median_of(&es), median_of(&ms))
            else {
                continue;
            };
            for (k, &(i, e, m)) in rows.iter().enumerate() {
                let factor = r[k] / rm;
                if !(1.0 / f..=f).contains(&factor) {
                    flagged.push(ScaleFlag {
                        trial: out.trials[i].trial.clone(),
                        against: None,
                        channel: c.clone(),
                        envelope_ratio: e / em,
                        moment_ratio: m / mm,
                        factor,
                    });
                }
            }
        }
    }
    for g in &flagged {
        let reference = g
            .against
            .as_ref()
            .map_or("the session's median".to_string(), |a| format!("{a}'s"));
        out.warnings.push(format!(
            "{}: {}: envelope {}× {reference} while the moment is {}×: its scale per moment differs by a factor {} (beyond {}; another gain, electrode or normalisation?)",
            g.trial,
            g.channel,
            num(g.envelope_ratio, 2),
            num(g.moment_ratio, 2),
            num(g.factor, 2),
            num(f, 1)
        ));
    }
    out.flagged = flagged;
    out
}
