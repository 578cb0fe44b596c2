//! Behaviour of the annealer and its driver: eq. 13, bounds, determinism,
//! failed evaluations, budget, observers, initial temperature, errors.

use std::ops::ControlFlow;

use identify_sa::test_functions::{Kind, TestFunction};
use identify_sa::{
    reflect_into_unit, run, Acceptance, AnnealPhase, AnnealProgress, AnnealSettings,
    AnnealStopReason, Annealer, Error, FnObjective, NelderMeadSettings, NoObserver, Objective,
};
use numerics::NumericsError as N;

#[test]
fn logistic_acceptance_is_eq_13() {
    for &(delta, t) in &[
        (1.0, 1.0),
        (-2.0, 0.5),
        (0.3, 7.0),
        (5.0, 1e-3),
        (-5.0, 1e-3),
    ] {
        let expected = 1.0 / (1.0 + f64::exp(delta / t));
        let p = Acceptance::Logistic.probability(delta, t);
        assert!(
            (p - expected).abs() <= 1e-15,
            "Δ={delta} T={t}: {p} vs {expected}"
        );
    }
    // No change: one half. Symmetry: p(Δ) + p(−Δ) = 1.
    assert_eq!(Acceptance::Logistic.probability(0.0, 3.0), 0.5);
    for &d in &[0.1, 1.0, 10.0, 700.0, 1e5] {
        let s =
            Acceptance::Logistic.probability(d, 1.0) + Acceptance::Logistic.probability(-d, 1.0);
        assert!((s - 1.0).abs() < 1e-15);
    }
    // No overflow to NaN at extreme Δ/T, and the zero-temperature limits.
    assert_eq!(Acceptance::Logistic.probability(1e300, 1e-300), 0.0);
    assert_eq!(Acceptance::Logistic.probability(-1e300, 1e-300), 1.0);
    assert_eq!(Acceptance::Logistic.probability(1.0, 0.0), 0.0);
    assert_eq!(Acceptance::Logistic.probability(-1.0, 0.0), 1.0);
    assert_eq!(Acceptance::Logistic.probability(0.0, 0.0), 0.5);
    assert_eq!(Acceptance::Logistic.probability(f64::NAN, 1.0), 0.0);
    // Metropolis for comparison.
    assert!((Acceptance::Metropolis.probability(2.0, 4.0) - (-0.5f64).exp()).abs() < 1e-15);
    assert_eq!(Acceptance::Metropolis.probability(-2.0, 4.0), 1.0);
}

#[test]
fn reflection_folds_into_the_unit_interval() {
    let mut y = -7.3;
    while y < 7.3 {
        let r = reflect_into_unit(y);
        assert!((0.0..=1.0).contains(&r), "{y} -> {r}");
        if (0.0..=1.0).contains(&y) {
            assert_eq!(r, y);
        }
        // Distance to the nearest even integer, folded.
        let m = y.rem_euclid(2.0);
        let expected = if m > 1.0 { 2.0 - m } else { m };
        assert!((r - expected).abs() < 1e-12);
        y += 0.0137;
    }
    assert_eq!(reflect_into_unit(f64::INFINITY), 0.5);
}

/// Records the box violations of every evaluated point.
struct Watched {
    bounds: Vec<(f64, f64)>,
    violations: usize,
    evaluations: u64,
}

impl Objective for Watched {
    fn dim(&self) -> usize {
        self.bounds.len()
    }
    fn bounds(&self) -> &[(f64, f64)] {
        &self.bounds
    }
    fn cost(&mut self, x: &[f64]) -> Option<f64> {
        self.evaluations += 1;
        for (v, &(lo, hi)) in x.iter().zip(&self.bounds) {
            if !(*v >= lo && *v <= hi) {
                self.violations += 1;
            }
        }
        // Minimum outside the box in coordinates 0 and 2 (the optimum lies on a
        // face), inside in coordinate 1.
        Some((x[0] - 10.0).powi(2) + (x[1] - 0.2).powi(2) + (x[2] + 3.0).powi(2))
    }
}

#[test]
fn every_evaluation_is_inside_the_bounds_and_optimum_on_a_face_is_found() {
    let mut obj = Watched {
        bounds: vec![(-1.0, 2.5), (0.1, 0.3), (-1.0, 1e-3)],
        violations: 0,
        evaluations: 0,
    };
    let settings = AnnealSettings::default()
        .with_seed(7)
        .with_max_evaluations(20_000);
    let out = run(&mut obj, None, &settings, &mut NoObserver).unwrap();
    assert_eq!(obj.violations, 0);
    assert_eq!(obj.evaluations, out.evaluations);
    assert!((out.x[0] - 2.5).abs() < 1e-6, "{:?}", out.x);
    assert!((out.x[1] - 0.2).abs() < 1e-6, "{:?}", out.x);
    assert!((out.x[2] + 1.0).abs() < 1e-6, "{:?}", out.x);
}

#[test]
fn same_seed_same_result_other_seed_other_path() {
    let go = |seed| {
        let mut f = TestFunction::new(Kind::Rastrigin, 3);
        let s = AnnealSettings::default()
            .with_seed(seed)
            .with_max_evaluations(15_000);
        run(&mut f, None, &s, &mut NoObserver).unwrap()
    };
    let a = go(11);
    let b = go(11);
    assert_eq!(
        a, b,
        "same seed must reproduce the outcome and history exactly"
    );
    let c = go(12);
    assert_ne!(a.history, c.history);
}

#[test]
fn the_annealer_step_can_be_driven_by_hand_like_run() {
    let settings = AnnealSettings::default()
        .with_seed(3)
        .with_max_evaluations(8_000)
        .with_polish(0.0, Default::default());
    let mut f = TestFunction::new(Kind::Ackley, 2);
    let out = run(&mut f, Some(&[10.0, -20.0]), &settings, &mut NoObserver).unwrap();

    let mut g = TestFunction::new(Kind::Ackley, 2);
    let mut a = Annealer::new(&g, settings).unwrap();
    a.init(&mut g, Some(&[10.0, -20.0]), 8_000).unwrap();
    let mut stages = 0;
    while a.next_iter(&mut g, 8_000).is_some() {
        stages += 1;
    }
    assert_eq!(a.stop_reason(), Some(AnnealStopReason::MaxEvaluations));
    assert_eq!(a.evaluations(), 8_000);
    assert_eq!(a.best_cost(), out.cost);
    assert_eq!(a.best_x(), out.x);
    assert_eq!(a.history(), &out.history[..]);
    assert_eq!(stages, out.stages);
    assert!(a.steps().iter().all(|&v| v > 0.0 && v <= 1.0));
}

/// Deterministic pseudo-random failure pattern from the bits of x.
fn fails(x: &[f64]) -> bool {
    let mut h: u64 = 0x9E37_79B9_7F4A_7C15;
    for v in x {
        h ^= v.to_bits();
        h = h.wrapping_mul(0xBF58_476D_1CE4_E5B9);
        h ^= h >> 31;
    }
    h % 5 == 0
}

#[test]
fn failed_evaluations_are_rejected_moves_not_crashes() {
    let calls = std::cell::Cell::new(0u64);
    // A fifth of the points fail, and so does the whole region x0 > 2;
    // non-finite values are failures too.
    let mut f = FnObjective::new(vec![(-3.0, 3.0); 2], |x: &[f64]| {
        calls.set(calls.get() + 1);
        if x[0] > 2.0 || fails(x) {
            None
        } else if x[1] < -2.9 {
            Some(f64::NAN)
        } else {
            Some((x[0] - 1.0).powi(2) + (x[1] + 0.5).powi(2))
        }
    });
    let settings = AnnealSettings::default()
        .with_seed(5)
        .with_max_evaluations(10_000);
    let out = run(&mut f, None, &settings, &mut NoObserver).unwrap();
    assert!(out.failed_evaluations > 1000, "{}", out.failed_evaluations);
    assert_eq!(out.evaluations, calls.get());
    assert!(out.cost.is_finite() && out.cost < 1e-8, "{}", out.cost);
    assert!(out
        .history
        .iter()
        .all(|r| r.best_cost.is_finite() && r.current_cost.is_finite()));
    assert!((out.x[0] - 1.0).abs() < 1e-4 && (out.x[1] + 0.5).abs() < 1e-4);
}

#[test]
fn start_failures_are_errors() {
    let mut never = FnObjective::new(vec![(0.0, 1.0); 2], |_: &[f64]| None);
    let s = AnnealSettings::default().with_max_evaluations(1_000);
    assert_eq!(
        run(&mut never, None, &s, &mut NoObserver).unwrap_err(),
        Error::NoFeasibleStart { attempts: 100 }
    );
    assert_eq!(
        run(&mut never, Some(&[0.5, 0.5]), &s, &mut NoObserver).unwrap_err(),
        Error::Numerics(N::StartEvaluationFailed)
    );
    let mut ok = FnObjective::new(vec![(0.0, 1.0); 2], |x: &[f64]| Some(x[0]));
    assert_eq!(
        run(&mut ok, Some(&[0.5, 1.5]), &s, &mut NoObserver).unwrap_err(),
        Error::Numerics(N::StartOutOfBounds {
            index: 1,
            value: 1.5,
            lower: 0.0,
            upper: 1.0
        })
    );
    assert_eq!(
        run(&mut ok, Some(&[0.5]), &s, &mut NoObserver).unwrap_err(),
        Error::Numerics(N::DimensionMismatch {
            expected: 2,
            found: 1
        })
    );
}

#[test]
fn bad_bounds_and_settings_are_errors() {
    let s = AnnealSettings::default();
    let mut flat = FnObjective::new(vec![(0.0, 1.0), (2.0, 2.0)], |_: &[f64]| Some(0.0));
    assert_eq!(
        run(&mut flat, None, &s, &mut NoObserver).unwrap_err(),
        Error::Numerics(N::InvalidBounds {
            index: 1,
            lower: 2.0,
            upper: 2.0
        })
    );
    let mut nan = FnObjective::new(vec![(f64::NAN, 1.0)], |_: &[f64]| Some(0.0));
    assert!(matches!(
        run(&mut nan, None, &s, &mut NoObserver),
        Err(Error::Numerics(N::InvalidBounds { index: 0, .. }))
    ));
    let mut empty = FnObjective::new(vec![], |_: &[f64]| Some(0.0));
    assert_eq!(
        run(&mut empty, None, &s, &mut NoObserver).unwrap_err(),
        Error::Numerics(N::EmptyProblem)
    );

    let name = |r: Result<AnnealSettings, Error>| match r {
        Err(Error::Numerics(N::InvalidSetting { name, .. })) => name,
        other => panic!("expected an invalid setting, got {other:?}"),
    };
    assert_eq!(name(AnnealSettings::new(1, 0)), "max_evaluations");
    assert_eq!(name(s.with_cooling(1.0).validate()), "cooling");
    assert_eq!(name(s.with_cooling(f64::NAN).validate()), "cooling");
    assert_eq!(name(s.with_initial_step(0.0).validate()), "initial_step");
    assert_eq!(
        name(s.with_target_acceptance(0.6, 0.4).validate()),
        "target_acceptance_high"
    );
    assert_eq!(
        name(s.with_stage_length(0, 5).validate()),
        "moves_per_adaptation"
    );
    assert_eq!(
        name(s.with_reannealing(3, 1.5, 0.1).validate()),
        "reanneal_temperature"
    );
    assert_eq!(
        name(s.with_polish(1.0, Default::default()).validate()),
        "polish_fraction"
    );
    assert_eq!(
        name(
            s.with_polish(0.1, NelderMeadSettings::default().with_xtol(-1.0))
                .validate()
        ),
        "xtol"
    );
    assert!(AnnealSettings::new(9, 1234).is_ok());
}

#[test]
fn settings_round_trip_through_json_and_missing_fields_default() {
    let s = AnnealSettings::default()
        .with_seed(99)
        .with_acceptance(Acceptance::Metropolis)
        .with_cooling(0.9);
    let json = serde_json::to_string(&s).unwrap();
    let back: AnnealSettings = serde_json::from_str(&json).unwrap();
    assert_eq!(back, s);
    let partial: AnnealSettings =
        serde_json::from_str(r#"{"seed": 5, "acceptance": "logistic"}"#).unwrap();
    assert_eq!(partial, AnnealSettings::default().with_seed(5));
}

#[test]
fn budget_is_a_hard_limit_and_polish_gets_its_share() {
    for budget in [1u64, 2, 50, 333, 4_000] {
        let mut f = TestFunction::new(Kind::Rosenbrock, 3);
        let s = AnnealSettings::default()
            .with_seed(1)
            .with_max_evaluations(budget);
        let out = run(&mut f, None, &s, &mut NoObserver).unwrap();
        assert_eq!(f.evaluations, out.evaluations);
        assert!(out.evaluations <= budget, "{} > {budget}", out.evaluations);
        assert!(out.cost <= out.annealing_cost);
        if budget >= 50 {
            assert!(out.polish_evaluations > 0);
            assert_eq!(out.stop, AnnealStopReason::MaxEvaluations);
        }
    }
}

#[test]
fn converges_and_stops_when_reanneals_are_exhausted() {
    let mut f = TestFunction::new(Kind::Sphere, 3);
    let s = AnnealSettings::default()
        .with_seed(2)
        .with_max_evaluations(1_000_000)
        .with_reannealing(2, 0.3, 0.1);
    let out = run(&mut f, None, &s, &mut NoObserver).unwrap();
    assert_eq!(out.stop, AnnealStopReason::Converged);
    assert_eq!(out.reanneals, 2);
    assert!(out.evaluations < 200_000, "{}", out.evaluations);
    assert!(out.cost < 1e-12, "{}", out.cost);
    // Best cost never increases along the history; temperatures are positive.
    for w in out.history.windows(2) {
        assert!(w[1].best_cost <= w[0].best_cost);
        assert!(w[1].evaluations > w[0].evaluations);
    }
    assert!(out.history.iter().all(|r| r.temperature > 0.0));
}

#[test]
fn observer_sees_progress_and_can_interrupt() {
    let mut seen: Vec<AnnealProgress> = Vec::new();
    let mut f = TestFunction::new(Kind::Ackley, 2);
    let s = AnnealSettings::default()
        .with_seed(4)
        .with_max_evaluations(10_000);
    let out = run(&mut f, None, &s, &mut |p: &AnnealProgress| {
        seen.push(*p);
        ControlFlow::Continue(())
    })
    .unwrap();
    assert_eq!(
        seen.first().map(|p| p.phase),
        Some(AnnealPhase::InitialTemperature)
    );
    assert_eq!(seen.last().map(|p| p.phase), Some(AnnealPhase::Polish));
    assert_eq!(seen.len() as u64, out.stages + 2);
    assert!(seen
        .windows(2)
        .all(|w| w[1].evaluations >= w[0].evaluations));
    assert!(seen.iter().all(|p| p.max_evaluations == 10_000));
    assert_eq!(seen.last().unwrap().best_cost, out.cost);

    let mut g = TestFunction::new(Kind::Ackley, 2);
    let mut calls = 0;
    let stopped = run(&mut g, None, &s, &mut |_: &AnnealProgress| {
        calls += 1;
        if calls == 3 {
            ControlFlow::Break(())
        } else {
            ControlFlow::Continue(())
        }
    })
    .unwrap();
    assert_eq!(stopped.stop, AnnealStopReason::Interrupted);
    assert_eq!(stopped.stages, 2);
    assert_eq!(stopped.polish_evaluations, 0);
    assert!(stopped.evaluations < out.evaluations);
}

#[test]
fn initial_temperature_scales_with_the_cost() {
    // The search sees only Δ/T, so multiplying the cost by 1000 multiplies the
    // initial temperature by 1000 and leaves the path unchanged.
    let t0 = |scale: f64| {
        let mut f = FnObjective::new(vec![(-5.12, 5.12); 3], move |x: &[f64]| {
            Some(scale * TestFunction::new(Kind::Rastrigin, 3).value(x))
        });
        let s = AnnealSettings::default()
            .with_seed(8)
            .with_max_evaluations(6_000);
        run(&mut f, None, &s, &mut NoObserver).unwrap()
    };
    let a = t0(1.0);
    let b = t0(1000.0);
    assert!(a.initial_temperature > 0.0);
    assert!((b.initial_temperature / a.initial_temperature - 1000.0).abs() < 1e-6);
    // And it is of the order of the cost differences across the box (Rastrigin's
    // values span 0..~120 in 3D): neither negligible nor huge.
    assert!(
        a.initial_temperature > 0.5 && a.initial_temperature < 500.0,
        "{}",
        a.initial_temperature
    );
    // History stage 0 is the search; its temperature is T0.
    assert_eq!(a.history[0].stage, 0);
    assert_eq!(a.history[0].temperature, a.initial_temperature);
}

/// The messages of the errors the shared optimisers report, through `Error::Numerics`, are the
/// texts this crate has always printed.
#[test]
fn numerics_errors_display_as_before() {
    let cases: [(N, &str); 6] = [
        (
            N::EmptyProblem,
            "the objective has no parameters (dimension 0)",
        ),
        (
            N::DimensionMismatch {
                expected: 2,
                found: 1,
            },
            "dimension mismatch: expected 2 values, found 1",
        ),
        (
            N::InvalidBounds {
                index: 1,
                lower: 2.0,
                upper: 2.0,
            },
            "invalid bounds for parameter 1: lower 2, upper 2 (need finite lower < upper)",
        ),
        (
            N::InvalidSetting {
                name: "cooling",
                value: 1.0,
                reason: "must be in (0, 1)",
            },
            "invalid setting `cooling` = 1: must be in (0, 1)",
        ),
        (
            N::StartOutOfBounds {
                index: 1,
                value: 1.5,
                lower: 0.0,
                upper: 1.0,
            },
            "start point coordinate 1 = 1.5 is outside [0, 1]",
        ),
        (
            N::StartEvaluationFailed,
            "the objective failed at the supplied start point",
        ),
    ];
    for (e, text) in cases {
        assert_eq!(Error::from(e).to_string(), text);
    }
}
