//! Diagnosis and sensitivity figures: candidate-effect ranking and the sensitivity curves.

use plotters::coord::types::RangedCoordf64;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};

use super::{
    draw_err, draw_line, legend_strip, linear_chart, mesh_colours, min_max, padded, render, style,
    text_width, tick_text, titled, Area, Mark, DESC_PX, FONT, SMALL_PX, TICK_PX,
};
use crate::error::{ReportError, Result};
use crate::labels::format_sig;
use crate::palette::{SeriesStyle, BLUE, GREY, VERMILLION};

/// One candidate effect scored by the diagnosis.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Candidate<'a> {
    /// Effect name (e.g. `electromechanical_delay`).
    pub name: &'a str,
    /// Evidence for the effect (score-test `LM − p ln n`, about the BIC gain; may be negative).
    pub evidence: f64,
    /// Held-out RMS torque error of the model extended by this effect (N·m).
    pub heldout_rms_nm: Option<f64>,
    /// Whether the diagnosis kept it as a cause (drawn in vermillion).
    pub selected: bool,
}

/// One point of a one-at-a-time sensitivity sweep.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SensitivityPoint<'a> {
    /// Parameter label (with its unit if wanted).
    pub param: &'a str,
    /// Relative change of the parameter (%).
    pub change_pct: f64,
    /// RMS torque change against the nominal run (N·m); `None` when that simulation failed
    /// (the point is left out).
    pub rms_change_nm: Option<f64>,
}

fn check_value(figure: &'static str, what: String, v: f64, index: usize) -> Result<()> {
    if v.is_finite() {
        Ok(())
    } else {
        Err(ReportError::NonFinite {
            figure,
            series: what,
            index,
            value: v,
        })
    }
}

/// Candidate effects as horizontal bars, in the order given (put the best first): their
/// evidence on the left, the held-out RMS error of the extended model on the right, with the
/// baseline's held-out RMS as a dashed line when given. Selected causes are vermillion, the
/// others blue.
pub fn candidate_ranking(
    rows: &[Candidate<'_>],
    baseline_heldout_rms_nm: Option<f64>,
) -> Result<String> {
    const FIG: &str = "candidate_ranking";
    if rows.is_empty() {
        return Err(ReportError::Empty {
            figure: FIG,
            series: "candidates".into(),
        });
    }
    for (i, r) in rows.iter().enumerate() {
        check_value(FIG, format!("{} evidence", r.name), r.evidence, i)?;
        if let Some(h) = r.heldout_rms_nm {
            check_value(FIG, format!("{} heldout_rms_nm", r.name), h, i)?;
        }
    }
    if let Some(b) = baseline_heldout_rms_nm {
        check_value(FIG, "baseline_heldout_rms_nm".into(), b, 0)?;
    }
    let n = rows.len();
    let label_w = rows
        .iter()
        .map(|r| text_width(r.name, TICK_PX))
        .max()
        .unwrap_or(100)
        .clamp(80, 320) as u32
        + 20;
    let height = 170 + 46 * n as u32;
    render(FIG, (1100, height), |root| {
        let body = titled(FIG, root, "Candidate effects ranked by evidence")?;
        let mut entries = vec![
            ("kept as a cause".to_string(), Mark::Swatch(VERMILLION, 1.0)),
            ("not kept".to_string(), Mark::Swatch(BLUE, 1.0)),
        ];
        if let Some(b) = baseline_heldout_rms_nm {
            entries.push((
                format!("baseline held-out RMS {b:.2} N·m"),
                Mark::Line(
                    SeriesStyle {
                        colour: GREY,
                        dashed: true,
                    },
                    2,
                ),
            ));
        }
        let body = legend_strip(FIG, &body, &entries)?;
        let (w, _) = body.dim_in_pixel();
        let (l, r) = body.split_horizontally(label_w + (w - label_w) * 55 / 100);
        let ev = min_max(rows.iter().map(|r| r.evidence).chain([0.0])).unwrap_or((0.0, 1.0));
        let ev = padded(ev, 0.12);
        let ev = (if ev.0 > 0.0 { 0.0 } else { ev.0 }, ev.1);
        bar_panel(
            FIG,
            &l,
            rows,
            ev,
            label_w,
            "evidence (score test, ≈ BIC gain)",
            |r| Some(r.evidence),
            None,
            true,
        )?;
        let rm = rows
            .iter()
            .filter_map(|r| r.heldout_rms_nm)
            .chain(baseline_heldout_rms_nm)
            .fold(0.0, f64::max);
        bar_panel(
            FIG,
            &r,
            rows,
            (0.0, if rm > 0.0 { rm * 1.2 } else { 1.0 }),
            12,
            "held-out RMS error (N·m)",
            |r| r.heldout_rms_nm,
            baseline_heldout_rms_nm,
            false,
        )
    })
}

#[allow(clippy::too_many_arguments)]
fn bar_panel(
    figure: &'static str,
    area: &Area<'_>,
    rows: &[Candidate<'_>],
    x: (f64, f64),
    label_w: u32,
    x_desc: &str,
    value: impl Fn(&Candidate<'_>) -> Option<f64>,
    reference: Option<f64>,
    names: bool,
) -> Result<()> {
    let e = draw_err(figure);
    let n = rows.len();
    let mut chart = ChartBuilder::on(area)
        .margin_right(20)
        .margin_top(6)
        .x_label_area_size(56)
        .y_label_area_size(label_w)
        .build_cartesian_2d(x.0..x.1, 0.0..n as f64)
        .map_err(&e)?;
    let xs = x.1 - x.0;
    let xf = move |v: &f64| tick_text(*v, xs);
    let (bold, light) = mesh_colours();
    chart
        .configure_mesh()
        .disable_y_mesh()
        .bold_line_style(bold)
        .light_line_style(light)
        .x_labels(6)
        .y_labels(0)
        .x_label_formatter(&xf)
        .label_style((FONT, TICK_PX))
        .axis_desc_style((FONT, DESC_PX))
        .x_desc(x_desc)
        .draw()
        .map_err(&e)?;
    let value_font = (FONT, SMALL_PX)
        .into_font()
        .color(&plotters::style::BLACK)
        .pos(Pos::new(HPos::Left, VPos::Center));
    let name_font = (FONT, TICK_PX)
        .into_font()
        .color(&plotters::style::BLACK)
        .pos(Pos::new(HPos::Right, VPos::Center));
    let base = area.get_base_pixel();
    for (k, r) in rows.iter().enumerate() {
        // Best first, at the top.
        let y = (n - 1 - k) as f64;
        let c = if r.selected { VERMILLION } else { BLUE };
        let (v, label) = match value(r) {
            Some(v) => (v, format_sig(v, 3)),
            None => (x.0, "not refitted".to_string()),
        };
        if value(r).is_some() {
            chart
                .draw_series(std::iter::once(Rectangle::new(
                    [(0.0, y + 0.18), (v, y + 0.82)],
                    c.mix(0.85).filled(),
                )))
                .map_err(&e)?;
        }
        let at = chart.backend_coord(&(v.max(0.0), y + 0.5));
        area.draw(&Text::new(
            label,
            (at.0 - base.0 + 6, at.1 - base.1),
            value_font.clone(),
        ))
        .map_err(&e)?;
        if names {
            let at = chart.backend_coord(&(x.0, y + 0.5));
            area.draw(&Text::new(
                r.name.to_string(),
                (at.0 - base.0 - 10, at.1 - base.1),
                name_font.clone(),
            ))
            .map_err(&e)?;
        }
    }
    if let Some(b) = reference {
        chart
            .draw_series(DashedLineSeries::new(
                vec![(b, 0.0), (b, n as f64)],
                8,
                5,
                GREY.stroke_width(2),
            ))
            .map_err(&e)?;
    }
    Ok(())
}

/// The dissertation's Fig. 6: RMS torque change (N·m) against the relative change of each
/// parameter (%), one curve per parameter in first-appearance order. The nominal point
/// (0 %, 0 N·m) is added to every curve; points whose simulation failed are left out.
pub fn sensitivity_curves(points: &[SensitivityPoint<'_>]) -> Result<String> {
    const FIG: &str = "sensitivity_curves";
    let mut params: Vec<&str> = Vec::new();
    for (i, p) in points.iter().enumerate() {
        check_value(FIG, format!("{} change_pct", p.param), p.change_pct, i)?;
        if let Some(v) = p.rms_change_nm {
            check_value(FIG, format!("{} rms_change_nm", p.param), v, i)?;
        }
        if !params.contains(&p.param) {
            params.push(p.param);
        }
    }
    let mut curves: Vec<Vec<(f64, f64)>> = params
        .iter()
        .map(|name| {
            let mut c: Vec<(f64, f64)> = points
                .iter()
                .filter(|p| p.param == *name)
                .filter_map(|p| p.rms_change_nm.map(|v| (p.change_pct, v)))
                .collect();
            if !c.iter().any(|p| p.0 == 0.0) {
                c.push((0.0, 0.0));
            }
            c.sort_by(|a, b| a.0.total_cmp(&b.0));
            c
        })
        .collect();
    if curves.iter().all(|c| c.len() < 2) {
        return Err(ReportError::Empty {
            figure: FIG,
            series: "sensitivity points with an RMS change".into(),
        });
    }
    let x = padded(
        min_max(curves.iter().flatten().map(|p| p.0)).unwrap_or((-20.0, 20.0)),
        0.03,
    );
    let top = min_max(curves.iter().flatten().map(|p| p.1)).map_or(1.0, |r| r.1);
    let y = (0.0, if top > 0.0 { top * 1.06 } else { 1.0 });
    render(FIG, (1000, 760), |root| {
        let body = titled(
            FIG,
            root,
            "Sensitivity of the torque to each parameter (one at a time)",
        )?;
        let entries: Vec<_> = params
            .iter()
            .enumerate()
            .map(|(i, p)| (p.to_string(), Mark::Line(style(i), 2)))
            .collect();
        let body = legend_strip(FIG, &body, &entries)?;
        let e = draw_err(FIG);
        let mut chart = linear_chart(
            FIG,
            &body,
            (x, y),
            90,
            ("parameter change (%)", "RMS torque change (N·m)"),
        )?;
        for (i, c) in curves.iter_mut().enumerate() {
            let st = style(i);
            draw_line(FIG, &mut chart, c.clone(), st, 2)?;
            chart
                .draw_series(c.iter().map(|p| Circle::new(*p, 4, st.colour.filled())))
                .map_err(&e)?;
        }
        Ok(())
    })
}

/// One flexible term of a diagnosis (the shape of a structure no catalogued effect explains):
/// its value at points of its state variable with the half-width of its 95 % band.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FlexibleTermView<'a> {
    /// State variable (e.g. `angle`, `velocity`, `direction`, `time`, `activation`).
    pub variable: &'a str,
    /// Unit of `points` (empty: dimensionless).
    pub unit: &'a str,
    /// Points of the variable; for `direction` −1 (plantarflexing, q̇ < 0) and +1
    /// (dorsiflexing, q̇ > 0).
    pub points: &'a [f64],
    /// Term at each point (N·m).
    pub value_nm: &'a [f64],
    /// Half-width of the 95 % band at each point (N·m; NaN when not computed: no band drawn).
    pub band_nm: &'a [f64],
}

/// Label of a `direction` point: the sign of the angular velocity in words.
fn direction_label(x: f64) -> &'static str {
    if x < 0.0 {
        "plantarflexing (q̇<0)"
    } else {
        "dorsiflexing (q̇>0)"
    }
}

/// The x-axis title of a term's panel.
fn term_axis(t: &FlexibleTermView<'_>) -> String {
    match (t.variable, t.unit) {
        ("direction", _) => "direction of motion (sign of q̇)".to_string(),
        (v, "") => format!("{v} (normalised)"),
        (v, u) => format!("{v} ({u})"),
    }
}

/// The flexible terms of a diagnosis, one panel per term, stacked: the term (N·m) against its
/// variable with its 95 % band shaded and a zero line (the terms are centred: their mean over
/// the trial is zero). A `direction` term is drawn as two points with 95 % error bars,
/// plantarflexing (q̇ < 0) and dorsiflexing (q̇ > 0).
pub fn flexible_terms(terms: &[FlexibleTermView<'_>]) -> Result<String> {
    const FIG: &str = "flexible_terms";
    if terms.is_empty() {
        return Err(ReportError::Empty {
            figure: FIG,
            series: "flexible terms".into(),
        });
    }
    for t in terms {
        let n = t.points.len();
        if n == 0 {
            return Err(ReportError::Empty {
                figure: FIG,
                series: format!("{} points", t.variable),
            });
        }
        for (what, v) in [("value_nm", t.value_nm), ("band_nm", t.band_nm)] {
            if v.len() != n {
                return Err(ReportError::LengthMismatch {
                    figure: FIG,
                    series: format!("{} {what}", t.variable),
                    expected: n,
                    got: v.len(),
                });
            }
        }
        for (i, &x) in t.points.iter().enumerate() {
            check_value(FIG, format!("{} points", t.variable), x, i)?;
        }
        for (i, &v) in t.value_nm.iter().enumerate() {
            check_value(FIG, format!("{} value_nm", t.variable), v, i)?;
        }
        // a band is NaN when not computed; anything else must be a finite half-width
        for (i, &b) in t.band_nm.iter().enumerate() {
            if !b.is_nan() {
                check_value(FIG, format!("{} band_nm", t.variable), b, i)?;
            }
        }
    }
    let any_band = terms
        .iter()
        .any(|t| t.band_nm.iter().any(|b| b.is_finite()));
    let panel_h = 380;
    let height = 130 + panel_h * terms.len() as u32;
    render(FIG, (1000, height), |root| {
        let title = if terms.len() == 1 {
            "The flexible term: what the unexplained structure depends on".to_string()
        } else {
            "The flexible terms: what the unexplained structure depends on".to_string()
        };
        let body = titled(FIG, root, &title)?;
        let mut entries = vec![(
            "flexible term (centred: zero mean over the trial)".to_string(),
            Mark::Line(
                SeriesStyle {
                    colour: VERMILLION,
                    dashed: false,
                },
                2,
            ),
        )];
        if any_band {
            entries.push(("95 % band".to_string(), Mark::Swatch(VERMILLION, 0.25)));
        } else {
            entries.push(("band not computed".to_string(), Mark::None));
        }
        entries.push((
            "zero".to_string(),
            Mark::Line(
                SeriesStyle {
                    colour: GREY,
                    dashed: true,
                },
                2,
            ),
        ));
        let body = legend_strip(FIG, &body, &entries)?;
        let panels = body.split_evenly((terms.len(), 1));
        for (t, area) in terms.iter().zip(&panels) {
            term_panel(FIG, area, t)?;
        }
        Ok(())
    })
}

/// A chart on `f64` axes, as [`linear_chart`] builds it.
type Chart<'b, 'a> = ChartContext<'b, SVGBackend<'a>, Cartesian2d<RangedCoordf64, RangedCoordf64>>;

/// One term's panel: a `direction` term as two points with error bars, any other as a curve
/// with its band.
fn term_panel(figure: &'static str, area: &Area<'_>, t: &FlexibleTermView<'_>) -> Result<()> {
    let y = padded(term_extent(t), 0.08);
    if t.variable == "direction" {
        direction_panel(figure, area, t, y)
    } else {
        curve_panel(figure, area, t, y)
    }
}

/// The half-width of the band drawn at point `i`: 0 where the band was not computed.
fn drawn_band(t: &FlexibleTermView<'_>, i: usize) -> f64 {
    let b = t.band_nm[i];
    if b.is_finite() {
        b
    } else {
        0.0
    }
}

/// The range of values a term's panel shows: the term with its band, and zero.
fn term_extent(t: &FlexibleTermView<'_>) -> (f64, f64) {
    min_max(
        t.value_nm
            .iter()
            .enumerate()
            .flat_map(|(i, v)| [v - drawn_band(t, i), v + drawn_band(t, i)])
            .chain([0.0]),
    )
    .unwrap_or((-1.0, 1.0))
}

/// The y-axis title of a term's panel.
fn term_value_axis(t: &FlexibleTermView<'_>) -> String {
    format!("{} term (N·m)", t.variable)
}

/// The shading of a band (a box round a direction point, or the area round a curve).
fn band_fill() -> ShapeStyle {
    VERMILLION.mix(0.25).filled()
}

/// The dashed zero line from `x.0` to `x.1` (the terms are centred: zero is their mean).
fn draw_zero_line(figure: &'static str, chart: &mut Chart<'_, '_>, x: (f64, f64)) -> Result<()> {
    chart
        .draw_series(DashedLineSeries::new(
            vec![(x.0, 0.0), (x.1, 0.0)],
            8,
            5,
            GREY.stroke_width(2),
        ))
        .map_err(draw_err(figure))?;
    Ok(())
}

/// A `direction` term's panel: the two directions as points with 95 % error bars, joined by a
/// dashed step, and named under the axis.
fn direction_panel(
    figure: &'static str,
    area: &Area<'_>,
    t: &FlexibleTermView<'_>,
    y: (f64, f64),
) -> Result<()> {
    let x = (-1.8, 1.8);
    let mut chart = direction_chart(figure, area, t, x, y)?;
    draw_zero_line(figure, &mut chart, x)?;
    draw_direction_step(figure, &mut chart, t)?;
    draw_direction_points(figure, &mut chart, t)?;
    draw_direction_names(figure, area, &chart, t, y.0)
}

/// The chart of a `direction` panel with its mesh: no x ticks (the directions are categories,
/// named by [`draw_direction_names`]).
fn direction_chart<'b, 'a>(
    figure: &'static str,
    area: &'b Area<'a>,
    t: &FlexibleTermView<'_>,
    x: (f64, f64),
    y: (f64, f64),
) -> Result<Chart<'b, 'a>> {
    let e = draw_err(figure);
    let mut chart = ChartBuilder::on(area)
        .margin_right(24)
        .margin_top(10)
        .x_label_area_size(70)
        .y_label_area_size(90)
        .build_cartesian_2d(x.0..x.1, y.0..y.1)
        .map_err(&e)?;
    let ys = y.1 - y.0;
    let yf = move |v: &f64| tick_text(*v, ys);
    let (bold, light) = mesh_colours();
    chart
        .configure_mesh()
        .disable_x_mesh()
        .bold_line_style(bold)
        .light_line_style(light)
        .x_labels(0)
        .y_label_formatter(&yf)
        .label_style((FONT, TICK_PX))
        .axis_desc_style((FONT, DESC_PX))
        .x_desc(term_axis(t))
        .y_desc(term_value_axis(t))
        .draw()
        .map_err(&e)?;
    Ok(chart)
}

/// The step between the two directions, dashed and faint (drawn only when there are two).
fn draw_direction_step(
    figure: &'static str,
    chart: &mut Chart<'_, '_>,
    t: &FlexibleTermView<'_>,
) -> Result<()> {
    let mut pts: Vec<(f64, f64)> = t
        .points
        .iter()
        .zip(t.value_nm)
        .map(|(x, v)| (*x, *v))
        .collect();
    pts.sort_by(|a, b| a.0.total_cmp(&b.0));
    if pts.len() == 2 {
        let mid = 0.5 * (pts[0].0 + pts[1].0);
        chart
            .draw_series(DashedLineSeries::new(
                vec![
                    (pts[0].0, pts[0].1),
                    (mid, pts[0].1),
                    (mid, pts[1].1),
                    (pts[1].0, pts[1].1),
                ],
                6,
                6,
                VERMILLION.mix(0.6).stroke_width(1),
            ))
            .map_err(draw_err(figure))?;
    }
    Ok(())
}

/// Each direction's point, over its band (a shaded box and an error bar) where it has one.
fn draw_direction_points(
    figure: &'static str,
    chart: &mut Chart<'_, '_>,
    t: &FlexibleTermView<'_>,
) -> Result<()> {
    let e = draw_err(figure);
    let line = VERMILLION.stroke_width(2);
    for (i, (&px, &v)) in t.points.iter().zip(t.value_nm).enumerate() {
        let b = drawn_band(t, i);
        if b > 0.0 {
            chart
                .draw_series(std::iter::once(Rectangle::new(
                    [(px - 0.18, v - b), (px + 0.18, v + b)],
                    band_fill(),
                )))
                .map_err(&e)?;
            // the error bar: a whisker with a cap at each end
            let whiskers = [
                vec![(px, v - b), (px, v + b)],
                vec![(px - 0.08, v - b), (px + 0.08, v - b)],
                vec![(px - 0.08, v + b), (px + 0.08, v + b)],
            ];
            chart
                .draw_series(whiskers.into_iter().map(|w| PathElement::new(w, line)))
                .map_err(&e)?;
        }
        chart
            .draw_series(std::iter::once(Circle::new(
                (px, v),
                6,
                VERMILLION.filled(),
            )))
            .map_err(&e)?;
    }
    Ok(())
}

/// The directions' names under the axis (at `y0`, its bottom), in place of x tick labels.
fn draw_direction_names(
    figure: &'static str,
    area: &Area<'_>,
    chart: &Chart<'_, '_>,
    t: &FlexibleTermView<'_>,
    y0: f64,
) -> Result<()> {
    let base = area.get_base_pixel();
    let font = (FONT, TICK_PX)
        .into_font()
        .color(&plotters::style::BLACK)
        .pos(Pos::new(HPos::Center, VPos::Top));
    for &px in t.points {
        let at = chart.backend_coord(&(px, y0));
        area.draw(&Text::new(
            direction_label(px).to_string(),
            (at.0 - base.0, at.1 - base.1 + 8),
            font.clone(),
        ))
        .map_err(draw_err(figure))?;
    }
    Ok(())
}

/// A term's panel against a continuous variable: its band shaded, the zero line, and the term
/// as a line through its points, in the order of the variable.
fn curve_panel(
    figure: &'static str,
    area: &Area<'_>,
    t: &FlexibleTermView<'_>,
    y: (f64, f64),
) -> Result<()> {
    let x = padded(
        min_max(t.points.iter().copied()).unwrap_or((0.0, 1.0)),
        0.02,
    );
    let mut chart = linear_chart(
        figure,
        area,
        (x, y),
        90,
        (&term_axis(t), &term_value_axis(t)),
    )?;
    let mut order: Vec<usize> = (0..t.points.len()).collect();
    order.sort_by(|a, b| t.points[*a].total_cmp(&t.points[*b]));
    draw_curve_band(figure, &mut chart, t, &order)?;
    draw_zero_line(figure, &mut chart, x)?;
    draw_curve(figure, &mut chart, t, &order)
}

/// The band round the curve as one polygon (up along its upper edge, back along the lower),
/// when some point has a band; `order` sorts the points by the variable.
fn draw_curve_band(
    figure: &'static str,
    chart: &mut Chart<'_, '_>,
    t: &FlexibleTermView<'_>,
    order: &[usize],
) -> Result<()> {
    if order.iter().any(|&i| drawn_band(t, i) > 0.0) {
        let mut poly: Vec<(f64, f64)> = order
            .iter()
            .map(|&i| (t.points[i], t.value_nm[i] + drawn_band(t, i)))
            .collect();
        poly.extend(
            order
                .iter()
                .rev()
                .map(|&i| (t.points[i], t.value_nm[i] - drawn_band(t, i))),
        );
        chart
            .draw_series(std::iter::once(Polygon::new(poly, band_fill())))
            .map_err(draw_err(figure))?;
    }
    Ok(())
}

/// The term as a line with a dot at each point; `order` sorts the points by the variable.
fn draw_curve(
    figure: &'static str,
    chart: &mut Chart<'_, '_>,
    t: &FlexibleTermView<'_>,
    order: &[usize],
) -> Result<()> {
    let curve: Vec<(f64, f64)> = order
        .iter()
        .map(|&i| (t.points[i], t.value_nm[i]))
        .collect();
    draw_line(
        figure,
        chart,
        curve.clone(),
        SeriesStyle {
            colour: VERMILLION,
            dashed: false,
        },
        2,
    )?;
    chart
        .draw_series(
            curve
                .iter()
                .map(|p| Circle::new(*p, 4, VERMILLION.filled())),
        )
        .map_err(draw_err(figure))?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::check_svg;

    #[test]
    fn flexible_terms_two_panels_well_formed() {
        let points: Vec<f64> = (0..8).map(|k| -20.0 + 5.0 * k as f64).collect();
        let value: Vec<f64> = points.iter().map(|q| 0.05 * q).collect();
        let band = vec![0.3; 8];
        let dir_points = [-1.0, 1.0];
        let dir_value = [0.8, -0.8];
        let dir_band = [0.15, 0.2];
        let terms = [
            FlexibleTermView {
                variable: "direction",
                unit: "",
                points: &dir_points,
                value_nm: &dir_value,
                band_nm: &dir_band,
            },
            FlexibleTermView {
                variable: "angle",
                unit: "°",
                points: &points,
                value_nm: &value,
                band_nm: &band,
            },
        ];
        let svg = flexible_terms(&terms).unwrap();
        assert!(svg.starts_with("<svg") && svg.trim_end().ends_with("</svg>"));
        let s = check_svg(&svg).expect("well-formed SVG");
        for label in [
            "plantarflexing (q̇<0)",
            "dorsiflexing (q̇>0)",
            "angle (°)",
            "angle term (N·m)",
            "direction term (N·m)",
            "95 % band",
        ] {
            assert!(s.has_text(label), "missing {label:?} in {:?}", s.texts);
        }
        assert!(s.count("polygon") >= 1, "{:?}", s.elements);
        assert!(s.count("circle") >= 10, "{:?}", s.elements);
        for size in svg.split("font-size=\"").skip(1) {
            let v: f64 = size[..size.find('"').unwrap()].parse().unwrap();
            assert!(v >= 14.0 - 1e-9, "font size {v}");
        }
        assert_eq!(flexible_terms(&terms).unwrap(), svg, "deterministic");

        // no band computed: drawn without it; bad input is an error, not a panic
        let nan = [f64::NAN; 8];
        let no_band = FlexibleTermView {
            band_nm: &nan,
            ..terms[1]
        };
        let svg = flexible_terms(&[no_band]).unwrap();
        assert!(check_svg(&svg).unwrap().has_text("band not computed"));
        assert!(flexible_terms(&[]).is_err());
        let short = FlexibleTermView {
            value_nm: &value[..3],
            ..terms[1]
        };
        assert!(matches!(
            flexible_terms(&[short]),
            Err(ReportError::LengthMismatch { .. })
        ));
        let inf = [f64::INFINITY, 0.0];
        let bad = FlexibleTermView {
            value_nm: &inf,
            ..terms[0]
        };
        assert!(matches!(
            flexible_terms(&[bad]),
            Err(ReportError::NonFinite { .. })
        ));
    }
}
