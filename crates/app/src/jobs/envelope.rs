//! `surae envelope`: normalised EMG envelopes of a trial (filter chain in docs/model.md).

use super::{load_trial, out_file};
use crate::error::{AppError, AppResult};
use crate::output::write_file_checked;
use crate::Reporter;
use experiment::EmgMuscle;
use muscle_model::Muscle;
use std::path::PathBuf;

/// Arguments of `surae envelope`.
#[derive(Debug)]
pub struct EnvelopeJob {
    /// Trial: a trial CSV, a recording map (`.json`) of a lab's files (docs/formats.md);
    /// the bundled seed trial when omitted.
    pub trial: Option<PathBuf>,
    /// Output: a `.csv` file, or a folder to write `envelope.csv` into
    /// (default `out/envelope/envelope.csv`).
    pub out: Option<PathBuf>,
    /// Normalise a channel by an MVC reference instead of the trial maximum,
    /// e.g. `--mvc emg_sol=0.41` (in the raw EMG's unit, after band-pass,
    /// rectification and low-pass). Repeat for several channels.
    pub mvc: Vec<String>,
}

fn parse_mvc(items: &[String]) -> AppResult<Vec<(String, f64)>> {
    items
        .iter()
        .map(|s| {
            let (k, v) = s
                .split_once('=')
                .ok_or_else(|| AppError::bad(format!("--mvc {s}: expected COLUMN=VALUE")))?;
            let k = k.trim();
            let k = if k.starts_with("emg_") {
                k.to_string()
            } else {
                format!("emg_{k}")
            };
            if !["emg_sol", "emg_gm", "emg_gl", "emg_ta"].contains(&k.as_str()) {
                return Err(AppError::bad(format!(
                    "--mvc {s}: unknown channel '{k}' (emg_sol, emg_gm, emg_gl, emg_ta)"
                )));
            }
            let v: f64 = v
                .trim()
                .parse()
                .map_err(|_| AppError::bad(format!("--mvc {s}: '{v}' is not a number")))?;
            if !(v.is_finite() && v > 0.0) {
                return Err(AppError::bad(format!(
                    "--mvc {s}: the MVC value must be positive"
                )));
            }
            Ok((k, v))
        })
        .collect()
}

/// Runs the command.
pub fn run(args: EnvelopeJob, rep: &Reporter) -> AppResult {
    let mvc = parse_mvc(&args.mvc)?;
    let loaded = load_trial(args.trial.as_deref(), None, rep)?;
    let trial = &loaded.trial;
    let fs = trial.sample_rate_hz();
    let mut opts = experiment::InputOptions::default();
    for (k, v) in &mvc {
        let m = match k.as_str() {
            "emg_sol" => EmgMuscle::Sol,
            "emg_gm" => EmgMuscle::Gm,
            "emg_gl" => EmgMuscle::Gl,
            _ => EmgMuscle::Ta,
        };
        if m == EmgMuscle::Ta && trial.emg_ta.is_none() {
            return Err(AppError::bad(format!(
                "--mvc: {} has no column {k}",
                loaded.name
            )));
        }
        opts = opts.with_mvc(m, *v);
    }
    let inputs =
        experiment::model_inputs_named(trial, &opts, &loaded.name).map_err(AppError::bad)?;
    let mut envs: Vec<(&str, &[f64])> = vec![
        ("emg_sol", inputs.envelope(Muscle::Sol)),
        ("emg_gm", inputs.envelope(Muscle::Gm)),
        ("emg_gl", inputs.envelope(Muscle::Gl)),
    ];
    if let Some(ta) = inputs.envelope_ta() {
        envs.push(("emg_ta", ta));
    }

    let mut text = String::with_capacity(trial.len() * 16 * (1 + envs.len()));
    text.push_str("time_s");
    for (name, _) in &envs {
        text.push(',');
        text.push_str(name);
    }
    text.push('\n');
    for i in 0..trial.len() {
        experiment::write_f64(&mut text, trial.time_s[i]);
        for (_, e) in &envs {
            text.push(',');
            experiment::write_f64(&mut text, e[i]);
        }
        text.push('\n');
    }
    let target = out_file(args.out.as_deref(), "envelope", "envelope.csv");
    let inputs: Vec<PathBuf> = loaded
        .path
        .iter()
        .map(|p| std::fs::canonicalize(p).unwrap_or_else(|_| p.clone()))
        .collect();
    write_file_checked(&target, text.as_bytes(), &inputs)?;

    rep.say(&format!(
        "envelope: {} ({} samples at {:.1} Hz, {:.2} s)",
        loaded.name,
        trial.len(),
        fs,
        trial.time_s[trial.len() - 1] - trial.time_s[0]
    ));
    for (name, e) in &envs {
        let mean = e.iter().sum::<f64>() / e.len() as f64;
        let (imax, _) =
            e.iter().enumerate().fold(
                (0, f64::MIN),
                |acc, (i, &v)| if v > acc.1 { (i, v) } else { acc },
            );
        rep.say(&format!(
            "  {name:<8} mean {mean:.3}, peak at {:.3} s",
            trial.time_s[imax]
        ));
    }
    rep.say(&format!("wrote {}", target.display()));
    Ok(())
}
