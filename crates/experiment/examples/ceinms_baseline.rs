//! The linear baseline on CEINMS trials, and the check of CEINMS's sign convention.
//!
//! `cargo run --release -p experiment --example ceinms_baseline -- DIR [JOINT]`, where `DIR`
//! holds CEINMS trial folders (e.g. CEINMS's `TestData/unix`) and `JOINT` defaults to
//! `R_ankle_fe`.
//!
//! Sign check, per trial, in surae's convention (plantarflexion > 0, CEINMS's signs
//! negated): the mean moment arm of each muscle over the trial, and the correlation of the
//! measured moment with `Σ_m e_m·r_m` (all muscles of the moment-arm file, and the triceps
//! surae alone). Baseline: the moment regressed on each muscle's envelope × moment arm
//! (`τ ≈ c + Σ_m F_m·e_m·r_m`, one coefficient per muscle, `F_m` a force in N) by least
//! squares over the torque file's own samples of all trials jointly; RMS (N·m) and R² per
//! trial at those samples, with and without the intercept `c`; then each trial predicted by
//! the regression fitted on the other trials (leave one out). The peronei brevis, longus and
//! tertius share one EMG channel, so their three regressors are nearly collinear and their
//! per-muscle forces come out large and of opposite signs; the last variant pools the
//! muscles of each channel (`τ ≈ Σ_c F_c·e_c·Σ_{m∈c} r_m`), one force per channel.

use ceinms_files::emg_channel_for;
use experiment::{
    ceinms_trial_dirs, least_squares, moment_fit, read_ceinms_trial, CeinmsModelTrial,
    CEINMS_IDENTIFIED,
};
use std::path::PathBuf;

fn correlation(a: &[f64], b: &[f64]) -> f64 {
    let n = a.len() as f64;
    let (ma, mb) = (a.iter().sum::<f64>() / n, b.iter().sum::<f64>() / n);
    let (mut sab, mut saa, mut sbb) = (0.0, 0.0, 0.0);
    for (x, y) in a.iter().zip(b) {
        sab += (x - ma) * (y - mb);
        saa += (x - ma).powi(2);
        sbb += (y - mb).powi(2);
    }
    sab / (saa * sbb).sqrt()
}

/// Each muscle's drive at the torque file's samples.
fn drives(
    t: &CeinmsModelTrial,
    muscles: &[String],
) -> Result<Vec<Vec<f64>>, experiment::ExperimentError> {
    muscles
        .iter()
        .map(|m| t.at_torque_samples(&t.drive(m)?))
        .collect()
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let Some(dir) = args.first().map(PathBuf::from) else {
        eprintln!("usage: ceinms_baseline DIR [JOINT]  (DIR holds CEINMS trial folders)");
        std::process::exit(2);
    };
    let joint = args.get(1).map_or("R_ankle_fe", String::as_str);
    if let Err(e) = run(&dir, joint) {
        eprintln!("error: {e}");
        std::process::exit(2);
    }
}

fn run(dir: &std::path::Path, joint: &str) -> Result<(), experiment::ExperimentError> {
    let trials = ceinms_trial_dirs(dir)?
        .iter()
        .map(|d| read_ceinms_trial(d, joint))
        .collect::<Result<Vec<_>, _>>()?;
    let muscles = trials[0].muscles.clone();
    println!("sign check (surae's convention: plantarflexion > 0)");
    print!("{:<16}", "trial");
    for m in &muscles {
        print!(" {:>9}", m);
    }
    println!(" {:>9} {:>9} {:>9}", "mean τ", "r(all)", "r(TS)");
    let mut x: Vec<Vec<f64>> = vec![Vec::new(); muscles.len()];
    let mut y = Vec::new();
    let mut per_trial = Vec::new();
    for t in &trials {
        if t.muscles != muscles {
            return Err(experiment::ExperimentError::Invalid {
                what: "trials".to_string(),
                kind: experiment::ErrorKind::MissingColumn,
                reason: format!(
                    "{} has other muscles in its moment-arm file than {}",
                    t.name, trials[0].name
                ),
            });
        }
        let d = drives(t, &muscles)?;
        print!("{:<16}", t.name);
        for m in &muscles {
            let g = t
                .inputs
                .geometry(experiment::surae_muscle_name(m))
                .expect("every muscle has geometry");
            let r = &g.moment_arm_m;
            print!(" {:>9.4}", r.iter().sum::<f64>() / r.len() as f64);
        }
        let tau = &t.torque_at_samples;
        let all: Vec<f64> = (0..tau.len())
            .map(|i| d.iter().map(|c| c[i]).sum())
            .collect();
        let ts: Vec<f64> = (0..tau.len())
            .map(|i| {
                muscles
                    .iter()
                    .zip(&d)
                    .filter(|(m, _)| CEINMS_IDENTIFIED.contains(&m.as_str()))
                    .map(|(_, c)| c[i])
                    .sum()
            })
            .collect();
        println!(
            " {:>9.2} {:>9.3} {:>9.3}",
            tau.iter().sum::<f64>() / tau.len() as f64,
            correlation(tau, &all),
            correlation(tau, &ts)
        );
        for (xc, dc) in x.iter_mut().zip(&d) {
            xc.extend_from_slice(dc);
        }
        y.extend_from_slice(tau);
        per_trial.push((t.name.clone(), d, tau.clone()));
    }
    // muscles driven by one EMG channel pooled into one regressor (one force per channel)
    let channels: Vec<String> = muscles.iter().fold(Vec::new(), |mut v, m| {
        let c = emg_channel_for(m);
        if !v.contains(&c) {
            v.push(c);
        }
        v
    });
    let pool = |d: &[Vec<f64>]| -> Vec<Vec<f64>> {
        channels
            .iter()
            .map(|c| {
                let mut s = vec![0.0; d[0].len()];
                for (m, dm) in muscles.iter().zip(d) {
                    if emg_channel_for(m) == *c {
                        s.iter_mut().zip(dm).for_each(|(a, b)| *a += b);
                    }
                }
                s
            })
            .collect()
    };
    for (per_channel, intercept) in [(false, false), (false, true), (true, false)] {
        let names = if per_channel { &channels } else { &muscles };
        let mut cols = if per_channel { pool(&x) } else { x.clone() };
        if intercept {
            cols.push(vec![1.0; y.len()]);
        }
        let b = least_squares(&cols, &y)?;
        println!(
            "\nlinear baseline, one force per {}, {} intercept, fitted on the {} trials jointly \
             ({} samples)",
            if per_channel { "EMG channel" } else { "muscle" },
            if intercept { "with" } else { "without" },
            trials.len(),
            y.len()
        );
        for (m, f) in names.iter().zip(&b) {
            println!("  F[{m}] = {f:.0} N");
        }
        if intercept {
            println!("  c = {:.2} N·m", b[names.len()]);
        }
        let mut scores = Scores::default();
        for (name, d, tau) in &per_trial {
            let d = if per_channel { pool(d) } else { d.clone() };
            let c = if intercept { b[names.len()] } else { 0.0 };
            scores.add(name, tau, &linear(&d, &b, c));
        }
        scores.print_mean();
    }
    // each trial predicted by the regression fitted on the others: what the baseline does on
    // a trial it has not seen, the measure a calibration is judged by
    for per_channel in [false, true] {
        println!(
            "\nlinear baseline, one force per {}, leave one trial out (fitted on the others, \
             predicting the one left out)",
            if per_channel { "EMG channel" } else { "muscle" }
        );
        let mut scores = Scores::default();
        for (k, (name, d, tau)) in per_trial.iter().enumerate() {
            let mut cols: Vec<Vec<f64>> = Vec::new();
            let mut yk = Vec::new();
            for (j, (_, dj, tj)) in per_trial.iter().enumerate() {
                if j == k {
                    continue;
                }
                let dj = if per_channel { pool(dj) } else { dj.clone() };
                if cols.is_empty() {
                    cols = vec![Vec::new(); dj.len()];
                }
                for (c, v) in cols.iter_mut().zip(&dj) {
                    c.extend_from_slice(v);
                }
                yk.extend_from_slice(tj);
            }
            let b = least_squares(&cols, &yk)?;
            let d = if per_channel { pool(d) } else { d.clone() };
            scores.add(name, tau, &linear(&d, &b, 0.0));
        }
        scores.print_mean();
    }
    Ok(())
}

/// `c + Σ_k b_k·d_k` at every sample.
fn linear(d: &[Vec<f64>], b: &[f64], c: f64) -> Vec<f64> {
    (0..d[0].len())
        .map(|i| c + d.iter().zip(b).map(|(col, f)| col[i] * f).sum::<f64>())
        .collect()
}

/// Per-trial RMS and R², printed as they come, and their means.
#[derive(Default)]
struct Scores {
    rms: Vec<f64>,
    r2: Vec<f64>,
}

impl Scores {
    fn add(&mut self, name: &str, measured: &[f64], predicted: &[f64]) {
        let (rms, r2) = moment_fit(measured, predicted);
        println!("  {name:<16} RMS {rms:6.2} N·m  R² {r2:.3}");
        self.rms.push(rms);
        self.r2.push(r2);
    }

    fn print_mean(&self) {
        let n = self.rms.len() as f64;
        println!(
            "  {:<16} RMS {:6.2} N·m  R² {:.3}",
            "mean",
            self.rms.iter().sum::<f64>() / n,
            self.r2.iter().sum::<f64>() / n
        );
    }
}
