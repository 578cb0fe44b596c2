//! MCMC figures: trace plots, R̂ history, marginal histograms and the corner plot.

use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};

use super::{
    check_finite, check_names, correlation, decimate, draw_err, draw_line, legend_strip,
    mesh_colours, min_max, padded, px, render, style, thin_indices, tick_text, titled, Area, Mark,
    DESC_PX, FONT, SMALL_PX, TICK_PX,
};
use crate::error::{ReportError, Result};
use crate::palette::{SeriesStyle, BLUE, GREY, LIGHT_GREY, SKY_BLUE, VERMILLION};

/// Rows and columns of a grid of `n` panels (three columns at most).
fn grid(n: usize) -> (usize, usize) {
    let cols = n.clamp(1, 3);
    (n.div_ceil(cols), cols)
}

/// Quantile `p` of sorted data (linear interpolation).
fn quantile(sorted: &[f64], p: f64) -> f64 {
    if sorted.is_empty() {
        return f64::NAN;
    }
    let h = p * (sorted.len() - 1) as f64;
    let (lo, hi) = (h.floor() as usize, h.ceil() as usize);
    sorted[lo] + (h - lo as f64) * (sorted[hi] - sorted[lo])
}

fn check_truth(figure: &'static str, truth: Option<&[f64]>, n: usize) -> Result<()> {
    if let Some(t) = truth {
        if t.len() != n {
            return Err(ReportError::LengthMismatch {
                figure,
                series: "truth".into(),
                expected: n,
                got: t.len(),
            });
        }
        check_finite(figure, "truth", t)?;
    }
    Ok(())
}

/// Most points drawn per chain in a trace panel.
const TRACE_POINTS: usize = 600;

/// Trace plots, one panel per parameter with every chain overlaid (the dissertation's
/// Figs. 16–17).
///
/// `chains[p][c][k]` is draw `k` of chain `c` for parameter `p`, iterations counted from 0;
/// `names[p]` is the parameter's label with its unit (e.g. `"LST sol (m)"`). The first
/// `warmup` iterations are shaded as discarded warm-up (0 for none).
pub fn traces(names: &[&str], chains: &[Vec<Vec<f64>>], warmup: usize) -> Result<String> {
    const FIG: &str = "traces";
    check_names(FIG, names, chains.len(), "chains")?;
    let mut longest = 0;
    for (p, per) in chains.iter().enumerate() {
        if per.is_empty() {
            return Err(ReportError::Empty {
                figure: FIG,
                series: format!("chains of {}", names[p]),
            });
        }
        for (c, ch) in per.iter().enumerate() {
            check_finite(FIG, &format!("{} chain {c}", names[p]), ch)?;
            longest = longest.max(ch.len());
        }
    }
    let n_chains = chains.iter().map(Vec::len).max().unwrap_or(0);
    let (rows, cols) = grid(names.len());
    let panel_h = 280;
    let height = 100 + rows as u32 * panel_h;
    render(FIG, (1200, height), |root| {
        let body = titled(FIG, root, "MCMC traces")?;
        let mut entries = vec![(
            format!("{n_chains} chains, one colour each"),
            Mark::Line(style(0), 1),
        )];
        if warmup > 0 {
            entries.push((
                format!("warm-up ({warmup} iterations, discarded)"),
                Mark::Swatch(LIGHT_GREY, 1.0),
            ));
        }
        let body = legend_strip(FIG, &body, &entries)?;
        let areas = body.split_evenly((rows, cols));
        for (p, area) in areas.iter().enumerate().take(names.len()) {
            let e = draw_err(FIG);
            let y = padded(
                min_max(chains[p].iter().flat_map(|c| c.iter().copied())).unwrap_or((0.0, 1.0)),
                0.05,
            );
            let x = (0.0, (longest.max(2) - 1) as f64);
            let bottom = p / cols == rows - 1 || p + cols >= names.len();
            let mut chart = ChartBuilder::on(area)
                .caption(names[p], (FONT, px(17)))
                .margin(8)
                .margin_right(22)
                .x_label_area_size(if bottom { 50 } else { 26 })
                .y_label_area_size(78)
                .build_cartesian_2d(x.0..x.1, y.0..y.1)
                .map_err(&e)?;
            let (xs, ys) = (x.1 - x.0, y.1 - y.0);
            let xf = move |v: &f64| tick_text(*v, xs);
            let yf = move |v: &f64| tick_text(*v, ys);
            let (bold, light) = mesh_colours();
            let mut mesh = chart.configure_mesh();
            mesh.bold_line_style(bold)
                .light_line_style(light)
                .x_labels(4)
                .y_labels(5)
                .x_label_formatter(&xf)
                .y_label_formatter(&yf)
                .label_style((FONT, SMALL_PX))
                .axis_desc_style((FONT, TICK_PX));
            if bottom {
                mesh.x_desc("iteration");
            }
            mesh.draw().map_err(&e)?;
            if warmup > 0 {
                let w = (warmup as f64).min(x.1);
                chart
                    .draw_series(std::iter::once(Rectangle::new(
                        [(0.0, y.0), (w, y.1)],
                        LIGHT_GREY.mix(0.8).filled(),
                    )))
                    .map_err(&e)?;
            }
            for (c, ch) in chains[p].iter().enumerate() {
                let it: Vec<f64> = (0..ch.len()).map(|k| k as f64).collect();
                let st = SeriesStyle {
                    colour: style(c).colour,
                    dashed: false,
                };
                draw_line(FIG, &mut chart, decimate(&it, ch, TRACE_POINTS), st, 1)?;
            }
        }
        Ok(())
    })
}

fn log_tick(v: f64) -> String {
    if v >= 1.0 {
        format!("{v:.0}")
    } else {
        let d = (-v.log10()).ceil().clamp(0.0, 8.0) as usize;
        format!("{v:.d$}")
    }
}

/// The Gelman–Rubin R̂ of each parameter against iterations (the dissertation's Fig. 15),
/// drawn as R̂ − 1 on a logarithmic axis with the usual R̂ = 1.01 convergence line.
///
/// `rhat[p][k]` is the R̂ of parameter `p` computed at `iterations[k]`. Non-finite values
/// (R̂ undefined early on) are left as gaps; values below 1 + 10⁻⁵ are drawn at 1 + 10⁻⁵.
/// Fails when a parameter has no finite R̂ at all.
pub fn rhat_history(names: &[&str], iterations: &[f64], rhat: &[Vec<f64>]) -> Result<String> {
    const FIG: &str = "rhat_history";
    check_names(FIG, names, rhat.len(), "rhat")?;
    check_finite(FIG, "iterations", iterations)?;
    for (p, r) in rhat.iter().enumerate() {
        if r.len() != iterations.len() {
            return Err(ReportError::LengthMismatch {
                figure: FIG,
                series: names[p].to_string(),
                expected: iterations.len(),
                got: r.len(),
            });
        }
        if !r.iter().any(|v| v.is_finite()) {
            return Err(ReportError::Invalid {
                figure: FIG,
                reason: format!("no finite R̂ for {}", names[p]),
            });
        }
    }
    const FLOOR: f64 = 1e-5;
    let excess = |v: f64| (v - 1.0).max(FLOOR);
    let (lo, hi) = min_max(
        rhat.iter()
            .flatten()
            .copied()
            .filter(|v| v.is_finite())
            .map(excess),
    )
    .unwrap_or((1e-3, 1.0));
    let (lo, hi) = ((lo.min(0.005) / 1.5).max(FLOOR / 1.5), hi.max(0.02) * 1.5);
    let x = min_max(iterations.iter().copied()).unwrap_or((0.0, 1.0));
    let x = if x.1 > x.0 { x } else { padded(x, 0.0) };
    render(FIG, (1000, 700), |root| {
        let body = titled(FIG, root, "Gelman–Rubin R̂ over iterations")?;
        let mut entries: Vec<_> = names
            .iter()
            .enumerate()
            .map(|(i, n)| (n.to_string(), Mark::Line(style(i), 2)))
            .collect();
        entries.push((
            "R̂ = 1.01".into(),
            Mark::Line(
                SeriesStyle {
                    colour: GREY,
                    dashed: true,
                },
                2,
            ),
        ));
        let body = legend_strip(FIG, &body, &entries)?;
        let e = draw_err(FIG);
        let mut chart = ChartBuilder::on(&body)
            .margin_right(24)
            .margin_top(6)
            .x_label_area_size(56)
            .y_label_area_size(90)
            .build_cartesian_2d(x.0..x.1, (lo..hi).log_scale())
            .map_err(&e)?;
        let xs = x.1 - x.0;
        let xf = move |v: &f64| tick_text(*v, xs);
        let yf = |v: &f64| log_tick(*v);
        let (bold, light) = mesh_colours();
        chart
            .configure_mesh()
            .bold_line_style(bold)
            .light_line_style(light)
            .x_label_formatter(&xf)
            .y_label_formatter(&yf)
            .label_style((FONT, TICK_PX))
            .axis_desc_style((FONT, DESC_PX))
            .x_desc("iteration")
            .y_desc("R-hat − 1 (log scale)")
            .draw()
            .map_err(&e)?;
        chart
            .draw_series(DashedLineSeries::new(
                vec![(x.0, 0.01), (x.1, 0.01)],
                10,
                6,
                GREY.stroke_width(2),
            ))
            .map_err(&e)?;
        for (p, r) in rhat.iter().enumerate() {
            // Split into runs of finite values.
            let mut run: Vec<(f64, f64)> = Vec::new();
            let st = style(p);
            for (k, v) in r.iter().enumerate() {
                if v.is_finite() {
                    run.push((iterations[k], excess(*v)));
                } else if !run.is_empty() {
                    let pts = std::mem::take(&mut run);
                    draw_run(FIG, &mut chart, pts, st)?;
                }
            }
            if !run.is_empty() {
                draw_run(FIG, &mut chart, run, st)?;
            }
        }
        Ok(())
    })
}

fn draw_run<DB: DrawingBackend, CT: CoordTranslate<From = (f64, f64)>>(
    figure: &'static str,
    chart: &mut ChartContext<'_, DB, CT>,
    pts: Vec<(f64, f64)>,
    st: SeriesStyle,
) -> Result<()> {
    if pts.len() == 1 {
        chart
            .draw_series(std::iter::once(Circle::new(pts[0], 3, st.colour.filled())))
            .map_err(draw_err(figure))?;
        return Ok(());
    }
    draw_line(figure, chart, pts, st, 2)
}

fn check_draws(figure: &'static str, names: &[&str], draws: &[Vec<f64>]) -> Result<()> {
    check_names(figure, names, draws.len(), "draws")?;
    for (p, d) in draws.iter().enumerate() {
        check_finite(figure, names[p], d)?;
    }
    Ok(())
}

/// Bin counts of `d` over `[lo, hi]`.
fn bin_counts(d: &[f64], lo: f64, hi: f64, bins: usize) -> Vec<usize> {
    let mut counts = vec![0usize; bins];
    let w = (hi - lo) / bins as f64;
    for v in d {
        let k = (((v - lo) / w).floor().max(0.0) as usize).min(bins - 1);
        counts[k] += 1;
    }
    counts
}

const BINS: usize = 30;

/// Marginal posterior histograms, one panel per parameter, with the 90 % interval shaded, the
/// posterior mean (dashed) and, when given, the true value.
///
/// `draws[p]` holds the pooled post-warm-up draws of parameter `p`; `names[p]` its label with
/// unit; `truth[p]` its true value.
pub fn histograms(names: &[&str], draws: &[Vec<f64>], truth: Option<&[f64]>) -> Result<String> {
    const FIG: &str = "histograms";
    check_draws(FIG, names, draws)?;
    check_truth(FIG, truth, names.len())?;
    let (rows, cols) = grid(names.len());
    let height = 100 + rows as u32 * 280;
    render(FIG, (1200, height), |root| {
        let body = titled(FIG, root, "Marginal posterior distributions")?;
        let mut entries = vec![
            ("posterior draws".to_string(), Mark::Swatch(SKY_BLUE, 1.0)),
            ("90 % interval".to_string(), Mark::Swatch(LIGHT_GREY, 1.0)),
            (
                "posterior mean".to_string(),
                Mark::Line(
                    SeriesStyle {
                        colour: BLUE,
                        dashed: true,
                    },
                    2,
                ),
            ),
        ];
        if truth.is_some() {
            entries.push((
                "true value".to_string(),
                Mark::Line(
                    SeriesStyle {
                        colour: VERMILLION,
                        dashed: false,
                    },
                    3,
                ),
            ));
        }
        let body = legend_strip(FIG, &body, &entries)?;
        let areas = body.split_evenly((rows, cols));
        for (p, area) in areas.iter().enumerate().take(names.len()) {
            let t = truth.map(|t| t[p]);
            let left = p % cols == 0;
            hist_panel(FIG, area, names[p], &draws[p], t, true, left)?;
        }
        Ok(())
    })
}

/// One histogram panel; `caption` on top, x axis titled with `x_desc`.
fn hist_panel(
    figure: &'static str,
    area: &Area<'_>,
    name: &str,
    d: &[f64],
    truth: Option<f64>,
    full: bool,
    y_desc: bool,
) -> Result<()> {
    let e = draw_err(figure);
    let mut sorted = d.to_vec();
    sorted.sort_by(f64::total_cmp);
    let (mut lo, mut hi) = (sorted[0], sorted[sorted.len() - 1]);
    if let Some(t) = truth {
        lo = lo.min(t);
        hi = hi.max(t);
    }
    let (lo, hi) = padded((lo, hi), 0.03);
    let counts = bin_counts(d, lo, hi, BINS);
    let top = counts.iter().copied().max().unwrap_or(1).max(1) as f64 * 1.08;
    let w = (hi - lo) / BINS as f64;
    let mut builder = ChartBuilder::on(area);
    if full {
        builder
            .caption(name, (FONT, px(17)))
            .margin(8)
            .margin_right(22)
            .x_label_area_size(44)
            .y_label_area_size(if y_desc { 70 } else { 52 });
    }
    let mut chart = builder.build_cartesian_2d(lo..hi, 0.0..top).map_err(&e)?;
    if full {
        let xs = hi - lo;
        let xf = move |v: &f64| tick_text(*v, xs);
        let yf = |v: &f64| format!("{v:.0}");
        let (bold, light) = mesh_colours();
        let mut mesh = chart.configure_mesh();
        mesh.bold_line_style(bold)
            .light_line_style(light)
            .x_labels(4)
            .y_labels(4)
            .x_label_formatter(&xf)
            .y_label_formatter(&yf)
            .label_style((FONT, SMALL_PX))
            .axis_desc_style((FONT, TICK_PX));
        if y_desc {
            mesh.y_desc("draws per bin");
        }
        mesh.draw().map_err(&e)?;
    }
    let (q05, q95) = (quantile(&sorted, 0.05), quantile(&sorted, 0.95));
    chart
        .draw_series(std::iter::once(Rectangle::new(
            [(q05, 0.0), (q95, top)],
            LIGHT_GREY.mix(0.9).filled(),
        )))
        .map_err(&e)?;
    chart
        .draw_series(
            counts
                .iter()
                .enumerate()
                .filter(|(_, c)| **c > 0)
                .map(|(k, c)| {
                    let x0 = lo + k as f64 * w;
                    Rectangle::new([(x0, 0.0), (x0 + w, *c as f64)], SKY_BLUE.filled())
                }),
        )
        .map_err(&e)?;
    let mean = d.iter().sum::<f64>() / d.len() as f64;
    chart
        .draw_series(DashedLineSeries::new(
            vec![(mean, 0.0), (mean, top)],
            8,
            5,
            BLUE.stroke_width(2),
        ))
        .map_err(&e)?;
    if let Some(t) = truth {
        chart
            .draw_series(LineSeries::new(
                vec![(t, 0.0), (t, top)],
                VERMILLION.stroke_width(3),
            ))
            .map_err(&e)?;
    }
    Ok(())
}

/// Total scatter points in a corner plot (split evenly over the panels).
const CORNER_POINTS: usize = 9_000;

/// Corner plot: pairwise scatter of the posterior draws below the diagonal (thinned by a fixed
/// stride), marginal histograms on the diagonal, and the correlation coefficient ρ of every
/// pair above it (cell shaded blue for ρ > 0, vermillion for ρ < 0, darker for larger |ρ|).
///
/// `draws[p]` holds the pooled draws of parameter `p` (all of the same length); `truth` marks
/// the true values when given.
pub fn corner(names: &[&str], draws: &[Vec<f64>], truth: Option<&[f64]>) -> Result<String> {
    const FIG: &str = "corner";
    check_draws(FIG, names, draws)?;
    check_truth(FIG, truth, names.len())?;
    let m = draws[0].len();
    for (p, d) in draws.iter().enumerate() {
        if d.len() != m {
            return Err(ReportError::LengthMismatch {
                figure: FIG,
                series: names[p].to_string(),
                expected: m,
                got: d.len(),
            });
        }
    }
    let n = names.len();
    let pairs = (n * (n - 1) / 2).max(1);
    let keep = thin_indices(m, (CORNER_POINTS / pairs).clamp(200, 3000));
    let cell: u32 = (1300 / n as u32).clamp(120, 320);
    let (left, bottom) = (110u32, 70u32);
    let width = left + n as u32 * cell + 10;
    let height = 40 + 36 + n as u32 * cell + bottom;
    let ranges: Vec<(f64, f64)> = draws
        .iter()
        .enumerate()
        .map(|(p, d)| {
            let r = min_max(d.iter().copied().chain(truth.map(|t| t[p]))).unwrap_or((0.0, 1.0));
            padded(r, 0.04)
        })
        .collect();
    let font_px = (cell / 7).clamp(14, 28);
    render(FIG, (width, height), |root| {
        let body = titled(
            FIG,
            root,
            "Posterior draws: pairwise scatter and correlations",
        )?;
        let mut entries = vec![(
            format!("{} of {m} draws per panel", keep.len()),
            Mark::Dot(BLUE),
        )];
        if truth.is_some() {
            entries.push((
                "true value".into(),
                Mark::Line(
                    SeriesStyle {
                        colour: VERMILLION,
                        dashed: false,
                    },
                    3,
                ),
            ));
        }
        entries.push(("ρ: correlation coefficient".into(), Mark::None));
        let body = legend_strip(FIG, &body, &entries)?;
        let xs: Vec<u32> = (1..n as u32).map(|k| left + k * cell).collect();
        let ys: Vec<u32> = (1..n as u32).map(|k| k * cell).collect();
        let areas = body.split_by_breakpoints(xs, ys);
        for i in 0..n {
            for j in 0..n {
                let area = &areas[i * n + j];
                let (first_col, last_row) = (j == 0, i == n - 1);
                if j > i {
                    corr_cell(FIG, area, correlation(&draws[i], &draws[j]), font_px)?;
                    continue;
                }
                let e = draw_err(FIG);
                let (xr, yr) = (ranges[j], ranges[i]);
                let mut chart = ChartBuilder::on(area)
                    .margin(3)
                    .x_label_area_size(if last_row { bottom } else { 0 })
                    .y_label_area_size(if first_col { left } else { 0 })
                    .build_cartesian_2d(xr.0..xr.1, yr.0..yr.1)
                    .map_err(&e)?;
                let (sx, sy) = (xr.1 - xr.0, yr.1 - yr.0);
                let xf = move |v: &f64| tick_text(*v, sx * 5.0 / 3.0);
                let diag = i == j;
                let yf = move |v: &f64| {
                    if diag {
                        String::new()
                    } else {
                        tick_text(*v, sy * 5.0 / 3.0)
                    }
                };
                let (bold, light) = mesh_colours();
                let mut mesh = chart.configure_mesh();
                mesh.bold_line_style(bold)
                    .light_line_style(light)
                    .x_labels(3)
                    .y_labels(3)
                    .x_label_formatter(&xf)
                    .y_label_formatter(&yf)
                    .label_style((FONT, SMALL_PX))
                    .axis_desc_style((FONT, TICK_PX));
                if last_row {
                    mesh.x_desc(names[j]);
                }
                if first_col && !diag {
                    mesh.y_desc(names[i]);
                }
                mesh.draw().map_err(&e)?;
                if diag {
                    let d = &draws[i];
                    let counts = bin_counts(d, xr.0, xr.1, BINS);
                    let top = counts.iter().copied().max().unwrap_or(1).max(1) as f64 * 1.08;
                    let w = (xr.1 - xr.0) / BINS as f64;
                    let scale = (yr.1 - yr.0) / top;
                    chart
                        .draw_series(counts.iter().enumerate().filter(|(_, c)| **c > 0).map(
                            |(k, c)| {
                                let x0 = xr.0 + k as f64 * w;
                                Rectangle::new(
                                    [(x0, yr.0), (x0 + w, yr.0 + *c as f64 * scale)],
                                    SKY_BLUE.filled(),
                                )
                            },
                        ))
                        .map_err(&e)?;
                    if let Some(t) = truth {
                        chart
                            .draw_series(LineSeries::new(
                                vec![(t[i], yr.0), (t[i], yr.1)],
                                VERMILLION.stroke_width(2),
                            ))
                            .map_err(&e)?;
                    }
                } else {
                    chart
                        .draw_series(keep.iter().map(|&k| {
                            Circle::new((draws[j][k], draws[i][k]), 1, BLUE.mix(0.35).filled())
                        }))
                        .map_err(&e)?;
                    if let Some(t) = truth {
                        let c = VERMILLION.stroke_width(2);
                        chart
                            .draw_series([
                                PathElement::new(vec![(t[j], yr.0), (t[j], yr.1)], c),
                                PathElement::new(vec![(xr.0, t[i]), (xr.1, t[i])], c),
                            ])
                            .map_err(&e)?;
                    }
                }
            }
        }
        Ok(())
    })
}

/// An upper-triangle cell: ρ written in the middle on a shade that grows with |ρ|.
fn corr_cell(figure: &'static str, area: &Area<'_>, rho: f64, size: u32) -> Result<()> {
    let e = draw_err(figure);
    let (w, h) = area.dim_in_pixel();
    let base = if rho >= 0.0 { BLUE } else { VERMILLION };
    area.draw(&Rectangle::new(
        [(3, 3), (w as i32 - 3, h as i32 - 3)],
        base.mix(0.08 + 0.5 * rho.abs()).filled(),
    ))
    .map_err(&e)?;
    let font = (FONT, px(size))
        .into_font()
        .color(&plotters::style::BLACK)
        .pos(Pos::new(HPos::Center, VPos::Center));
    area.draw(&Text::new(
        format!("ρ = {rho:.2}"),
        (w as i32 / 2, h as i32 / 2),
        font,
    ))
    .map_err(&e)?;
    Ok(())
}
