//! SVG figures from plain data; every function returns the SVG document as a `String`.
//!
//! All figures share one look: white background, sans-serif text of at least 14 px (tick labels
//! 16 px, axis titles 18 px, figure titles 22 px), the Okabe–Ito palette ([`crate::palette`]),
//! legends in a strip above the plot (never over the data), axes titled with units.
//! Long series are decimated for drawing (min/max per bucket, at most
//! [`MAX_LINE_POINTS`] points per line) and scatter plots are thinned by a fixed stride, so a
//! figure stays well under 1 MB and the same input always gives the same bytes.

mod design;
mod diagnosis;
mod ensemble;
mod mcmc;
mod time;

pub use design::{design_sds, DesignSeries};
pub use diagnosis::{
    candidate_ranking, flexible_terms, sensitivity_curves, Candidate, FlexibleTermView,
    SensitivityPoint,
};
pub use ensemble::{residual_ensemble, stride_ensemble};
pub use mcmc::{corner, histograms, rhat_history, traces};
pub use time::{fit_comparison, residual_vs_angle, residual_vs_time, torque_fit};

use plotters::coord::types::RangedCoordf64;
use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};

use crate::error::{ReportError, Result};
use crate::palette::{self, SeriesStyle};

/// Most points drawn per line (min/max decimation above this).
pub const MAX_LINE_POINTS: usize = 4000;
/// Most points drawn in one scatter plot (stride thinning above this).
pub const MAX_SCATTER_POINTS: usize = 4000;

pub(crate) const FONT: &str = "sans-serif";
/// plotters writes `font-size = size / 1.24` into the SVG (and rounds `size` down to whole
/// pixels for axis labels); sizes below are scaled back up and rounded up so that the
/// document carries at least the pixel size named here.
const PLOTTERS_FONT_SCALE: f64 = 1.24;
/// A font size for plotters that comes out as at least `px` pixels in the SVG.
pub(crate) const fn px(px: u32) -> f64 {
    ((px * 124).div_ceil(100)) as f64
}
pub(crate) const TICK_PX: f64 = px(16);
pub(crate) const SMALL_PX: f64 = px(14);
pub(crate) const DESC_PX: f64 = px(18);
pub(crate) const TITLE_PX: f64 = px(22);
pub(crate) const LEGEND_PX: f64 = px(16);
pub(crate) const LEGEND_ROW: u32 = 28;

pub(crate) type Area<'a> = DrawingArea<SVGBackend<'a>, Shift>;

/// Maps any drawing error to [`ReportError::Draw`].
pub(crate) fn draw_err<E: std::fmt::Display>(figure: &'static str) -> impl Fn(E) -> ReportError {
    move |e| ReportError::Draw {
        figure,
        message: e.to_string(),
    }
}

/// Fails on an empty series or a non-finite value.
pub(crate) fn check_finite(figure: &'static str, series: &str, v: &[f64]) -> Result<()> {
    if v.is_empty() {
        return Err(ReportError::Empty {
            figure,
            series: series.to_string(),
        });
    }
    if let Some((index, &value)) = v.iter().enumerate().find(|(_, x)| !x.is_finite()) {
        return Err(ReportError::NonFinite {
            figure,
            series: series.to_string(),
            index,
            value,
        });
    }
    Ok(())
}

/// [`check_finite`] plus a length check.
pub(crate) fn check_parallel(
    figure: &'static str,
    series: &str,
    v: &[f64],
    expected: usize,
) -> Result<()> {
    if v.len() != expected {
        return Err(ReportError::LengthMismatch {
            figure,
            series: series.to_string(),
            expected,
            got: v.len(),
        });
    }
    check_finite(figure, series, v)
}

/// Fails when `names` is empty or has another length than the data.
pub(crate) fn check_names(
    figure: &'static str,
    names: &[&str],
    expected: usize,
    what: &str,
) -> Result<()> {
    if expected == 0 {
        return Err(ReportError::Empty {
            figure,
            series: what.to_string(),
        });
    }
    if names.len() != expected {
        return Err(ReportError::LengthMismatch {
            figure,
            series: "names".into(),
            expected,
            got: names.len(),
        });
    }
    Ok(())
}

/// Smallest and largest of finite values; `None` when there are none.
pub(crate) fn min_max(values: impl IntoIterator<Item = f64>) -> Option<(f64, f64)> {
    let mut out: Option<(f64, f64)> = None;
    for v in values.into_iter().filter(|v| v.is_finite()) {
        out = Some(match out {
            None => (v, v),
            Some((lo, hi)) => (lo.min(v), hi.max(v)),
        });
    }
    out
}

/// Widens `[lo, hi]` by `frac` of its span on each side; a zero span becomes a small interval
/// around the value.
pub(crate) fn padded((lo, hi): (f64, f64), frac: f64) -> (f64, f64) {
    let span = hi - lo;
    if span > 0.0 && span.is_finite() {
        (lo - frac * span, hi + frac * span)
    } else {
        let d = if lo == 0.0 { 1.0 } else { 0.05 * lo.abs() };
        (lo - d, hi + d)
    }
}

/// Decimals for tick labels of an axis spanning `span` with about five ticks.
fn decimals(span: f64) -> usize {
    if !(span.is_finite() && span > 0.0) {
        return 2;
    }
    let step = span / 5.0;
    (-step.log10().floor()).clamp(0.0, 8.0) as usize
}

/// Tick-label text for an axis spanning `span`: fixed decimals chosen from the tick step,
/// with `-0` written as `0`.
pub(crate) fn tick_text(v: f64, span: f64) -> String {
    let s = format!("{:.*}", decimals(span), v);
    if s.starts_with('-') && s[1..].chars().all(|c| c == '0' || c == '.') {
        s[1..].to_string()
    } else {
        s
    }
}

/// Min/max decimation of a line to at most about `max_points` points: the index range is cut
/// into `max_points / 2` buckets and each bucket contributes its lowest and highest point, in
/// their original order. Peaks survive; short lines are returned whole.
pub(crate) fn decimate(x: &[f64], y: &[f64], max_points: usize) -> Vec<(f64, f64)> {
    let n = x.len().min(y.len());
    if n <= max_points || max_points < 4 {
        return x.iter().copied().zip(y.iter().copied()).take(n).collect();
    }
    let buckets = max_points / 2;
    let mut out = Vec::with_capacity(2 * buckets);
    for b in 0..buckets {
        let (s, e) = (b * n / buckets, (b + 1) * n / buckets);
        if s >= e {
            continue;
        }
        let (mut lo, mut hi) = (s, s);
        for i in s..e {
            if y[i] < y[lo] {
                lo = i;
            }
            if y[i] > y[hi] {
                hi = i;
            }
        }
        let (a, c) = if lo <= hi { (lo, hi) } else { (hi, lo) };
        out.push((x[a], y[a]));
        if c != a {
            out.push((x[c], y[c]));
        }
    }
    out
}

/// Indices `0..n` thinned by a fixed stride to at most `max` (all of them when `n <= max`).
pub(crate) fn thin_indices(n: usize, max: usize) -> Vec<usize> {
    if n <= max {
        (0..n).collect()
    } else {
        (0..max).map(|k| k * n / max).collect()
    }
}

/// Pearson correlation of two equally long series (0 when either is constant).
pub(crate) fn correlation(a: &[f64], b: &[f64]) -> f64 {
    let n = a.len().min(b.len());
    if n < 2 {
        return 0.0;
    }
    let ma = a[..n].iter().sum::<f64>() / n as f64;
    let mb = b[..n].iter().sum::<f64>() / n as f64;
    let (mut sab, mut saa, mut sbb) = (0.0, 0.0, 0.0);
    for i in 0..n {
        let (da, db) = (a[i] - ma, b[i] - mb);
        sab += da * db;
        saa += da * da;
        sbb += db * db;
    }
    if saa > 0.0 && sbb > 0.0 {
        (sab / (saa * sbb).sqrt()).clamp(-1.0, 1.0)
    } else {
        0.0
    }
}

pub(crate) use numerics::rms;

/// How a legend entry is drawn.
#[derive(Clone, Copy, Debug)]
pub(crate) enum Mark {
    /// A line sample.
    Line(SeriesStyle, u32),
    /// A filled dot.
    Dot(RGBColor),
    /// A filled box (bars, shaded regions).
    Swatch(RGBColor, f64),
    /// No sample: plain text.
    None,
}

/// Rough width in pixels of `text` at `px` (sans-serif averages about 0.55 em per glyph).
pub(crate) fn text_width(text: &str, size: f64) -> i32 {
    (text.chars().count() as f64 * size / PLOTTERS_FONT_SCALE * 0.56).ceil() as i32
}

/// Rows a legend of `entries` needs in `width` pixels.
pub(crate) fn legend_rows(entries: &[(String, Mark)], width: u32) -> u32 {
    let mut rows = 1;
    let mut x = 10;
    for (label, _) in entries {
        let w = 40 + text_width(label, LEGEND_PX) + 24;
        if x + w > width as i32 && x > 10 {
            rows += 1;
            x = 10;
        }
        x += w;
    }
    rows
}

/// Draws a legend strip (entries left to right, wrapping) at the top of `area` and returns the
/// area below it.
pub(crate) fn legend_strip<'a>(
    figure: &'static str,
    area: &Area<'a>,
    entries: &[(String, Mark)],
) -> Result<Area<'a>> {
    if entries.is_empty() {
        return Ok(area.clone());
    }
    let (w, _) = area.dim_in_pixel();
    let rows = legend_rows(entries, w);
    let (strip, rest) = area.split_vertically(rows * LEGEND_ROW + 6);
    let font = (FONT, LEGEND_PX)
        .into_font()
        .color(&BLACK)
        .pos(Pos::new(HPos::Left, VPos::Center));
    let mut x = 10;
    let mut row = 0;
    for (label, mark) in entries {
        let wdt = 40 + text_width(label, LEGEND_PX) + 24;
        if x + wdt > w as i32 && x > 10 {
            row += 1;
            x = 10;
        }
        let y = (row * LEGEND_ROW + LEGEND_ROW / 2 + 3) as i32;
        let e = draw_err(figure);
        match *mark {
            Mark::Line(style, width) => {
                let st = style.colour.stroke_width(width + 1);
                if style.dashed {
                    for k in 0..3 {
                        strip
                            .draw(&PathElement::new(
                                vec![(x + k * 11, y), (x + k * 11 + 7, y)],
                                st,
                            ))
                            .map_err(&e)?;
                    }
                } else {
                    strip
                        .draw(&PathElement::new(vec![(x, y), (x + 30, y)], st))
                        .map_err(&e)?;
                }
            }
            Mark::Dot(c) => {
                strip
                    .draw(&Circle::new((x + 15, y), 5, c.filled()))
                    .map_err(&e)?;
            }
            Mark::Swatch(c, alpha) => {
                strip
                    .draw(&Rectangle::new(
                        [(x + 3, y - 8), (x + 27, y + 8)],
                        c.mix(alpha).filled(),
                    ))
                    .map_err(&e)?;
            }
            Mark::None => {}
        }
        let tx = if matches!(mark, Mark::None) {
            x
        } else {
            x + 38
        };
        strip
            .draw(&Text::new(label.clone(), (tx, y), font.clone()))
            .map_err(&e)?;
        x += if matches!(mark, Mark::None) {
            text_width(label, LEGEND_PX) + 24
        } else {
            wdt
        };
    }
    Ok(rest)
}

/// Draws the figure title at the top of `area` and returns the area below it.
pub(crate) fn titled<'a>(figure: &'static str, area: &Area<'a>, title: &str) -> Result<Area<'a>> {
    area.titled(title, (FONT, TITLE_PX).into_font().color(&BLACK))
        .map_err(draw_err(figure))
}

/// Draws one line series (solid or dashed) into a chart.
pub(crate) fn draw_line<DB, CT>(
    figure: &'static str,
    chart: &mut ChartContext<'_, DB, CT>,
    points: Vec<(f64, f64)>,
    style: SeriesStyle,
    width: u32,
) -> Result<()>
where
    DB: DrawingBackend,
    CT: CoordTranslate<From = (f64, f64)>,
{
    let st = style.colour.stroke_width(width);
    if style.dashed {
        chart
            .draw_series(DashedLineSeries::new(points, 8, 5, st))
            .map_err(draw_err(figure))?;
    } else {
        chart
            .draw_series(LineSeries::new(points, st))
            .map_err(draw_err(figure))?;
    }
    Ok(())
}

/// A linear x–y chart on `area` with the figures' margins, tick labels and axis titles, its
/// mesh drawn.
pub(crate) fn linear_chart<'b, 'a>(
    figure: &'static str,
    area: &'b Area<'a>,
    (x, y): ((f64, f64), (f64, f64)),
    y_label_px: u32,
    (x_desc, y_desc): (&str, &str),
) -> Result<ChartContext<'b, SVGBackend<'a>, Cartesian2d<RangedCoordf64, RangedCoordf64>>> {
    let e = draw_err(figure);
    let mut chart = ChartBuilder::on(area)
        .margin_right(24)
        .margin_top(6)
        .x_label_area_size(56)
        .y_label_area_size(y_label_px)
        .build_cartesian_2d(x.0..x.1, y.0..y.1)
        .map_err(&e)?;
    let (xs, ys) = (x.1 - x.0, y.1 - y.0);
    let xf = move |v: &f64| tick_text(*v, xs);
    let yf = move |v: &f64| tick_text(*v, ys);
    let (bold, light) = mesh_colours();
    chart
        .configure_mesh()
        .bold_line_style(bold)
        .light_line_style(light)
        .x_label_formatter(&xf)
        .y_label_formatter(&yf)
        .label_style((FONT, TICK_PX))
        .axis_desc_style((FONT, DESC_PX))
        .x_desc(x_desc)
        .y_desc(y_desc)
        .draw()
        .map_err(&e)?;
    Ok(chart)
}

/// Grid lines used by every chart.
pub(crate) fn mesh_colours() -> (RGBColor, RGBColor) {
    (RGBColor(0xd0, 0xd0, 0xd0), RGBColor(0xee, 0xee, 0xee))
}

/// A style for the `i`-th data series.
pub(crate) fn style(i: usize) -> SeriesStyle {
    palette::series_style(i)
}

/// Renders a figure of `size` pixels with `draw` into an SVG string.
pub(crate) fn render(
    figure: &'static str,
    size: (u32, u32),
    draw: impl FnOnce(&Area<'_>) -> Result<()>,
) -> Result<String> {
    let mut buf = String::new();
    {
        let root = SVGBackend::with_string(&mut buf, size).into_drawing_area();
        root.fill(&WHITE).map_err(draw_err(figure))?;
        draw(&root)?;
        root.present().map_err(draw_err(figure))?;
    }
    // `stroke="none"` makes the stroke width moot and opacity 1 is the default: dropping them
    // keeps point clouds small without changing the picture.
    Ok(buf
        .replace(" stroke=\"none\" stroke-width=\"1\"", "")
        .replace(" stroke=\"none\"", "")
        .replace(" opacity=\"1\"", ""))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn decimation_keeps_extremes_and_bounds_size() {
        let n = 100_000;
        let x: Vec<f64> = (0..n).map(|i| i as f64).collect();
        let mut y: Vec<f64> = x.iter().map(|t| (t / 1000.0).sin()).collect();
        y[54_321] = 9.0;
        y[7_777] = -9.0;
        let d = decimate(&x, &y, 1000);
        assert!(d.len() <= 1000, "{}", d.len());
        assert!(d.iter().any(|p| p == &(54_321.0, 9.0)));
        assert!(d.iter().any(|p| p == &(7_777.0, -9.0)));
        assert!(d.windows(2).all(|w| w[0].0 < w[1].0), "order kept");
        let short = decimate(&x[..10], &y[..10], 1000);
        assert_eq!(short.len(), 10);
    }

    #[test]
    fn thinning_and_stats() {
        assert_eq!(thin_indices(5, 10), vec![0, 1, 2, 3, 4]);
        let t = thin_indices(1000, 10);
        assert_eq!(t.len(), 10);
        assert_eq!(t[1], 100);
        let a = [1.0, 2.0, 3.0, 4.0];
        assert!((correlation(&a, &[2.0, 4.0, 6.0, 8.0]) - 1.0).abs() < 1e-12);
        assert!((correlation(&a, &[8.0, 6.0, 4.0, 2.0]) + 1.0).abs() < 1e-12);
        assert_eq!(correlation(&a, &[1.0; 4]), 0.0);
        assert!((rms(&[3.0, -3.0]) - 3.0).abs() < 1e-12);
    }

    #[test]
    fn tick_labels() {
        assert_eq!(tick_text(3000.0, 1000.0), "3000");
        assert_eq!(tick_text(0.2634, 0.02), "0.263");
        assert_eq!(tick_text(-0.0001, 1.0), "0.0");
        assert_eq!(padded((1.0, 1.0), 0.1), (0.95, 1.05));
        assert_eq!(padded((0.0, 10.0), 0.1), (-1.0, 11.0));
    }
}
