//! Sample a correlated 2-D Gaussian and print the posterior summary.
//!
//! `cargo run --release -p identify-mcmc --example gaussian2d`

use std::ops::ControlFlow;

use identify_mcmc::{run_with_observer, ChainPhase, FnLogDensity, McmcSettings};

fn main() -> Result<(), identify_mcmc::McmcError> {
    let rho: f64 = 0.9;
    let target = FnLogDensity::new(vec![(-10.0, 10.0), (-10.0, 10.0)], move |x: &[f64]| {
        let q = (x[0] * x[0] - 2.0 * rho * x[0] * x[1] + x[1] * x[1]) / (1.0 - rho * rho);
        Some(-0.5 * q)
    });
    let settings = McmcSettings {
        seed: 1,
        ..McmcSettings::default()
    };
    let result = run_with_observer(&target, &settings, None, |p| {
        let phase = match p.phase {
            ChainPhase::Warmup => "warm-up ",
            ChainPhase::Sampling => "sampling",
            _ => "        ",
        };
        println!(
            "{phase} {:>6} iterations  max R-hat {:.4}  min bulk ESS {:>7.1}  acceptance {:.3}",
            p.iterations, p.max_rhat, p.min_ess_bulk, p.acceptance_rate
        );
        ControlFlow::Continue(())
    })?;
    println!(
        "stop: {:?} after {} warm-up + {} sampling iterations per chain",
        result.stop, result.warmup_iterations, result.sampling_iterations
    );
    for (i, s) in result.summary.iter().enumerate() {
        println!(
            "x{i}: mean {:+.3}  sd {:.3}  [{:+.3}, {:+.3}]  R-hat {:.4}  ESS bulk {:.0} tail {:.0}  sd/prior {:.3}  identifiable {}",
            s.mean, s.sd, s.q05, s.q95, s.rhat, s.ess_bulk, s.ess_tail, s.prior_sd_ratio, s.identifiable
        );
    }
    let top = result.strongest_correlations[0];
    println!(
        "strongest correlation: x{} ~ x{}: {:+.3}",
        top.i, top.j, top.r
    );
    Ok(())
}
