//! The calibrated model extended with a flexible residual term, leave one trial out, against
//! the linear baseline (docs/real-data.md, "What the diagnosis finds on these trials").
//!
//! `cargo run --release -p experiment --example ceinms_extension -- DIR SIMS [FIGURE.svg]`
//!
//! - `DIR` holds the CEINMS trial folders (`_FastWalking_`, …; CEINMS's `TestData/unix`).
//! - `SIMS/<left out>/<trial>.csv` is the moment of the model calibrated without trial
//!   `<left out>`, on every trial (the CSVs of `surae simulate --session calib.json --params
//!   <identify.json of the calibration without <left out>> --out SIMS/<left out>`); trial
//!   names are the folders' names without their underscores.
//!
//! For each trial left out, at the torque file's own samples:
//!
//! - **calibrated**: the model calibrated on the other trials, as simulated;
//! - **+ stance**: the same plus `g(s)`, `s` the stance fraction (0 at the first moment
//!   sample, 1 at the last) and `g` piecewise linear on `K` uniform knots over `[0, 1]` (hat
//!   basis), its knot values by least squares on the training trials' residuals (measured
//!   minus calibrated model) and applied to the trial left out, whose samples are never used;
//! - **+ activation**: the same in `a`, the mean normalised triceps surae envelope (sol, gm,
//!   gl), knots uniform over the training trials' range of `a`, constant beyond it;
//! - **+ both**: `g(s) + h(a)` fitted together (the last activation hat dropped: the two
//!   bases each sum to one);
//! - **linear**: the moment regressed on each muscle's envelope × moment arm
//!   (`τ ≈ Σ_m F_m·e_m·r_m`), fitted on the training trials (as `ceinms_baseline`).
//!
//! It prints RMS error (N·m) and R² per trial left out and their means, for `K` = 6 and the
//! means for `K` = 5, 7 and 8, and with `FIGURE.svg` draws, per trial left out, the three
//! training trials' residuals over stance and the stance term fitted to them (`K` = 6).
//! Deterministic: no random choice.

use experiment::{ceinms_trial_dirs, least_squares, moment_fit, read_ceinms_trial};
use experiment::{CeinmsModelTrial, ExperimentError};
use muscle_model::Muscle;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// Knots of the main table.
const KNOTS: usize = 6;

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let (Some(dir), Some(sims)) = (args.first(), args.get(1)) else {
        eprintln!("usage: ceinms_extension DIR SIMS [FIGURE.svg]  (module docs)");
        std::process::exit(2);
    };
    if let Err(e) = run(
        Path::new(dir),
        Path::new(sims),
        args.get(2).map(PathBuf::from),
    ) {
        eprintln!("error: {e}");
        std::process::exit(2);
    }
}

/// One trial at the torque file's samples.
struct Samples {
    name: String,
    /// Measured moment (N·m).
    tau: Vec<f64>,
    /// Stance fraction.
    s: Vec<f64>,
    /// Mean normalised triceps surae envelope.
    a: Vec<f64>,
    /// Each muscle's envelope × moment arm (m).
    drives: Vec<Vec<f64>>,
}

fn err(what: &str, reason: String) -> ExperimentError {
    ExperimentError::Invalid {
        what: what.to_string(),
        kind: experiment::ErrorKind::InvalidSettings,
        reason,
    }
}

fn samples(t: &CeinmsModelTrial) -> Result<Samples, ExperimentError> {
    let times = &t.torque_times;
    let (t0, t1) = (times[0], times[times.len() - 1]);
    let n = t.inputs.len();
    let mean_ts: Vec<f64> = (0..n)
        .map(|i| {
            Muscle::ALL
                .iter()
                .map(|m| t.inputs.envelope(*m)[i])
                .sum::<f64>()
                / 3.0
        })
        .collect();
    Ok(Samples {
        name: t.name.trim_matches('_').to_string(),
        tau: t.torque_at_samples.clone(),
        s: times.iter().map(|x| (x - t0) / (t1 - t0)).collect(),
        a: t.at_torque_samples(&mean_ts)?,
        drives: t
            .muscles
            .iter()
            .map(|m| t.at_torque_samples(&t.drive(m)?))
            .collect::<Result<_, _>>()?,
    })
}

/// The model moment of `SIMS/<left>/<trial>.csv` (`time_s, torque_nm, …`) at the trial's
/// torque samples.
fn simulated(
    sims: &Path,
    left: &str,
    trial: &CeinmsModelTrial,
) -> Result<Vec<f64>, ExperimentError> {
    let name = trial.name.trim_matches('_');
    let path = sims.join(left).join(format!("{name}.csv"));
    let text = std::fs::read_to_string(&path)
        .map_err(|e| err(&path.display().to_string(), e.to_string()))?;
    let mut tau = Vec::new();
    for (k, line) in text.lines().enumerate().skip(1) {
        let v: Vec<&str> = line.split(',').collect();
        let x = v
            .get(1)
            .and_then(|x| x.trim().parse::<f64>().ok())
            .ok_or_else(|| err(&path.display().to_string(), format!("line {}", k + 1)))?;
        tau.push(x);
    }
    if tau.len() != trial.inputs.len() {
        return Err(err(
            &path.display().to_string(),
            format!(
                "{} rows for a trial of {} samples",
                tau.len(),
                trial.inputs.len()
            ),
        ));
    }
    trial.at_torque_samples(&tau)
}

/// Hat functions on `k` uniform knots over `[lo, hi]` at `v` (constant beyond the ends).
fn hats(v: f64, lo: f64, hi: f64, k: usize) -> Vec<f64> {
    let h = (hi - lo) / (k - 1) as f64;
    let u = ((v.clamp(lo, hi) - lo) / h).min((k - 1) as f64);
    let j = (u.floor() as usize).min(k - 2);
    let f = u - j as f64;
    let mut row = vec![0.0; k];
    row[j] = 1.0 - f;
    row[j + 1] = f;
    row
}

#[derive(Clone, Copy, PartialEq)]
enum Term {
    Stance,
    Activation,
    Both,
}

/// A fitted flexible term: knot values of the stance and activation parts.
struct Fitted {
    term: Term,
    k: usize,
    a_range: (f64, f64),
    beta: Vec<f64>,
}

impl Fitted {
    fn row(&self, s: f64, a: f64) -> Vec<f64> {
        let (lo, hi) = self.a_range;
        match self.term {
            Term::Stance => hats(s, 0.0, 1.0, self.k),
            Term::Activation => hats(a, lo, hi, self.k),
            Term::Both => {
                let mut r = hats(s, 0.0, 1.0, self.k);
                r.extend_from_slice(&hats(a, lo, hi, self.k)[..self.k - 1]);
                r
            }
        }
    }

    fn fit(
        term: Term,
        k: usize,
        train: &[(&Samples, Vec<f64>)],
    ) -> Result<Fitted, ExperimentError> {
        let a_range = train
            .iter()
            .flat_map(|(t, _)| t.a.iter())
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), &x| {
                (l.min(x), h.max(x))
            });
        let mut f = Fitted {
            term,
            k,
            a_range,
            beta: Vec::new(),
        };
        let mut cols: Vec<Vec<f64>> = Vec::new();
        let mut y = Vec::new();
        for (t, resid) in train {
            for (i, (s, a)) in t.s.iter().zip(&t.a).enumerate().take(t.tau.len()) {
                let r = f.row(*s, *a);
                if cols.is_empty() {
                    cols = vec![Vec::new(); r.len()];
                }
                for (c, v) in cols.iter_mut().zip(r) {
                    c.push(v);
                }
                y.push(resid[i]);
            }
        }
        f.beta = least_squares(&cols, &y)?;
        Ok(f)
    }

    fn eval(&self, t: &Samples) -> Vec<f64> {
        (0..t.tau.len())
            .map(|i| {
                self.row(t.s[i], t.a[i])
                    .iter()
                    .zip(&self.beta)
                    .map(|(r, b)| r * b)
                    .sum()
            })
            .collect()
    }
}

const VARIANTS: [&str; 5] = [
    "calibrated",
    "+ stance",
    "+ activation",
    "+ both",
    "linear (per muscle)",
];

/// Per variant, per trial left out: (RMS, R²); and, for the figure, per trial left out, the
/// training residuals and the stance term.
type Study = (Vec<Vec<(f64, f64)>>, Vec<Panel>);

struct Panel {
    left: String,
    train: Vec<(String, Vec<f64>, Vec<f64>)>,
    term: Vec<f64>,
}

fn study(
    trials: &[CeinmsModelTrial],
    data: &[Samples],
    sims: &Path,
    k: usize,
) -> Result<Study, ExperimentError> {
    let mut scores = vec![Vec::new(); VARIANTS.len()];
    let mut panels = Vec::new();
    for (l, held) in data.iter().enumerate() {
        // the model calibrated without trial l, on every trial
        let model: Vec<Vec<f64>> = trials
            .iter()
            .map(|t| simulated(sims, &held.name, t))
            .collect::<Result<_, _>>()?;
        let train: Vec<(&Samples, Vec<f64>)> = data
            .iter()
            .zip(&model)
            .enumerate()
            .filter(|(j, _)| *j != l)
            .map(|(_, (t, m))| (t, t.tau.iter().zip(m).map(|(y, p)| y - p).collect()))
            .collect();
        let base = &model[l];
        scores[0].push(moment_fit(&held.tau, base));
        for (v, term) in [Term::Stance, Term::Activation, Term::Both]
            .into_iter()
            .enumerate()
        {
            let f = Fitted::fit(term, k, &train)?;
            let pred: Vec<f64> = base.iter().zip(f.eval(held)).map(|(p, g)| p + g).collect();
            scores[v + 1].push(moment_fit(&held.tau, &pred));
            if term == Term::Stance {
                let grid: Vec<f64> = (0..=100).map(|i| i as f64 / 100.0).collect();
                panels.push(Panel {
                    left: held.name.clone(),
                    train: train
                        .iter()
                        .map(|(t, r)| (t.name.clone(), t.s.clone(), r.clone()))
                        .collect(),
                    term: grid
                        .iter()
                        .map(|s| f.row(*s, 0.0).iter().zip(&f.beta).map(|(r, b)| r * b).sum())
                        .collect(),
                });
            }
        }
        // linear baseline on the training trials
        let nm = held.drives.len();
        let mut cols = vec![Vec::new(); nm];
        let mut y = Vec::new();
        for (t, _) in &train {
            for (c, d) in cols.iter_mut().zip(&t.drives) {
                c.extend_from_slice(d);
            }
            y.extend_from_slice(&t.tau);
        }
        let b = least_squares(&cols, &y)?;
        let pred: Vec<f64> = (0..held.tau.len())
            .map(|i| held.drives.iter().zip(&b).map(|(d, f)| d[i] * f).sum())
            .collect();
        scores[4].push(moment_fit(&held.tau, &pred));
    }
    Ok((scores, panels))
}

fn mean(v: &[(f64, f64)]) -> (f64, f64) {
    let n = v.len() as f64;
    (
        v.iter().map(|x| x.0).sum::<f64>() / n,
        v.iter().map(|x| x.1).sum::<f64>() / n,
    )
}

fn run(dir: &Path, sims: &Path, figure: Option<PathBuf>) -> Result<(), ExperimentError> {
    let trials = ceinms_trial_dirs(dir)?
        .iter()
        .map(|d| read_ceinms_trial(d, "R_ankle_fe"))
        .collect::<Result<Vec<_>, _>>()?;
    let data: Vec<Samples> = trials.iter().map(samples).collect::<Result<_, _>>()?;
    let (scores, panels) = study(&trials, &data, sims, KNOTS)?;
    println!(
        "leave one trial out, {KNOTS} knots: RMS error (N·m) / R² of the trial left out, at \
         the torque file's samples"
    );
    print!("| trial left out |");
    for v in VARIANTS {
        print!(" {v} |");
    }
    println!();
    println!("|---|{}", "---|".repeat(VARIANTS.len()));
    for (l, t) in data.iter().enumerate() {
        print!("| {} |", t.name);
        for s in &scores {
            print!(" {:.2} / {:.3} |", s[l].0, s[l].1);
        }
        println!();
    }
    print!("| mean |");
    for s in &scores {
        let (r, q) = mean(s);
        print!(" {r:.2} / {q:.3} |");
    }
    println!();
    println!("\nmeans with other knot counts (RMS / R²)");
    for k in [5, 7, 8] {
        let (s, _) = study(&trials, &data, sims, k)?;
        print!("  K = {k}:");
        for (v, sc) in VARIANTS.iter().zip(&s).take(4).skip(1) {
            let (r, q) = mean(sc);
            print!("  {v} {r:.2} / {q:.3};");
        }
        println!();
    }
    println!("\nstance term (N·m) at its knots (stance fraction 0 … 1), {KNOTS} knots");
    for p in &panels {
        let knots: Vec<String> = (0..KNOTS)
            .map(|j| format!("{:+.1}", p.term[j * 100 / (KNOTS - 1)]))
            .collect();
        println!("  {:<12} left out: {}", p.left, knots.join(" "));
    }
    if let Some(path) = figure {
        std::fs::write(&path, svg(&panels))
            .map_err(|e| err(&path.display().to_string(), e.to_string()))?;
        println!("\nwrote {}", path.display());
    }
    Ok(())
}

/// Four panels: per trial left out, the training trials' residuals over stance (thin) and the
/// stance term fitted to them (thick, black).
fn svg(panels: &[Panel]) -> String {
    let (pw, ph, ml, mt, gap) = (300.0, 220.0, 50.0, 30.0, 30.0);
    let lo = panels
        .iter()
        .flat_map(|p| p.train.iter().flat_map(|t| t.2.iter()))
        .fold(0.0_f64, |m, &x| m.min(x));
    let hi = panels
        .iter()
        .flat_map(|p| p.train.iter().flat_map(|t| t.2.iter()))
        .fold(0.0_f64, |m, &x| m.max(x));
    let (lo, hi) = ((lo / 50.0).floor() * 50.0, (hi / 50.0).ceil() * 50.0);
    let colours = [
        ("FastWalking", "#1f77b4"),
        ("Running1", "#ff7f0e"),
        ("CrossOvers1", "#2ca02c"),
        ("SideStep1", "#d62728"),
    ];
    let colour = |n: &str| colours.iter().find(|c| c.0 == n).map_or("#888888", |c| c.1);
    let w = ml + 2.0 * (pw + gap);
    let h = mt + 2.0 * (ph + gap + 20.0) + 30.0;
    let mut o = String::new();
    let _ = writeln!(
        o,
        r##"<svg xmlns="http://www.w3.org/2000/svg" width="{w}" height="{h}" font-family="sans-serif" font-size="11">"##
    );
    let _ = writeln!(o, r##"<rect width="{w}" height="{h}" fill="white"/>"##);
    for (p_i, p) in panels.iter().enumerate() {
        let x0 = ml + (p_i % 2) as f64 * (pw + gap);
        let y0 = mt + (p_i / 2) as f64 * (ph + gap + 20.0);
        let px = |s: f64| x0 + s * pw;
        let py = |v: f64| y0 + ph - (v - lo) / (hi - lo) * ph;
        let _ = writeln!(
            o,
            r##"<rect x="{x0}" y="{y0}" width="{pw}" height="{ph}" fill="none" stroke="#999"/>"##
        );
        let _ = writeln!(
            o,
            r##"<text x="{}" y="{}" text-anchor="middle">{} left out</text>"##,
            x0 + pw / 2.0,
            y0 - 6.0,
            p.left
        );
        let mut v = lo;
        while v <= hi + 1e-9 {
            let _ = writeln!(
                o,
                r##"<line x1="{x0}" x2="{}" y1="{y}" y2="{y}" stroke="{}" stroke-width="0.5"/><text x="{}" y="{}" text-anchor="end">{v:.0}</text>"##,
                x0 + pw,
                if v == 0.0 { "#444" } else { "#ddd" },
                x0 - 4.0,
                py(v) + 4.0,
                y = py(v)
            );
            v += 50.0;
        }
        for s in [0.0, 0.2, 0.4, 0.6, 0.8, 1.0] {
            let _ = writeln!(
                o,
                r##"<text x="{}" y="{}" text-anchor="middle">{s:.1}</text>"##,
                px(s),
                y0 + ph + 13.0
            );
        }
        for (name, s, r) in &p.train {
            let pts: Vec<String> = s
                .iter()
                .zip(r)
                .map(|(s, r)| format!("{:.1},{:.1}", px(*s), py(*r)))
                .collect();
            let _ = writeln!(
                o,
                r##"<polyline points="{}" fill="none" stroke="{}" stroke-width="1"/>"##,
                pts.join(" "),
                colour(name)
            );
        }
        let pts: Vec<String> = p
            .term
            .iter()
            .enumerate()
            .map(|(i, g)| format!("{:.1},{:.1}", px(i as f64 / 100.0), py(*g)))
            .collect();
        let _ = writeln!(
            o,
            r##"<polyline points="{}" fill="none" stroke="black" stroke-width="2.5"/>"##,
            pts.join(" ")
        );
    }
    let yb = h - 14.0;
    let _ = writeln!(
        o,
        r##"<text x="{}" y="{}" text-anchor="middle">stance fraction (first to last moment sample); residual = measured − calibrated model (N·m)</text>"##,
        ml + pw,
        yb - 14.0
    );
    let mut x = ml;
    for (n, c) in colours {
        let _ = writeln!(
            o,
            r##"<line x1="{x}" x2="{}" y1="{yb}" y2="{yb}" stroke="{c}" stroke-width="2"/><text x="{}" y="{}">{n}</text>"##,
            x + 18.0,
            x + 22.0,
            yb + 4.0
        );
        x += 110.0;
    }
    let _ = writeln!(
        o,
        r##"<line x1="{x}" x2="{}" y1="{yb}" y2="{yb}" stroke="black" stroke-width="2.5"/><text x="{}" y="{}">stance term ({KNOTS} knots)</text>"##,
        x + 18.0,
        x + 22.0,
        yb + 4.0
    );
    let _ = writeln!(o, "</svg>");
    o
}
