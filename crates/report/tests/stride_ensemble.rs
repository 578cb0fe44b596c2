//! The ensemble-over-strides figure: well-formed SVG with one band and one mean line per series
//! in each panel, the axes titled with units and the legend naming the strides and each
//! model's residual; bad input is an error.

use report::{check_svg, figures, ReportError};

const POINTS: usize = 101;

fn percent() -> Vec<f64> {
    (0..POINTS).map(|j| j as f64).collect()
}

/// `strides` stance curves of a push-off moment peaking near 60 % at `peak` N·m, stride `k`
/// scaled by `1 + 0.02·(k mod 5 − 2)`.
fn curves(strides: usize, peak: f64) -> Vec<Vec<f64>> {
    (0..strides)
        .map(|k| {
            let g = 1.0 + 0.02 * ((k % 5) as f64 - 2.0);
            (0..POINTS)
                .map(|j| {
                    let p = j as f64 / 100.0;
                    g * peak * (std::f64::consts::PI * p).sin().powi(3) * (0.3 + p)
                })
                .collect()
        })
        .collect()
}

#[test]
fn two_panels_with_bands_lines_and_labels() {
    let measured = curves(49, 100.0);
    let sa = curves(49, 92.0);
    let linear = curves(49, 80.0);
    let svg = figures::stride_ensemble(
        &percent(),
        &measured,
        &[("model (SA)", &sa), ("linear baseline", &linear)],
        "stance",
    )
    .unwrap();
    let s = check_svg(&svg).unwrap();
    // Bands: measured + 2 models above, 2 residuals below.
    assert_eq!(s.count("polygon"), 5, "{:?}", s.elements);
    for label in [
        "Ankle moment over strides, by % of stance",
        "ankle moment (N·m, plantarflexion > 0)",
        "residual: measured − model (N·m)",
        "% of stance",
        "measured (49 strides)",
        "model (SA) (RMS residual",
        "linear baseline (RMS residual",
        "shaded: mean ± 1 sd across strides",
    ] {
        assert!(s.has_text(label), "missing {label:?} in {:?}", s.texts);
    }
    // Two x axes titled; the mean lines: 3 above + 2 below, each of 101 points.
    assert_eq!(s.texts.iter().filter(|t| *t == "% of stance").count(), 2);
    let full: Vec<usize> = svg
        .split("points=\"")
        .skip(1)
        .map(|pl| pl[..pl.find('"').unwrap()].split_whitespace().count())
        .collect();
    assert_eq!(full.iter().filter(|&&n| n == POINTS).count(), 5, "{full:?}");
    // the residual of the SA model: mean of 8 % of the measured curve; its RMS is in the legend
    let all: Vec<f64> = measured
        .iter()
        .zip(&sa)
        .flat_map(|(a, b)| a.iter().zip(b).map(|(x, y)| x - y))
        .collect();
    assert!(s.has_text(&format!(
        "model (SA) (RMS residual {:.2} N·m)",
        numerics::rms(&all)
    )));
    for size in svg.split("font-size=\"").skip(1) {
        let v: f64 = size[..size.find('"').unwrap()].parse().unwrap();
        assert!(v >= 14.0 - 1e-9, "font size {v}");
    }
    // Deterministic.
    let again = figures::stride_ensemble(
        &percent(),
        &measured,
        &[("model (SA)", &sa), ("linear baseline", &linear)],
        "stance",
    )
    .unwrap();
    assert_eq!(svg, again);
}

#[test]
fn measured_alone_and_one_stride_draw() {
    let one = curves(1, 50.0);
    let svg = figures::stride_ensemble(&percent(), &one, &[], "gait cycle").unwrap();
    let s = check_svg(&svg).unwrap();
    assert_eq!(s.count("polygon"), 1);
    assert!(s.has_text("% of gait cycle") && s.has_text("measured (1 stride)"));
    assert!(!s.has_text("residual"));
}

#[test]
fn bad_input_is_an_error() {
    let m = curves(5, 100.0);
    let p = percent();
    let fewer = curves(4, 90.0);
    let e = figures::stride_ensemble(&p, &m, &[("model", &fewer)], "stance").unwrap_err();
    assert!(matches!(e, ReportError::LengthMismatch { .. }), "{e}");
    assert!(e.to_string().contains("model (strides)"), "{e}");
    let mut nan = m.clone();
    nan[3][40] = f64::NAN;
    let e = figures::stride_ensemble(&p, &nan, &[], "stance").unwrap_err();
    assert!(e.to_string().contains("measured, stride 3"), "{e}");
    let e = figures::stride_ensemble(&p[..50], &m, &[], "stance").unwrap_err();
    assert!(matches!(e, ReportError::LengthMismatch { .. }), "{e}");
    assert!(figures::stride_ensemble(&p, &[], &[], "stance").is_err());
    assert!(figures::stride_ensemble(&p, &m, &[], " ").is_err());
    let mut back = p.clone();
    back.swap(3, 4);
    assert!(figures::stride_ensemble(&back, &m, &[], "stance").is_err());
}

#[test]
fn the_residual_alone_draws_one_band_per_model_around_zero() {
    let measured = curves(12, 100.0);
    let model = curves(12, 92.0);
    let resid: Vec<Vec<f64>> = measured
        .iter()
        .zip(&model)
        .map(|(a, b)| a.iter().zip(b).map(|(x, y)| x - y).collect())
        .collect();
    let linear: Vec<Vec<f64>> = resid
        .iter()
        .map(|r| r.iter().map(|v| 2.0 * v - 5.0).collect())
        .collect();
    let svg = figures::residual_ensemble(
        &percent(),
        &[("model", &resid), ("linear", &linear)],
        "gait cycle",
    )
    .unwrap();
    let s = check_svg(&svg).unwrap();
    assert_eq!(s.count("polygon"), 2, "{:?}", s.elements);
    let all: Vec<f64> = resid.iter().flatten().copied().collect();
    for label in [
        "Residual of the ankle moment over strides, by % of gait cycle".to_string(),
        "residual: measured − model (N·m)".to_string(),
        "% of gait cycle".to_string(),
        format!(
            "model (RMS residual {:.2} N·m over 12 strides)",
            numerics::rms(&all)
        ),
        "shaded: mean ± 1 sd across strides".to_string(),
    ] {
        assert!(s.has_text(&label), "missing {label:?} in {:?}", s.texts);
    }
    assert!(!s.has_text("ankle moment (N·m, plantarflexion > 0)"));
    // bad input
    let p = percent();
    assert!(figures::residual_ensemble(&p, &[], "stance").is_err());
    let e =
        figures::residual_ensemble(&p, &[("model", &resid), ("linear", &linear[..3])], "stance")
            .unwrap_err();
    assert!(matches!(e, ReportError::LengthMismatch { .. }), "{e}");
    assert!(figures::residual_ensemble(&p, &[("model", &resid)], "").is_err());
    assert!(figures::residual_ensemble(&p[..50], &[("model", &resid)], "stance").is_err());
}
