//! How well the dynamometer correction is estimated from many simulated unloaded runs.
//!
//! `cargo run --release -p diagnose --example template_scan -- BASE COUNT`
//!
//! For each of the 13 scenarios of the confusion study and `i < COUNT`, the unloaded run of
//! seed `BASE + 100000·scenario + i` (the run [`diagnose::scenarios::hidden_trial`] supplies)
//! is fitted as identification and diagnosis fit it
//! ([`experiment::DynamometerCorrection::from_unloaded`]). Prints, per run, the transient's
//! relative L2 error over its first 0.5 s against the simulated one (1.0: no transient
//! found), the largest event-time error of [`experiment::detect_events`] against the
//! protocol's events, and the relative errors of the random part's `σ_ar`, correlation time
//! and `σ_w` (the truth's white SD includes the ADC's quantisation, `step/√12`); then the
//! medians and means of those errors and the number of runs with a template error above 0.4.

use diagnose::Transient;
use experiment::{detect_events, DynamometerCorrection, DynamometerSettings, Protocol};

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let [base, count] = args.as_slice() else {
        return Err("usage: template_scan BASE COUNT".into());
    };
    let (base, count): (u64, u64) = (base.parse()?, count.parse()?);
    let s = DynamometerSettings::default();
    let truth = Transient {
        b_nm: s.transient_amplitude_nm,
        c_nm: 0.0,
        tau_s: s.transient_tau_s,
        freq_hz: s.transient_freq_hz,
    };
    let q = s.quantisation_step_nm();
    let white_truth = (s.white_sd_nm.powi(2) + q * q / 12.0).sqrt();
    let true_events = Protocol::unloaded().trace()?.events.all();
    let mut errs: [Vec<f64>; 5] = Default::default();
    let mut bad = 0;
    for scenario in 0..13u64 {
        for i in 0..count {
            let seed = base + 100_000 * scenario + i;
            let t = diagnose::scenarios::hidden_trial(&[], false, seed)?;
            let u = &t.synthetic.unloaded;
            let c = DynamometerCorrection::from_unloaded(u)?;
            let r = c.report();
            let template = c.transient.relative_error(&truth, 0.5, 2048.0);
            let found = detect_events(&u.time_s, &u.ankle_angle_deg)?.all();
            let event = if found.len() == true_events.len() {
                found
                    .iter()
                    .zip(&true_events)
                    .map(|(a, b)| (a - b).abs())
                    .fold(0.0, f64::max)
            } else {
                f64::INFINITY
            };
            let rel = |est: f64, truth: f64| (est / truth - 1.0).abs();
            let row = [
                template,
                event,
                rel(r.ar1_sd_nm, s.ar1_sd_nm),
                rel(r.ar1_corr_time_s, s.ar1_corr_time_s),
                rel(r.white_sd_nm, white_truth),
            ];
            if template > 0.4 {
                bad += 1;
            }
            for (e, v) in errs.iter_mut().zip(row) {
                e.push(v);
            }
            println!(
                "{seed} err {template:.3} event {event:.2e} s ar1_sd {:.3} corr_time {:.3} white {:.3} {r:?}",
                row[2], row[3], row[4]
            );
        }
    }
    let names = [
        "template",
        "event time (s)",
        "ar1_sd",
        "ar1_corr_time",
        "white_sd",
    ];
    for (name, e) in names.iter().zip(&errs) {
        let mean = e.iter().sum::<f64>() / e.len() as f64;
        println!(
            "{name}: median error {:.4}, mean {mean:.4}",
            median(e.clone())
        );
    }
    println!(
        "template error above 0.4 on {bad} of {} runs",
        errs[0].len()
    );
    Ok(())
}
