//! NUTS on a standard normal in `d` dimensions (default 10) inside a wide box: prints every
//! parameter's mean, sd, R̂ and bulk/tail ESS, and the sampler's statistics.
//!
//! ```text
//! cargo run --release -p identify-mcmc --example nuts_normal -- [dim] [seed]
//! ```

use std::time::Instant;

use identify_mcmc::{run_nuts, FnGradLogDensity, NutsSettings};

fn main() {
    let mut args = std::env::args().skip(1);
    let d: usize = args.next().map_or(10, |s| s.parse().expect("dimension"));
    let seed: u64 = args.next().map_or(1, |s| s.parse().expect("seed"));
    let target = FnGradLogDensity::new(vec![(-20.0, 20.0); d], |x: &[f64], g: &mut [f64]| {
        for (g, x) in g.iter_mut().zip(x) {
            *g = -x;
        }
        Some(-0.5 * x.iter().map(|v| v * v).sum::<f64>())
    });
    let settings = NutsSettings {
        seed,
        ..NutsSettings::default()
    };
    let start = Instant::now();
    let run = run_nuts(&target, &settings, None).expect("valid settings and target");
    let seconds = start.elapsed().as_secs_f64();
    println!(
        "{} chains × {} draws after {} warm-up iterations, {seconds:.2} s",
        settings.chains, settings.draws, settings.warmup
    );
    println!(" param     mean       sd      R̂   ESS bulk  ESS tail");
    for (i, s) in run.summary.iter().enumerate() {
        println!(
            "{i:>6} {:>8.4} {:>8.4} {:>7.4} {:>9.0} {:>9.0}",
            s.mean, s.sd, s.rhat, s.ess_bulk, s.ess_tail
        );
    }
    println!(
        "step sizes {:.3?}; mean accept_stat {:.3} (adaptation stretch {:.3?}); mean n_leapfrog {:.2}",
        run.step_size,
        run.mean_accept_stat(),
        run.adaptation_accept_stat,
        run.mean_leapfrog()
    );
    println!(
        "divergences {} (warm-up {}), max-depth hits {}, gradient evaluations {}",
        run.divergences, run.warmup_divergences, run.max_depth_hits, run.gradient_evaluations
    );
}
