//! `surae diagnose`: what the baseline model gets wrong, which catalogued
//! effect explains it, and what the extension buys out of sample; with `--session`, the
//! session's trials jointly and every trial on its own (`session_run`).

use super::{load_trial_pair, prepare_trial, ModelSettings};
use crate::error::{AppError, AppResult};
use crate::memory::InMemory;
use crate::output::OutDir;
use crate::Reporter;
use diagnose::{DiagnoseSettings, Diagnosis};
use muscle_model::{Effects, ModelParams};
use std::path::{Path, PathBuf};

mod pages;
mod session_run;
mod window;

use pages::write_figures;

pub use session_run::{
    FitFigures, MomentFitReport, SessionDiagnosisReport, SessionTrialDiagnosisRow,
};

/// Files `surae diagnose` writes. A figure not drawn on this run (the residual against the
/// angle without a joint angle, the flexible terms without unexplained structure) is removed
/// from the folder, so that none from an earlier run is left beside this run's report.
const PLANNED: &[&str] = &[
    "diagnosis.json",
    "torque_fit.svg",
    "residual_vs_angle.svg",
    "residual_vs_time.svg",
    "fit_comparison.svg",
    "candidates.svg",
    "flexible_terms.svg",
    "report.html",
];

/// Arguments of `surae diagnose`.
#[derive(Debug)]
pub struct DiagnoseJob {
    /// Trial: a trial CSV, a recording map (`.json`) of a lab's files, or a CEINMS trial folder (a session of one) (docs/formats.md);
    /// the bundled seed trial (and its unloaded run) when omitted.
    pub trial: Option<PathBuf>,
    /// Unloaded run CSV: its cycle-locked error is removed from the measured
    /// torque and its noise sets the likelihood. Strongly recommended.
    pub unloaded: Option<PathBuf>,
    /// Session manifest (docs/formats.md): the trials diagnosed jointly (shared muscle
    /// parameters and subject effects, per-trial offset and gravity, held-out gain by leaving
    /// one trial out) into `DIR/diagnosis_session.json`, and every trial on its own with the
    /// session's parameters into `--out DIR/<trial>/`.
    pub session: Option<PathBuf>,
    /// With `--session`: parameters replacing the session's (parameters JSON, `.osim`, CEINMS
    /// subject XML), or an `identify.json` whose identified values are set over them.
    pub params: Option<PathBuf>,
    /// The EMG columns are already normalised envelopes in [0, 1].
    pub emg_is_envelope: bool,
    pub knee: super::KneeSettings,
    /// Output folder (default `out/diagnose`).
    pub out: Option<PathBuf>,
    /// The trial given in memory, in place of `trial`.
    pub trial_data: Option<InMemory<experiment::Trial>>,
    /// The unloaded run given in memory, in place of `unloaded`.
    pub unloaded_data: Option<InMemory<experiment::Unloaded>>,
    /// With `session`: parameters given in memory, in place of `params`.
    pub params_data: Option<InMemory<serde_json::Value>>,
    /// Write no files: the result reaches the caller as [`crate::JobObserver::result_json`].
    pub discard_files: bool,
}

/// Runs the command.
pub fn run(args: DiagnoseJob, rep: &Reporter) -> AppResult {
    if let Some(session) = &args.session {
        if args.knee.knee_angle_deg.is_some() {
            return Err(AppError::bad(
                "--knee-angle-deg: with --session, each trial's knee angle is in the manifest",
            ));
        }
        return session_run::run(&args, session, rep);
    }
    if let Some(folder) = args.trial.as_deref().filter(|p| p.is_dir()) {
        if args.unloaded.is_some() || args.knee.knee_angle_deg.is_some() {
            return Err(AppError::bad(format!(
                "{}: a CEINMS trial folder has no unloaded run or knee angle (its lengths and \
                 moment arms hold the knee's); --unloaded and --knee-angle-deg do not apply",
                folder.display()
            )));
        }
        return session_run::run(&args, folder, rep);
    }
    let (loaded, unloaded) = load_trial_pair(
        (args.trial.as_deref(), args.trial_data.as_ref()),
        (args.unloaded.as_deref(), args.unloaded_data.as_ref()),
        rep,
    )?;
    let emg_is_envelope = args.emg_is_envelope || loaded.emg_is_envelope;
    let model_args = ModelSettings {
        emg_is_envelope,
        knee: args.knee,
        ..ModelSettings::default()
    };
    let settings = DiagnoseSettings {
        input_options: args.knee.input_options(emg_is_envelope),
        ..DiagnoseSettings::default()
    };
    // the trial prepared once, its errors naming the file: crosstalk decision, model inputs
    // and the unloaded run's correction
    let prepared = prepare_trial(
        &loaded,
        unloaded.as_ref().map(|(u, n)| (u, n.as_str())),
        &model_args,
        &settings.crosstalk_settings(),
    )?;
    // the figures draw the envelopes as recorded
    let inputs = prepared
        .uncorrected_inputs
        .as_ref()
        .unwrap_or(&prepared.inputs);
    let mut inputs_read: Vec<&Path> = loaded.path.iter().map(|p| p.as_path()).collect();
    inputs_read.extend(loaded.data_files.iter().map(|p| p.as_path()));
    if let Some(p) = &args.unloaded {
        inputs_read.push(p.as_path());
    }
    let out_dir = args
        .out
        .clone()
        .unwrap_or_else(|| crate::default_out("diagnose"));
    let out = OutDir::prepare_or_discard(&out_dir, &inputs_read, PLANNED, args.discard_files)?;

    let show = rep.show();
    let progress = rep.progress(0, "diag");
    let mut observer = |p: &diagnose::DiagnosisProgress| {
        progress.message(format!("{} ({} simulations)", p.message, p.evaluations));
        progress.flow()
    };
    let d = diagnose::run_trial(
        &prepared,
        &ModelParams::nominal(),
        &Effects::none(),
        &settings,
        &mut observer,
    )
    .map_err(|e| {
        if progress.stop_requested() {
            return AppError::Interrupted;
        }
        let names = match &unloaded {
            Some((_, n)) => format!("{} / {n}", loaded.name),
            None => loaded.name.clone(),
        };
        AppError::bad(format!("{names}: {e}"))
    })?;
    progress.finish();

    // the correction subtracted, in the same form `identify` reports it; its AR(1)
    // correlation time is per sample of the recording the noise was fitted on
    let fitted_on = match &unloaded {
        Some((u, _)) => u.sample_rate_hz(),
        None => loaded.trial.sample_rate_hz(),
    };
    let unloaded_name = unloaded.as_ref().map(|(_, n)| n.as_str());
    let checks = super::inspect::trial_checks(&loaded, emg_is_envelope);
    let text = diagnosis_json(
        &d,
        &loaded.name,
        unloaded_name,
        fitted_on,
        None,
        Some(&checks),
    )?;
    let path = out.write("diagnosis.json", text.as_bytes())?;
    let closing = Closing::of_trial(&d, &trial_args(&args));
    let files = write_figures(
        &out,
        &loaded.name,
        &loaded.trial.torque_nm,
        inputs,
        &d,
        0..inputs.len(),
        &closing,
        rep,
    )?;

    rep.print_json(&text);
    if show {
        let say = |s: &str| rep.say(s);
        say(&format!("diagnose: {}", loaded.name));
        if unloaded.is_none() {
            say("  (no unloaded run: the dynamometer's own error cannot be told from a torque offset)");
        }
        for l in d.summary_lines() {
            say(&l);
        }
        for l in super::inspect::check_lines(&checks) {
            say(&l);
        }
        say(&format!(
            "wrote {} and {} figure/report files in {}",
            path.display(),
            files.len(),
            out_dir.display()
        ));
        say(&closing.terminal_line());
    }
    Ok(())
}

/// The end of a diagnosis report and of its terminal summary: the command line that identifies
/// the muscle parameters with the causes named.
pub(super) struct Closing {
    /// The command (`surae identify --method mcmc … [--with …]`).
    command: String,
    /// Causes it identifies with (empty: the baseline model).
    with: Vec<String>,
    /// A note under the command (e.g. per-trial causes a session cannot identify jointly).
    note: Option<String>,
}

impl Closing {
    /// For a trial diagnosed on its own, named by `args` (as [`trial_args`] gives them).
    fn of_trial(d: &Diagnosis, args: &str) -> Self {
        let command = d
            .identify_command(args)
            .unwrap_or_else(|| identify_base(args));
        Closing {
            command,
            with: d.causes.clone(),
            note: None,
        }
    }

    /// For a session named by `args`, with the `causes` of its joint diagnosis. A per-trial
    /// cause (scope `trial`) is left out of `--with` in a session of several trials, where
    /// `identify --session` refuses it, and named in a note.
    pub(super) fn of_session(causes: &[diagnose::SessionCause], args: &str, trials: usize) -> Self {
        let (with, per_trial): (Vec<&diagnose::SessionCause>, Vec<&diagnose::SessionCause>) =
            causes
                .iter()
                .partition(|c| trials < 2 || c.scope == diagnose::EffectScope::Subject);
        let with: Vec<String> = with.iter().map(|c| c.effect.clone()).collect();
        let mut command = identify_base(args);
        if !with.is_empty() {
            command.push_str(" --with ");
            command.push_str(&with.join(","));
        }
        let note = (!per_trial.is_empty()).then(|| {
            let names: Vec<&str> = per_trial.iter().map(|c| c.effect.as_str()).collect();
            format!(
                "{} {} a property of each trial's setup: `identify --session` does not identify \
                 {} with the muscles in a session of several trials; identify a trial on its \
                 own (`--trial … --with {}`) to estimate {}.",
                names.join(" and "),
                if names.len() == 1 { "is" } else { "are" },
                if names.len() == 1 { "it" } else { "them" },
                names.join(","),
                if names.len() == 1 { "it" } else { "them" },
            )
        });
        Closing {
            command,
            with,
            note,
        }
    }

    /// The report's closing section.
    fn add_to(&self, page: &mut report::Report) {
        page.heading("Identify");
        if self.with.is_empty() {
            page.paragraph(format!(
                "No cause named: `{}` identifies the baseline model.",
                self.command
            ));
        } else {
            page.paragraph("Identify the muscle parameters with the named causes:");
            page.preformatted(self.command.clone());
        }
        if let Some(n) = &self.note {
            page.paragraph(n.clone());
        }
    }

    /// The last line of the terminal summary.
    pub(super) fn terminal_line(&self) -> String {
        if self.with.is_empty() {
            format!(
                "identify     no cause named: `{}` identifies the baseline model",
                self.command
            )
        } else {
            format!("identify     {}", self.command)
        }
    }
}

/// `surae identify --method mcmc` with the arguments `args` that name the trial(s).
fn identify_base(args: &str) -> String {
    let mut cmd = String::from("surae identify --method mcmc");
    if !args.trim().is_empty() {
        cmd.push(' ');
        cmd.push_str(args.trim());
    }
    cmd
}

/// A path as a shell word: as it is when it holds only plain characters, else single-quoted.
fn shell_word(p: &Path) -> String {
    let s = p.display().to_string();
    let plain = !s.is_empty()
        && s.chars()
            .all(|c| c.is_ascii_alphanumeric() || "_-./:=+,@%".contains(c));
    if plain {
        s
    } else {
        format!("'{}'", s.replace('\'', "'\\''"))
    }
}

/// The arguments of `surae diagnose` that name the trial and how it is read, as the user gave
/// them, for `surae identify`: `--trial`, `--unloaded`, `--session` (with `--params`),
/// `--emg-is-envelope` and `--knee-angle-deg` (nothing for the bundled trial).
pub(super) fn trial_args(args: &DiagnoseJob) -> String {
    let mut a: Vec<String> = Vec::new();
    let mut flag = |name: &str, p: Option<&PathBuf>| {
        if let Some(p) = p {
            a.push(format!("{name} {}", shell_word(p)));
        }
    };
    flag("--session", args.session.as_ref());
    flag("--trial", args.trial.as_ref());
    flag("--unloaded", args.unloaded.as_ref());
    flag("--params", args.params.as_ref());
    if args.emg_is_envelope {
        a.push("--emg-is-envelope".into());
    }
    if let Some(k) = args.knee.knee_angle_deg {
        a.push(format!("--knee-angle-deg {k}"));
    }
    a.join(" ")
}

/// `diagnosis.json`: the diagnosis with the trial's name, its unloaded run's (or `null`), the
/// dynamometer correction subtracted, for a session's trial where it was read from, and the
/// recording checks.
#[derive(Debug, Clone, serde::Serialize)]
#[non_exhaustive]
pub struct TrialDiagnosisReport<'a> {
    /// The diagnosis, its members at the top level of the JSON.
    #[serde(flatten)]
    pub diagnosis: &'a Diagnosis,
    /// The recording's checks (a session's CEINMS trial has none).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub checks: Option<&'a recording::checks::TrialChecks>,
    /// The trial's name.
    pub trial: &'a str,
    /// Where a session's trial was read from.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub source: Option<&'a str>,
    /// The unloaded run's name (`null` without one).
    pub unloaded: Option<&'a str>,
    /// The dynamometer correction the noise model implies, its AR(1) correlation time per
    /// sample of the recording.
    pub dynamometer: experiment::DynamometerReport,
}

/// [`TrialDiagnosisReport`] as written, of a recording fitted at `fitted_on_hz`.
fn diagnosis_json(
    d: &Diagnosis,
    name: &str,
    unloaded: Option<&str>,
    fitted_on_hz: f64,
    source: Option<&str>,
    checks: Option<&recording::checks::TrialChecks>,
) -> AppResult<String> {
    let report = TrialDiagnosisReport {
        diagnosis: d,
        checks,
        trial: name,
        source,
        unloaded,
        dynamometer: d.noise.dynamometer(1.0 / fitted_on_hz),
    };
    Ok(serde_json::to_string_pretty(&report).map_err(AppError::internal)? + "\n")
}

#[cfg(test)]
mod tests {
    use super::*;
    use diagnose::{EffectScope, SessionCause};

    fn cause(effect: &str, scope: EffectScope) -> SessionCause {
        SessionCause {
            effect: effect.into(),
            scope,
            values: None,
            per_trial: None,
        }
    }

    #[test]
    fn session_command_leaves_per_trial_causes_to_the_trials() {
        let causes = [
            cause("electromechanical_delay", EffectScope::Subject),
            cause("torque_offset", EffectScope::Trial),
        ];
        let c = Closing::of_session(&causes, "--session s.json", 3);
        assert_eq!(
            c.command,
            "surae identify --method mcmc --session s.json --with electromechanical_delay"
        );
        assert!(c.note.as_deref().unwrap().starts_with("torque_offset is"));
        assert_eq!(c.terminal_line(), format!("identify     {}", c.command));
        // a session of one trial identifies every cause
        let c = Closing::of_session(&causes, "--trial d", 1);
        assert!(c
            .command
            .ends_with("--trial d --with electromechanical_delay,torque_offset"));
        assert!(c.note.is_none());
        // only per-trial causes in a session of several: the baseline command and the note
        let c = Closing::of_session(&causes[1..], "--session s.json", 2);
        assert_eq!(c.command, "surae identify --method mcmc --session s.json");
        assert!(c.with.is_empty() && c.note.is_some());
        let mut page = report::Report::new("t");
        c.add_to(&mut page);
        let html = page.to_html();
        assert!(html.contains("<h2>Identify</h2>") && html.contains("identifies the baseline"));
    }

    #[test]
    fn paths_as_shell_words() {
        assert_eq!(shell_word(Path::new("data/t-1.csv")), "data/t-1.csv");
        assert_eq!(shell_word(Path::new("my trial.csv")), "'my trial.csv'");
        assert_eq!(shell_word(Path::new("it's.csv")), "'it'\\''s.csv'");
    }
}
