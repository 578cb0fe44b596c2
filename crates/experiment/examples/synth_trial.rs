//! Writes a synthetic trial and its unloaded run as CSV files (docs/formats.md), for any protocol.
//!
//! `cargo run --release -p experiment --example synth_trial -- PROTOCOL SEED EFFECTS_JSON OUT_DIR`
//!
//! e.g. `-- relaxed+8 77 '{"electromechanical_delay": {"delay_ms": 40}}' /tmp/r8` writes
//! `/tmp/r8/trial.csv` and `/tmp/r8/unloaded.csv`: nominal muscle parameters, the given
//! effects (`{}` for none), nominal dynamometer error and synthetic EMG, all from `SEED`.
//! Then `surae diagnose --trial /tmp/r8/trial.csv --unloaded /tmp/r8/unloaded.csv`.
//!
//! `PROTOCOL` may hold the knee flexed: `knee90` (the seed motion at 90° of knee flexion) or
//! `relaxed+2@knee60`; the trial then has a `knee_angle_deg` column and the gastrocnemii's EMG
//! drive is lowered (docs/formats.md, "Synthetic trials").

use experiment::{synthesize, SynthConfig, SynthProtocol};
use muscle_model::{Effects, ModelParams};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let [protocol, seed, effects, out] = args.as_slice() else {
        return Err("usage: synth_trial PROTOCOL SEED EFFECTS_JSON OUT_DIR".into());
    };
    let protocol: SynthProtocol = protocol.parse()?;
    let effects = Effects::from_json_str(effects)?;
    let cfg = SynthConfig::for_protocol(protocol, seed.parse()?)
        .with_params(ModelParams::nominal())
        .with_effects(effects);
    let s = synthesize(&cfg)?;
    let out = std::path::Path::new(out);
    std::fs::create_dir_all(out)?;
    experiment::files::write_trial(out.join("trial.csv"), &s.trial)?;
    experiment::files::write_unloaded(out.join("unloaded.csv"), &s.unloaded)?;
    println!(
        "wrote {} and {} ({} samples, {:.1} s)",
        out.join("trial.csv").display(),
        out.join("unloaded.csv").display(),
        s.trial.time_s.len(),
        s.trial.time_s.last().copied().unwrap_or(0.0)
    );
    Ok(())
}
