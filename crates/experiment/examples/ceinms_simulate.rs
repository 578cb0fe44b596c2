//! CEINMS's subject parameters in surae's model, on CEINMS trial folders.
//!
//! `cargo run --release -p experiment --example ceinms_simulate -- DIR [JOINT]`, where `DIR`
//! holds CEINMS trial folders and the subject files `uncalibratedSubject.xml` and
//! `subjectCalibrated.xml` (CEINMS's `TestData/unix`). For each subject file and trial it
//! simulates the model (sol, gm, gl and every other muscle of the trial's moment-arm file as
//! a fixed muscle, all with the trial's own lengths and moment arms) and prints the ankle
//! moment's RMS error (N·m) and R² at the torque file's own samples.

use experiment::{
    ceinms_model_params, ceinms_trial_dirs, moment_fit, read_ceinms_trial, ExperimentError,
};
use muscle_model::{simulate, Effects, SimSettings};
use std::path::{Path, PathBuf};

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let Some(dir) = args.first().map(PathBuf::from) else {
        eprintln!(
            "usage: ceinms_simulate DIR [JOINT]  (DIR holds CEINMS trial folders and subject XML)"
        );
        std::process::exit(2);
    };
    let joint = args.get(1).map_or("R_ankle_fe", String::as_str);
    if let Err(e) = run(&dir, joint) {
        eprintln!("error: {e}");
        std::process::exit(2);
    }
}

fn run(dir: &Path, joint: &str) -> Result<(), ExperimentError> {
    let trials = ceinms_trial_dirs(dir)?
        .iter()
        .map(|d| read_ceinms_trial(d, joint))
        .collect::<Result<Vec<_>, _>>()?;
    for file in ["uncalibratedSubject.xml", "subjectCalibrated.xml"] {
        let subject = ceinms_files::read_subject(&dir.join(file))?;
        println!(
            "{file} (electromechanical delay {} s, not applied)",
            subject.global_em_delay_s()
        );
        let (mut rms_sum, mut r2_sum) = (0.0, 0.0);
        for t in &trials {
            let p = ceinms_model_params(&subject, &t.muscles)?;
            let out = simulate(
                &t.inputs,
                &p.params,
                &Effects::none(),
                &SimSettings::default(),
            )
            .map_err(|e| ExperimentError::Invalid {
                what: t.name.clone(),
                kind: experiment::ErrorKind::InvalidSettings,
                reason: format!("the simulation failed: {e}"),
            })?;
            let pred = t.at_torque_samples(&out.torque)?;
            let (rms, r2) = moment_fit(&t.torque_at_samples, &pred);
            rms_sum += rms;
            r2_sum += r2;
            println!("  {:<16} RMS {rms:7.2} N·m  R² {r2:7.3}", t.name);
        }
        let n = trials.len() as f64;
        println!(
            "  {:<16} RMS {:7.2} N·m  R² {:7.3}",
            "mean",
            rms_sum / n,
            r2_sum / n
        );
    }
    Ok(())
}
