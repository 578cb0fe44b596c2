//! Print the stage history of one run on a standard function.
//!
//! `cargo run --release -p identify-sa --example trace -- KIND DIM BUDGET SEED`

use identify_sa::test_functions::{Kind, TestFunction};
use identify_sa::{run, AnnealSettings, NoObserver};

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let kind = match args.get(1).map(String::as_str) {
        Some("rastrigin") => Kind::Rastrigin,
        Some("ackley") => Kind::Ackley,
        Some("sphere") => Kind::Sphere,
        _ => Kind::Rosenbrock,
    };
    let dim = args.get(2).and_then(|s| s.parse().ok()).unwrap_or(5);
    let budget = args.get(3).and_then(|s| s.parse().ok()).unwrap_or(60_000);
    let seed = args.get(4).and_then(|s| s.parse().ok()).unwrap_or(0);
    let mut f = TestFunction::new(kind, dim);
    let base: AnnealSettings = std::env::var("SA_SETTINGS")
        .ok()
        .and_then(|j| serde_json::from_str(&j).ok())
        .unwrap_or_default();
    let s = base.with_seed(seed).with_max_evaluations(budget);
    match run(&mut f, None, &s, &mut NoObserver) {
        Ok(out) => {
            for r in &out.history {
                println!(
                    "stage {:4} evals {:7} T {:10.3e} best {:10.4e} cur {:10.4e} acc {:5.3} step {:9.2e} re {}",
                    r.stage, r.evaluations, r.temperature, r.best_cost, r.current_cost, r.acceptance, r.mean_step, r.reanneals
                );
            }
            println!(
                "cost {:.4e} (annealing {:.4e}), evals {}, polish {}, stop {:?}, x {:?}",
                out.cost,
                out.annealing_cost,
                out.evaluations,
                out.polish_evaluations,
                out.stop,
                out.x
            );
        }
        Err(e) => println!("error: {e}"),
    }
}
