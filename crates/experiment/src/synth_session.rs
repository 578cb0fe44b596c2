//! Synthetic sessions: several trials of one synthetic subject, written as trial CSVs, their
//! unloaded runs and a session manifest (docs/formats.md, "Session manifest").
//!
//! Every trial of a session shares the true muscle parameters and effects, and its true torque
//! is computed from EMG envelopes normalised the way a session is read: each channel by its
//! largest envelope over all the session's trials (so the flexed knee's weaker gastrocnemius
//! drive stays weaker). Each trial has its own
//! protocol (knee angle, speed, cycles), its own seed (`seed + i` for the `i`-th trial, so the
//! EMG carriers and the dynamometer noise are independent between trials) and its own unloaded
//! run at its own speed. The files are named after the protocol: `knee0_30.csv`,
//! `knee0_30_unloaded.csv`, … and `session.json` lists them.
//!
//! ```
//! use experiment::synth_session::{session_manifest, session_trial_name, synthesize_session};
//! use muscle_model::{Effects, ModelParams};
//!
//! let protocols = ["knee0@30".parse()?, "knee90@30".parse()?];
//! let session = synthesize_session(&protocols, 7, &ModelParams::nominal(), &Effects::none())?;
//! assert_eq!(session.len(), 2);
//! assert_eq!(session_trial_name(&protocols[1]), "knee90_30");
//! let manifest = session_manifest("S01", &protocols);
//! assert_eq!(manifest["trials"][1]["trial"], "knee90_30.csv");
//! # Ok::<(), experiment::ExperimentError>(())
//! ```

use std::path::{Path, PathBuf};

use muscle_model::{Effects, ModelParams};
use serde_json::{json, Value};

use crate::error::{ErrorKind, ExperimentError, Result};
use crate::files::{write_trial, write_unloaded};
use crate::model_inputs::{envelope_peaks, EmgReferences, InputOptions};
use crate::protocol::{Protocol, SynthProtocol};
use crate::synth::{
    sorted_json, synthesize_referenced, synthetic_recording, SynthConfig, Synthetic,
};

/// The name of a session trial: `knee<K>_<speed>`, with `x<N>` for `N` cycles and the motion
/// in front for a relaxed protocol (`relaxed2_knee0_30`).
#[must_use]
pub fn session_trial_name(p: &SynthProtocol) -> String {
    let num = |x: f64| {
        let s = format!("{x}");
        s.replace('.', "p")
    };
    let base = format!("knee{}_{}", num(p.knee_angle_deg), num(p.speed_deg_s));
    match p.protocol {
        Protocol::Seed => base,
        Protocol::Cycles { cycles } => format!("{base}x{cycles}"),
        Protocol::Relaxed { cycles } => format!("relaxed{cycles}_{base}"),
    }
}

/// The configuration of the `i`-th trial of a session: protocol `p`, seed `seed + i`, the
/// session's true parameters and effects.
#[must_use]
pub fn session_trial_config(
    p: &SynthProtocol,
    i: usize,
    seed: u64,
    params: &ModelParams,
    effects: &Effects,
) -> SynthConfig {
    SynthConfig::for_protocol(*p, seed.wrapping_add(i as u64))
        .with_params(*params)
        .with_effects(*effects)
}

/// Synthesises every trial of a session (see the module documentation).
///
/// # Errors
/// No protocol, two trials with the same name, or any error of [`crate::synthesize`].
pub fn synthesize_session(
    protocols: &[SynthProtocol],
    seed: u64,
    params: &ModelParams,
    effects: &Effects,
) -> Result<Vec<Synthetic>> {
    check_names(protocols)?;
    let configs: Vec<SynthConfig> = protocols
        .iter()
        .enumerate()
        .map(|(i, p)| session_trial_config(p, i, seed, params, effects))
        .collect();
    synthesize_session_configs(&configs)
}

/// Synthesises trials of one session from their own configurations (any seeds, truths or
/// effects per trial), the EMG of every trial normalised by each channel's largest envelope
/// over all of them, as [`synthesize_session`] does.
///
/// # Errors
/// No configuration, or any error of [`synthesize_referenced`].
pub fn synthesize_session_configs(configs: &[SynthConfig]) -> Result<Vec<Synthetic>> {
    if configs.is_empty() {
        return Err(ExperimentError::invalid(
            "session",
            ErrorKind::InvalidProtocol,
            "a session needs at least one trial",
        ));
    }
    let mut peaks = Vec::with_capacity(configs.len());
    for cfg in configs {
        let (_, trial) = synthetic_recording(cfg)?;
        peaks.push(envelope_peaks(&trial, &InputOptions::default(), "<trial>")?);
    }
    let refs = EmgReferences::largest(&peaks);
    configs
        .iter()
        .map(|cfg| synthesize_referenced(cfg, &refs))
        .collect()
}

fn check_names(protocols: &[SynthProtocol]) -> Result<()> {
    let bad =
        |reason: String| ExperimentError::invalid("session", ErrorKind::InvalidProtocol, reason);
    if protocols.is_empty() {
        return Err(bad("a session needs at least one trial".into()));
    }
    let names: Vec<String> = protocols.iter().map(session_trial_name).collect();
    for (i, n) in names.iter().enumerate() {
        if names[..i].contains(n) {
            return Err(bad(format!(
                "two trials would both be named '{n}': give each protocol once"
            )));
        }
    }
    Ok(())
}

/// The session manifest of `protocols` (file names of [`write_session`]), keys sorted.
#[must_use]
pub fn session_manifest(subject: &str, protocols: &[SynthProtocol]) -> Value {
    let trials: Vec<Value> = protocols
        .iter()
        .map(|p| {
            let name = session_trial_name(p);
            json!({
                "name": name,
                "trial": format!("{name}.csv"),
                "unloaded": format!("{name}_unloaded.csv"),
            })
        })
        .collect();
    sorted_json(&json!({"subject": subject, "trials": trials}))
}

/// Writes a synthesised session into `dir` (created if needed): each trial's CSV and unloaded
/// run and `session.json`. Returns the manifest's path.
///
/// # Errors
/// Mismatched lengths, duplicate names, or a file that cannot be written.
pub fn write_session(
    dir: &Path,
    subject: &str,
    protocols: &[SynthProtocol],
    session: &[Synthetic],
) -> Result<PathBuf> {
    check_names(protocols)?;
    if protocols.len() != session.len() {
        return Err(ExperimentError::invalid(
            "session",
            ErrorKind::InvalidSettings,
            format!(
                "{} protocols for {} synthesised trials",
                protocols.len(),
                session.len()
            ),
        ));
    }
    let io = |p: &Path, e: std::io::Error| ExperimentError::File {
        path: p.display().to_string(),
        kind: ErrorKind::Io,
        reason: e.to_string(),
    };
    std::fs::create_dir_all(dir).map_err(|e| io(dir, e))?;
    for (p, s) in protocols.iter().zip(session) {
        let name = session_trial_name(p);
        write_trial(dir.join(format!("{name}.csv")), &s.trial)?;
        write_unloaded(dir.join(format!("{name}_unloaded.csv")), &s.unloaded)?;
    }
    let path = dir.join("session.json");
    let mut text =
        serde_json::to_string_pretty(&session_manifest(subject, protocols)).map_err(|e| {
            ExperimentError::invalid("session", ErrorKind::InvalidSettings, e.to_string())
        })?;
    text.push('\n');
    std::fs::write(&path, text).map_err(|e| io(&path, e))?;
    Ok(path)
}
