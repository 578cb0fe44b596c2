//! The exact torque Jacobian (forward sensitivities) on the seed fixture, against difference
//! columns of tight simulations, and what it costs against a simulation. Measures the numbers
//! of `docs/model.md`, "Exact derivatives".
//!
//! `cargo run --release -p muscle-model --example exact_jacobian [-- POINTS SEED]`
//!
//! At the nominal point and `POINTS` random points of the bounds box (LST ±5 %, F0 and α0
//! ±20 %, ChaCha8 seed `SEED`), for the 9 identified parameters and the extensions' ones
//! (`curves.e0t`, `curves.flen`, an offset, gravity):
//!
//! * reference: Richardson extrapolation of central differences at steps 1e-2 and 5e-3 of the
//!   bound width, the fast form at rtol 1e-12, atol 1e-14;
//! * the exact column at the same settings, at `rtol 1e-10`, and at the default settings;
//! * a central difference at the default settings with the step in use (1e-3 of the width).
//!
//! Each as the RMS deviation from the reference in % of the reference's RMS, the worst over
//! the points.

use muscle_model::{
    simulate, Effects, ModelParams, ParamId, Problem, ProblemWorkspace, SimSettings,
};
use numerics::rms;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use std::time::Instant;

type Res<T> = Result<T, Box<dyn std::error::Error>>;

const FREE: [&str; 13] = [
    "sol.lst_m",
    "sol.fom_n",
    "sol.alpha_deg",
    "gm.lst_m",
    "gm.fom_n",
    "gm.alpha_deg",
    "gl.lst_m",
    "gl.fom_n",
    "gl.alpha_deg",
    "curves.e0t",
    "curves.flen",
    "torque_offset.offset_nm",
    "gravity.phase_deg",
];

fn fast(rtol: f64, atol: f64) -> SimSettings {
    SimSettings {
        rtol,
        atol,
        max_steps: 10_000_000,
        ..SimSettings::default()
    }
}

fn main() -> Res<()> {
    let args: Vec<u64> = std::env::args()
        .skip(1)
        .filter_map(|a| a.parse().ok())
        .collect();
    let points = args.first().copied().unwrap_or(4) as usize;
    let seed = args.get(1).copied().unwrap_or(2016);
    // the reference's smaller step (the larger is twice it)
    let ref_step: f64 = std::env::var("REF_STEP")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(5e-3);
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../../fixtures/seed/trial.csv");
    let trial = experiment::read_trial(path)?;
    let inputs = experiment::model_inputs(&trial, &Default::default())?;
    let n = inputs.len();
    let free: Vec<ParamId> = FREE
        .iter()
        .map(|s| ParamId::parse(s))
        .collect::<Result<_, _>>()?;
    let mut base_e = Effects::none();
    let mut base_p = ModelParams::nominal();
    // gravity present so that its phase has a derivative
    ParamId::parse("gravity.moment_nm")?.set(&mut base_p, &mut base_e, 3.0);
    let problem = |s: SimSettings| -> Res<Problem> {
        Ok(
            Problem::new(inputs.clone(), vec![0.0; n], base_p, base_e, free.clone())?
                .with_settings(s),
        )
    };
    let ref_rtol: f64 = std::env::var("REF_RTOL")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(1e-12);
    let reference_settings = fast(ref_rtol, ref_rtol * 1e-2);
    let p_ref = problem(reference_settings)?;
    let p_exact_tight = problem(fast(1e-12, 1e-14))?;
    let p_exact_mid = problem(fast(1e-10, 1e-12))?;
    let p_default = problem(SimSettings::default())?;
    let bounds = p_ref.bounds().to_vec();
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut xs = vec![p_ref.base_vector()];
    for _ in 0..points {
        xs.push(
            bounds
                .iter()
                .map(|&(lo, hi)| rng.random_range(lo..=hi))
                .collect(),
        );
    }
    let k = free.len();
    // worst % over the points, per column: [exact rtol 1e-12, exact 1e-10, exact default, FD default]
    let mut worst = vec![[0.0f64; 4]; k];
    let mut ws = ProblemWorkspace::new();
    for x in &xs {
        let central = |pr: &Problem, j: usize, s: f64| -> Res<Vec<f64>> {
            let h = s * (bounds[j].1 - bounds[j].0);
            let mut a = x.clone();
            let mut b = x.clone();
            a[j] += h;
            b[j] -= h;
            let (ta, tb) = (pr.predict(&a)?, pr.predict(&b)?);
            Ok(ta
                .iter()
                .zip(&tb)
                .map(|(p, q)| (p - q) / (2.0 * h))
                .collect())
        };
        let mut jacs = [Vec::new(), Vec::new(), Vec::new()];
        for (jac, pr) in jacs
            .iter_mut()
            .zip([&p_exact_tight, &p_exact_mid, &p_default])
        {
            pr.jacobian_with(x, &mut ws, jac)?;
        }
        for j in 0..k {
            let d1 = central(&p_ref, j, ref_step)?;
            let d2 = central(&p_ref, j, 2.0 * ref_step)?;
            let reference: Vec<f64> = d1
                .iter()
                .zip(&d2)
                .map(|(a, b)| (4.0 * a - b) / 3.0)
                .collect();
            let scale = rms(&reference).max(1e-300);
            let fd = central(&p_default, j, 1e-3)?;
            let cols: [&[f64]; 4] = [
                &jacs[0][j * n..(j + 1) * n],
                &jacs[1][j * n..(j + 1) * n],
                &jacs[2][j * n..(j + 1) * n],
                &fd,
            ];
            for (w, c) in worst[j].iter_mut().zip(cols) {
                let dev: Vec<f64> = c.iter().zip(&reference).map(|(a, b)| a - b).collect();
                *w = w.max(100.0 * rms(&dev) / scale);
            }
        }
    }
    println!(
        "seed trial, {n} samples, nominal + {points} random points (seed {seed}); RMS deviation \
         from the reference in % of its RMS, worst point"
    );
    println!(
        "{:>24} {:>14} {:>14} {:>14} {:>14}",
        "column", "exact 1e-12", "exact 1e-10", "exact default", "FD default"
    );
    for (j, w) in worst.iter().enumerate() {
        println!(
            "{:>24} {:>14.2e} {:>14.2e} {:>14.2e} {:>14.2e}",
            FREE[j], w[0], w[1], w[2], w[3]
        );
    }
    // cost: one simulation against one exact Jacobian, default settings (best of 5)
    let x = p_default.base_vector();
    let time = |f: &mut dyn FnMut() -> Res<()>| -> Res<f64> {
        let mut best = f64::INFINITY;
        for _ in 0..5 {
            let t = Instant::now();
            f()?;
            best = best.min(t.elapsed().as_secs_f64());
        }
        Ok(best)
    };
    let (p, e) = p_default.params_from_vector(&x)?;
    let t_sim = time(&mut || {
        simulate(&inputs, &p, &e, &SimSettings::default())?;
        Ok(())
    })?;
    let mut jac = Vec::new();
    let nine = Problem::new(
        inputs.clone(),
        vec![0.0; n],
        ModelParams::nominal(),
        Effects::none(),
        ParamId::identified().to_vec(),
    )?;
    let t_jac9 = time(&mut || {
        nine.jacobian_with(&nine.base_vector(), &mut ws, &mut jac)?;
        Ok(())
    })?;
    let t_jac = time(&mut || {
        p_default.jacobian_with(&x, &mut ws, &mut jac)?;
        Ok(())
    })?;
    println!(
        "\ncost, default settings (best of 5): simulation {:.2} ms; exact Jacobian, 9 identified \
         parameters {:.2} ms ({:.1} simulations); {} parameters {:.2} ms ({:.1} simulations)",
        1e3 * t_sim,
        1e3 * t_jac9,
        t_jac9 / t_sim,
        k,
        1e3 * t_jac,
        t_jac / t_sim
    );
    // a gait recording's size and free set: 61 s at 100 Hz (a low-rate trial, its tables on a
    // 400 Hz grid), the 9 identified parameters with the activation's shape and a delay
    let gait = muscle_model::synthetic::gait_like_trial(100.0, 61.0)?;
    let mut free = ParamId::identified().to_vec();
    free.push(ParamId::parse("activation.shape_a")?);
    free.push(ParamId::parse("electromechanical_delay.delay_ms")?);
    let (mut gp, mut ge) = (ModelParams::nominal(), Effects::none());
    free[9].set(&mut gp, &mut ge, 0.05);
    free[10].set(&mut gp, &mut ge, 40.0);
    let walk = Problem::new(gait.clone(), vec![0.0; gait.len()], gp, ge, free.clone())?;
    let t_gait_sim = time(&mut || {
        simulate(&gait, &gp, &ge, &SimSettings::default())?;
        Ok(())
    })?;
    let t_gait_jac = time(&mut || {
        walk.jacobian_with(&walk.base_vector(), &mut ws, &mut jac)?;
        Ok(())
    })?;
    println!(
        "61 s gait-like trial at 100 Hz: simulation {:.1} ms; exact Jacobian, {} parameters \
         (with activation.shape_a and the delay) {:.1} ms ({:.1} simulations)",
        1e3 * t_gait_sim,
        free.len(),
        1e3 * t_gait_jac,
        t_gait_jac / t_gait_sim
    );
    Ok(())
}
