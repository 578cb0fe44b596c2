//! Nelder–Mead used alone: quadratics inside the box and on its faces.

use numerics::{nelder_mead, FnObjective, NelderMeadSettings, NumericsError as Error, Objective};

#[test]
fn ill_conditioned_correlated_quadratic() {
    // f = (x − c)ᵀ A (x − c) with A = Lᵀ L, condition number ~1e4.
    let c = [0.3, -1.2, 2.0, 0.7];
    let l = [
        [1.0, 0.0, 0.0, 0.0],
        [0.9, 0.1, 0.0, 0.0],
        [0.2, 0.5, 2.0, 0.0],
        [0.0, 0.3, -0.4, 0.05],
    ];
    let mut calls = 0u64;
    let mut f = FnObjective::new(vec![(-5.0, 5.0); 4], |x: &[f64]| {
        calls += 1;
        let mut s = 0.0;
        for row in &l {
            let r: f64 = row
                .iter()
                .zip(x.iter().zip(&c))
                .map(|(a, (xi, ci))| a * (xi - ci))
                .sum();
            s += r * r;
        }
        Some(s)
    });
    let out = nelder_mead(
        &mut f,
        &[4.0, 4.0, -4.0, -4.0],
        &NelderMeadSettings::default(),
    )
    .unwrap();
    assert!(out.converged);
    assert!(out.cost < 1e-12, "{}", out.cost);
    for (xi, ci) in out.x.iter().zip(&c) {
        assert!((xi - ci).abs() < 1e-4, "{:?}", out.x);
    }
    assert!(out.evaluations <= 20_000);
    drop(f);
    assert_eq!(calls, out.evaluations);
}

#[test]
fn minimum_outside_the_box_lands_on_the_face() {
    let mut inside = true;
    let mut f = FnObjective::new(vec![(0.0, 1.0), (-1.0, 1.0)], |x: &[f64]| {
        inside &= (0.0..=1.0).contains(&x[0]) && (-1.0..=1.0).contains(&x[1]);
        Some((x[0] - 3.0).powi(2) + (x[1] - 0.25).powi(2))
    });
    let out = nelder_mead(&mut f, &[0.1, 0.9], &NelderMeadSettings::default()).unwrap();
    drop(f);
    assert!(inside, "an evaluation left the box");
    assert!((out.x[0] - 1.0).abs() < 1e-9, "{:?}", out.x);
    assert!((out.x[1] - 0.25).abs() < 1e-5, "{:?}", out.x);
    assert!((out.cost - 4.0).abs() < 1e-9);
}

#[test]
fn budget_and_failures() {
    let mut f = FnObjective::new(vec![(-2.0, 2.0); 3], |x: &[f64]| {
        if x[2] > 0.5 {
            None
        } else {
            Some(x.iter().map(|v| (v - 0.4) * (v - 0.4)).sum())
        }
    });
    let few = nelder_mead(
        &mut f,
        &[-1.5, 1.5, -1.5],
        &NelderMeadSettings::default().with_max_evaluations(25),
    )
    .unwrap();
    assert_eq!(few.evaluations, 25);
    assert!(!few.converged);
    let out = nelder_mead(&mut f, &[-1.5, 1.5, -1.5], &NelderMeadSettings::default()).unwrap();
    assert!(out.cost < 1e-12, "{}", out.cost);
    assert!(out.x.iter().all(|v| (v - 0.4).abs() < 1e-5));
    assert_eq!(
        nelder_mead(&mut f, &[0.0, 0.0, 1.0], &NelderMeadSettings::default()).unwrap_err(),
        Error::StartEvaluationFailed
    );
    assert_eq!(f.dim(), 3);
    assert!(matches!(
        NelderMeadSettings::new(0),
        Err(Error::InvalidSetting {
            name: "max_evaluations",
            ..
        })
    ));
}
