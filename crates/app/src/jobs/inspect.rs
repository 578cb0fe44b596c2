//! `surae inspect`: what a lab's file holds and a starter recording map for it; given a map,
//! the trial it reads and the checks a lab runs before trusting a file (docs/formats.md,
//! "A lab's recordings").

use crate::Reporter;
use std::path::{Path, PathBuf};

use super::{load_mapped_trial, trial_inputs, ModelSettings};
use crate::error::{AppError, AppResult};
use crate::output::OutDir;

/// Arguments of `surae inspect`.
#[derive(Debug)]
pub struct InspectJob {
    /// The file(s) of one recording: a delimited text export (comma, semicolon or tab), OpenSim
    /// `.sto`/`.mot` files (several: one recording split over them), a `.c3d`, a CEINMS trial
    /// folder, or a recording map (`.json`) to read and check.
    pub files: Vec<PathBuf>,
    /// Output folder (default `out/inspect`): `map.json`, the starter map, with paths relative
    /// to this folder, and `inspect.json`.
    pub out: Option<PathBuf>,
}

const PLANNED: &[&str] = &["map.json", "inspect.json"];

/// The checks of a trial, with the nominal model's torque as the EMG-driven prediction (the
/// sign check); `None` for the prediction when the model cannot run on it.
pub fn trial_checks(
    loaded: &super::LoadedTrial,
    emg_is_envelope: bool,
) -> recording::checks::TrialChecks {
    let model = ModelSettings {
        emg_is_envelope,
        ..ModelSettings::default()
    };
    let prediction = trial_inputs(loaded, &model)
        .ok()
        .and_then(|inputs| {
            muscle_model::simulate(
                &inputs,
                &muscle_model::ModelParams::nominal(),
                &muscle_model::Effects::none(),
                &muscle_model::SimSettings::default(),
            )
            .ok()
        })
        .map(|s| s.torque);
    // the kind (dynamometer or gait) is inferred from the trial: a ground force, or sweeps
    // that do not span the range, make it gait
    recording::checks::check_trial_in_context(
        &loaded.trial,
        prediction.as_deref(),
        &recording::checks::TrialContext {
            kind: None,
            emg_is_envelope,
        },
        &recording::checks::CheckSettings::default(),
    )
}

/// The summary lines of the checks in `identify` and `diagnose`: one line when the recording
/// passes them all, else a line per warning.
pub fn check_lines(checks: &recording::checks::TrialChecks) -> Vec<String> {
    if checks.warnings.is_empty() {
        return vec![format!(
            "recording checks: clean ({})",
            checks.applied_text()
        )];
    }
    let mut out = vec![format!(
        "recording checks: {} warning(s) (details under \"checks\" in the JSON):",
        checks.warnings.len()
    )];
    out.extend(checks.warnings.iter().map(|w| format!("  warning: {w}")));
    out
}

/// Runs the command.
pub fn run(args: InspectJob, rep: &Reporter) -> AppResult {
    let out_dir = args
        .out
        .clone()
        .unwrap_or_else(|| crate::default_out("inspect"));
    let is_map =
        args.files.len() == 1 && recording::file_kind(&args.files[0]) == recording::FileKind::Map;
    if !is_map {
        if let Some(m) = args
            .files
            .iter()
            .find(|p| recording::file_kind(p) == recording::FileKind::Map)
        {
            return Err(AppError::bad(format!(
                "{}: a map is inspected alone (surae inspect {})",
                m.display(),
                m.display()
            )));
        }
    }
    let inputs: Vec<&Path> = args.files.iter().map(PathBuf::as_path).collect();
    if is_map {
        return run_map(&args, &out_dir, &inputs, rep);
    }
    // read everything before the output folder is made: a bad file leaves nothing behind
    let found = recording::inspect::inspect(&args.files, &out_dir).map_err(AppError::bad)?;
    let out = OutDir::prepare(&out_dir, &inputs, PLANNED)?;
    let say = |l: &str| rep.say(l);
    for f in &found.files {
        for l in f.lines() {
            say(&l);
        }
    }
    let mut written = Vec::new();
    if let Some(map) = &found.map {
        let text = map.to_json_text();
        let p = out.write("map.json", text.as_bytes())?;
        say("");
        say(&format!(
            "starter recording map ({}; paths relative to its folder):",
            p.display()
        ));
        for l in text.lines() {
            say(&format!("  {l}"));
        }
        written.push(p);
    }
    for n in &found.notes {
        say(&format!("note: {n}"));
    }
    let text = serde_json::to_string_pretty(&found).map_err(AppError::internal)? + "\n";
    written.push(out.write("inspect.json", text.as_bytes())?);
    rep.print_json(&text);
    for p in written {
        say(&format!("wrote {}", p.display()));
    }
    Ok(())
}

/// A map: its files summarised, the trial it reads, and the checks.
fn run_map(args: &InspectJob, out_dir: &Path, inputs: &[&Path], rep: &Reporter) -> AppResult {
    let map_path = &args.files[0];
    let loaded = load_mapped_trial(map_path, rep)?;
    let map = recording::read_map(map_path).map_err(AppError::bad)?;
    // the files as the map reads them (its header line and decimal mark)
    let opts = recording::DelimitedOptions {
        header_line: map.header_line,
        decimal_comma: map.decimal_comma,
    };
    let mut files = Vec::new();
    for f in &loaded.data_files {
        let t = recording::open_table(f, &opts).map_err(AppError::bad)?;
        files.push(recording::inspect::FileSummary::of(&t));
    }
    let mut all_inputs: Vec<&Path> = inputs.to_vec();
    all_inputs.extend(loaded.data_files.iter().map(PathBuf::as_path));
    let out = OutDir::prepare(out_dir, &all_inputs, &PLANNED[1..])?;
    let say = |l: &str| rep.say(l);
    for s in &files {
        for l in s.lines() {
            say(&l);
        }
    }
    let t = &loaded.trial;
    say(&format!(
        "{}: a trial of {} samples at {:.3} Hz ({:.3}–{:.3} s), EMG {}",
        map_path.display(),
        t.len(),
        t.sample_rate_hz(),
        t.time_s[0],
        t.time_s[t.len() - 1],
        t.emg_channels()
            .iter()
            .map(|(n, _)| n.as_str())
            .collect::<Vec<_>>()
            .join(", ")
    ));
    let checks = trial_checks(&loaded, loaded.emg_is_envelope);
    for l in checks.summary_lines() {
        say(&format!("  {l}"));
    }
    let report = MapInspectionReport {
        map: map_path.display().to_string(),
        files,
        trial: TrialSpanReport {
            samples: t.len(),
            sample_rate_hz: t.sample_rate_hz(),
            start_s: t.time_s[0],
            end_s: t.time_s[t.len() - 1],
        },
        checks,
    };
    let text = serde_json::to_string_pretty(&report).map_err(AppError::internal)? + "\n";
    let p = out.write("inspect.json", text.as_bytes())?;
    rep.print_json(&text);
    say(&format!("wrote {}", p.display()));
    Ok(())
}

/// `inspect.json` of a recording map: its files, the trial it reads and the checks.
#[derive(Debug, Clone, serde::Serialize)]
#[non_exhaustive]
pub struct MapInspectionReport {
    /// The map's path.
    pub map: String,
    /// A summary of each data file the map reads.
    pub files: Vec<recording::inspect::FileSummary>,
    /// The trial the map reads.
    pub trial: TrialSpanReport,
    /// The recording's checks.
    pub checks: recording::checks::TrialChecks,
}

/// How many samples a trial has, at what rate, over which times.
#[derive(Debug, Clone, Copy, serde::Serialize)]
#[non_exhaustive]
pub struct TrialSpanReport {
    /// Samples.
    pub samples: usize,
    /// Sampling rate (Hz).
    pub sample_rate_hz: f64,
    /// First sample's time (s).
    pub start_s: f64,
    /// Last sample's time (s).
    pub end_s: f64,
}
