//! How well the dynamometer template is fitted on many SPEC unloaded runs (development probe).
//!
//! `cargo run --release -p diagnose --example template_scan -- BASE COUNT`
//!
//! For each of the 13 scenarios of the confusion study and `i < COUNT`, the unloaded run of
//! seed `BASE + 100000·scenario + i` (the run [`diagnose::scenarios::hidden_trial`] supplies)
//! is fitted as a diagnosis fits it ([`NoiseModel::fit`]). Prints, per run, the template's
//! relative L2 error over its first 0.5 s against the SPEC §4 transient (1.0: no transient
//! found) and the fitted noise model, then the number of runs with an error above 0.4.

use diagnose::{NoiseModel, NoiseSource, Segmentation, Transient};
use experiment::DynamometerSettings;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let [base, count] = args.as_slice() else {
        return Err("usage: template_scan BASE COUNT".into());
    };
    let (base, count): (u64, u64) = (base.parse()?, count.parse()?);
    let s = DynamometerSettings::default();
    let (mut bad, mut total) = (0, 0);
    for scenario in 0..13u64 {
        for i in 0..count {
            let seed = base + 100_000 * scenario + i;
            let t = diagnose::scenarios::hidden_trial(&[], false, seed)?;
            let u = &t.synthetic.unloaded;
            let fs = u.sample_rate_hz();
            let seg = Segmentation::new(&u.ankle_angle_deg, fs, None)?;
            let m = NoiseModel::fit(&u.torque_nm, fs, &seg.events, true, NoiseSource::Unloaded);
            let truth = Transient {
                b_nm: s.transient_amplitude_nm,
                c_nm: 0.0,
                tau_s: s.transient_tau_s,
                freq_hz: s.transient_freq_hz,
            };
            let err = m.transient.relative_error(&truth, 0.5, 2048.0);
            total += 1;
            if err > 0.4 {
                bad += 1;
            }
            println!("{seed} err {err:.3} {m:?}");
        }
    }
    println!("template error above 0.4 on {bad} of {total} runs");
    Ok(())
}
