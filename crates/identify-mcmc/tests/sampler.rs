//! The sampler on targets with known moments, its determinism, failure handling
//! and its honesty about the convergence cap.

use std::ops::ControlFlow;

use identify_mcmc::diagnostics::ess_mean;
use identify_mcmc::{
    run, run_with_observer, ChainPhase, ChainStopReason, FnLogDensity, LogDensity, McmcError,
    McmcSettings, Proposal, RunResult,
};

/// `E f` from the pooled draws and its Monte Carlo standard error
/// `sd(f)/√ESS(f)`, ESS from the split-chain estimator of `f`'s own chains.
fn estimate(result: &RunResult, f: impl Fn(&[f64]) -> f64) -> (f64, f64) {
    let n_chains = result.draws[0].len();
    let n = result.draws[0][0].len();
    let chains: Vec<Vec<f64>> = (0..n_chains)
        .map(|c| {
            (0..n)
                .map(|k| {
                    let x: Vec<f64> = (0..result.dim).map(|i| result.draws[i][c][k]).collect();
                    f(&x)
                })
                .collect()
        })
        .collect();
    let refs: Vec<&[f64]> = chains.iter().map(|c| c.as_slice()).collect();
    let all: Vec<f64> = chains.iter().flatten().copied().collect();
    let m = all.iter().sum::<f64>() / all.len() as f64;
    let sd = (all.iter().map(|v| (v - m) * (v - m)).sum::<f64>() / (all.len() - 1) as f64).sqrt();
    let ess = ess_mean(&refs);
    assert!(ess.is_finite() && ess > 100.0, "ESS of the estimate {ess}");
    (m, sd / ess.sqrt())
}

/// Assert `|E f − truth| < 4·MCSE` and return the error in MCSE units.
fn check_moment(result: &RunResult, name: &str, truth: f64, f: impl Fn(&[f64]) -> f64) -> f64 {
    let (m, se) = estimate(result, f);
    let z = (m - truth) / se;
    eprintln!("{name}: estimate {m:.4}, truth {truth:.4}, MCSE {se:.4}, z = {z:+.2}");
    assert!(
        z.abs() < 4.0,
        "{name}: {m} vs {truth} is {z:.2} Monte Carlo standard errors off"
    );
    z
}

fn gaussian_2d() -> FnLogDensity<impl Fn(&[f64]) -> Option<f64> + Sync> {
    // Means (1, −2), sds (1, 2), correlation 0.9.
    let (m1, m2, s1, s2, rho) = (1.0, -2.0, 1.0, 2.0, 0.9);
    FnLogDensity::new(vec![(-20.0, 20.0), (-40.0, 40.0)], move |x: &[f64]| {
        let a = (x[0] - m1) / s1;
        let b = (x[1] - m2) / s2;
        Some(-0.5 * (a * a - 2.0 * rho * a * b + b * b) / (1.0 - rho * rho))
    })
}

fn check_gaussian(result: &RunResult) {
    let (m1, m2, s1, s2, rho) = (1.0, -2.0, 1.0, 2.0, 0.9);
    check_moment(result, "mean x", m1, |x| x[0]);
    check_moment(result, "mean y", m2, |x| x[1]);
    check_moment(result, "var x", s1 * s1, |x| (x[0] - m1).powi(2));
    check_moment(result, "var y", s2 * s2, |x| (x[1] - m2).powi(2));
    check_moment(result, "cov xy", rho * s1 * s2, |x| {
        (x[0] - m1) * (x[1] - m2)
    });
}

#[test]
fn adaptive_sampler_recovers_correlated_gaussian() {
    let target = gaussian_2d();
    let settings = McmcSettings {
        seed: 11,
        ess_target: 2000.0,
        ..McmcSettings::default()
    };
    let result = run(&target, &settings, None).unwrap();
    assert!(result.converged, "stop = {:?}", result.stop);
    assert_eq!(result.stop, ChainStopReason::Converged);
    for s in &result.summary {
        assert!(s.rhat < 1.01 && s.ess_bulk >= 2000.0);
    }
    for &a in &result.acceptance_rate {
        assert!(a > 0.15 && a < 0.45, "acceptance {a}");
    }
    assert!((result.correlation[0][1] - 0.9).abs() < 0.02);
    eprintln!(
        "gaussian: warm-up {}, sampling {}, acceptance {:?}",
        result.warmup_iterations, result.sampling_iterations, result.acceptance_rate
    );
    check_gaussian(&result);
}

#[test]
fn dissertation_proposal_recovers_correlated_gaussian() {
    let target = gaussian_2d();
    let settings = McmcSettings {
        seed: 5,
        proposal: Proposal::Dissertation { scale: 0.02 },
        ess_target: 1500.0,
        max_total: 200_000,
        ..McmcSettings::default()
    };
    let result = run(&target, &settings, None).unwrap();
    assert!(result.converged, "stop = {:?}", result.stop);
    check_gaussian(&result);
}

#[test]
fn adaptive_sampler_recovers_banana() {
    // Haario et al.'s twisted Gaussian: y = (x1, x2 + b·x1² − 100b) ~ N(0, diag(100, 1)).
    // E x = 0, var x1 = 100, var x2 = 1 + 2·b²·100² = 19, cov = 0.
    let b = 0.03;
    let target = FnLogDensity::new(vec![(-60.0, 60.0), (-120.0, 20.0)], move |x: &[f64]| {
        let y2 = x[1] + b * x[0] * x[0] - 100.0 * b;
        Some(-0.5 * (x[0] * x[0] / 100.0 + y2 * y2))
    });
    let settings = McmcSettings {
        seed: 3,
        ess_target: 1500.0,
        max_total: 400_000,
        ..McmcSettings::default()
    };
    let result = run(&target, &settings, None).unwrap();
    assert!(result.converged, "stop = {:?}", result.stop);
    eprintln!(
        "banana: warm-up {}, sampling {}",
        result.warmup_iterations, result.sampling_iterations
    );
    check_moment(&result, "mean x1", 0.0, |x| x[0]);
    check_moment(&result, "mean x2", 0.0, |x| x[1]);
    check_moment(&result, "var x1", 100.0, |x| x[0] * x[0]);
    check_moment(&result, "var x2", 19.0, |x| x[1] * x[1]);
    check_moment(&result, "cov x1 x2", 0.0, |x| x[0] * x[1]);
}

#[test]
fn results_do_not_depend_on_thread_count() {
    let target = gaussian_2d();
    let settings = McmcSettings {
        seed: 99,
        warmup_min: 1000,
        block: 500,
        max_total: 6000,
        ..McmcSettings::default()
    };
    let run_on = |threads: usize| {
        rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap()
            .install(|| run(&target, &settings, None).unwrap())
    };
    let one = run_on(1);
    let two = run_on(2);
    assert!(!one.draws[0][0].is_empty());
    // Bit-identical draws (f64 == on every value) and identical bookkeeping.
    assert_eq!(one.draws, two.draws);
    assert_eq!(one.log_density, two.log_density);
    assert_eq!(one.warmup_iterations, two.warmup_iterations);
    assert_eq!(one.evaluations, two.evaluations);
    // Different seeds give different chains, and the chains differ from each other.
    let other = run(
        &target,
        &McmcSettings {
            seed: 100,
            ..settings
        },
        None,
    )
    .unwrap();
    assert_ne!(one.draws[0][0][..10], other.draws[0][0][..10]);
    assert_ne!(one.draws[0][0][..10], one.draws[0][1][..10]);
}

#[test]
fn failed_evaluations_are_rejections() {
    // A standard normal whose "simulation" fails for x > 0.5 and returns NaN for x < −2.
    let target = FnLogDensity::new(vec![(-5.0, 5.0)], |x: &[f64]| {
        if x[0] > 0.5 {
            None
        } else if x[0] < -2.0 {
            Some(f64::NAN)
        } else {
            Some(-0.5 * x[0] * x[0])
        }
    });
    let settings = McmcSettings {
        seed: 1,
        warmup_min: 1000,
        block: 1000,
        max_total: 20_000,
        ..McmcSettings::default()
    };
    let result = run(&target, &settings, None).unwrap();
    assert!(result.failed_evaluations > 100);
    let all: Vec<f64> = result.draws[0].iter().flatten().copied().collect();
    assert!(!all.is_empty());
    assert!(all.iter().all(|&v| (-2.0..=0.5).contains(&v)));
    // The truncated normal on [−2, 0.5] has mean (φ(−2) − φ(0.5))/(Φ(0.5) − Φ(−2)).
    check_moment(&result, "truncated mean", -0.445_743_778_3, |x| x[0]);
}

#[test]
fn cap_is_reported_not_claimed_as_convergence() {
    // Two far-apart modes: chains stuck in different modes never agree.
    let target = FnLogDensity::new(vec![(-30.0, 30.0)], |x: &[f64]| {
        let a = -0.5 * (x[0] - 15.0).powi(2);
        let b = -0.5 * (x[0] + 15.0).powi(2);
        Some(a.max(b) + (1.0 + (-(a - b).abs()).exp()).ln())
    });
    let init = vec![vec![15.0], vec![-15.0], vec![15.0], vec![-15.0]];
    let settings = McmcSettings {
        seed: 2,
        warmup_min: 1000,
        block: 1000,
        max_total: 8000,
        ..McmcSettings::default()
    };
    let mut reports = Vec::new();
    let result = run_with_observer(&target, &settings, Some(&init), |p| {
        reports.push(*p);
        ControlFlow::Continue(())
    })
    .unwrap();
    assert_eq!(result.stop, ChainStopReason::CapReached);
    assert!(!result.converged);
    assert!(!result.warmup_converged);
    assert_eq!(result.warmup_iterations + result.sampling_iterations, 8000);
    assert!(
        result.summary[0].rhat > 1.5,
        "rhat {}",
        result.summary[0].rhat
    );
    assert!(reports.iter().any(|p| p.phase == ChainPhase::Warmup));
    assert!(reports.iter().any(|p| p.phase == ChainPhase::Sampling));
    assert_eq!(reports.last().unwrap().iterations, 8000);

    // An unreachable ESS target on an easy target also ends at the cap.
    let easy = gaussian_2d();
    let settings = McmcSettings {
        ess_target: 1e9,
        warmup_min: 1000,
        block: 1000,
        max_total: 5000,
        ..McmcSettings::default()
    };
    let result = run(&easy, &settings, None).unwrap();
    assert_eq!(result.stop, ChainStopReason::CapReached);
    assert!(!result.converged);
}

#[test]
fn observer_can_stop_the_run() {
    let target = gaussian_2d();
    let settings = McmcSettings {
        warmup_min: 1000,
        block: 500,
        ess_target: 1e9,
        ..McmcSettings::default()
    };
    let mut calls = 0;
    let result = run_with_observer(&target, &settings, None, |p| {
        calls += 1;
        if p.phase == ChainPhase::Sampling {
            ControlFlow::Break(())
        } else {
            ControlFlow::Continue(())
        }
    })
    .unwrap();
    assert_eq!(result.stop, ChainStopReason::Stopped);
    assert!(!result.converged);
    assert_eq!(result.sampling_iterations, 500);
    assert_eq!(result.draws[0][0].len(), 500);
    assert!(calls >= 3);
}

#[test]
fn thinning_keeps_every_kth_state() {
    let target = gaussian_2d();
    let settings = McmcSettings {
        thin: 5,
        warmup_min: 1000,
        block: 1000,
        max_total: 4000,
        ess_target: 1e9,
        ..McmcSettings::default()
    };
    let result = run(&target, &settings, None).unwrap();
    assert_eq!(
        result.draws[0][0].len() * 5,
        result.sampling_iterations,
        "kept draws"
    );
}

#[test]
fn identifiability_flags_an_unconstrained_parameter() {
    // x0 is pinned by the data, x1 is not (flat on its bounds).
    let target = FnLogDensity::new(vec![(0.0, 1.0), (0.0, 1.0)], |x: &[f64]| {
        Some(-0.5 * ((x[0] - 0.3) / 0.01).powi(2))
    });
    let settings = McmcSettings {
        seed: 8,
        ..McmcSettings::default()
    };
    let result = run(&target, &settings, None).unwrap();
    assert!(result.converged);
    let s = &result.summary;
    assert!(s[0].identifiable && s[0].prior_sd_ratio < 0.1);
    assert!(!s[1].identifiable && (s[1].prior_sd_ratio - 1.0).abs() < 0.1);
    assert!((s[0].q05 - (0.3 - 1.645 * 0.01)).abs() < 0.003);
    assert!((s[0].q95 - (0.3 + 1.645 * 0.01)).abs() < 0.003);
}

#[test]
fn invalid_input_is_an_error() {
    let target = gaussian_2d();
    let bad = McmcSettings {
        n_chains: 0,
        ..McmcSettings::default()
    };
    assert!(matches!(
        run(&target, &bad, None),
        Err(McmcError::InvalidSetting {
            name: "n_chains",
            ..
        })
    ));
    let bad = McmcSettings {
        proposal: Proposal::Dissertation { scale: -1.0 },
        ..McmcSettings::default()
    };
    assert!(matches!(
        run(&target, &bad, None),
        Err(McmcError::InvalidSetting { .. })
    ));
    let bad = McmcSettings {
        max_total: 10,
        ..McmcSettings::default()
    };
    assert!(matches!(
        run(&target, &bad, None),
        Err(McmcError::InvalidSetting {
            name: "max_total",
            ..
        })
    ));
    let ok = McmcSettings::default();
    let wrong_count = vec![vec![0.0, 0.0]; 3];
    assert_eq!(
        run(&target, &ok, Some(&wrong_count)).unwrap_err(),
        McmcError::InitCount {
            expected: 4,
            got: 3
        }
    );
    let mut outside = vec![vec![0.0, 0.0]; 4];
    outside[2] = vec![0.0, 50.0];
    assert_eq!(
        run(&target, &ok, Some(&outside)).unwrap_err(),
        McmcError::InitOutOfBounds {
            chain: 2,
            index: 1,
            value: 50.0
        }
    );
    let short = vec![vec![0.0]; 4];
    assert!(matches!(
        run(&target, &ok, Some(&short)),
        Err(McmcError::InitDimension { chain: 0, .. })
    ));
    let inverted = FnLogDensity::new(vec![(1.0, -1.0)], |_: &[f64]| Some(0.0));
    assert!(matches!(
        run(&inverted, &ok, None),
        Err(McmcError::InvalidBounds { index: 0, .. })
    ));
    let always_fails = FnLogDensity::new(vec![(0.0, 1.0)], |_: &[f64]| None);
    assert!(matches!(
        run(&always_fails, &ok, None),
        Err(McmcError::NoValidStart { chain: 0, .. })
    ));
    assert_eq!(always_fails.dim(), 1);
}

#[test]
fn settings_round_trip_through_json() {
    let s = McmcSettings {
        seed: 3,
        proposal: Proposal::Dissertation { scale: 0.01 },
        ..McmcSettings::default()
    };
    let json = serde_json::to_string(&s).unwrap();
    let back: McmcSettings = serde_json::from_str(&json).unwrap();
    assert_eq!(s, back);
    // Missing fields take their defaults.
    let partial: McmcSettings = serde_json::from_str(r#"{"seed": 9}"#).unwrap();
    assert_eq!(
        partial,
        McmcSettings {
            seed: 9,
            ..McmcSettings::default()
        }
    );
}

#[test]
fn narrow_correlated_posterior_in_a_wide_box() {
    // The identification setting: 9 parameters, posterior sd ~ 0.2–1 % of the
    // bounds width, neighbours correlated (AR(1) covariance, ρ = 0.8).
    let d = 9;
    let sd: Vec<f64> = (0..d).map(|i| 0.002 + 0.001 * i as f64).collect();
    let centre: Vec<f64> = (0..d).map(|i| 0.3 + 0.05 * i as f64).collect();
    let rho: f64 = 0.8;
    let (c, s) = (centre.clone(), sd.clone());
    // AR(1) precision is tridiagonal: log π = −½ Σ … with u_i = (x_i − c_i)/s_i.
    let target = FnLogDensity::new(vec![(0.0, 1.0); d], move |x: &[f64]| {
        let u: Vec<f64> = (0..x.len()).map(|i| (x[i] - c[i]) / s[i]).collect();
        let mut q = u[0] * u[0];
        for i in 1..u.len() {
            let e = u[i] - rho * u[i - 1];
            q += e * e / (1.0 - rho * rho);
        }
        Some(-0.5 * q)
    });
    let settings = McmcSettings {
        seed: 21,
        ..McmcSettings::default()
    };
    let result = run(&target, &settings, None).unwrap();
    eprintln!(
        "9-D: warm-up {}, sampling {}, acceptance {:?}, evaluations {}",
        result.warmup_iterations,
        result.sampling_iterations,
        result.acceptance_rate,
        result.evaluations
    );
    assert!(result.converged, "stop = {:?}", result.stop);
    for i in 0..d {
        check_moment(&result, &format!("mean x{i}"), centre[i], |x| x[i]);
        let s = &result.summary[i];
        assert!(s.identifiable && s.rhat < 1.01 && s.ess_bulk >= 400.0);
        assert!(
            (s.sd / sd[i] - 1.0).abs() < 0.2,
            "sd x{i}: {} vs {}",
            s.sd,
            sd[i]
        );
    }
    // Neighbours are the strongest correlations (theory 0.8; next-nearest 0.64).
    let top = result.strongest_correlations[0];
    assert_eq!(top.j, top.i + 1);
    assert!((top.r - 0.8).abs() < 0.1, "r = {}", top.r);
}

/// A target sampled in `v` that reports `x = 3 + 2v` (bounds `(−7, 13)`) and stores
/// `log π + 1`: draws, summaries and the stored log density are the reported ones, the
/// monitored coordinates too.
struct Shifted;

impl LogDensity for Shifted {
    fn dim(&self) -> usize {
        1
    }
    fn bounds(&self) -> &[(f64, f64)] {
        &[(-5.0, 5.0)]
    }
    fn log_density(&self, v: &[f64]) -> Option<f64> {
        Some(-0.5 * v[0] * v[0])
    }
    fn report_bounds(&self) -> &[(f64, f64)] {
        &[(-7.0, 13.0)]
    }
    fn evaluate(&self, v: &[f64], report: &mut [f64]) -> Option<(f64, f64)> {
        report[0] = 3.0 + 2.0 * v[0];
        self.log_density(v).map(|l| (l, l + 1.0))
    }
}

#[test]
fn draws_and_summaries_are_in_reported_coordinates() {
    let settings = McmcSettings {
        seed: 5,
        warmup_min: 1_000,
        block: 500,
        max_total: 20_000,
        ..McmcSettings::default()
    };
    let r = run(&Shifted, &settings, None).unwrap();
    assert!(r.converged);
    check_moment(&r, "mean x", 3.0, |x| x[0]);
    check_moment(&r, "E (x − 3)²", 4.0, |x| (x[0] - 3.0) * (x[0] - 3.0));
    for (xs, lps) in r.draws[0].iter().zip(&r.log_density) {
        for (x, lp) in xs.iter().zip(lps) {
            let v = (x - 3.0) / 2.0;
            assert!((lp - (1.0 - 0.5 * v * v)).abs() < 1e-12);
        }
    }
    // The prior sd is that of the reported bounds: 20/√12.
    assert!((r.summary[0].prior_sd - 20.0 / 12f64.sqrt()).abs() < 1e-12);
    // The sampler's own coordinate stays within |v| ≲ 5.
    assert!(r.max_abs_coordinate > 2.0 && r.max_abs_coordinate <= 5.0);
}

/// Two well separated 2-D Gaussian modes with weights 0.3 / 0.7: a local random walk started
/// in one mode never reaches the other, the mode-jumping mixture proposal recovers the weights.
#[test]
fn mixture_proposal_crosses_between_separated_modes() {
    use identify_mcmc::{run_with_proposal, ComponentSpec, MixtureProposal};
    let (w1, w2) = (0.3f64, 0.7f64);
    let log_pdf = move |x: &[f64]| {
        let a = -0.5 * ((x[0] + 6.0).powi(2) + (x[1] - 1.0).powi(2));
        let b = -0.5 * ((x[0] - 6.0).powi(2) + (x[1] + 1.0).powi(2));
        let m = a.max(b);
        Some(m + (w1 * (a - m).exp() + w2 * (b - m).exp()).ln())
    };
    let target = FnLogDensity::new(vec![(-20.0, 20.0), (-20.0, 20.0)], log_pdf);
    let settings = McmcSettings {
        seed: 11,
        warmup_min: 2_000,
        block: 1_000,
        max_total: 40_000,
        ..McmcSettings::default()
    };
    // Every chain starts in the left mode (weight 0.3).
    let inits = vec![vec![-6.0, 1.0]; settings.n_chains];
    let local = McmcSettings {
        proposal: Proposal::Dissertation { scale: 0.02 },
        ..settings
    };
    let rw = run(&target, &local, Some(&inits)).unwrap();
    let right = |r: &RunResult| {
        let all: Vec<f64> = r.draws[0].iter().flatten().copied().collect();
        all.iter().filter(|v| **v > 0.0).count() as f64 / all.len() as f64
    };
    assert!(right(&rw) < 0.01, "the random walk crossed: {}", right(&rw));
    // Components deliberately off-centre and too wide: the MH correction must fix that.
    let comps = [
        ComponentSpec {
            weight: 1.0,
            mean: vec![-5.5, 0.5],
            cov: vec![2.0, 0.3, 0.3, 1.5],
        },
        ComponentSpec {
            weight: 1.0,
            mean: vec![6.5, -0.5],
            cov: vec![1.5, 0.0, 0.0, 2.0],
        },
    ];
    let mix = MixtureProposal::new(vec![0, 1], &comps, 4.0, 0.3).unwrap();
    let res = run_with_proposal(&target, &settings, Some(&inits), Some(&mix), |_| {
        ControlFlow::Continue(())
    })
    .unwrap();
    assert!(res.converged, "stopped by {:?}", res.stop);
    let z = check_moment(&res, "P(right mode)", w2, |x| {
        f64::from(u8::from(x[0] > 0.0))
    });
    assert!(z.abs() < 4.0);
    check_moment(&res, "E x", w1 * -6.0 + w2 * 6.0, |x| x[0]);
    check_moment(&res, "E y", w1 - w2, |x| x[1]);
    let jump: Vec<f64> = res.jump_acceptance_rate.clone();
    assert!(
        jump.iter().all(|r| *r > 0.05 && *r < 1.0),
        "jump acceptance {jump:?}"
    );
}
