//! Integration jitter on the seed fixture: how far the simulated torque moves when the angle or
//! one parameter moves by a hair, and what that does to finite-difference Jacobians. Measures
//! the numbers of `docs/model.md`, section 6, "Integration jitter".
//!
//! `cargo run --release -p muscle-model --example jitter`
//!
//! 1. The angle: every `ankle_angle_deg` of the trial plus δ = 1e-12 … 1e-3 degrees.
//! 2. One parameter times (1 + δ), δ = 1e-12 … 1e-3, at the nominal parameters; then
//!    `POINTS` random points of the bounds box (LST ±5 %, F0 and α0 ±20 %; ChaCha8, seed
//!    `SEED`) with the angle and each of the nine identified parameters moved by 1e-12.
//! 3. Central (and forward) difference columns `∂τ/∂θ` with the step a share `s` of the
//!    parameter's bound width, as the project's Jacobians take it, against a reference from
//!    the tight settings (Richardson extrapolation of central differences at `s` = 1e-2 and
//!    5e-3), at the nominal point and at the random point of 2 whose parameter jump is largest.
//!
//! `JITTER_TRIAL=<file.csv>` also writes the seed trial with every angle + 1e-12° (for
//! `surae simulate` / `surae identify` on both).
//!
//! Deviations are max and RMS over the samples; "slope" is RMS(Δτ)/δ (N·m per degree for the
//! angle, N·m per unit relative change for a parameter), constant when the torque moves
//! smoothly with δ and growing as δ shrinks where a jitter floor takes over.

use muscle_model::{
    simulate, Effects, Formulation, ModelParams, ParamId, SimSettings, TrialInputs,
};
use numerics::rms;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use std::time::Instant;

/// A change of the torque larger than this (N·m) is a jump of the step sequence, not rounding.
const JUMP: f64 = 1e-7;

type Res<T> = Result<T, Box<dyn std::error::Error>>;

fn env(k: &str, d: u64) -> u64 {
    std::env::var(k)
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(d)
}

/// (max, RMS) of `a − b`.
fn dev(a: &[f64], b: &[f64]) -> (f64, f64) {
    let d: Vec<f64> = a.iter().zip(b).map(|(x, y)| x - y).collect();
    (d.iter().fold(0.0, |m, x| f64::max(m, x.abs())), rms(&d))
}

fn torque(inputs: &TrialInputs, p: &ModelParams, s: &SimSettings) -> Res<Vec<f64>> {
    Ok(simulate(inputs, p, &Effects::none(), s)?.torque)
}

/// The torque and the right-hand-side evaluations of the three muscles.
fn run(inputs: &TrialInputs, p: &ModelParams, s: &SimSettings) -> Res<(Vec<f64>, i64)> {
    let out = simulate(inputs, p, &Effects::none(), s)?;
    let calls = i64::try_from(out.total_stats().rhs_calls)?;
    Ok((out.torque, calls))
}

/// `p` with parameter `id` set to `v`.
fn with(p: &ModelParams, id: ParamId, v: f64) -> ModelParams {
    let mut q = *p;
    id.set(&mut q, &mut Effects::none(), v);
    q
}

fn get(p: &ModelParams, id: ParamId) -> f64 {
    id.get(p, &Effects::none())
}

/// The bound width of `id` around the nominal parameters (`ParamId::default_bounds`: LST ±5 %,
/// F0 and α0 ±20 %).
fn width(id: ParamId) -> f64 {
    let (lo, hi) = id.default_bounds(&ModelParams::nominal(), &Effects::none());
    hi - lo
}

fn pid(name: &str) -> ParamId {
    ParamId::parse(name).expect("parameter name")
}

/// The FD columns of a few parameters at `p` with steps `s·(bound width)`, as the RMS deviation
/// from the tight reference in % of the reference's RMS.
fn fd_table(
    inputs: &TrialInputs,
    label: &str,
    p: &ModelParams,
    schemes: &[(&str, SimSettings, bool)],
) -> Res<()> {
    let steps = [1e-2, 4e-3, 1e-3, 1e-4, 1e-5, 1e-6, 1e-7, 1e-8];
    let central = |id: ParamId, h: f64, s: &SimSettings| -> Res<Vec<f64>> {
        let v = get(p, id);
        let a = torque(inputs, &with(p, id, v + h), s)?;
        let b = torque(inputs, &with(p, id, v - h), s)?;
        Ok(a.iter().zip(&b).map(|(x, y)| (x - y) / (2.0 * h)).collect())
    };
    println!(
        "\n(c) {label}: difference column ∂τ/∂θ, step h = s·(bound width), RMS deviation from \
         the reference (tight, Richardson of central differences at s = 1e-2 and 5e-3), \
         % of the reference's RMS"
    );
    print!("{:>12} {:20}", "parameter", "scheme");
    for s in steps {
        print!(" {s:>8.0e}");
    }
    println!();
    let tight = SimSettings::tight();
    for name in ["sol.lst_m", "gm.alpha_deg", "gl.alpha_deg", "sol.fom_n"] {
        let id = pid(name);
        let w = width(id);
        let d1 = central(id, 5e-3 * w, &tight)?;
        let d2 = central(id, 1e-2 * w, &tight)?;
        let reference: Vec<f64> = d1
            .iter()
            .zip(&d2)
            .map(|(a, b)| (4.0 * a - b) / 3.0)
            .collect();
        let scale = rms(&reference);
        for (scheme, s, is_central) in schemes {
            print!("{name:>12} {scheme:20}");
            let base = if *is_central {
                Vec::new()
            } else {
                torque(inputs, p, s)?
            };
            for st in steps {
                let h = st * w;
                let col = if *is_central {
                    central(id, h, s)?
                } else {
                    let a = torque(inputs, &with(p, id, get(p, id) + h), s)?;
                    a.iter().zip(&base).map(|(x, y)| (x - y) / h).collect()
                };
                let (_, r) = dev(&col, &reference);
                print!(" {:>8.2e}", 100.0 * r / scale);
            }
            println!();
        }
        println!("{name:>12} reference RMS {scale:.4e} N·m per unit, bound width {w:.4e}");
    }
    Ok(())
}

/// (b') `POINTS` random points of the bounds box with the angle (`angle_moved`) and each
/// identified parameter moved by 1e-12; returns the point whose parameter jump is largest.
fn random_points(
    inputs: &TrialInputs,
    angle_moved: &TrialInputs,
    nominal: &ModelParams,
    fast: &SimSettings,
) -> Res<ModelParams> {
    let points = env("POINTS", 16) as usize;
    let seed = env("SEED", 2016);
    let ids = ParamId::identified();
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    println!(
        "\n(b') {points} random points of the box (ChaCha8 seed {seed}), default settings: \
         max and RMS |Δτ| (N·m) over the samples; for the parameters the largest of the nine \
         and how many of them jump (max |Δτ| > {JUMP:.0e} N·m)"
    );
    println!(
        "{:>5} {:>9} {:>9}   {:>9} {:>9} {:>13} {:>5}",
        "point", "angle max", "RMS", "param max", "RMS", "which", "jumps"
    );
    let (mut worst_angle, mut worst_param) = (0.0_f64, 0.0_f64);
    let (mut worst_point, mut worst_k) = (*nominal, 0);
    let (mut angle_jumps, mut param_jumps) = (0, 0);
    for k in 0..points {
        let mut p = *nominal;
        for id in ids {
            let (lo, hi) = id.default_bounds(nominal, &Effects::none());
            id.set(&mut p, &mut Effects::none(), rng.random_range(lo..hi));
        }
        let b = torque(inputs, &p, fast)?;
        let (a_mx, a_rms) = dev(&torque(angle_moved, &p, fast)?, &b);
        let (mut p_mx, mut p_rms, mut which, mut jumps) = (0.0_f64, 0.0, String::new(), 0);
        for id in ids {
            let q = with(&p, id, get(&p, id) * (1.0 + 1e-12));
            let (mx, r) = dev(&torque(inputs, &q, fast)?, &b);
            jumps += usize::from(mx > JUMP);
            if mx > p_mx {
                (p_mx, p_rms, which) = (mx, r, id.name());
            }
        }
        angle_jumps += usize::from(a_mx > JUMP);
        param_jumps += jumps;
        worst_angle = worst_angle.max(a_mx);
        if p_mx > worst_param {
            worst_param = p_mx;
            worst_point = p;
            worst_k = k;
        }
        println!(
            "{k:>5} {a_mx:>9.2e} {a_rms:>9.2e}   {p_mx:>9.2e} {p_rms:>9.2e} {which:>13} {jumps:>5}"
        );
    }
    println!(
        "jumps: angle at {angle_jumps} of {points} points, parameters {param_jumps} of {}; \
         worst: angle {worst_angle:.2e} N·m, parameter {worst_param:.2e} N·m (point {worst_k})",
        9 * points
    );
    Ok(worst_point)
}

/// RHS calls and time (median of 5) of one simulation at the nominal point under each scheme's
/// settings but the forward difference's (the same as the central one's).
fn simulation_times(
    inputs: &TrialInputs,
    nominal: &ModelParams,
    schemes: &[(&str, SimSettings, bool)],
) -> Res<()> {
    println!("\nOne simulation (nominal, 3 muscles): RHS calls, time (median of 5, this machine)");
    for (label, s, _) in schemes {
        if label.ends_with("forward, default") {
            continue;
        }
        let out = simulate(inputs, nominal, &Effects::none(), s)?;
        let mut times: Vec<f64> = (0..5)
            .map(|_| {
                let t0 = Instant::now();
                simulate(inputs, nominal, &Effects::none(), s).map(|_| t0.elapsed().as_secs_f64())
            })
            .collect::<Result<_, _>>()?;
        times.sort_by(f64::total_cmp);
        println!(
            "  {:22} {:>6} {:>8.2} ms",
            label.trim_start_matches("central, "),
            out.total_stats().rhs_calls,
            1e3 * times[2]
        );
    }
    Ok(())
}

fn main() -> Res<()> {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../../fixtures/seed/trial.csv");
    let trial = experiment::read_trial(path)?;
    let opts = experiment::InputOptions::default();
    let inputs = experiment::model_inputs(&trial, &opts)?;
    let shifted = |delta: f64| -> Res<TrialInputs> {
        let mut t = trial.clone();
        t.ankle_angle_deg.iter_mut().for_each(|q| *q += delta);
        Ok(experiment::model_inputs(&t, &opts)?)
    };
    let nominal = ModelParams::nominal();
    let fast = SimSettings::default();
    let four = SimSettings {
        formulation: Formulation::FourState,
        ..fast
    };
    let tight = SimSettings::tight();
    let settings = [("default", fast), ("four-state", four), ("tight", tight)];
    println!("seed fixture: {} samples", trial.len());
    if let Ok(out) = std::env::var("JITTER_TRIAL") {
        let mut t = trial.clone();
        t.ankle_angle_deg.iter_mut().for_each(|q| *q += 1e-12);
        experiment::write_trial(&out, &t)?;
        println!("wrote the trial with every angle + 1e-12° to {out}");
    }

    // 1. the angle
    println!(
        "\n(a) every angle + δ (nominal parameters); ΔRHS: change of the RHS evaluations \
         (≠ 0: another step sequence)"
    );
    println!(
        "{:>8} {:11} {:>10} {:>10} {:>12} {:>6}",
        "δ (°)", "settings", "max (N·m)", "RMS (N·m)", "slope N·m/°", "ΔRHS"
    );
    let deltas = [1e-12, 1e-9, 1e-6, 1e-3];
    let base: Vec<(Vec<f64>, i64)> = settings
        .iter()
        .map(|(_, s)| run(&inputs, &nominal, s))
        .collect::<Res<_>>()?;
    for d in deltas {
        let moved = shifted(d)?;
        for ((name, s), (b, calls)) in settings.iter().zip(&base) {
            let (t, c) = run(&moved, &nominal, s)?;
            let (mx, r) = dev(&t, b);
            println!(
                "{d:>8.0e} {name:11} {mx:>10.2e} {r:>10.2e} {:>12.4e} {:>6}",
                r / d,
                c - calls
            );
        }
    }

    // 2. one parameter, nominal point
    println!("\n(b) one parameter × (1 + δ), nominal point");
    println!(
        "{:>12} {:>8} {:11} {:>10} {:>10} {:>12} {:>6}",
        "parameter", "δ (rel)", "settings", "max (N·m)", "RMS (N·m)", "slope N·m", "ΔRHS"
    );
    let probe = ["sol.fom_n", "gm.alpha_deg", "sol.lst_m"];
    for name in probe {
        let id = pid(name);
        let v = get(&nominal, id);
        for d in [1e-12, 1e-9, 1e-6, 1e-3] {
            let p = with(&nominal, id, v * (1.0 + d));
            for ((sname, s), (b, calls)) in settings.iter().zip(&base) {
                let (t, c) = run(&inputs, &p, s)?;
                let (mx, r) = dev(&t, b);
                println!(
                    "{name:>12} {d:>8.0e} {sname:11} {mx:>10.2e} {r:>10.2e} {:>12.4e} {:>6}",
                    r / d,
                    c - calls
                );
            }
        }
    }

    // random points of the box: angle and each parameter moved by 1e-12
    let worst_point = random_points(&inputs, &shifted(1e-12)?, &nominal, &fast)?;

    // 3. finite-difference columns, at the nominal point and at the random point with the
    // largest jump
    let schemes: [(&str, SimSettings, bool); 5] = [
        ("central, tight", tight, true),
        ("central, default", fast, true),
        ("forward, default", fast, false),
        (
            "central, fast 1e-8",
            SimSettings {
                rtol: 1e-8,
                atol: 1e-10,
                ..fast
            },
            true,
        ),
        (
            "central, fast 1e-10",
            SimSettings {
                rtol: 1e-10,
                atol: 1e-12,
                ..fast
            },
            true,
        ),
    ];
    simulation_times(&inputs, &nominal, &schemes)?;
    for (label, p) in [("nominal point", nominal), ("random point", worst_point)] {
        fd_table(&inputs, label, &p, &schemes)?;
    }
    println!(
        "\nsteps in use (share of the bound width): design::jacobian central 4e-3 (tight); \
         identify-sa polish central 1e-3, diagnose forward 1e-3, identify-mcmc Laplace central \
         1e-3 (default settings)"
    );
    Ok(())
}
