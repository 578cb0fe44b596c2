//! Writes every figure and a `report.html` from synthetic data:
//! `cargo run -p report --example demo -- out/demo`.

// Index loops over parallel synthetic arrays read better here than zipped iterators.
#![allow(clippy::needless_range_loop, clippy::vec_init_then_push)]

use std::path::PathBuf;

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};
use report::figures::{self, Candidate, SensitivityPoint};
use report::{param_label, write_figure, DiagnosisSummary, Report};

const NAMES: [&str; 9] = [
    "sol.lst_m",
    "gm.lst_m",
    "gl.lst_m",
    "sol.fom_n",
    "gm.fom_n",
    "gl.fom_n",
    "sol.alpha_deg",
    "gm.alpha_deg",
    "gl.alpha_deg",
];
const NOMINAL: [f64; 9] = [0.268, 0.39, 0.39, 3549.0, 1558.0, 683.0, 25.0, 17.0, 8.0];

/// A synthetic relaxed+1 trial at 2048 Hz: angle, envelopes, "measured" and model torque.
struct Trial {
    t: Vec<f64>,
    angle: Vec<f64>,
    env: [Vec<f64>; 3],
    measured: Vec<f64>,
    baseline: Vec<f64>,
    extended: Vec<f64>,
    phase: Vec<usize>,
}

fn trial(rng: &mut ChaCha8Rng) -> Trial {
    let fs = 2048.0;
    let n = (6.0 * fs) as usize;
    let noise = Normal::new(0.0, 1.2).expect("valid sd");
    let mut tr = Trial {
        t: Vec::with_capacity(n),
        angle: Vec::with_capacity(n),
        env: [Vec::new(), Vec::new(), Vec::new()],
        measured: Vec::new(),
        baseline: Vec::new(),
        extended: Vec::new(),
        phase: Vec::new(),
    };
    for i in 0..n {
        let t = i as f64 / fs;
        // hold 0.5 s, concentric 35° at 30°/s, eccentric back, hold.
        let (q, ph) = if t < 0.5 {
            (15.0, 0)
        } else if t < 0.5 + 35.0 / 30.0 {
            (15.0 - 30.0 * (t - 0.5), 1)
        } else if t < 0.5 + 70.0 / 30.0 {
            (-20.0 + 30.0 * (t - 0.5 - 35.0 / 30.0), 2)
        } else {
            (15.0, 0)
        };
        let drive = (1.0 - (-(t / 0.2)).exp())
            * if t > 5.2 {
                (-(t - 5.2) / 0.1).exp()
            } else {
                1.0
            };
        let e: [f64; 3] = [0.9 * drive, 0.75 * drive, 0.6 * drive];
        let true_tq = 90.0 * drive * (1.0 + 0.01 * q) + if ph == 2 { 12.0 * drive } else { 0.0 };
        let base = 90.0 * drive * (1.0 + 0.009 * q) + 2.0;
        let ext = true_tq + 0.3 * (t * 3.0).sin();
        tr.t.push(t);
        tr.angle.push(q);
        for k in 0..3 {
            tr.env[k].push(e[k]);
        }
        tr.measured.push(true_tq + noise.sample(rng));
        tr.baseline.push(base);
        tr.extended.push(ext);
        tr.phase.push(ph);
    }
    tr
}

/// Correlated synthetic MCMC chains `[param][chain][draw]` that start dispersed and converge.
fn chains(rng: &mut ChaCha8Rng, n_chains: usize, draws: usize) -> Vec<Vec<Vec<f64>>> {
    let z = Normal::new(0.0, 1.0).expect("valid sd");
    let mut out = vec![vec![Vec::with_capacity(draws); n_chains]; 9];
    for c in 0..n_chains {
        let mut state: Vec<f64> = (0..9).map(|_| rng.random_range(-3.0..3.0)).collect();
        for _ in 0..draws {
            for x in state.iter_mut() {
                *x = 0.9 * *x + 0.44 * z.sample(rng);
            }
            for p in 0..9 {
                // F0 sol follows LST sol (ρ ≈ 0.85), α0 sol opposes it (ρ ≈ −0.7).
                let x = match p {
                    3 => 0.85 * state[0] + 0.53 * state[3],
                    6 => -0.7 * state[0] + 0.71 * state[6],
                    _ => state[p],
                };
                let scale = NOMINAL[p] * if p < 3 { 0.01 } else { 0.04 };
                out[p][c].push(NOMINAL[p] + scale * x);
            }
        }
    }
    out
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let dir = PathBuf::from(std::env::args().nth(1).unwrap_or_else(|| "out/demo".into()));
    std::fs::create_dir_all(&dir)?;
    let mut rng = ChaCha8Rng::seed_from_u64(7);
    let tr = trial(&mut rng);
    let labels: Vec<String> = NAMES.iter().map(|n| param_label(n)).collect();
    let names: Vec<&str> = labels.iter().map(String::as_str).collect();
    let resid = |m: &[f64]| -> Vec<f64> { tr.measured.iter().zip(m).map(|(a, b)| a - b).collect() };
    let (rb, re) = (resid(&tr.baseline), resid(&tr.extended));

    let mut page = Report::new("surae demo report");
    page.subtitle("synthetic data made by `cargo run -p report --example demo`");
    let mut figs: Vec<(&str, String, String)> = Vec::new();
    figs.push((
        "torque_fit.svg",
        figures::torque_fit(
            &tr.t,
            &tr.measured,
            &[
                ("baseline model", &tr.baseline),
                ("extended model", &tr.extended),
            ],
            &tr.angle,
            &[("sol", &tr.env[0]), ("gm", &tr.env[1]), ("gl", &tr.env[2])],
        )?,
        "Measured and model torque with the ankle angle and EMG envelopes beneath.".into(),
    ));
    figs.push((
        "residual_vs_angle.svg",
        figures::residual_vs_angle(
            &tr.angle,
            &rb,
            &tr.phase,
            &["hold", "concentric", "eccentric"],
        )?,
        "Baseline residual against the ankle angle, by phase.".into(),
    ));
    figs.push((
        "residual_vs_time.svg",
        figures::residual_vs_time(&tr.t, &[("baseline", &rb), ("extended", &re)])?,
        "Residuals over time.".into(),
    ));
    figs.push((
        "fit_comparison.svg",
        figures::fit_comparison(&tr.t, &tr.measured, &tr.baseline, &tr.extended)?,
        "Baseline vs extended model.".into(),
    ));
    let cands = [
        Candidate {
            name: "eccentric_enhancement",
            evidence: 5210.0,
            heldout_rms_nm: Some(1.31),
            selected: true,
        },
        Candidate {
            name: "torque_offset",
            evidence: 880.0,
            heldout_rms_nm: Some(4.9),
            selected: false,
        },
        Candidate {
            name: "passive_joint_torque",
            evidence: 410.0,
            heldout_rms_nm: Some(5.2),
            selected: false,
        },
        Candidate {
            name: "viscous_damping",
            evidence: 97.0,
            heldout_rms_nm: Some(5.6),
            selected: false,
        },
        Candidate {
            name: "antagonist_coactivation",
            evidence: -12.0,
            heldout_rms_nm: Some(6.1),
            selected: false,
        },
    ];
    figs.push((
        "candidate_ranking.svg",
        figures::candidate_ranking(&cands, Some(6.02))?,
        "Candidate effects.".into(),
    ));
    let ch = chains(&mut rng, 10, 3000);
    let warmup = 1000;
    figs.push((
        "traces.svg",
        figures::traces(&names, &ch, warmup)?,
        "Traces.".into(),
    ));
    let iters: Vec<f64> = (1..=30).map(|k| k as f64 * 100.0).collect();
    let rhat: Vec<Vec<f64>> = (0..9)
        .map(|p| {
            iters
                .iter()
                .enumerate()
                .map(|(k, it)| {
                    if k == 0 && p == 0 {
                        f64::NAN
                    } else {
                        1.0 + 4.0 * (1.0 + p as f64 * 0.2) / (it / 60.0)
                    }
                })
                .collect()
        })
        .collect();
    figs.push((
        "rhat.svg",
        figures::rhat_history(&names, &iters, &rhat)?,
        "R̂.".into(),
    ));
    let pooled: Vec<Vec<f64>> = ch
        .iter()
        .map(|per| {
            per.iter()
                .flat_map(|c| c[warmup..].iter().copied())
                .collect()
        })
        .collect();
    let truth: Vec<f64> = NOMINAL.to_vec();
    figs.push((
        "histograms.svg",
        figures::histograms(&names, &pooled, Some(&truth))?,
        "Marginals.".into(),
    ));
    figs.push((
        "corner.svg",
        figures::corner(&names, &pooled, Some(&truth))?,
        "Corner plot.".into(),
    ));
    let mut sens = Vec::new();
    for (p, name) in names.iter().enumerate() {
        for c in [-20.0, -15.0, -10.0, -5.0, 5.0, 10.0, 15.0, 20.0] {
            let k = [9.0, 3.0, 1.5, 1.2, 0.6, 0.3, 0.5, 0.2, 0.1][p];
            let v = if p == 0 && c > 15.0 {
                None
            } else {
                Some(k * f64::abs(c) / 20.0 * (1.0 + 0.01 * c))
            };
            sens.push(SensitivityPoint {
                param: name,
                change_pct: c,
                rms_change_nm: v,
            });
        }
    }
    figs.push((
        "sensitivity.svg",
        figures::sensitivity_curves(&sens)?,
        "Sensitivity.".into(),
    ));

    page.heading("Diagnosis");
    let summary = DiagnosisSummary {
        adequate: false,
        causes: &["eccentric_enhancement"],
        unexplained_structure: false,
        baseline_rms_nm: 5.8,
        baseline_heldout_rms_nm: 6.02,
        extended_heldout_rms_nm: Some(1.31),
        heldout_rms_reduction_pct: 78.2,
        delta_bic: 5100.0,
        effect_values: &[("Flen", 1.68)],
        near_ties: &[],
    };
    for p in report::diagnosis_in_words(&summary) {
        page.paragraph(p);
    }
    page.heading("Parameters");
    let rows: Vec<Vec<String>> = (0..9)
        .map(|p| {
            let mut d = pooled[p].clone();
            d.sort_by(f64::total_cmp);
            let mean = d.iter().sum::<f64>() / d.len() as f64;
            vec![
                names[p].to_string(),
                report::format_sig(mean, 4),
                report::format_sig(d[d.len() / 20], 4),
                report::format_sig(d[d.len() * 19 / 20], 4),
                report::format_sig(truth[p], 4),
                report::format_sig(100.0 * (mean - truth[p]) / truth[p], 2),
            ]
        })
        .collect();
    page.table(
        "Posterior (synthetic)",
        &["parameter", "mean", "q05", "q95", "truth", "error %"],
        &rows,
    )?;
    page.heading("Figures");
    let mut total = 0;
    for (file, svg, caption) in &figs {
        total += svg.len();
        write_figure(&dir, file, svg)?;
        page.figure(caption.clone(), svg)?;
        println!("{file}: {} kB", svg.len() / 1024);
    }
    page.write(&dir.join("report.html"))?;
    println!(
        "report.html with {} figures ({} kB of SVG) in {}",
        figs.len(),
        total / 1024,
        dir.display()
    );
    Ok(())
}
