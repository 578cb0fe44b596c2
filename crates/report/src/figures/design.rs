//! Protocol-design figure: the expected posterior sd of each parameter under each protocol.

use plotters::coord::ranged1d::{AsRangedCoord, ValueFormatter};
use plotters::coord::types::RangedCoordf64;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};

use super::{
    check_finite, check_names, check_parallel, draw_err, legend_strip, mesh_colours, min_max,
    render, style, text_width, titled, Area, Mark, DESC_PX, FONT, TICK_PX,
};
use crate::error::{ReportError, Result};
use crate::palette::{SeriesStyle, BLACK};

/// One protocol's bars: its sd of every parameter (% of nominal), in the parameters' order.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DesignSeries<'a> {
    /// Legend label (the protocol).
    pub label: &'a str,
    /// Expected posterior sd per parameter (% of nominal), positive.
    pub sd_pct: &'a [f64],
}

/// The figure's name in errors.
const FIG: &str = "design_sds";

/// The value range above which the axis is logarithmic (largest / smallest value).
const LOG_RATIO: f64 = 20.0;

/// One bar group per parameter, one bar per protocol, and the bounds' prior sd of each
/// parameter as a black tick across its group. The sd axis is logarithmic when the values span
/// more than a factor of 20 (then every value must be positive), linear from 0 otherwise.
///
/// # Errors
/// No parameter or protocol, series of the wrong length, non-finite values, or a value ≤ 0 on
/// a logarithmic axis.
pub fn design_sds(
    params: &[&str],
    series: &[DesignSeries<'_>],
    prior_sd_pct: &[f64],
) -> Result<String> {
    check_input(params, series, prior_sd_pct)?;
    let (lo, hi, log) = sd_axis(series, prior_sd_pct)?;
    let entries = legend(series);
    let chart = BarChart {
        params,
        series,
        prior_sd_pct,
    };
    let width = (220 + 110 * prior_sd_pct.len() as u32).max(900);
    render(FIG, (width, 640), |root| {
        let body = titled(
            FIG,
            root,
            "Expected posterior sd per parameter and protocol",
        )?;
        let body = legend_strip(FIG, &body, &entries)?;
        if log {
            let y = (lo / 1.5)..(hi * 1.5);
            chart.draw(
                root,
                &body,
                y.clone().log_scale(),
                y.start,
                "sd (% of nominal, log scale)",
            )
        } else {
            let y = 0.0..(hi * 1.15).max(1e-9);
            chart.draw(root, &body, y.clone(), y.start, "sd (% of nominal)")
        }
    })
}

/// Checks the names, the prior sds and every protocol's series against each other.
fn check_input(params: &[&str], series: &[DesignSeries<'_>], prior_sd_pct: &[f64]) -> Result<()> {
    let n = prior_sd_pct.len();
    check_names(FIG, params, n, "parameters")?;
    check_finite(FIG, "prior_sd_pct", prior_sd_pct)?;
    if series.is_empty() {
        return Err(ReportError::Empty {
            figure: FIG,
            series: "protocols".into(),
        });
    }
    for s in series {
        check_parallel(FIG, s.label, s.sd_pct, n)?;
    }
    Ok(())
}

/// The smallest and largest value drawn, and whether the axis is logarithmic (all positive
/// and spanning more than [`LOG_RATIO`]); a negative value is an error on a linear axis.
fn sd_axis(series: &[DesignSeries<'_>], prior_sd_pct: &[f64]) -> Result<(f64, f64, bool)> {
    let all = series
        .iter()
        .flat_map(|s| s.sd_pct.iter().copied())
        .chain(prior_sd_pct.iter().copied());
    let (lo, hi) = min_max(all).unwrap_or((1.0, 1.0));
    let log = lo > 0.0 && hi / lo > LOG_RATIO;
    if !log && lo < 0.0 {
        return Err(ReportError::Invalid {
            figure: FIG,
            reason: format!("negative sd {lo}"),
        });
    }
    Ok((lo, hi, log))
}

/// A swatch per protocol, then the prior's tick.
fn legend(series: &[DesignSeries<'_>]) -> Vec<(String, Mark)> {
    series
        .iter()
        .enumerate()
        .map(|(i, s)| (s.label.to_string(), Mark::Swatch(style(i).colour, 1.0)))
        .chain([(
            "prior sd (uniform on the bounds)".to_string(),
            Mark::Line(
                SeriesStyle {
                    colour: BLACK,
                    dashed: false,
                },
                3,
            ),
        )])
        .collect()
}

/// What the chart draws: a group of bars per parameter (one per protocol) with the prior tick.
struct BarChart<'d> {
    params: &'d [&'d str],
    series: &'d [DesignSeries<'d>],
    prior_sd_pct: &'d [f64],
}

impl BarChart<'_> {
    /// Draws the chart on `body` with the sd axis `y` (linear or logarithmic) from `floor`, the
    /// parameters named under it on `root`.
    fn draw<Y>(
        &self,
        root: &Area<'_>,
        body: &Area<'_>,
        y: Y,
        floor: f64,
        y_desc: &str,
    ) -> Result<()>
    where
        Y: AsRangedCoord<Value = f64>,
        Y::CoordDescType: ValueFormatter<f64>,
    {
        let e = draw_err(FIG);
        let (bold, light) = mesh_colours();
        let label_px = (text_width("10000", TICK_PX) + 30).max(70) as u32;
        let mut chart = ChartBuilder::on(body)
            .margin_right(20)
            .margin_top(6)
            .x_label_area_size(56)
            .y_label_area_size(label_px)
            .build_cartesian_2d(0.0..self.prior_sd_pct.len() as f64, y)
            .map_err(&e)?;
        // no x ticks: the groups are named by `draw_names`
        chart
            .configure_mesh()
            .disable_x_mesh()
            .bold_line_style(bold)
            .light_line_style(light)
            .x_labels(0)
            .y_label_formatter(&|v: &f64| crate::labels::format_sig(*v, 2))
            .label_style((FONT, TICK_PX))
            .axis_desc_style((FONT, DESC_PX))
            .y_desc(y_desc)
            .draw()
            .map_err(&e)?;
        chart.draw_series(self.bars(floor)).map_err(&e)?;
        chart.draw_series(self.prior_ticks()).map_err(&e)?;
        self.draw_names(root, &chart, floor)
    }

    /// The bars, rising from `floor`: protocol `j`'s in its slot of the middle 80 % of each
    /// parameter's unit-wide group.
    fn bars(&self, floor: f64) -> Vec<Rectangle<(f64, f64)>> {
        let k = self.series.len();
        let mut out = Vec::new();
        for (j, s) in self.series.iter().enumerate() {
            for (i, v) in s.sd_pct.iter().enumerate() {
                let x0 = i as f64 + 0.1 + 0.8 * j as f64 / k as f64;
                let x1 = i as f64 + 0.1 + 0.8 * (j + 1) as f64 / k as f64;
                out.push(Rectangle::new(
                    [(x0, floor), (x1, *v)],
                    style(j).colour.filled(),
                ));
            }
        }
        out
    }

    /// The prior sd of each parameter as a tick across its group.
    fn prior_ticks(&self) -> Vec<PathElement<(f64, f64)>> {
        self.prior_sd_pct
            .iter()
            .enumerate()
            .map(|(i, p)| {
                PathElement::new(
                    vec![(i as f64 + 0.04, *p), (i as f64 + 0.96, *p)],
                    BLACK.stroke_width(3),
                )
            })
            .collect()
    }

    /// Each parameter's name centred under its group (below the axis at `floor`).
    fn draw_names<YC: Ranged<ValueType = f64>>(
        &self,
        root: &Area<'_>,
        chart: &ChartContext<'_, SVGBackend<'_>, Cartesian2d<RangedCoordf64, YC>>,
        floor: f64,
    ) -> Result<()> {
        let e = draw_err(FIG);
        let name_font = (FONT, TICK_PX)
            .into_font()
            .color(&BLACK)
            .pos(Pos::new(HPos::Center, VPos::Top));
        for (i, name) in self.params.iter().enumerate() {
            let (px, py) = chart.backend_coord(&(i as f64 + 0.5, floor));
            root.draw(&Text::new(
                name.to_string(),
                (px, py + 10),
                name_font.clone(),
            ))
            .map_err(&e)?;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn draws_groups_and_rejects_bad_input() {
        let names = ["sol LST", "sol F0"];
        let a = [0.5, 7.0];
        let b = [0.1, 1200.0];
        let svg = design_sds(
            &names,
            &[
                DesignSeries {
                    label: "knee0@30",
                    sd_pct: &a,
                },
                DesignSeries {
                    label: "knee0@30,knee90@30",
                    sd_pct: &b,
                },
            ],
            &[2.9, 11.5],
        )
        .unwrap();
        assert!(svg.contains("log scale"));
        assert!(svg.contains("knee0@30,knee90@30") && svg.contains("sol F0"));
        crate::check_svg(&svg).unwrap();
        let c = [3.0, 7.0];
        let lin = design_sds(
            &names,
            &[DesignSeries {
                label: "p",
                sd_pct: &c,
            }],
            &[2.9, 11.5],
        )
        .unwrap();
        assert!(!lin.contains("log scale"));
        let short = [1.0];
        assert!(design_sds(
            &names,
            &[DesignSeries {
                label: "p",
                sd_pct: &short,
            }],
            &[2.9, 11.5],
        )
        .is_err());
        assert!(design_sds(&names, &[], &[2.9, 11.5]).is_err());
    }
}
