//! The No-U-Turn Sampler on targets with known moments. Every statistical check is a bound of
//! a few Monte Carlo standard errors, `MCSE = sd(f)/√ESS(f)` with ESS from
//! [`diagnostics::ess_mean`], at a fixed seed.

use std::time::Instant;

use identify_mcmc::diagnostics::ess_mean;
use identify_mcmc::{run_nuts, FnGradLogDensity, McmcError, NutsRun, NutsSettings};
use numerics::special::normal_cdf;

/// Bounds in MCSE units of every moment check.
const Z: f64 = 5.0;

/// Estimate of `E[f(x)]` over all chains and its MCSE; `f` maps a draw (all coordinates) to a
/// number.
fn estimate(run: &NutsRun, f: impl Fn(&[f64]) -> f64) -> (f64, f64) {
    let chains = run.draws[0].len();
    let n = run.draws[0][0].len();
    let values: Vec<Vec<f64>> = (0..chains)
        .map(|c| {
            (0..n)
                .map(|k| {
                    let x: Vec<f64> = (0..run.dim).map(|i| run.draws[i][c][k]).collect();
                    f(&x)
                })
                .collect()
        })
        .collect();
    let all: Vec<f64> = values.iter().flatten().copied().collect();
    let s = all.len() as f64;
    let mean = all.iter().sum::<f64>() / s;
    let sd = (all.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / (s - 1.0)).sqrt();
    let slices: Vec<&[f64]> = values.iter().map(Vec::as_slice).collect();
    (mean, sd / ess_mean(&slices).sqrt())
}

/// Asserts `|E[f] − want| ≤ Z·MCSE` and returns the error in MCSE units.
fn check(run: &NutsRun, what: &str, want: f64, f: impl Fn(&[f64]) -> f64) -> f64 {
    let (got, mcse) = estimate(run, f);
    let z = (got - want) / mcse;
    eprintln!("  {what}: {got:.5} vs {want:.5} (MCSE {mcse:.2e}, {z:+.2})");
    assert!(
        z.abs() <= Z,
        "{what}: {got} vs {want}, MCSE {mcse}, {z:.2} MCSE"
    );
    z
}

fn normal_target(
    d: usize,
    half_width: f64,
) -> FnGradLogDensity<impl Fn(&[f64], &mut [f64]) -> Option<f64> + Sync> {
    FnGradLogDensity::new(
        vec![(-half_width, half_width); d],
        |x: &[f64], g: &mut [f64]| {
            for (g, x) in g.iter_mut().zip(x) {
                *g = -x;
            }
            Some(-0.5 * x.iter().map(|v| v * v).sum::<f64>())
        },
    )
}

fn report(name: &str, run: &NutsRun, seconds: f64) {
    eprintln!(
        "{name}: max R̂ {:.4}, min bulk ESS {:.0}, min tail ESS {:.0}, mean n_leapfrog {:.2}, \
         mean accept_stat {:.3}, step sizes {:?}, divergences {}, gradient evaluations {}, {seconds:.2} s",
        run.max_rhat(),
        run.min_ess_bulk(),
        run.min_ess_tail(),
        run.mean_leapfrog(),
        run.mean_accept_stat(),
        run.step_size,
        run.divergences,
        run.gradient_evaluations
    );
}

#[test]
fn standard_normal_10d() {
    let d = 10;
    let target = normal_target(d, 20.0);
    let settings = NutsSettings {
        seed: 11,
        ..NutsSettings::default()
    };
    let t = Instant::now();
    let run = run_nuts(&target, &settings, None).unwrap();
    report("normal 10-D", &run, t.elapsed().as_secs_f64());
    assert_eq!(run.draws.len(), d);
    assert_eq!(run.draws[0].len(), 4);
    assert_eq!(run.draws[0][0].len(), 1000);
    for i in 0..d {
        check(&run, &format!("mean x{i}"), 0.0, |x| x[i]);
        check(&run, &format!("E[x{i}²]"), 1.0, |x| x[i] * x[i]);
        let s = &run.summary[i];
        assert!(s.rhat < 1.01, "R̂ x{i} = {}", s.rhat);
        assert!(s.ess_bulk >= 400.0, "bulk ESS x{i} = {}", s.ess_bulk);
        assert!(s.ess_tail >= 400.0, "tail ESS x{i} = {}", s.ess_tail);
    }
    assert!(run.mean_leapfrog() <= 20.0, "{}", run.mean_leapfrog());
    assert_eq!(run.divergences, 0);
    assert_eq!(run.max_depth_hits, 0);
    assert_eq!(run.failed_evaluations, 0);
    // Every draw's statistics are consistent with each other.
    for s in run.stats.iter().flatten() {
        assert!(s.n_leapfrog >= 1 && s.n_leapfrog < (1 << (s.tree_depth + 1)));
        assert!((0.0..=1.0).contains(&s.accept_stat));
        assert!(s.energy.is_finite() && s.lp.is_finite());
    }
    // log π(x) of each kept draw is the target's value there.
    for c in 0..4 {
        for k in [0, 500, 999] {
            let sq: f64 = (0..d).map(|i| run.draws[i][c][k].powi(2)).sum();
            assert!((run.log_density[c][k] + 0.5 * sq).abs() < 1e-9);
        }
    }
}

/// Dual averaging drives the mean acceptance statistic over its adaptation stretch to `δ`.
/// The kept draws run at `exp(x̄)`, a smaller step than the typical adapted one, so their mean
/// lies above `δ` (as with Stan on Gaussian targets) but never below it by more than the same
/// margin.
#[test]
fn step_size_adapts_to_target_acceptance() {
    let target = normal_target(10, 20.0);
    for (seed, delta) in [(5, 0.8), (6, 0.9), (7, 0.65)] {
        let settings = NutsSettings {
            seed,
            target_accept: delta,
            ..NutsSettings::default()
        };
        let run = run_nuts(&target, &settings, None).unwrap();
        report(&format!("adaptation δ = {delta}"), &run, 0.0);
        let n = run.adaptation_accept_stat.len() as f64;
        let adapt = run.adaptation_accept_stat.iter().sum::<f64>() / n;
        eprintln!(
            "  adaptation-stretch accept_stat {adapt:.3} {:.3?}",
            run.adaptation_accept_stat
        );
        assert!(
            (adapt - delta).abs() < 0.05,
            "adaptation accept_stat {adapt} for δ = {delta}"
        );
        let kept = run.mean_accept_stat();
        assert!(
            kept > delta - 0.05,
            "kept accept_stat {kept} for δ = {delta}"
        );
    }
}

#[test]
fn correlated_gaussian_2d() {
    let rho: f64 = 0.9;
    let target = FnGradLogDensity::new(vec![(-10.0, 10.0); 2], move |x: &[f64], g: &mut [f64]| {
        let c = 1.0 / (1.0 - rho * rho);
        g[0] = -c * (x[0] - rho * x[1]);
        g[1] = -c * (x[1] - rho * x[0]);
        Some(-0.5 * c * (x[0] * x[0] - 2.0 * rho * x[0] * x[1] + x[1] * x[1]))
    });
    let settings = NutsSettings {
        seed: 12,
        ..NutsSettings::default()
    };
    let t = Instant::now();
    let run = run_nuts(&target, &settings, None).unwrap();
    report("correlated 2-D", &run, t.elapsed().as_secs_f64());
    for i in 0..2 {
        check(&run, &format!("mean x{i}"), 0.0, |x| x[i]);
        check(&run, &format!("E[x{i}²]"), 1.0, |x| x[i] * x[i]);
        // ESS here is ~800 of 4000 draws, at which R̂ itself scatters by ~0.005: the bound
        // checks that the chains agree, not the 1.01 convergence target.
        assert!(
            run.summary[i].rhat < 1.05,
            "R̂ x{i} = {}",
            run.summary[i].rhat
        );
        assert!(run.summary[i].ess_bulk >= 400.0);
    }
    check(&run, "E[x0·x1]", rho, |x| x[0] * x[1]);
    assert_eq!(run.divergences, 0);
}

#[test]
fn a_dense_metric_undoes_a_strong_correlation() {
    // ρ = 0.99: a diagonal metric leaves the long, narrow ridge for the trajectories to wind
    // along (deep trees); the dense metric warm-up estimates maps it to a round one.
    let rho: f64 = 0.99;
    let target = FnGradLogDensity::new(vec![(-20.0, 20.0); 2], move |x: &[f64], g: &mut [f64]| {
        let c = 1.0 / (1.0 - rho * rho);
        g[0] = -c * (x[0] - rho * x[1]);
        g[1] = -c * (x[1] - rho * x[0]);
        Some(-0.5 * c * (x[0] * x[0] - 2.0 * rho * x[0] * x[1] + x[1] * x[1]))
    });
    let run = |dense: bool| {
        let settings = NutsSettings {
            seed: 31,
            dense_metric: dense,
            ..NutsSettings::default()
        };
        let t = Instant::now();
        let run = run_nuts(&target, &settings, None).unwrap();
        report(
            if dense {
                "ρ 0.99, dense"
            } else {
                "ρ 0.99, diagonal"
            },
            &run,
            t.elapsed().as_secs_f64(),
        );
        run
    };
    let (diag, dense) = (run(false), run(true));
    for i in 0..2 {
        check(&dense, &format!("mean x{i}"), 0.0, |x| x[i]);
        check(&dense, &format!("E[x{i}²]"), 1.0, |x| x[i] * x[i]);
        assert!(
            dense.summary[i].rhat < 1.01,
            "R̂ x{i} = {}",
            dense.summary[i].rhat
        );
    }
    check(&dense, "E[x0·x1]", rho, |x| x[0] * x[1]);
    assert_eq!(dense.divergences, 0);
    // the adapted inverse metric is the covariance [[1, ρ], [ρ, 1]] (to sampling error)
    for m in &dense.inv_metric {
        assert_eq!(m.len(), 4);
        assert!((m[1] / (m[0] * m[3]).sqrt() - rho).abs() < 0.01, "{m:?}");
    }
    assert!(
        dense.mean_leapfrog() * 3.0 < diag.mean_leapfrog(),
        "dense {} against diagonal {} leapfrog steps per draw",
        dense.mean_leapfrog(),
        diag.mean_leapfrog()
    );
    assert!(dense.min_ess_bulk() > diag.min_ess_bulk());
}

/// Beta(1.5, 20) has its mass against the lower bound of (0, 1), Beta(½, ½) against both:
/// their moments come out right only with the transform's Jacobian.
#[test]
fn beta_densities_against_the_bounds() {
    let ab = [(1.5, 20.0), (0.5, 0.5)];
    let target = FnGradLogDensity::new(vec![(0.0, 1.0); 2], move |x: &[f64], g: &mut [f64]| {
        let mut lp = 0.0;
        for i in 0..2 {
            let (a, b) = ab[i];
            lp += (a - 1.0) * x[i].ln() + (b - 1.0) * (1.0 - x[i]).ln();
            g[i] = (a - 1.0) / x[i] - (b - 1.0) / (1.0 - x[i]);
        }
        Some(lp)
    });
    let settings = NutsSettings {
        seed: 13,
        ..NutsSettings::default()
    };
    let t = Instant::now();
    let run = run_nuts(&target, &settings, None).unwrap();
    report("Beta", &run, t.elapsed().as_secs_f64());
    for (i, &(a, b)) in ab.iter().enumerate() {
        let mean = a / (a + b);
        let var = a * b / ((a + b) * (a + b) * (a + b + 1.0));
        check(&run, &format!("Beta({a}, {b}) mean"), mean, |x| x[i]);
        check(&run, &format!("Beta({a}, {b}) variance"), var, |x| {
            (x[i] - mean).powi(2)
        });
        assert!(run.summary[i].rhat < 1.01);
        assert!(run.summary[i].ess_bulk >= 400.0);
    }
    for c in &run.draws {
        for x in c.iter().flatten() {
            assert!((0.0..=1.0).contains(x));
        }
    }
}

/// A flat density on a box is the uniform prior: on the unconstrained coordinates only the
/// transform's Jacobian (a logistic density) is left, and the draws must be uniform on
/// `(lo, hi)`: mean `(lo + hi)/2`, variance `(hi − lo)²/12`.
#[test]
fn flat_density_gives_the_uniform_prior() {
    let bounds = vec![(2.0, 5.0), (-1e-3, 1e-3)];
    let target = FnGradLogDensity::new(bounds.clone(), |_: &[f64], g: &mut [f64]| {
        g.iter_mut().for_each(|g| *g = 0.0);
        Some(0.0)
    });
    let settings = NutsSettings {
        seed: 15,
        ..NutsSettings::default()
    };
    let run = run_nuts(&target, &settings, None).unwrap();
    report("flat", &run, 0.0);
    for (i, &(lo, hi)) in bounds.iter().enumerate() {
        let mean = 0.5 * (lo + hi);
        check(&run, &format!("uniform mean x{i}"), mean, |x| x[i]);
        check(
            &run,
            &format!("uniform variance x{i}"),
            (hi - lo).powi(2) / 12.0,
            |x| (x[i] - mean).powi(2),
        );
        assert!(run.summary[i].rhat < 1.01);
    }
    assert_eq!(run.divergences, 0);
}

#[test]
fn bit_identical_for_any_thread_count() {
    let target = normal_target(3, 10.0);
    let settings = NutsSettings {
        seed: 99,
        warmup: 300,
        draws: 200,
        ..NutsSettings::default()
    };
    let on = |threads: usize| {
        rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap()
            .install(|| run_nuts(&target, &settings, None).unwrap())
    };
    let one = on(1);
    let two = on(2);
    let bits = |r: &NutsRun| -> Vec<u64> {
        let mut v: Vec<u64> = r
            .draws
            .iter()
            .flatten()
            .flatten()
            .map(|x| x.to_bits())
            .collect();
        for s in r.stats.iter().flatten() {
            v.extend([
                s.lp.to_bits(),
                s.accept_stat.to_bits(),
                s.step_size.to_bits(),
                s.energy.to_bits(),
                u64::from(s.n_leapfrog),
                u64::from(s.tree_depth),
                u64::from(s.divergent),
            ]);
        }
        v
    };
    assert_eq!(bits(&one), bits(&two));
    assert_eq!(one.gradient_evaluations, two.gradient_evaluations);
    // Different chains see different streams.
    assert_ne!(one.draws[0][0], one.draws[0][1]);
}

/// The gradient fails (`None`) for `x₀ > 1` and is NaN for `x₁ > 1.5`: those trajectories
/// diverge, the run finishes, and no kept draw lies where the density could not be evaluated.
#[test]
fn failing_gradient_gives_divergences_not_panics() {
    let target = FnGradLogDensity::new(vec![(-10.0, 10.0); 2], |x: &[f64], g: &mut [f64]| {
        if x[0] > 1.0 {
            return None;
        }
        g[0] = -x[0];
        g[1] = if x[1] > 1.5 { f64::NAN } else { -x[1] };
        Some(-0.5 * (x[0] * x[0] + x[1] * x[1]))
    });
    let settings = NutsSettings {
        seed: 14,
        ..NutsSettings::default()
    };
    let run = run_nuts(&target, &settings, None).unwrap();
    report("failing gradient", &run, 0.0);
    assert!(run.divergences > 0);
    assert!(run.failed_evaluations > 0);
    let divergent = run.stats.iter().flatten().filter(|s| s.divergent).count() as u64;
    assert_eq!(divergent, run.divergences);
    assert!(run.draws[0].iter().flatten().all(|&x| x <= 1.0));
    assert!(run.draws[1].iter().flatten().all(|&x| x <= 1.5));
    // Where the density cannot be evaluated it is in effect zero: the draws follow the normal
    // truncated to x₀ ≤ 1, x₁ ≤ 1.5, whose means are −φ(c)/Φ(c).
    for (i, c) in [(0, 1.0), (1, 1.5)] {
        let want = -std_normal_pdf(c) / normal_cdf(c);
        check(&run, &format!("truncated mean x{i}"), want, |x| x[i]);
    }
}

fn std_normal_pdf(x: f64) -> f64 {
    (-0.5 * x * x).exp() / (2.0 * std::f64::consts::PI).sqrt()
}

#[test]
fn invalid_settings_and_starts_are_errors() {
    let target = normal_target(2, 5.0);
    let bad = NutsSettings {
        target_accept: 1.0,
        ..NutsSettings::default()
    };
    assert!(matches!(
        run_nuts(&target, &bad, None),
        Err(McmcError::InvalidSetting {
            name: "target_accept",
            ..
        })
    ));
    let bad = NutsSettings {
        max_depth: 0,
        ..NutsSettings::default()
    };
    assert!(run_nuts(&target, &bad, None).is_err());
    let settings = NutsSettings {
        chains: 2,
        warmup: 50,
        draws: 10,
        ..NutsSettings::default()
    };
    let on_bound = vec![vec![0.0, 5.0], vec![0.0, 0.0]];
    assert!(matches!(
        run_nuts(&target, &settings, Some(&on_bound)),
        Err(McmcError::InitOutOfBounds {
            chain: 0,
            index: 1,
            ..
        })
    ));
    let one = vec![vec![0.0, 0.0]];
    assert!(matches!(
        run_nuts(&target, &settings, Some(&one)),
        Err(McmcError::InitCount { .. })
    ));
    let good = vec![vec![0.5, -0.5], vec![1.0, 2.0]];
    let run = run_nuts(&target, &settings, Some(&good)).unwrap();
    assert_eq!(run.draws[0][0].len(), 10);
}

/// The NUTS CmdStan CSV: CmdStan's column order, the adaptation block, every value read back
/// bit for bit.
#[test]
fn cmdstan_nuts_columns_and_values() {
    use identify_mcmc::write_cmdstan_nuts_chain;
    let target = normal_target(2, 10.0);
    let settings = NutsSettings {
        seed: 21,
        chains: 2,
        warmup: 200,
        draws: 50,
        ..NutsSettings::default()
    };
    let run = run_nuts(&target, &settings, None).unwrap();
    let mut buf = Vec::new();
    write_cmdstan_nuts_chain(&run, &["a.b", "c"], 1, &["nuts test"], &mut buf).unwrap();
    let text = String::from_utf8(buf).unwrap();
    let mut lines = text.lines().filter(|l| !l.starts_with('#'));
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    assert_eq!(
        header,
        [
            "lp__",
            "accept_stat__",
            "stepsize__",
            "treedepth__",
            "n_leapfrog__",
            "divergent__",
            "energy__",
            "a_b",
            "c"
        ]
    );
    let rows: Vec<Vec<f64>> = lines
        .map(|l| l.split(',').map(|v| v.parse().unwrap()).collect())
        .collect();
    assert_eq!(rows.len(), 50);
    for (k, row) in rows.iter().enumerate() {
        let s = &run.stats[1][k];
        assert_eq!(row[0].to_bits(), s.lp.to_bits());
        assert_eq!(row[1].to_bits(), s.accept_stat.to_bits());
        assert_eq!(row[2].to_bits(), s.step_size.to_bits());
        assert_eq!(row[3], f64::from(s.tree_depth));
        assert_eq!(row[4], f64::from(s.n_leapfrog));
        assert_eq!(row[5], f64::from(u8::from(s.divergent)));
        assert_eq!(row[6].to_bits(), s.energy.to_bits());
        assert_eq!(row[7].to_bits(), run.draws[0][1][k].to_bits());
        assert_eq!(row[8].to_bits(), run.draws[1][1][k].to_bits());
    }
    assert!(text.contains("# nuts test\n"));
    assert!(text.contains("#     algorithm = hmc\n"));
    assert!(text.contains("#         engine = nuts\n"));
    assert!(text.contains("# id = 2\n"));
    assert!(text.contains(&format!("# Step size = {}\n", run.step_size[1])));
    assert!(write_cmdstan_nuts_chain(&run, &["a"], 0, &[], Vec::new()).is_err());
    assert!(write_cmdstan_nuts_chain(&run, &["a", "b"], 2, &[], Vec::new()).is_err());
}

/// `max_depth` caps every trajectory at `2^max_depth − 1` steps, and the caps are counted.
#[test]
fn max_depth_caps_the_trajectory() {
    let rho: f64 = 0.99;
    let target = FnGradLogDensity::new(vec![(-10.0, 10.0); 2], move |x: &[f64], g: &mut [f64]| {
        let c = 1.0 / (1.0 - rho * rho);
        g[0] = -c * (x[0] - rho * x[1]);
        g[1] = -c * (x[1] - rho * x[0]);
        Some(-0.5 * c * (x[0] * x[0] - 2.0 * rho * x[0] * x[1] + x[1] * x[1]))
    });
    let settings = NutsSettings {
        seed: 16,
        warmup: 300,
        draws: 300,
        max_depth: 2,
        ..NutsSettings::default()
    };
    let run = run_nuts(&target, &settings, None).unwrap();
    report("max depth 2", &run, 0.0);
    assert!(run
        .stats
        .iter()
        .flatten()
        .all(|s| s.tree_depth <= 2 && s.n_leapfrog <= 3));
    let hits = run
        .stats
        .iter()
        .flatten()
        .filter(|s| s.tree_depth == 2)
        .count() as u64;
    assert_eq!(hits, run.max_depth_hits);
    assert!(hits > 0);
}
