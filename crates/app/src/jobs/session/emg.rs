//! A session's EMG normalisation: one reference per channel for all its trials (the largest
//! envelope over its MVC trials, or over all its trials), so that a weaker trial stays
//! weaker.

use super::read::read_session_trial;
use crate::error::{AppError, AppResult};
use crate::jobs::ModelSettings;
use crate::Reporter;
use session::SessionManifest;
use std::path::PathBuf;

/// Where the session's EMG references come from.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum EmgReferenceSource {
    /// The largest envelope of each channel over the session's MVC trials.
    Mvc,
    /// The largest envelope of each channel over all the session's trial CSVs.
    SessionMaximum,
    /// None: the columns are envelopes already (`--emg-is-envelope`), or the session has no
    /// trial CSV (CEINMS envelopes come normalised).
    AsGiven,
    /// Every trial's channels divided by their own peak over that trial (the manifest's
    /// `"emg_normalisation": "trial"`).
    TrialMaximum,
}

/// The EMG normalisation of a session's trial CSVs: one reference per channel for all trials,
/// so that a weaker trial stays weaker (docs/formats.md, "Session manifest").
#[derive(Clone, Debug)]
pub struct SessionEmgNormalisation {
    /// Where the references come from.
    pub source: EmgReferenceSource,
    /// Each channel's reference, in the unit of its raw envelope.
    pub references: experiment::EmgReferences,
}

impl SessionEmgNormalisation {
    /// Each trial's channels are divided by their own peak after preparation.
    pub fn per_trial(&self) -> bool {
        self.source == EmgReferenceSource::TrialMaximum
    }

    /// `inputs` as the session normalises them: unchanged, or (per trial) every envelope
    /// divided by its own peak.
    pub(super) fn apply(&self, inputs: muscle_model::TrialInputs) -> muscle_model::TrialInputs {
        if self.per_trial() {
            inputs.scaled_to_own_peaks().0
        } else {
            inputs
        }
    }

    /// A summary line per channel: its reference and where it comes from.
    pub fn summary_lines(&self) -> Vec<String> {
        let from = match self.source {
            EmgReferenceSource::Mvc => "largest envelope over the MVC trials",
            EmgReferenceSource::SessionMaximum => "largest envelope over the session's trials",
            EmgReferenceSource::AsGiven => return vec!["  EMG: envelopes as given".into()],
            EmgReferenceSource::TrialMaximum => {
                return vec![
                    "  EMG: every trial's channels divided by their own peak (emg_normalisation \"trial\")"
                        .into(),
                ]
            }
        };
        self.references
            .iter()
            .map(|(k, v)| format!("  EMG emg_{k:<8} reference {v:.6} ({from})"))
            .collect()
    }

    /// `{"source": "mvc" | "session_maximum" | "as_given" | "trial_maximum", "references":
    /// {"sol": …}}`.
    pub fn report(&self) -> EmgNormalisationReport {
        EmgNormalisationReport {
            source: match self.source {
                EmgReferenceSource::Mvc => "mvc",
                EmgReferenceSource::SessionMaximum => "session_maximum",
                EmgReferenceSource::AsGiven => "as_given",
                EmgReferenceSource::TrialMaximum => "trial_maximum",
            },
            // per trial, the session's references cancel and each trial's peaks are its own
            references: if self.per_trial() {
                std::collections::BTreeMap::new()
            } else {
                self.references
                    .iter()
                    .map(|(k, v)| (k.to_string(), v))
                    .collect()
            },
        }
    }
}

/// How a session's EMG was normalised (`"emg_normalisation"`).
#[derive(Debug, Clone, serde::Serialize)]
#[non_exhaustive]
pub struct EmgNormalisationReport {
    /// `mvc`, `session_maximum`, `as_given` or `trial_maximum` (each trial by its own peaks;
    /// `references` is then empty).
    pub source: &'static str,
    /// Each channel's reference, in the unit of its raw envelope.
    pub references: std::collections::BTreeMap<String, f64>,
}

/// Relative excess over the MVC reference above which a trial's envelope is reported: surface
/// EMG in a submaximal or isokinetic trial can pass an isometric MVC by a few per cent.
const MVC_EXCESS_WARNING: f64 = 0.10;

/// The references of the session's trial CSVs: the largest envelope of each channel over the
/// MVC trials when the manifest lists them (channels the MVC trials lack fall back to the
/// session's maximum, with a warning), else over all the trials.
pub(super) fn session_emg_references(
    manifest: &SessionManifest,
    trials: &[(&str, &experiment::Trial)],
    model: &ModelSettings,
    read: &mut Vec<PathBuf>,
    rep: &Reporter,
) -> AppResult<SessionEmgNormalisation> {
    let mut refs = session_references(manifest, trials, model, read, rep)?;
    if manifest.emg_normalisation == session::EmgNormalisationScope::Trial {
        // the session's references still bring raw EMG to [0, 1] before each trial is
        // divided by its own peak, which then cancels them
        refs.source = EmgReferenceSource::TrialMaximum;
    }
    Ok(refs)
}

/// The session-wide references (the manifest's MVC trials, else the session's maximum).
fn session_references(
    manifest: &SessionManifest,
    trials: &[(&str, &experiment::Trial)],
    model: &ModelSettings,
    read: &mut Vec<PathBuf>,
    rep: &Reporter,
) -> AppResult<SessionEmgNormalisation> {
    let opts = experiment::InputOptions {
        emg_is_envelope: model.emg_is_envelope,
        ..experiment::InputOptions::default()
    };
    if model.emg_is_envelope || trials.is_empty() {
        if !manifest.mvc.is_empty() {
            rep.warn(format!(
                "{}: mvc: not used: {}",
                manifest.path.display(),
                if trials.is_empty() {
                    "the session has no trial CSV (CEINMS envelopes come normalised)"
                } else {
                    "the EMG columns are envelopes already (--emg-is-envelope)"
                }
            ));
        }
        return Ok(SessionEmgNormalisation {
            source: EmgReferenceSource::AsGiven,
            references: experiment::EmgReferences::default(),
        });
    }
    let mut trial_peaks = Vec::with_capacity(trials.len());
    for (entry, (_, trial)) in manifest
        .trials
        .iter()
        .filter(|t| !t.source.path().is_dir())
        .zip(trials)
    {
        let name = entry.source.path().display().to_string();
        trial_peaks.push(experiment::envelope_peaks(trial, &opts, &name).map_err(AppError::bad)?);
    }
    let session_max = experiment::EmgReferences::largest(&trial_peaks);
    if manifest.mvc.is_empty() {
        return Ok(SessionEmgNormalisation {
            source: EmgReferenceSource::SessionMaximum,
            references: session_max,
        });
    }
    let mut mvc_peaks = Vec::with_capacity(manifest.mvc.len());
    for p in &manifest.mvc {
        read.push(p.clone());
        let (t, _) = read_session_trial(p, model, rep)?;
        mvc_peaks.push(
            experiment::envelope_peaks(&t, &opts, &p.display().to_string())
                .map_err(AppError::bad)?,
        );
    }
    let mut refs = experiment::EmgReferences::largest(&mvc_peaks);
    for (channel, v) in session_max.iter() {
        match refs.get(channel) {
            None => {
                rep.warn(format!(
                    "{}: mvc: no MVC trial has emg_{channel}; that channel is normalised by its \
                     largest envelope over the session's trials",
                    manifest.path.display()
                ));
                refs.set(channel, v);
            }
            Some(m) if v > m * (1.0 + MVC_EXCESS_WARNING) => {
                let name = trials
                    .iter()
                    .zip(&trial_peaks)
                    .find(|(_, p)| p.get(channel) == Some(v))
                    .map_or("?", |((n, _), _)| *n);
                rep.warn(format!(
                    "{}: trial {name}: the emg_{channel} envelope reaches {:.0} % of the MVC \
                     reference; its normalised envelope is clipped at 1",
                    manifest.path.display(),
                    100.0 * v / m
                ));
            }
            Some(_) => {}
        }
    }
    Ok(SessionEmgNormalisation {
        source: EmgReferenceSource::Mvc,
        references: refs,
    })
}
