//! `surae`: identify triceps-surae muscle parameters from an isokinetic
//! dynamometer trial with surface EMG, and find what the model gets wrong.
//!
//! Every command runs on the bundled seed trial when `--trial` is not given,
//! writes into `--out` (default `out/<command>`), prints a short human
//! summary, and exits 0 on success, 2 on bad input (one line naming the file,
//! line and column), 1 on an internal failure.

mod args;
mod terminal;

use clap::{Parser, Subcommand};
use std::sync::Arc;
use surae_app::{AppResult, Reporter};
use terminal::Terminal;

/// Identify the calf's muscle parameters (soleus, gastrocnemius medialis and lateralis) from
/// EMG and a measured ankle moment, and find what the model still gets wrong.
#[derive(Parser, Debug)]
#[command(name = "surae", version, long_about = None)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand, Debug)]
enum Command {
    /// Normalised EMG envelopes (band-pass 10–350 Hz, rectify, 2 Hz low-pass, ÷ max).
    Envelope(args::EnvelopeArgs),
    /// Model torque for a trial (total and per muscle), optionally with effects.
    Simulate(args::SimulateArgs),
    /// One-at-a-time ±20 % parameter sweeps: RMS torque change (dissertation Fig. 6).
    Sensitivity(args::SensitivityArgs),
    /// Identify LST, F0 and α0 of sol, gm, gl, and with --with the parameters of named
    /// effects; then test the fit for structure left in its residual (writes identify.json).
    Identify(args::IdentifyArgs),
    /// What the model gets wrong: residual analysis, the named cause(s), the
    /// extended model and its held-out gain (writes diagnosis.json).
    Diagnose(args::DiagnoseArgs),
    /// Expected posterior sd of each parameter for candidate protocols, before testing.
    Design(args::DesignArgs),
    /// What a lab's file holds (channels, rate, duration, ranges) and a starter recording map;
    /// given a map, the trial it reads and the checks of the recording.
    Inspect(args::InspectArgs),
    /// Held-out prediction of a calibrated model: leave one trial out, the later strides, leave
    /// one condition out; beside the linear EMG baseline and peer parameters (writes
    /// validate.json).
    Validate(args::ValidateArgs),
}

fn main() {
    let cli = match Cli::try_parse() {
        Ok(c) => c,
        Err(e) => {
            // --help and --version are not failures
            if !e.use_stderr() {
                let _ = e.print();
                std::process::exit(0);
            }
            // a usage error: one line (everything before clap's usage
            // block, folded), exit code 2
            let text = e.render().to_string();
            let reason: Vec<&str> = text
                .lines()
                .take_while(|l| !l.starts_with("Usage:"))
                .map(|l| l.trim())
                .filter(|l| !l.is_empty() && !l.starts_with("tip:"))
                .collect();
            let reason = reason.join(" ");
            let reason = reason.trim_start_matches("error: ");
            eprintln!("error: {reason} (see 'surae --help')");
            std::process::exit(2);
        }
    };
    let (terminal, result) = run(cli.command);
    match result {
        Ok(()) => {
            for w in terminal.take_warnings() {
                eprintln!("warning: {w}");
            }
        }
        Err(f) => {
            // a failure is reported on one line; warnings would only add noise
            eprintln!("{f}");
            std::process::exit(f.exit_code());
        }
    }
}

/// Runs one command: its options as the library's settings, reported to the terminal.
fn run(command: Command) -> (Arc<Terminal>, AppResult) {
    let report = match &command {
        Command::Identify(a) => a.report,
        Command::Diagnose(a) => a.report,
        Command::Design(a) => a.report,
        Command::Inspect(a) => a.report,
        Command::Validate(a) => a.report,
        // these print no progress and a summary only when they write
        Command::Envelope(_) | Command::Simulate(_) | Command::Sensitivity(_) => {
            args::ReportArgs::default()
        }
    };
    let terminal = Arc::new(Terminal::new(report));
    let rep = Reporter::new(terminal.clone(), report.quiet);
    let result = match command {
        Command::Envelope(a) => surae_app::envelope(a.into(), &rep),
        Command::Simulate(a) => surae_app::simulate(a.into(), &rep),
        Command::Sensitivity(a) => surae_app::sensitivity(a.into(), &rep),
        Command::Identify(a) => surae_app::identify(a.into(), &rep),
        Command::Diagnose(a) => surae_app::diagnose(a.into(), &rep),
        Command::Design(a) => surae_app::design(a.into(), &rep),
        Command::Inspect(a) => surae_app::inspect(a.into(), &rep),
        Command::Validate(a) => surae_app::validate(a.into(), &rep),
    };
    (terminal, result)
}
