//! Writes a synthetic trial and its unloaded run as CSV files (docs/formats.md), for any
//! protocol, or a synthetic session of several trials with its manifest.
//!
//! `cargo run --release -p experiment --example synth_trial -- PROTOCOL SEED EFFECTS_JSON OUT_DIR`
//!
//! e.g. `-- relaxed+8 77 '{"electromechanical_delay": {"delay_ms": 40}}' /tmp/r8` writes
//! `/tmp/r8/trial.csv` and `/tmp/r8/unloaded.csv`: nominal muscle parameters, the given
//! effects (`{}` for none), nominal dynamometer error and synthetic EMG, all from `SEED`.
//! Then `surae diagnose --trial /tmp/r8/trial.csv --unloaded /tmp/r8/unloaded.csv`.
//!
//! `PROTOCOL` may hold the knee flexed and set the speed: `knee90` (the seed motion at 90° of
//! knee flexion), `knee0@60` (at 60 °/s), `relaxed+2@knee60`; a flexed knee gives the trial a
//! `knee_angle_deg` column and lowers the gastrocnemii's EMG drive (docs/formats.md,
//! "Synthetic trials").
//!
//! A comma-separated list of protocols writes a session: `-- knee0@30,knee90@30,knee0@60 5 '{}'
//! /tmp/s3` writes `knee0_30.csv`, `knee0_30_unloaded.csv`, … (seeds 5, 6, 7) and
//! `/tmp/s3/session.json`; then `surae identify --session /tmp/s3/session.json`.

use experiment::synth_session::{synthesize_session, write_session};
use experiment::{synthesize, SynthConfig, SynthProtocol};
use muscle_model::{Effects, ModelParams};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let [protocol, seed, effects, out] = args.as_slice() else {
        return Err("usage: synth_trial PROTOCOL[,PROTOCOL…] SEED EFFECTS_JSON OUT_DIR".into());
    };
    let effects = Effects::from_json_str(effects)?;
    let seed: u64 = seed.parse()?;
    let out = std::path::Path::new(out);
    if protocol.contains(',') {
        let protocols: Vec<SynthProtocol> = protocol
            .split(',')
            .map(str::parse)
            .collect::<Result<_, _>>()?;
        let session = synthesize_session(&protocols, seed, &ModelParams::nominal(), &effects)?;
        let manifest = write_session(out, "synthetic", &protocols, &session)?;
        println!("wrote {} trials and {}", session.len(), manifest.display());
        return Ok(());
    }
    let protocol: SynthProtocol = protocol.parse()?;
    let cfg = SynthConfig::for_protocol(protocol, seed)
        .with_params(ModelParams::nominal())
        .with_effects(effects);
    let s = synthesize(&cfg)?;
    std::fs::create_dir_all(out)?;
    experiment::write_trial(out.join("trial.csv"), &s.trial)?;
    experiment::write_unloaded(out.join("unloaded.csv"), &s.unloaded)?;
    println!(
        "wrote {} and {} ({} samples, {:.1} s)",
        out.join("trial.csv").display(),
        out.join("unloaded.csv").display(),
        s.trial.time_s.len(),
        s.trial.time_s.last().copied().unwrap_or(0.0)
    );
    Ok(())
}
