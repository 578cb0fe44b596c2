//! Time-series figures of a fit: torque with angle and EMG beneath, residuals, baseline vs
//! extended model.

use numerics::rms_diff;
use plotters::prelude::*;

use super::{
    check_finite, check_parallel, decimate, draw_err, draw_line, legend_strip, linear_chart,
    mesh_colours, min_max, padded, render, rms, style, thin_indices, tick_text, titled, Area, Mark,
    DESC_PX, FONT, MAX_LINE_POINTS, MAX_SCATTER_POINTS, TICK_PX,
};

use crate::error::{ReportError, Result};
use crate::palette::{SeriesStyle, BLACK, GREY};

/// One line of a panel.
struct Line {
    points: Vec<(f64, f64)>,
    style: SeriesStyle,
    width: u32,
}

/// Options of one panel of stacked time series.
struct Panel<'p> {
    x: (f64, f64),
    y: (f64, f64),
    x_desc: Option<&'p str>,
    y_desc: &'p str,
    zero_line: bool,
}

const Y_LABEL_AREA: u32 = 90;

/// Draws lines into `area` with the axes of `p`.
fn line_panel(figure: &'static str, area: &Area<'_>, p: &Panel<'_>, lines: &[Line]) -> Result<()> {
    let e = draw_err(figure);
    let mut chart = ChartBuilder::on(area)
        .margin_right(24)
        .margin_top(6)
        .x_label_area_size(if p.x_desc.is_some() { 56 } else { 0 })
        .y_label_area_size(Y_LABEL_AREA)
        .build_cartesian_2d(p.x.0..p.x.1, p.y.0..p.y.1)
        .map_err(&e)?;
    let (xs, ys) = (p.x.1 - p.x.0, p.y.1 - p.y.0);
    let xf = move |v: &f64| tick_text(*v, xs);
    let yf = move |v: &f64| tick_text(*v, ys);
    let (bold, light) = mesh_colours();
    let mut mesh = chart.configure_mesh();
    mesh.bold_line_style(bold)
        .light_line_style(light)
        .x_labels(10)
        .y_labels(6)
        .x_label_formatter(&xf)
        .y_label_formatter(&yf)
        .label_style((FONT, TICK_PX))
        .axis_desc_style((FONT, DESC_PX))
        .y_desc(p.y_desc);
    if let Some(d) = p.x_desc {
        mesh.x_desc(d);
    }
    mesh.draw().map_err(&e)?;
    if p.zero_line && p.y.0 < 0.0 && p.y.1 > 0.0 {
        chart
            .draw_series(LineSeries::new(
                vec![(p.x.0, 0.0), (p.x.1, 0.0)],
                GREY.stroke_width(1),
            ))
            .map_err(&e)?;
    }
    for l in lines {
        draw_line(figure, &mut chart, l.points.clone(), l.style, l.width)?;
    }
    Ok(())
}

fn y_range_of<'s>(series: impl IntoIterator<Item = &'s [f64]>, pad: f64) -> (f64, f64) {
    let all = series.into_iter().flat_map(|s| s.iter().copied());
    padded(min_max(all).unwrap_or((0.0, 1.0)), pad)
}

fn time_range(time: &[f64]) -> (f64, f64) {
    let r = min_max(time.iter().copied()).unwrap_or((0.0, 1.0));
    if r.1 > r.0 {
        r
    } else {
        padded(r, 0.0)
    }
}

const MEASURED: SeriesStyle = SeriesStyle {
    colour: BLACK,
    dashed: false,
};

/// Measured vs model torque over time, with the ankle angle and the EMG envelopes in panels
/// beneath (the dissertation's Figs. 11 and 21).
///
/// * `time` — sample times (s), increasing;
/// * `measured` — measured joint torque (N·m), one per time;
/// * `models` — `(label, torque N·m)` per model curve (e.g. `("model (SA)", &pred)`);
/// * `angle_deg` — ankle angle (deg, dorsiflexion positive);
/// * `envelopes` — `(channel, normalised envelope 0…1)` per EMG channel.
///
/// Every series must have `time.len()` finite values; `models` and `envelopes` may be empty
/// (their panel is then left out for the envelopes).
///
/// ```
/// let t: Vec<f64> = (0..200).map(|i| i as f64 * 0.01).collect();
/// let m: Vec<f64> = t.iter().map(|x| 50.0 * x.sin()).collect();
/// let q: Vec<f64> = t.iter().map(|x| 15.0 - 10.0 * x).collect();
/// let e: Vec<f64> = t.iter().map(|x| 0.5 + 0.4 * x.sin()).collect();
/// let svg = report::figures::torque_fit(&t, &m, &[("model", &m)], &q, &[("sol", &e)])?;
/// assert!(svg.contains("torque (N·m)"));
/// # Ok::<(), report::ReportError>(())
/// ```
pub fn torque_fit(
    time: &[f64],
    measured: &[f64],
    models: &[(&str, &[f64])],
    angle_deg: &[f64],
    envelopes: &[(&str, &[f64])],
) -> Result<String> {
    const FIG: &str = "torque_fit";
    check_finite(FIG, "time", time)?;
    let n = time.len();
    check_parallel(FIG, "measured", measured, n)?;
    for (name, m) in models {
        check_parallel(FIG, name, m, n)?;
    }
    check_parallel(FIG, "angle_deg", angle_deg, n)?;
    for (name, e) in envelopes {
        check_parallel(FIG, name, e, n)?;
    }
    let x = time_range(time);
    let height = if envelopes.is_empty() { 760 } else { 980 };
    render(FIG, (1000, height), |root| {
        let body = titled(FIG, root, "Measured and model ankle torque")?;
        let mut entries = vec![("measured".to_string(), Mark::Line(MEASURED, 2))];
        let mut lines = vec![Line {
            points: decimate(time, measured, MAX_LINE_POINTS),
            style: MEASURED,
            width: 2,
        }];
        for (i, (name, m)) in models.iter().enumerate() {
            let label = format!("{name} (RMS error {:.2} N·m)", rms_diff(measured, m));
            entries.push((label, Mark::Line(style(i), 2)));
            lines.push(Line {
                points: decimate(time, m, MAX_LINE_POINTS),
                style: style(i),
                width: 2,
            });
        }
        let body = legend_strip(FIG, &body, &entries)?;
        let (_, h) = body.dim_in_pixel();
        let (top, rest) = if envelopes.is_empty() {
            body.split_vertically(h * 68 / 100)
        } else {
            body.split_vertically(h * 52 / 100)
        };
        let torque_range = y_range_of(
            std::iter::once(measured).chain(models.iter().map(|m| m.1)),
            0.05,
        );
        line_panel(
            FIG,
            &top,
            &Panel {
                x,
                y: torque_range,
                x_desc: None,
                y_desc: "torque (N·m)",
                zero_line: true,
            },
            &lines,
        )?;
        let angle_panel = |area: &Area<'_>, last: bool| {
            line_panel(
                FIG,
                area,
                &Panel {
                    x,
                    y: y_range_of([angle_deg], 0.08),
                    x_desc: last.then_some("time (s)"),
                    y_desc: "ankle angle (deg)",
                    zero_line: false,
                },
                &[Line {
                    points: decimate(time, angle_deg, MAX_LINE_POINTS),
                    style: MEASURED,
                    width: 2,
                }],
            )
        };
        if envelopes.is_empty() {
            return angle_panel(&rest, true);
        }
        let (_, h2) = rest.dim_in_pixel();
        let (mid, low) = rest.split_vertically(h2 * 38 / 100);
        angle_panel(&mid, false)?;
        let offset = models.len();
        let mut e_entries = Vec::new();
        let mut e_lines = Vec::new();
        for (i, (name, e)) in envelopes.iter().enumerate() {
            let st = style(offset + i);
            e_entries.push((format!("EMG envelope {name}"), Mark::Line(st, 2)));
            e_lines.push(Line {
                points: decimate(time, e, MAX_LINE_POINTS),
                style: st,
                width: 2,
            });
        }
        let low = legend_strip(FIG, &low, &e_entries)?;
        let hi = min_max(envelopes.iter().flat_map(|e| e.1.iter().copied()))
            .map_or(1.0, |r| r.1.max(1.0));
        line_panel(
            FIG,
            &low,
            &Panel {
                x,
                y: (0.0, hi * 1.05),
                x_desc: Some("time (s)"),
                y_desc: "EMG (normalised)",
                zero_line: false,
            },
            &e_lines,
        )
    })
}

/// Residual (measured − model torque, N·m) against the ankle angle (deg), one colour per
/// movement phase (e.g. hold, concentric, eccentric).
///
/// `phase[i]` indexes `phase_names` for sample `i`. At most
/// [`MAX_SCATTER_POINTS`](super::MAX_SCATTER_POINTS) points are drawn (fixed-stride thinning).
pub fn residual_vs_angle(
    angle_deg: &[f64],
    residual: &[f64],
    phase: &[usize],
    phase_names: &[&str],
) -> Result<String> {
    const FIG: &str = "residual_vs_angle";
    check_finite(FIG, "angle_deg", angle_deg)?;
    let n = angle_deg.len();
    check_parallel(FIG, "residual", residual, n)?;
    if phase.len() != n {
        return Err(ReportError::LengthMismatch {
            figure: FIG,
            series: "phase".into(),
            expected: n,
            got: phase.len(),
        });
    }
    if phase_names.is_empty() {
        return Err(ReportError::Empty {
            figure: FIG,
            series: "phase_names".into(),
        });
    }
    if let Some((i, p)) = phase
        .iter()
        .enumerate()
        .find(|(_, p)| **p >= phase_names.len())
    {
        return Err(ReportError::Invalid {
            figure: FIG,
            reason: format!(
                "phase[{i}] = {p} but there are only {} phase names",
                phase_names.len()
            ),
        });
    }
    let x = padded(
        min_max(angle_deg.iter().copied()).unwrap_or((0.0, 1.0)),
        0.04,
    );
    let y = y_range_of([residual], 0.06);
    let keep = thin_indices(n, MAX_SCATTER_POINTS);
    render(FIG, (1000, 700), |root| {
        let body = titled(FIG, root, "Residual against ankle angle, by movement phase")?;
        let entries: Vec<_> = phase_names
            .iter()
            .enumerate()
            .map(|(k, name)| {
                let count = phase.iter().filter(|p| **p == k).count();
                (
                    format!("{name} ({count} samples)"),
                    Mark::Dot(style(k).colour),
                )
            })
            .collect();
        let body = legend_strip(FIG, &body, &entries)?;
        let e = draw_err(FIG);
        let mut chart = linear_chart(
            FIG,
            &body,
            (x, y),
            Y_LABEL_AREA,
            (
                "ankle angle (deg, dorsiflexion > 0)",
                "residual: measured − model (N·m)",
            ),
        )?;
        if y.0 < 0.0 && y.1 > 0.0 {
            chart
                .draw_series(LineSeries::new(
                    vec![(x.0, 0.0), (x.1, 0.0)],
                    GREY.stroke_width(1),
                ))
                .map_err(&e)?;
        }
        for k in 0..phase_names.len() {
            let c = style(k).colour;
            chart
                .draw_series(
                    keep.iter()
                        .filter(|&&i| phase[i] == k)
                        .map(|&i| Circle::new((angle_deg[i], residual[i]), 2, c.mix(0.7).filled())),
                )
                .map_err(&e)?;
        }
        Ok(())
    })
}

/// Residuals (measured − model, N·m) over time (s), one line per `(label, residual)`.
pub fn residual_vs_time(time: &[f64], residuals: &[(&str, &[f64])]) -> Result<String> {
    const FIG: &str = "residual_vs_time";
    check_finite(FIG, "time", time)?;
    if residuals.is_empty() {
        return Err(ReportError::Empty {
            figure: FIG,
            series: "residuals".into(),
        });
    }
    for (name, r) in residuals {
        check_parallel(FIG, name, r, time.len())?;
    }
    render(FIG, (1000, 600), |root| {
        let body = titled(FIG, root, "Residual over time")?;
        let entries: Vec<_> = residuals
            .iter()
            .enumerate()
            .map(|(i, (name, r))| {
                (
                    format!("{name} (RMS {:.2} N·m)", rms(r)),
                    Mark::Line(style(i), 2),
                )
            })
            .collect();
        let body = legend_strip(FIG, &body, &entries)?;
        let lines: Vec<Line> = residuals
            .iter()
            .enumerate()
            .map(|(i, (_, r))| Line {
                points: decimate(time, r, MAX_LINE_POINTS),
                style: style(i),
                width: if residuals.len() > 1 { 1 } else { 2 },
            })
            .collect();
        line_panel(
            FIG,
            &body,
            &Panel {
                x: time_range(time),
                y: y_range_of(residuals.iter().map(|r| r.1), 0.06),
                x_desc: Some("time (s)"),
                y_desc: "residual: measured − model (N·m)",
                zero_line: true,
            },
            &lines,
        )
    })
}

/// Baseline vs extended model: torque (N·m) over time (s) with the measured torque, and both
/// residuals beneath.
pub fn fit_comparison(
    time: &[f64],
    measured: &[f64],
    baseline: &[f64],
    extended: &[f64],
) -> Result<String> {
    const FIG: &str = "fit_comparison";
    check_finite(FIG, "time", time)?;
    let n = time.len();
    check_parallel(FIG, "measured", measured, n)?;
    check_parallel(FIG, "baseline", baseline, n)?;
    check_parallel(FIG, "extended", extended, n)?;
    let res = |m: &[f64]| -> Vec<f64> { measured.iter().zip(m).map(|(a, b)| a - b).collect() };
    let (rb, re) = (res(baseline), res(extended));
    let x = time_range(time);
    render(FIG, (1000, 820), |root| {
        let body = titled(FIG, root, "Baseline and extended model")?;
        let entries = vec![
            ("measured".to_string(), Mark::Line(MEASURED, 2)),
            (
                format!("baseline model (RMS error {:.2} N·m)", rms(&rb)),
                Mark::Line(style(1), 2),
            ),
            (
                format!("extended model (RMS error {:.2} N·m)", rms(&re)),
                Mark::Line(style(0), 2),
            ),
        ];
        let body = legend_strip(FIG, &body, &entries)?;
        let (_, h) = body.dim_in_pixel();
        let (top, low) = body.split_vertically(h * 60 / 100);
        line_panel(
            FIG,
            &top,
            &Panel {
                x,
                y: y_range_of([measured, baseline, extended], 0.05),
                x_desc: None,
                y_desc: "torque (N·m)",
                zero_line: true,
            },
            &[
                Line {
                    points: decimate(time, measured, MAX_LINE_POINTS),
                    style: MEASURED,
                    width: 2,
                },
                Line {
                    points: decimate(time, baseline, MAX_LINE_POINTS),
                    style: style(1),
                    width: 2,
                },
                Line {
                    points: decimate(time, extended, MAX_LINE_POINTS),
                    style: style(0),
                    width: 2,
                },
            ],
        )?;
        line_panel(
            FIG,
            &low,
            &Panel {
                x,
                y: y_range_of([rb.as_slice(), re.as_slice()], 0.06),
                x_desc: Some("time (s)"),
                y_desc: "residual (N·m)",
                zero_line: true,
            },
            &[
                Line {
                    points: decimate(time, &rb, MAX_LINE_POINTS),
                    style: style(1),
                    width: 1,
                },
                Line {
                    points: decimate(time, &re, MAX_LINE_POINTS),
                    style: style(0),
                    width: 1,
                },
            ],
        )
    })
}
