//! The integrators against problems with known solutions.

use ode::{dopri5_dense, rk4_fixed, rk_fixed, AdaptiveSettings, DoPri5, OdeError, DP5, RK4};

fn decay(_t: f64, y: &[f64; 1], dy: &mut [f64; 1]) {
    dy[0] = -1.5 * y[0];
}

/// Harmonic oscillator y'' = −ω² y with ω = 2.
fn oscillator(_t: f64, y: &[f64; 2], dy: &mut [f64; 2]) {
    dy[0] = y[1];
    dy[1] = -4.0 * y[0];
}

/// Logistic growth y' = r y (1 − y/K), r = 2, K = 10, y(0) = 0.5.
fn logistic(_t: f64, y: &[f64; 1], dy: &mut [f64; 1]) {
    dy[0] = 2.0 * y[0] * (1.0 - y[0] / 10.0);
}
fn logistic_exact(t: f64) -> f64 {
    10.0 * 0.5 / (0.5 + (10.0 - 0.5) * (-2.0 * t).exp())
}

fn grid(t_end: f64, n: usize) -> Vec<f64> {
    (0..=n).map(|i| t_end * i as f64 / n as f64).collect()
}

#[test]
fn adaptive_matches_exponential_decay_on_a_grid() {
    let t = grid(4.0, 400);
    let mut got = vec![0.0; t.len()];
    let s = AdaptiveSettings::default().with_rtol(1e-8).with_atol(1e-12);
    let stats = dopri5_dense(&mut decay, [2.0], &t, &s, |i, y| got[i] = y[0]).unwrap();
    let max_err = t
        .iter()
        .zip(&got)
        .map(|(t, g)| (g - 2.0 * (-1.5 * t).exp()).abs())
        .fold(0.0, f64::max);
    assert!(max_err < 1e-8, "max error {max_err:e}");
    // dense output: far fewer steps than output points
    assert!(stats.accepted < 100, "{stats:?}");
    assert_eq!(stats.rhs_calls, 2 + 6 * (stats.accepted + stats.rejected));
}

#[test]
fn adaptive_matches_harmonic_oscillator() {
    let t = grid(10.0, 1000);
    let mut got = vec![[0.0; 2]; t.len()];
    let s = AdaptiveSettings::default().with_rtol(1e-9).with_atol(1e-12);
    dopri5_dense(&mut oscillator, [1.0, 0.0], &t, &s, |i, y| got[i] = *y).unwrap();
    for (ti, g) in t.iter().zip(&got) {
        let exact = [(2.0 * ti).cos(), -2.0 * (2.0 * ti).sin()];
        assert!((g[0] - exact[0]).abs() < 1e-7, "t={ti} {g:?}");
        assert!((g[1] - exact[1]).abs() < 2e-7, "t={ti} {g:?}");
    }
}

#[test]
fn adaptive_matches_logistic_growth() {
    let t = grid(5.0, 50);
    let mut got = vec![0.0; t.len()];
    let s = AdaptiveSettings::default().with_rtol(1e-9).with_atol(1e-12);
    dopri5_dense(&mut logistic, [0.5], &t, &s, |i, y| got[i] = y[0]).unwrap();
    for (ti, g) in t.iter().zip(&got) {
        assert!((g - logistic_exact(*ti)).abs() < 1e-7, "t={ti}");
    }
}

#[test]
fn dense_output_between_steps_is_accurate() {
    // Few, long steps: interpolated values must still be close to exact.
    let s = AdaptiveSettings::default().with_rtol(1e-6).with_atol(1e-9);
    let mut st = DoPri5::<2>::new(s).unwrap();
    let mut sys = oscillator;
    st.init(&mut sys, 0.0, [1.0, 0.0], 6.0).unwrap();
    let mut worst: f64 = 0.0;
    let mut buf = [0.0; 2];
    while st.t() < 6.0 {
        st.step(&mut sys).unwrap();
        let (a, b) = (st.t_prev(), st.t());
        for k in 0..=10 {
            let t = a + (b - a) * k as f64 / 10.0;
            st.interpolate(t, &mut buf);
            worst = worst.max((buf[0] - (2.0 * t).cos()).abs());
        }
    }
    assert!(worst < 1e-4, "worst interpolation error {worst:e}");
    assert!(st.stats().accepted > 5);
}

#[test]
fn error_scales_with_tolerance() {
    let t = [0.0, 10.0];
    let mut errs = Vec::new();
    for tol in [1e-4, 1e-6, 1e-8, 1e-10] {
        let s = AdaptiveSettings::default().with_rtol(tol).with_atol(tol);
        let mut end = [0.0; 2];
        dopri5_dense(&mut oscillator, [1.0, 0.0], &t, &s, |_, y| end = *y).unwrap();
        errs.push((end[0] - 20.0f64.cos()).abs());
    }
    // each 100x tighter tolerance gives a clearly smaller error, by a factor
    // within a broad band around 100 (global error ~ tol for a PI-controlled DP5)
    for w in errs.windows(2) {
        let ratio = w[0] / w[1];
        assert!(ratio > 10.0 && ratio < 1000.0, "errors {errs:?}");
    }
    // and the loosest is not far off its tolerance
    assert!(errs[0] < 1e-2, "{errs:?}");
}

fn observed_order(errs: &[f64]) -> f64 {
    // least-squares slope of log2(err) against halvings
    let n = errs.len() as f64;
    let xs: Vec<f64> = (0..errs.len()).map(|i| i as f64).collect();
    let ys: Vec<f64> = errs.iter().map(|e| e.log2()).collect();
    let mx = xs.iter().sum::<f64>() / n;
    let my = ys.iter().sum::<f64>() / n;
    let sxy: f64 = xs.iter().zip(&ys).map(|(x, y)| (x - mx) * (y - my)).sum();
    let sxx: f64 = xs.iter().map(|x| (x - mx).powi(2)).sum();
    -sxy / sxx
}

#[test]
fn rk4_converges_with_order_four() {
    let mut errs = Vec::new();
    for k in 0..5 {
        let n = 10usize << k;
        let h = 2.0 / n as f64;
        let mut end = [0.0; 2];
        rk4_fixed(&mut oscillator, 0.0, [1.0, 0.0], h, n, |_, _, y| end = *y).unwrap();
        errs.push((end[0] - 4.0f64.cos()).abs());
    }
    let p = observed_order(&errs);
    assert!((p - 4.0).abs() < 0.2, "observed order {p}, errors {errs:?}");
}

#[test]
fn dp5_fixed_converges_with_order_five() {
    let mut errs = Vec::new();
    for k in 0..5 {
        let n = 8usize << k;
        let h = 2.0 / n as f64;
        let mut end = [0.0; 1];
        rk_fixed(&DP5, &mut logistic, 0.0, [0.5], h, n, |_, _, y| end = *y).unwrap();
        errs.push((end[0] - logistic_exact(2.0)).abs());
    }
    let p = observed_order(&errs);
    assert!((p - 5.0).abs() < 0.3, "observed order {p}, errors {errs:?}");
    assert_eq!(RK4.order, 4);
    assert_eq!(DP5.order, 5);
}

#[test]
fn mildly_stiff_linear_problem_has_bounded_step_count() {
    // y1' = -500 (y1 - cos t), y2' = -y2: the fast mode decays, then the
    // step size is limited by stability (|hλ| ≲ 3.3), not accuracy.
    let mut sys = |t: f64, y: &[f64; 2], dy: &mut [f64; 2]| {
        dy[0] = -500.0 * (y[0] - t.cos());
        dy[1] = -y[1];
    };
    let s = AdaptiveSettings::default().with_rtol(1e-6).with_atol(1e-9);
    let mut end = [0.0; 2];
    let stats = dopri5_dense(&mut sys, [0.0, 1.0], &[0.0, 10.0], &s, |_, y| end = *y).unwrap();
    // quasi-steady solution y1 ≈ (500² cos t + 500 sin t)/(500² + 1)
    let exact1 = (250000.0 * 10.0f64.cos() + 500.0 * 10.0f64.sin()) / 250001.0;
    assert!((end[0] - exact1).abs() < 1e-5, "{end:?} vs {exact1}");
    assert!((end[1] - (-10.0f64).exp()).abs() < 1e-7);
    // stability bound: h ≤ ~3.3/500, so ≥ ~1500 steps over 10 s; we allow a
    // factor 1.5 above that for the controller's oscillation, and a modest
    // rejection count.
    eprintln!("stiff problem stats: {stats:?}");
    assert!(
        stats.accepted >= 1000 && stats.accepted <= 2500,
        "{stats:?}"
    );
    assert!(stats.rejected * 4 < stats.accepted, "{stats:?}");
}

#[test]
fn non_finite_rhs_is_an_error_not_a_panic() {
    let mut sys = |t: f64, y: &[f64; 1], dy: &mut [f64; 1]| {
        dy[0] = if t > 0.5 { f64::NAN } else { y[0] };
    };
    let r = dopri5_dense(
        &mut sys,
        [1.0],
        &[0.0, 1.0],
        &AdaptiveSettings::default(),
        |_, _| {},
    );
    assert!(matches!(r, Err(OdeError::NonFinite { .. })), "{r:?}");
}

#[test]
fn finite_time_blow_up_reports_underflow_or_non_finite() {
    // y' = y², y(0) = 1 blows up at t = 1.
    let mut sys = |_t: f64, y: &[f64; 1], dy: &mut [f64; 1]| dy[0] = y[0] * y[0];
    let r = dopri5_dense(
        &mut sys,
        [1.0],
        &[0.0, 2.0],
        &AdaptiveSettings::default(),
        |_, _| {},
    );
    assert!(
        matches!(
            r,
            Err(OdeError::StepSizeUnderflow { .. })
                | Err(OdeError::NonFinite { .. })
                | Err(OdeError::MaxSteps { .. })
        ),
        "{r:?}"
    );
    if let Err(OdeError::StepSizeUnderflow { t, .. }) = r {
        assert!((t - 1.0).abs() < 1e-3, "blow-up located at {t}");
    }
}

#[test]
fn step_budget_is_enforced() {
    let s = AdaptiveSettings::default()
        .with_rtol(1e-12)
        .with_atol(1e-14)
        .with_max_steps(10);
    let r = dopri5_dense(&mut oscillator, [1.0, 0.0], &[0.0, 100.0], &s, |_, _| {});
    assert!(
        matches!(r, Err(OdeError::MaxSteps { steps: 10, .. })),
        "{r:?}"
    );
}

/// `y'' = −k·y − c·y' + f(t)` with a forcing whose slope jumps at the zeros of `cos 3t`
/// (`|cos 3t|`), `k = 400`: stiff enough that the steps run near DoPri5's stability limit.
fn forced(t: f64, y: &[f64; 2], dy: &mut [f64; 2]) {
    dy[0] = y[1];
    dy[1] = -400.0 * y[0] - 0.5 * y[1] + (7.0 * t).sin() * (1.0 + (3.0 * t).cos().abs());
}

#[test]
fn near_the_stability_limit_a_damped_controller_rejects_fewer_steps_for_the_same_work() {
    // at rtol 1e-4 the steps are set by stability (eigenvalues about ±20i: h·20 runs near
    // DoPri5's stability boundary), where the plain controller swings between too long and too
    // short steps (measured: 16 % of the attempts rejected against 1.6 %, for the same number
    // of right-hand sides)
    let t = grid(20.0, 2000);
    let run = |beta: f64| {
        let s = AdaptiveSettings::default()
            .with_rtol(1e-4)
            .with_atol(1e-6)
            .with_pi_beta(beta);
        dopri5_dense(&mut forced, [0.0, 0.0], &t, &s, |_, _| {}).unwrap()
    };
    let (plain, damped) = (run(ode::DEFAULT_PI_BETA), run(ode::STABILISED_PI_BETA));
    let share = |s: ode::Stats| s.rejected as f64 / (s.accepted + s.rejected) as f64;
    assert!(share(plain) > 0.1, "{plain:?}");
    assert!(
        share(damped) < 0.25 * share(plain),
        "{damped:?} vs {plain:?}"
    );
    let ratio = damped.rhs_calls as f64 / plain.rhs_calls as f64;
    assert!((0.95..1.05).contains(&ratio), "{damped:?} vs {plain:?}");
}

#[test]
fn pi_beta_outside_its_range_is_an_error() {
    for beta in [-0.01, 0.11, f64::NAN] {
        let s = AdaptiveSettings::default().with_pi_beta(beta);
        assert!(DoPri5::<1>::new(s).is_err(), "β {beta}");
    }
    assert!(DoPri5::<1>::new(AdaptiveSettings::default().with_pi_beta(0.1)).is_ok());
}
