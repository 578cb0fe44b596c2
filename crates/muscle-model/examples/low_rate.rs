//! A long low-rate recording's cost and accuracy (docs/model.md, "Low-rate trials"): the
//! 60 s gait-like synthetic trial at 100 Hz and the same signals at 2048 Hz, default settings
//! against `SimSettings::tight()`; integrator work per muscle, rejected share, and the time of
//! one simulation (three muscles) and of an annealing move (one muscle).
//!
//! `cargo run --release -p muscle-model --example low_rate [-- SECONDS]`

use muscle_model::{
    simulate, simulate_into, synthetic, Effects, ModelParams, SimSettings, Workspace,
};
use numerics::rms_diff;
use std::time::Instant;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let secs: f64 = std::env::args().nth(1).map_or(Ok(60.0), |s| s.parse())?;
    let (p, e, s) = (
        ModelParams::nominal(),
        Effects::none(),
        SimSettings::default(),
    );
    for fs in [100.0, 2048.0] {
        let tr = synthetic::gait_like_trial(fs, secs)?;
        let tight = simulate(&tr, &p, &e, &SimSettings::tight())?;
        let out = simulate(&tr, &p, &e, &s)?;
        let st = out.total_stats();
        println!(
            "{fs} Hz, {secs} s ({} samples, low-rate {}): {} accepted, {} rejected ({:.1} % of \
             the attempts), {} RHS calls for 3 muscles; {:.2e} N·m RMS from tight",
            tr.len(),
            tr.is_low_rate(),
            st.accepted,
            st.rejected,
            100.0 * st.rejected as f64 / (st.accepted + st.rejected) as f64,
            st.rhs_calls,
            rms_diff(&out.torque, &tight.torque)
        );
        for m in &out.muscles {
            println!("  {}: {:?}", m.name, m.stats);
        }
        // median times: every muscle changed, and one muscle changed (an annealing move)
        for (label, all) in [("3 muscles", true), ("1 muscle (annealing move)", false)] {
            let mut ws = Workspace::new();
            let mut torque = vec![0.0; tr.len()];
            let mut pp = p;
            let mut times = Vec::new();
            for k in 0..25 {
                // a new value every call, so that no kept integration is reused
                let f = 1.0 + 1e-6 * (k + 1) as f64;
                for j in 0..if all { 3 } else { 1 } {
                    pp.muscles[j].lst_m = p.muscles[j].lst_m * f;
                }
                let t0 = Instant::now();
                simulate_into(&mut ws, &tr, &pp, &e, &s, &mut torque)?;
                if k >= 5 {
                    times.push(t0.elapsed().as_secs_f64());
                }
            }
            times.sort_by(f64::total_cmp);
            println!("  {label}: median {:.2} ms", times[times.len() / 2] * 1e3);
        }
    }
    Ok(())
}
