//! Joint MCMC on synthetic 3-trial sessions (knee0@30, knee90@30, knee0@60): convergence,
//! posterior sds, identifiability and 90 % interval coverage.
//!
//! `cargo run --release -p identify-mcmc --example session_coverage -- [N=20] [FIRST=1] [nominal]`
//! identifies replicates FIRST…FIRST+N−1 with the default settings (seed = replicate). Each
//! replicate draws its true parameters uniformly inside the bounds
//! (`experiment::random_params`, seeded by the replicate; `nominal`: the nominal parameters,
//! where the linearised expectation was computed) and synthesises the three trials, each
//! with its own unloaded run and the nominal dynamometer error; each trial is corrected by its
//! own unloaded run and keeps its own AR(1)+white noise model. Prints one line per replicate and
//! a table: coverage per parameter, mean posterior sd in % of nominal against the linearised
//! sd of the same trials at the truth (`design` crate, with the bounds' prior), against the
//! reference table, and how often each parameter is flagged identifiable.

use std::ops::ControlFlow;

#[path = "../tests/common/synthetic_session.rs"]
mod synthetic_session;

use identify_mcmc::{identify_session, McmcIdentifySettings};
use synthetic_session::{nominal_values, SyntheticSession, REFERENCE_TABLE_SD_PCT, THREE_TRIALS};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().collect();
    let n: u64 = args.get(1).map(|s| s.parse()).transpose()?.unwrap_or(20);
    let first: u64 = args.get(2).map(|s| s.parse()).transpose()?.unwrap_or(1);
    let at_nominal = args.iter().any(|a| a == "nominal");
    let nominal = nominal_values();
    let mut hits = [0usize; 9];
    let mut sd_sum = [0.0f64; 9];
    let mut sd_max = [0.0f64; 9];
    let mut lin_sum = [0.0f64; 9];
    let mut identifiable = [0usize; 9];
    let (mut converged, mut walls, mut worst_rhat, mut worst_ess) =
        (0usize, Vec::new(), 0.0f64, f64::INFINITY);
    let mut names = Vec::new();
    for rep in first..first + n {
        let session = if at_nominal {
            SyntheticSession::with_truth(&THREE_TRIALS, rep, muscle_model::ModelParams::nominal())
        } else {
            SyntheticSession::new(&THREE_TRIALS, rep)
        };
        let truth = session.true_values();
        for (acc, v) in lin_sum.iter_mut().zip(session.linearised_sds_pct()) {
            *acc += v;
        }
        let mut settings = McmcIdentifySettings::default();
        settings.mcmc.seed = rep;
        let res = identify_session(&session.trials(), &settings, |_| ControlFlow::Continue(()))?;
        names.clone_from(&res.names);
        converged += usize::from(res.converged);
        walls.push(res.wall_s);
        let (r, e) = res.worst_diagnostics();
        worst_rhat = worst_rhat.max(r);
        worst_ess = worst_ess.min(e);
        let mut line = format!("replicate {rep:3}: ");
        for (k, p) in res.posterior.iter().enumerate() {
            let c = p.covers(truth[k]);
            hits[k] += usize::from(c);
            let sd = 100.0 * p.sd / nominal[k];
            sd_sum[k] += sd;
            sd_max[k] = sd_max[k].max(sd);
            identifiable[k] += usize::from(p.identifiable);
            line.push(if c { '+' } else { '-' });
        }
        let rms: Vec<String> = res
            .trials
            .iter()
            .map(|t| format!("{:.2}", t.rms_corrected_nm))
            .collect();
        println!(
            "{line}  max R̂ {r:.4} min ESS {e:.0} converged {} modes {} wall {:.1} s  RMS {} N·m",
            res.converged,
            res.modes.len(),
            res.wall_s,
            rms.join("/")
        );
        // Where the modes kept by the search lie, in % of the truth (sol, gm, gl × LST, F0, α0).
        for md in &res.modes {
            let off: Vec<String> =
                md.x.iter()
                    .zip(&truth)
                    .map(|(x, t)| format!("{:+.1}", 100.0 * (x - t) / t))
                    .collect();
            println!(
                "    mode, {:.2} log units below the best: {} %",
                md.log_density_gap,
                off.join(" ")
            );
        }
    }
    let nf = n as f64;
    println!();
    println!(
        "| parameter | 90 % coverage | mean sd (% nominal) | max sd | linearised sd | sd / linearised | reference table | sd / table | identifiable |"
    );
    println!("|---|---|---|---|---|---|---|---|---|");
    for (k, name) in names.iter().enumerate() {
        let mean_sd = sd_sum[k] / nf;
        let lin = lin_sum[k] / nf;
        println!(
            "| {name} | {}/{n} ({:.2}) | {mean_sd:.3} | {:.3} | {lin:.3} | {:.2} | {} | {:.2} | {}/{n} |",
            hits[k],
            hits[k] as f64 / nf,
            sd_max[k],
            mean_sd / lin,
            REFERENCE_TABLE_SD_PCT[k],
            mean_sd / REFERENCE_TABLE_SD_PCT[k],
            identifiable[k]
        );
    }
    let total: usize = hits.iter().sum();
    walls.sort_by(f64::total_cmp);
    println!(
        "\nall parameters: {total}/{} covered ({:.3}); converged {converged}/{n}; worst R̂ {worst_rhat:.4}, \
         smallest bulk ESS {worst_ess:.0}; wall median {:.1} s, max {:.1} s",
        9 * n,
        total as f64 / (9.0 * nf),
        walls[walls.len() / 2],
        walls[walls.len() - 1]
    );
    Ok(())
}
