//! Criterion benches of the forward model on the seed fixture (`fixtures/seed/trial.csv`):
//! one full simulation (all three muscles integrated), one cost evaluation after an
//! annealing-like move of one muscle (one muscle integrated, two reused), and a move of `F0`
//! alone (nothing integrated).
//!
//! `cargo bench -p muscle-model --bench forward`

use criterion::{criterion_group, criterion_main, Criterion};
use muscle_model::{
    simulate, simulate_into, Effects, ModelParams, Problem, ProblemWorkspace, SimSettings,
    TrialInputs, Workspace,
};
use std::hint::black_box;

fn seed_inputs() -> (TrialInputs, Vec<f64>) {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../../fixtures/seed/trial.csv");
    let trial = experiment::read_trial(path).expect("fixtures/seed/trial.csv");
    let inputs = experiment::model_inputs(&trial, &Default::default()).expect("model inputs");
    let torque = trial.torque_nm.clone();
    (inputs, torque)
}

fn benches(c: &mut Criterion) {
    let (inputs, measured) = seed_inputs();
    let p = ModelParams::nominal();
    let e = Effects::none();
    let s = SimSettings::default();
    let mut ws = Workspace::new();
    let mut torque = vec![0.0; inputs.len()];
    // alternate between two parameter sets that differ in every muscle: no reuse possible
    // beyond the two cache slots, so use three sets
    let sets: Vec<ModelParams> = (0..3)
        .map(|k| {
            let mut q = p;
            for m in &mut q.muscles {
                m.lst_m *= 1.0 + 1e-4 * k as f64;
            }
            q
        })
        .collect();
    let mut k = 0;
    c.bench_function("forward simulation, seed trial, 3 muscles", |b| {
        b.iter(|| {
            k = (k + 1) % 3;
            simulate_into(&mut ws, &inputs, &sets[k], &e, &s, &mut torque).expect("sim");
            black_box(torque[100])
        })
    });
    c.bench_function("forward simulation, allocating simulate()", |b| {
        b.iter(|| black_box(simulate(&inputs, &p, &e, &s).expect("sim").torque[100]))
    });
    let problem = Problem::standard(inputs.clone(), measured).expect("problem");
    let x0 = problem.base_vector();
    let mut pws = ProblemWorkspace::new();
    let mut x = x0.clone();
    let mut j = 0;
    c.bench_function("cost, one muscle's LST moved (1 of 3 integrated)", |b| {
        b.iter(|| {
            j = (j + 1) % 3;
            x[0] = x0[0] * (1.0 + 1e-4 * j as f64);
            black_box(problem.sse_with(&x, &mut pws).expect("sse"))
        })
    });
    c.bench_function("cost, one muscle's F0 moved (none integrated)", |b| {
        b.iter(|| {
            j = (j + 1) % 3;
            x[1] = x0[1] * (1.0 + 1e-4 * j as f64);
            black_box(problem.sse_with(&x, &mut pws).expect("sse"))
        })
    });
}

criterion_group! {
    name = forward;
    config = Criterion::default().sample_size(30);
    targets = benches
}
criterion_main!(forward);
