//! Ensembles over strides: the ankle moment of every stride normalised to 0–100 % of the
//! cycle or of the stance, drawn as the mean ± one standard deviation across strides, measured
//! and model, with the residual's mean ± sd in a panel below (how a gait lab reads a fit).
//!
//! At each point `p` over strides `k = 1…N`: the mean `m(p) = Σ_k x_k(p)/N` and the sample
//! sd `s(p) = √(Σ_k (x_k(p) − m(p))²/(N − 1))` (0 for one stride). The residual of stride `k`
//! is `r_k(p) = measured_k(p) − model_k(p)`, paired stride by stride, so its sd is the
//! stride-to-stride spread of the error, not the difference of the two bands.

use plotters::prelude::*;

use super::{
    check_finite, check_parallel, draw_err, draw_line, legend_strip, linear_chart, min_max, padded,
    render, rms, style, titled, Mark,
};
use crate::error::{ReportError, Result};
use crate::palette::{SeriesStyle, BLACK, GREY};

const MEASURED: SeriesStyle = SeriesStyle {
    colour: BLACK,
    dashed: false,
};

/// Mean and sample sd at each point of equally long curves (`curves` non-empty).
fn mean_sd(curves: &[Vec<f64>], points: usize) -> (Vec<f64>, Vec<f64>) {
    let n = curves.len() as f64;
    let mean: Vec<f64> = (0..points)
        .map(|j| curves.iter().map(|c| c[j]).sum::<f64>() / n)
        .collect();
    let sd = (0..points)
        .map(|j| {
            if curves.len() < 2 {
                0.0
            } else {
                let ss: f64 = curves.iter().map(|c| (c[j] - mean[j]).powi(2)).sum();
                (ss / (n - 1.0)).sqrt()
            }
        })
        .collect();
    (mean, sd)
}

/// The ensembles' x axis: `percent` finite and increasing, `of` naming what it spans.
fn check_axis(figure: &'static str, percent: &[f64], of: &str) -> Result<()> {
    check_finite(figure, "percent", percent)?;
    if percent.windows(2).any(|w| w[1] <= w[0]) {
        return Err(ReportError::Invalid {
            figure,
            reason: "`percent` must increase".into(),
        });
    }
    if of.trim().is_empty() {
        return Err(ReportError::Invalid {
            figure,
            reason: "`of` must name what 0–100 % spans (\"stance\" or \"gait cycle\")".into(),
        });
    }
    Ok(())
}

/// Checks one set of per-stride curves: as many strides as `strides` (when given), each with
/// `points` finite values.
fn check_curves(
    figure: &'static str,
    name: &str,
    curves: &[Vec<f64>],
    points: usize,
    strides: Option<usize>,
) -> Result<()> {
    if curves.is_empty() {
        return Err(ReportError::Empty {
            figure,
            series: name.to_string(),
        });
    }
    if let Some(n) = strides {
        if curves.len() != n {
            return Err(ReportError::LengthMismatch {
                figure,
                series: format!("{name} (strides)"),
                expected: n,
                got: curves.len(),
            });
        }
    }
    for (k, c) in curves.iter().enumerate() {
        check_parallel(figure, &format!("{name}, stride {k}"), c, points)?;
    }
    Ok(())
}

/// One band: the mean line and the shaded `mean ± sd` polygon.
struct Band {
    mean: Vec<f64>,
    sd: Vec<f64>,
    style: SeriesStyle,
}

impl Band {
    fn extent(&self) -> impl Iterator<Item = f64> + '_ {
        self.mean
            .iter()
            .zip(&self.sd)
            .flat_map(|(m, s)| [m - s, m + s])
    }
}

/// Draws the bands (shading first, then the mean lines over all of them) into one panel.
fn band_panel(
    figure: &'static str,
    area: &super::Area<'_>,
    percent: &[f64],
    bands: &[Band],
    (x_desc, y_desc): (&str, &str),
    zero_line: bool,
) -> Result<()> {
    let x = (percent[0], percent[percent.len() - 1]);
    let x = if x.1 > x.0 { x } else { padded(x, 0.0) };
    let extent = min_max(
        bands
            .iter()
            .flat_map(Band::extent)
            .chain(zero_line.then_some(0.0)),
    )
    .unwrap_or((0.0, 1.0));
    let y = padded(extent, 0.06);
    let mut chart = linear_chart(figure, area, (x, y), 90, (x_desc, y_desc))?;
    let e = draw_err(figure);
    if zero_line && y.0 < 0.0 && y.1 > 0.0 {
        chart
            .draw_series(LineSeries::new(
                vec![(x.0, 0.0), (x.1, 0.0)],
                GREY.stroke_width(1),
            ))
            .map_err(&e)?;
    }
    for b in bands {
        let mut poly: Vec<(f64, f64)> = percent
            .iter()
            .zip(b.mean.iter().zip(&b.sd))
            .map(|(p, (m, s))| (*p, m + s))
            .collect();
        poly.extend(
            percent
                .iter()
                .zip(b.mean.iter().zip(&b.sd))
                .rev()
                .map(|(p, (m, s))| (*p, m - s)),
        );
        chart
            .draw_series(std::iter::once(Polygon::new(
                poly,
                b.style.colour.mix(0.18).filled(),
            )))
            .map_err(&e)?;
    }
    for b in bands {
        let line = percent
            .iter()
            .copied()
            .zip(b.mean.iter().copied())
            .collect();
        draw_line(figure, &mut chart, line, b.style, 2)?;
    }
    Ok(())
}

/// Ensembles over strides by % of the cycle or of the stance: the measured ankle moment's and
/// each model's mean ± sd across strides, and below it each model's residual (measured −
/// model, stride by stride) as mean ± sd.
///
/// * `percent` — the points' positions, % (increasing, e.g. `experiment::stride_percent(101)`);
/// * `measured` — one curve per stride (N·m, plantarflexion > 0), each `percent.len()` long;
/// * `models` — `(label, curves)` per model, as many strides as `measured`, in the same order;
/// * `of` — what 0–100 % spans, for the axis: `"stance"` or `"gait cycle"`.
///
/// ```
/// let pct: Vec<f64> = (0..=50).map(|j| 2.0 * j as f64).collect();
/// let stride = |k: usize| -> Vec<f64> {
///     pct.iter().map(|p| (k as f64 + 100.0) * (p / 100.0 * std::f64::consts::PI).sin()).collect()
/// };
/// let measured: Vec<Vec<f64>> = (0..10).map(stride).collect();
/// let model: Vec<Vec<f64>> = (0..10).map(|k| stride(k).iter().map(|v| 0.9 * v).collect()).collect();
/// let svg = report::figures::stride_ensemble(&pct, &measured, &[("model", &model)], "stance")?;
/// report::check_svg(&svg)?;
/// assert!(svg.contains("% of stance"));
/// # Ok::<(), report::ReportError>(())
/// ```
///
/// # Errors
/// Empty input, curves of another length than `percent`, a model with another number of
/// strides than `measured`, a non-finite value, or an empty `of`.
pub fn stride_ensemble(
    percent: &[f64],
    measured: &[Vec<f64>],
    models: &[(&str, &[Vec<f64>])],
    of: &str,
) -> Result<String> {
    const FIG: &str = "stride_ensemble";
    check_axis(FIG, percent, of)?;
    let points = percent.len();
    check_curves(FIG, "measured", measured, points, None)?;
    let n = measured.len();
    for (name, m) in models {
        check_curves(FIG, name, m, points, Some(n))?;
    }
    let (m_mean, m_sd) = mean_sd(measured, points);
    let mut top = vec![Band {
        mean: m_mean,
        sd: m_sd,
        style: MEASURED,
    }];
    let mut bottom = Vec::new();
    let mut entries = vec![(
        format!("measured ({n} stride{})", if n == 1 { "" } else { "s" }),
        Mark::Line(MEASURED, 2),
    )];
    for (i, (name, m)) in models.iter().enumerate() {
        let st = style(i);
        let (mean, sd) = mean_sd(m, points);
        top.push(Band {
            mean,
            sd,
            style: st,
        });
        let resid: Vec<Vec<f64>> = measured
            .iter()
            .zip(m.iter())
            .map(|(a, b)| a.iter().zip(b).map(|(x, y)| x - y).collect())
            .collect();
        let all: Vec<f64> = resid.iter().flatten().copied().collect();
        let (mean, sd) = mean_sd(&resid, points);
        bottom.push(Band {
            mean,
            sd,
            style: st,
        });
        entries.push((
            format!("{name} (RMS residual {:.2} N·m)", rms(&all)),
            Mark::Line(st, 2),
        ));
    }
    entries.push((
        "shaded: mean ± 1 sd across strides".to_string(),
        Mark::Swatch(GREY, 0.3),
    ));
    let x_desc = format!("% of {of}");
    let height = if models.is_empty() { 640 } else { 900 };
    render(FIG, (1000, height), |root| {
        let body = titled(
            FIG,
            root,
            &format!("Ankle moment over strides, by % of {of}"),
        )?;
        let body = legend_strip(FIG, &body, &entries)?;
        let moment_axis = "ankle moment (N·m, plantarflexion > 0)";
        if models.is_empty() {
            return band_panel(FIG, &body, percent, &top, (&x_desc, moment_axis), false);
        }
        let (_, h) = body.dim_in_pixel();
        let (upper, lower) = body.split_vertically(h * 60 / 100);
        band_panel(FIG, &upper, percent, &top, (&x_desc, moment_axis), false)?;
        band_panel(
            FIG,
            &lower,
            percent,
            &bottom,
            (&x_desc, "residual: measured − model (N·m)"),
            true,
        )
    })
}

/// The residual alone over strides, by % of the cycle or of the stance: each model's residual
/// (measured − model, stride by stride) as mean ± sd around a zero line, in one panel, so a
/// systematic miss at one phase of the stride reads at full height rather than below the
/// moments of [`stride_ensemble`].
///
/// * `percent` — the points' positions, % (increasing);
/// * `residuals` — `(label, curves)` per model, one curve per stride (N·m), each
///   `percent.len()` long, every model with as many strides as the first;
/// * `of` — what 0–100 % spans: `"stance"` or `"gait cycle"`.
///
/// # Errors
/// No model or an empty one, curves of another length than `percent`, models with different
/// numbers of strides, a non-finite value, or an empty `of`.
pub fn residual_ensemble(
    percent: &[f64],
    residuals: &[(&str, &[Vec<f64>])],
    of: &str,
) -> Result<String> {
    const FIG: &str = "residual_ensemble";
    check_axis(FIG, percent, of)?;
    let Some((_, first)) = residuals.first() else {
        return Err(ReportError::Empty {
            figure: FIG,
            series: "residuals".into(),
        });
    };
    let n = first.len();
    let points = percent.len();
    let mut bands = Vec::with_capacity(residuals.len());
    let mut entries = Vec::with_capacity(residuals.len() + 1);
    for (i, (name, r)) in residuals.iter().enumerate() {
        check_curves(FIG, name, r, points, Some(n))?;
        let st = style(i);
        let (mean, sd) = mean_sd(r, points);
        bands.push(Band {
            mean,
            sd,
            style: st,
        });
        let all: Vec<f64> = r.iter().flatten().copied().collect();
        entries.push((
            format!(
                "{name} (RMS residual {:.2} N·m over {n} stride{})",
                rms(&all),
                if n == 1 { "" } else { "s" }
            ),
            Mark::Line(st, 2),
        ));
    }
    entries.push((
        "shaded: mean ± 1 sd across strides".to_string(),
        Mark::Swatch(GREY, 0.3),
    ));
    let x_desc = format!("% of {of}");
    render(FIG, (1000, 640), |root| {
        let body = titled(
            FIG,
            root,
            &format!("Residual of the ankle moment over strides, by % of {of}"),
        )?;
        let body = legend_strip(FIG, &body, &entries)?;
        band_panel(
            FIG,
            &body,
            percent,
            &bands,
            (&x_desc, "residual: measured − model (N·m)"),
            true,
        )
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn mean_and_sample_sd() {
        let c = vec![vec![1.0, 2.0], vec![3.0, 2.0]];
        let (m, s) = mean_sd(&c, 2);
        assert_eq!(m, vec![2.0, 2.0]);
        assert!((s[0] - 2f64.sqrt()).abs() < 1e-15 && s[1] == 0.0);
        let (_, s1) = mean_sd(&c[..1], 2);
        assert_eq!(s1, vec![0.0, 0.0]);
    }
}
