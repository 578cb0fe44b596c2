//! A candidate protocol: a comma-separated list of trials, each an
//! [`experiment::SynthProtocol`] (`knee0@30,knee90@30,knee0@60`, `knee0@30x3`).

use std::fmt;
use std::str::FromStr;

use experiment::{SynthConfig, SynthProtocol};
use muscle_model::TrialInputs;

use crate::error::{DesignError, Result};

/// A protocol: the trials recorded from one subject and identified together.
#[derive(Clone, Debug, PartialEq)]
pub struct DesignProtocol {
    /// The protocol as written (trimmed).
    pub text: String,
    /// Its trials, in order.
    pub trials: Vec<SynthProtocol>,
}

impl DesignProtocol {
    /// The trials' names (`knee0@30`, …: each trial as [`SynthProtocol`] writes it, with the
    /// speed always shown).
    #[must_use]
    pub fn trial_names(&self) -> Vec<String> {
        self.trials.iter().map(trial_name).collect()
    }
}

/// A trial's name with its speed always written (`knee0@30`, `knee90@30`, `knee0@30x2`), so
/// that a table reads the same whatever the nominal speed.
#[must_use]
pub fn trial_name(t: &SynthProtocol) -> String {
    let k = t.knee_angle_deg;
    let v = t.speed_deg_s;
    match t.protocol {
        experiment::Protocol::Seed => format!("knee{k}@{v}"),
        experiment::Protocol::Cycles { cycles } => format!("knee{k}@{v}x{cycles}"),
        _ => t.to_string(),
    }
}

impl fmt::Display for DesignProtocol {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.text)
    }
}

impl FromStr for DesignProtocol {
    type Err = DesignError;
    fn from_str(s: &str) -> Result<Self> {
        let text = s.trim().to_string();
        let bad = |reason: String| DesignError::Protocol {
            protocol: text.clone(),
            reason,
        };
        if text.is_empty() {
            return Err(bad(
                "empty; expected trials such as 'knee0@30,knee90@30,knee0@60'".into(),
            ));
        }
        let mut trials = Vec::new();
        for part in text.split(',') {
            let part = part.trim();
            if part.is_empty() {
                return Err(bad("an empty trial between commas".into()));
            }
            let t: SynthProtocol = part
                .parse()
                .map_err(|e: experiment::ExperimentError| bad(format!("trial '{part}': {e}")))?;
            trials.push(t);
        }
        Ok(Self { text, trials })
    }
}

/// The model inputs of one protocol trial: the synthetic trial of
/// [`experiment::synthetic_recording`] with EMG seed `emg_seed`, through the same EMG
/// processing as a recorded trial, each channel normalised as a session normalises it (by its
/// largest envelope over the session's trials). The synthetic subject's largest envelopes are
/// those of its extended knee, where the gastrocnemii's drive is full: a trial's soleus is
/// divided by its own maximum, its gastrocnemii by their maximum over the drive factor
/// ([`experiment::gastrocnemius_drive_factor`], 0.7 at 90°), so a flexed-knee trial keeps its
/// weaker gastrocnemius input whatever else the protocol holds.
///
/// # Errors
/// [`DesignError::Synthesis`] when the trial cannot be synthesised.
pub fn trial_inputs(trial: &SynthProtocol, emg_seed: u64) -> Result<TrialInputs> {
    let fail = |e: experiment::ExperimentError| DesignError::Synthesis {
        trial: trial_name(trial),
        reason: e.to_string(),
    };
    let cfg = SynthConfig::for_protocol(*trial, emg_seed);
    let (_, recording) = experiment::synthetic_recording(&cfg).map_err(fail)?;
    let opts = experiment::InputOptions::default();
    let mut refs = experiment::envelope_peaks(&recording, &opts, "<design trial>").map_err(fail)?;
    let factor = experiment::gastrocnemius_drive_factor(trial.knee_angle_deg);
    for m in ["gm", "gl"] {
        if let Some(peak) = refs.get(m) {
            refs.set(m, peak / factor);
        }
    }
    experiment::model_inputs_referenced(&recording, &opts, &refs, "<design trial>").map_err(fail)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_lists_and_cycles() {
        let p: DesignProtocol = " knee0@30, knee90@30 ,knee0@60 ".parse().unwrap();
        assert_eq!(p.trials.len(), 3);
        assert_eq!(p.trial_names(), ["knee0@30", "knee90@30", "knee0@60"]);
        let p: DesignProtocol = "knee0@30x2".parse().unwrap();
        assert_eq!(p.trial_names(), ["knee0@30x2"]);
        assert_eq!(
            p.trials[0].protocol,
            experiment::Protocol::Cycles { cycles: 2 }
        );
    }

    #[test]
    fn rejects_bad_trials_naming_them() {
        for s in ["", "knee0@30,,knee90", "knee0@30,elbow", "knee0@-5"] {
            let e = s.parse::<DesignProtocol>().unwrap_err().to_string();
            assert!(e.starts_with("protocol '"), "{s}: {e}");
            assert!(!e.contains('\n'), "{e}");
        }
        let e = "knee0@30,elbow".parse::<DesignProtocol>().unwrap_err();
        assert!(e.to_string().contains("'elbow'"), "{e}");
    }
}
