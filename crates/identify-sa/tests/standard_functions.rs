//! Success rates on standard functions with known minima, over 20 seeds each,
//! within a fixed evaluation budget (default settings, random start).

use identify_sa::test_functions::{Kind, TestFunction};
use identify_sa::{run, AnnealSettings, NoObserver};

const SEEDS: std::ops::Range<u64> = 1000..1020;

/// Runs `kind` in `dim` dimensions for every seed; returns the successes.
fn successes(kind: Kind, dim: usize, budget: u64) -> usize {
    let mut ok = 0;
    for seed in SEEDS {
        let mut f = TestFunction::new(kind, dim);
        let settings = AnnealSettings::default()
            .with_seed(seed)
            .with_max_evaluations(budget);
        let out = run(&mut f, None, &settings, &mut NoObserver).expect("valid problem");
        // The budget is a hard limit and the count is exact.
        assert!(
            out.evaluations <= budget,
            "{kind:?} {dim}D seed {seed}: {} evaluations",
            out.evaluations
        );
        assert_eq!(out.evaluations, f.evaluations);
        assert_eq!(
            out.cost,
            f.value(&out.x),
            "reported cost must be the cost at x"
        );
        let success = match kind {
            // Global basin: every coordinate nearer to 0 than to any other local minimiser.
            Kind::Rastrigin => out.x.iter().all(|v| v.abs() < 0.5),
            _ => out.cost < 1e-4,
        };
        ok += usize::from(success);
    }
    eprintln!("{kind:?} {dim}D, budget {budget}: {ok}/20 successes");
    ok
}

#[test]
fn rosenbrock_2d_at_least_19_of_20_within_5000_evaluations() {
    let ok = successes(Kind::Rosenbrock, 2, 5_000);
    assert!(ok >= 19, "{ok}/20");
}

#[test]
fn rosenbrock_5d_at_least_17_of_20_within_20000_evaluations() {
    let ok = successes(Kind::Rosenbrock, 5, 20_000);
    assert!(ok >= 17, "{ok}/20");
}

#[test]
fn rosenbrock_10d_at_least_17_of_20_within_50000_evaluations() {
    let ok = successes(Kind::Rosenbrock, 10, 50_000);
    assert!(ok >= 17, "{ok}/20");
}

#[test]
fn rastrigin_2d_at_least_19_of_20_within_10000_evaluations() {
    let ok = successes(Kind::Rastrigin, 2, 10_000);
    assert!(ok >= 19, "{ok}/20");
}

#[test]
fn rastrigin_5d_at_least_16_of_20_within_100000_evaluations() {
    let ok = successes(Kind::Rastrigin, 5, 100_000);
    assert!(ok >= 16, "{ok}/20");
}

#[test]
fn ackley_2d_at_least_19_of_20_within_10000_evaluations() {
    let ok = successes(Kind::Ackley, 2, 10_000);
    assert!(ok >= 19, "{ok}/20");
}

#[test]
fn ackley_10d_at_least_19_of_20_within_50000_evaluations() {
    let ok = successes(Kind::Ackley, 10, 50_000);
    assert!(ok >= 19, "{ok}/20");
}
