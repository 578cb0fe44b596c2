//! `surae`: identify triceps-surae muscle parameters from an isokinetic
//! dynamometer trial with surface EMG, and find what the model gets wrong.
//!
//! Every command runs on the bundled seed trial when `--trial` is not given,
//! writes into `--out` (default `out/<command>`), prints a short human
//! summary, and exits 0 on success, 2 on bad input (one line naming the file,
//! line and column), 1 on an internal failure.

use clap::{Parser, Subcommand};
use cli::commands;

/// Triceps-surae muscle parameters from an isokinetic dynamometer test with EMG.
#[derive(Parser, Debug)]
#[command(name = "surae", version, about, long_about = None)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand, Debug)]
enum Command {
    /// Normalised EMG envelopes (band-pass 10–350 Hz, rectify, 2 Hz low-pass, ÷ max).
    Envelope(commands::envelope::EnvelopeArgs),
    /// Model torque for a trial (total and per muscle), optionally with effects.
    Simulate(commands::simulate::SimulateArgs),
    /// One-at-a-time ±20 % parameter sweeps: RMS torque change (dissertation Fig. 6).
    Sensitivity(commands::sensitivity::SensitivityArgs),
    /// Identify LST, F0 and α0 of sol, gm, gl, and with --with the parameters of named
    /// effects; then test the fit for structure left in its residual (writes identify.json).
    Identify(commands::identify::IdentifyArgs),
    /// What the model gets wrong: residual analysis, the named cause(s), the
    /// extended model and its held-out gain (writes diagnosis.json).
    Diagnose(commands::diagnose::DiagnoseArgs),
    /// Expected posterior sd of each parameter for candidate protocols, before testing.
    Design(commands::design::DesignArgs),
    /// What a lab's file holds (channels, rate, duration, ranges) and a starter recording map;
    /// given a map, the trial it reads and the checks of the recording.
    Inspect(commands::inspect::InspectArgs),
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
    let result = match cli.command {
        Command::Envelope(a) => commands::envelope::run(a),
        Command::Simulate(a) => commands::simulate::run(a),
        Command::Sensitivity(a) => commands::sensitivity::run(a),
        Command::Identify(a) => commands::identify::run(a),
        Command::Diagnose(a) => commands::diagnose::run(a),
        Command::Design(a) => commands::design::run(a),
        Command::Inspect(a) => commands::inspect::run(a),
    };
    match result {
        Ok(()) => {
            for w in cli::take_warnings() {
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
