//! Success rates of `run` on the standard test functions over many seeds.
//!
//! `cargo run --release -p identify-sa --example success_rates [SEEDS]`
//!
//! `SA_SETTINGS='{"cooling":0.8}'` overrides settings (JSON, missing fields
//! default); `SA_CASE=4` runs only that row of the table.

use identify_sa::test_functions::{Kind, TestFunction};
use identify_sa::{run, AnnealSettings, NoObserver, Objective};

fn main() {
    let seeds: u64 = std::env::args()
        .nth(1)
        .and_then(|s| s.parse().ok())
        .unwrap_or(20);
    let cases = [
        (Kind::Rosenbrock, 2, 5_000u64),
        (Kind::Rosenbrock, 5, 20_000),
        (Kind::Rosenbrock, 10, 50_000),
        (Kind::Rastrigin, 2, 10_000),
        (Kind::Rastrigin, 5, 100_000),
        (Kind::Ackley, 2, 10_000),
        (Kind::Ackley, 10, 50_000),
    ];
    let only: Option<usize> = std::env::var("SA_CASE").ok().and_then(|v| v.parse().ok());
    for (i, &(kind, dim, budget)) in cases.iter().enumerate() {
        if only.is_some_and(|o| o != i) {
            continue;
        }
        let mut ok = 0;
        let mut evals = Vec::new();
        let mut worst: f64 = 0.0;
        let mut reanneals = 0;
        let t = std::time::Instant::now();
        for seed in 0..seeds {
            let mut f = TestFunction::new(kind, dim);
            let base: AnnealSettings = std::env::var("SA_SETTINGS")
                .ok()
                .and_then(|j| serde_json::from_str(&j).ok())
                .unwrap_or_default();
            let s = base.with_seed(seed).with_max_evaluations(budget);
            let out = match run(&mut f, None, &s, &mut NoObserver) {
                Ok(o) => o,
                Err(e) => {
                    println!("error {e}");
                    continue;
                }
            };
            assert_eq!(out.evaluations, f.evaluations);
            let success = match kind {
                Kind::Rastrigin => {
                    let xs = f.minimiser();
                    out.x.iter().zip(&xs).all(|(a, b)| (a - b).abs() < 0.5)
                }
                _ => out.cost < 1e-4,
            };
            if success {
                ok += 1;
            }
            worst = worst.max(out.cost);
            evals.push(out.evaluations);
            reanneals += out.reanneals;
            let _ = f.dim();
        }
        evals.sort_unstable();
        println!(
            "{kind:?} {dim}D budget {budget}: {ok}/{seeds} success, median evals {}, worst cost {worst:.3e}, mean reanneals {:.1}, {:.2?}",
            evals[evals.len() / 2],
            f64::from(reanneals) / seeds as f64,
            t.elapsed()
        );
    }
}
