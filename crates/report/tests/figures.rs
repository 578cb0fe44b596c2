//! Every figure: well-formed SVG that draws something and carries its axis titles with units;
//! bad input (empty, NaN, mismatched lengths) is an error, not a panic; output is
//! deterministic and small.

use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};
use report::figures::{self, Candidate, SensitivityPoint};
use report::{check_svg, ReportError, XmlSummary};

/// 20 000 samples (about 10 s at 2048 Hz), so decimation is exercised.
struct Data {
    t: Vec<f64>,
    measured: Vec<f64>,
    model: Vec<f64>,
    angle: Vec<f64>,
    env: Vec<f64>,
    resid: Vec<f64>,
    phase: Vec<usize>,
}

fn data() -> Data {
    let n = 20_000;
    let mut rng = ChaCha8Rng::seed_from_u64(11);
    let noise = Normal::new(0.0, 1.0).unwrap();
    let t: Vec<f64> = (0..n).map(|i| i as f64 / 2048.0).collect();
    let model: Vec<f64> = t.iter().map(|x| 80.0 * (x * 0.7).sin().abs()).collect();
    let measured: Vec<f64> = model.iter().map(|m| m + noise.sample(&mut rng)).collect();
    let angle: Vec<f64> = t
        .iter()
        .map(|x| 15.0 - 35.0 * ((x * 0.3).sin().abs()))
        .collect();
    let env: Vec<f64> = t.iter().map(|x| (x * 0.7).sin().abs()).collect();
    let resid = measured.iter().zip(&model).map(|(a, b)| a - b).collect();
    let phase = (0..n).map(|i| (i / 3000) % 3).collect();
    Data {
        t,
        measured,
        model,
        angle,
        env,
        resid,
        phase,
    }
}

fn draws(m: usize, p: usize) -> Vec<Vec<f64>> {
    let mut rng = ChaCha8Rng::seed_from_u64(5);
    let z = Normal::new(0.0, 1.0).unwrap();
    let base: Vec<f64> = (0..m).map(|_| z.sample(&mut rng)).collect();
    (0..p)
        .map(|k| {
            base.iter()
                .map(|b| 10.0 * (k + 1) as f64 + 0.8 * b + 0.6 * z.sample(&mut rng))
                .collect()
        })
        .collect()
}

/// Well-formed, draws at least `marks` path/line/rect/circle elements, stays below 1 MB and
/// contains every label.
fn assert_figure(svg: &str, marks: usize, labels: &[&str]) -> XmlSummary {
    assert!(svg.starts_with("<svg"), "{}", &svg[..60.min(svg.len())]);
    assert!(svg.trim_end().ends_with("</svg>"));
    let s = check_svg(svg).expect("well-formed SVG");
    let drawn: usize = ["path", "polyline", "line", "rect", "circle", "polygon"]
        .iter()
        .map(|n| s.count(n))
        .sum();
    assert!(drawn >= marks, "only {drawn} marks: {:?}", s.elements);
    assert!(svg.len() < 1_000_000, "{} bytes", svg.len());
    for l in labels {
        assert!(
            s.has_text(l),
            "missing text {l:?} in {:?}",
            &s.texts[..s.texts.len().min(30)]
        );
    }
    // Every text is at least 14 px.
    for size in svg.split("font-size=\"").skip(1) {
        let v: f64 = size[..size.find('"').unwrap()].parse().unwrap();
        assert!(v >= 14.0 - 1e-9, "font size {v}");
    }
    s
}

#[test]
fn torque_fit_has_three_panels_with_units() {
    let d = data();
    let svg = figures::torque_fit(
        &d.t,
        &d.measured,
        &[("model", &d.model)],
        &d.angle,
        &[("sol", &d.env), ("gm", &d.env)],
    )
    .unwrap();
    let s = assert_figure(
        &svg,
        5,
        &[
            "torque (N·m)",
            "ankle angle (deg)",
            "EMG (normalised)",
            "time (s)",
            "measured",
            "EMG envelope gm",
        ],
    );
    assert!(s.count("polyline") >= 5, "{:?}", s.elements);
    // Decimated: no line has more than 4000 points.
    for pl in svg.split("points=\"").skip(1) {
        let pts = pl[..pl.find('"').unwrap()].split_whitespace().count();
        assert!(pts <= figures::MAX_LINE_POINTS, "{pts} points");
    }
    // RMS of the model error is in the legend.
    let rms = numerics::rms(&d.resid);
    assert!(s.has_text(&format!("RMS error {rms:.2} N·m")));
    // Without envelopes: two panels.
    let two = figures::torque_fit(&d.t, &d.measured, &[], &d.angle, &[]).unwrap();
    let s2 = assert_figure(&two, 2, &["torque (N·m)", "ankle angle (deg)", "time (s)"]);
    assert!(!s2.has_text("EMG"));
}

#[test]
fn residual_figures() {
    let d = data();
    let svg = figures::residual_vs_angle(
        &d.angle,
        &d.resid,
        &d.phase,
        &["hold", "concentric", "eccentric"],
    )
    .unwrap();
    let s = assert_figure(
        &svg,
        100,
        &[
            "ankle angle (deg, dorsiflexion > 0)",
            "residual: measured − model (N·m)",
            "eccentric",
        ],
    );
    assert!(s.count("circle") <= figures::MAX_SCATTER_POINTS + 10);
    assert!(s.count("circle") >= 1000);
    let svg =
        figures::residual_vs_time(&d.t, &[("baseline", &d.resid), ("extended", &d.resid)]).unwrap();
    assert_figure(
        &svg,
        2,
        &[
            "time (s)",
            "residual: measured − model (N·m)",
            "baseline (RMS",
        ],
    );
    let svg = figures::fit_comparison(&d.t, &d.measured, &d.model, &d.measured).unwrap();
    let s = assert_figure(&svg, 5, &["torque (N·m)", "residual (N·m)", "time (s)"]);
    assert!(s.has_text("extended model (RMS error 0.00 N·m)"));
}

#[test]
fn candidate_ranking_bars_in_order() {
    let rows = [
        Candidate {
            name: "electromechanical_delay",
            evidence: 812.0,
            heldout_rms_nm: Some(2.1),
            selected: true,
        },
        Candidate {
            name: "fatigue",
            evidence: 33.5,
            heldout_rms_nm: Some(4.0),
            selected: false,
        },
        Candidate {
            name: "inertia",
            evidence: -4.0,
            heldout_rms_nm: Some(4.4),
            selected: false,
        },
    ];
    let svg = figures::candidate_ranking(&rows, Some(4.5)).unwrap();
    let s = assert_figure(
        &svg,
        6,
        &[
            "held-out RMS error (N·m)",
            "electromechanical_delay",
            "812",
            "-4.00",
            "baseline held-out RMS 4.50 N·m",
        ],
    );
    let pos = |t: &str| s.texts.iter().position(|x| x == t).unwrap();
    assert!(pos("electromechanical_delay") < pos("fatigue") && pos("fatigue") < pos("inertia"));
    assert!(
        svg.contains("#D55E00") || svg.to_ascii_lowercase().contains("#d55e00"),
        "selected cause in vermillion"
    );
    assert!(matches!(
        figures::candidate_ranking(&[], None),
        Err(ReportError::Empty { .. })
    ));
}

#[test]
fn mcmc_figures() {
    let names = ["LST sol (m)", "F0 sol (N)", "α0 sol (deg)"];
    let chains: Vec<Vec<Vec<f64>>> = draws(4000, 3)
        .into_iter()
        .map(|d| d.chunks(1000).map(<[f64]>::to_vec).collect())
        .collect();
    let svg = figures::traces(&names, &chains, 200).unwrap();
    let s = assert_figure(
        &svg,
        12,
        &[
            "LST sol (m)",
            "α0 sol (deg)",
            "iteration",
            "4 chains, one colour each",
            "warm-up (200 iterations, discarded)",
        ],
    );
    assert!(s.count("polyline") >= 12);

    let iters: Vec<f64> = (1..=20).map(|k| 100.0 * k as f64).collect();
    let rhat: Vec<Vec<f64>> = (0..3)
        .map(|p| {
            iters
                .iter()
                .map(|i| {
                    if *i < 150.0 {
                        f64::NAN
                    } else {
                        1.0 + (p + 1) as f64 * 50.0 / i
                    }
                })
                .collect()
        })
        .collect();
    let svg = figures::rhat_history(&names, &iters, &rhat).unwrap();
    assert_figure(
        &svg,
        4,
        &["iteration", "R-hat − 1 (log scale)", "R̂ = 1.01", "0.01"],
    );
    let all_nan = vec![vec![f64::NAN; 20]; 3];
    assert!(matches!(
        figures::rhat_history(&names, &iters, &all_nan),
        Err(ReportError::Invalid { .. })
    ));

    let d = draws(5000, 3);
    let svg = figures::histograms(&names, &d, Some(&[10.0, 20.0, 30.0])).unwrap();
    assert_figure(
        &svg,
        3 * 20,
        &["draws per bin", "true value", "90 % interval", "F0 sol (N)"],
    );

    let svg = figures::corner(&names, &d, Some(&[10.0, 20.0, 30.0])).unwrap();
    let s = assert_figure(&svg, 500, &["LST sol (m)", "α0 sol (deg)"]);
    // The correlations written above the diagonal are those of the data (about 0.64).
    let rhos: Vec<f64> = s
        .texts
        .iter()
        .filter_map(|t| t.strip_prefix("ρ = "))
        .map(|v| v.parse().unwrap())
        .collect();
    assert_eq!(rhos.len(), 3);
    for r in rhos {
        assert!((r - 0.64).abs() < 0.05, "ρ = {r}");
    }
}

#[test]
fn corner_stays_small_with_nine_parameters_and_many_draws() {
    let d = draws(40_000, 9);
    let names: Vec<String> = (0..9).map(|k| format!("p{k} (m)")).collect();
    let names: Vec<&str> = names.iter().map(String::as_str).collect();
    let svg = figures::corner(&names, &d, None).unwrap();
    let s = assert_figure(&svg, 36 * 200, &["p0 (m)", "p8 (m)"]);
    assert_eq!(s.texts.iter().filter(|t| t.starts_with("ρ = ")).count(), 36);
}

#[test]
fn sensitivity_curves_one_per_parameter() {
    let mut pts = Vec::new();
    for (k, p) in ["LST sol (m)", "F0 gm (N)"].iter().enumerate() {
        for c in [-20.0, -10.0, 10.0, 20.0] {
            pts.push(SensitivityPoint {
                param: p,
                change_pct: c,
                rms_change_nm: Some((k + 1) as f64 * f64::abs(c) / 10.0),
            });
        }
    }
    pts.push(SensitivityPoint {
        param: "LST sol (m)",
        change_pct: 15.0,
        rms_change_nm: None,
    });
    let svg = figures::sensitivity_curves(&pts).unwrap();
    let s = assert_figure(
        &svg,
        10,
        &[
            "parameter change (%)",
            "RMS torque change (N·m)",
            "F0 gm (N)",
        ],
    );
    // 2 curves × 5 points (with the added nominal point) as markers, plus legend.
    assert!(s.count("circle") >= 10);
    let none = [SensitivityPoint {
        param: "x",
        change_pct: 5.0,
        rms_change_nm: None,
    }];
    assert!(figures::sensitivity_curves(&none).is_err());
    let nan = [SensitivityPoint {
        param: "x",
        change_pct: f64::NAN,
        rms_change_nm: Some(1.0),
    }];
    assert!(matches!(
        figures::sensitivity_curves(&nan),
        Err(ReportError::NonFinite { .. })
    ));
}

#[test]
fn bad_input_is_an_error_not_a_panic() {
    let t = [0.0, 1.0, 2.0];
    let y = [1.0, 2.0, 3.0];
    let nan = [1.0, f64::NAN, 3.0];
    let e = figures::torque_fit(&t, &nan, &[], &y, &[]).unwrap_err();
    assert!(matches!(e, ReportError::NonFinite { index: 1, .. }), "{e}");
    assert!(e.to_string().contains("measured"));
    assert!(matches!(
        figures::torque_fit(&[], &[], &[], &[], &[]),
        Err(ReportError::Empty { .. })
    ));
    assert!(matches!(
        figures::torque_fit(&t, &y, &[("m", &y[..2])], &y, &[]),
        Err(ReportError::LengthMismatch {
            expected: 3,
            got: 2,
            ..
        })
    ));
    assert!(figures::residual_vs_angle(&t, &y, &[0, 1, 5], &["a", "b"]).is_err());
    assert!(figures::residual_vs_angle(&t, &y, &[0, 1], &["a", "b"]).is_err());
    assert!(figures::residual_vs_time(&t, &[]).is_err());
    assert!(figures::residual_vs_time(&t, &[("r", &[f64::INFINITY, 0.0, 0.0])]).is_err());
    assert!(figures::fit_comparison(&t, &y, &y, &nan).is_err());
    assert!(figures::traces(&["a"], &[vec![]], 0).is_err());
    assert!(figures::traces(&["a", "b"], &[vec![vec![1.0]]], 0).is_err());
    assert!(figures::traces(&[], &[], 0).is_err());
    assert!(figures::histograms(&["a"], &[vec![1.0, f64::NAN]], None).is_err());
    assert!(figures::histograms(&["a"], &[vec![1.0, 2.0]], Some(&[1.0, 2.0])).is_err());
    assert!(figures::corner(&["a", "b"], &[vec![1.0, 2.0], vec![1.0]], None).is_err());
    assert!(figures::rhat_history(&["a"], &[1.0, 2.0], &[vec![1.1]]).is_err());
    let c = [Candidate {
        name: "x",
        evidence: f64::NAN,
        heldout_rms_nm: Some(1.0),
        selected: false,
    }];
    assert!(figures::candidate_ranking(&c, None).is_err());
}

#[test]
fn constant_and_single_point_series_still_draw() {
    let t = [0.0];
    let y = [5.0];
    let svg = figures::torque_fit(&t, &y, &[("m", &y)], &y, &[("sol", &[0.0])]).unwrap();
    assert_figure(&svg, 2, &["torque (N·m)"]);
    let d = vec![vec![2.0; 50], vec![3.0; 50]];
    let svg = figures::corner(&["a (m)", "b (N)"], &d, None).unwrap();
    let s = assert_figure(&svg, 3, &["a (m)", "ρ = 0.00"]);
    assert!(s.count("rect") > 1);
    assert_figure(
        &figures::histograms(&["a (m)"], &[vec![1.0]], None).unwrap(),
        2,
        &["a (m)"],
    );
}

#[test]
fn figures_are_deterministic() {
    let d = data();
    let a = figures::residual_vs_angle(&d.angle, &d.resid, &d.phase, &["a", "b", "c"]).unwrap();
    let b = figures::residual_vs_angle(&d.angle, &d.resid, &d.phase, &["a", "b", "c"]).unwrap();
    assert_eq!(a, b);
    let x = draws(3000, 4);
    let names = ["a", "b", "c", "d"];
    assert_eq!(
        figures::corner(&names, &x, None).unwrap(),
        figures::corner(&names, &x, None).unwrap()
    );
}
