//! What the per-trial detection limits cost in a diagnosis.
//!
//! `cargo run --release -p diagnose --example limit_cost -- N BASE_SEED`
//!
//! Diagnoses the no-effect trials `BASE_SEED + i`, `i < N` (relaxed+2 with `emg_ta`, every
//! effect eligible), and prints per trial the simulations and the wall time between the
//! observer's "detection limits" and "profile-likelihood intervals" messages (the limits and
//! the residual analysis) against the whole diagnosis's.
use std::ops::ControlFlow;
use std::time::Instant;

use diagnose::scenarios::hidden_trial;
use diagnose::{run, DiagnoseSettings, DiagnosisProgress};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let n: u64 = args.first().ok_or("usage: N BASE_SEED")?.parse()?;
    let base: u64 = args.get(1).ok_or("usage: N BASE_SEED")?.parse()?;
    let settings = DiagnoseSettings::default();
    for seed in base..base + n {
        let t = hidden_trial(&[], true, seed)?;
        let t0 = Instant::now();
        let mut marks: Vec<(String, usize, f64)> = Vec::new();
        let mut obs = |p: &DiagnosisProgress| {
            marks.push((p.message.clone(), p.evaluations, t0.elapsed().as_secs_f64()));
            ControlFlow::Continue(())
        };
        let d = run(
            &t.synthetic.trial,
            Some(&t.synthetic.unloaded),
            &settings,
            &mut obs,
        )?;
        let at = |prefix: &str| marks.iter().find(|m| m.0.starts_with(prefix)).cloned();
        let (Some(a), Some(b)) = (at("detection limits"), at("profile-likelihood")) else {
            return Err("the diagnosis did not report its stages".into());
        };
        println!(
            "{seed}: limits and analysis {} of {} simulations, {:.2} of {:.2} s",
            b.1 - a.1,
            d.evaluations,
            b.2 - a.2,
            d.wall_s
        );
    }
    Ok(())
}
