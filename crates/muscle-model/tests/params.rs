//! Parameters JSON and Effects JSON (`docs/formats.md`): merge, round trip, strict errors.

use muscle_model::{EffectKind, Effects, ModelError, ModelParams, Muscle, ParamId};

fn key_of(e: ModelError) -> String {
    match e {
        ModelError::UnknownKey { key, .. } | ModelError::InvalidValue { key, .. } => key,
        other => panic!("unexpected error {other:?}"),
    }
}

#[test]
fn spec_example_document_is_the_nominal_model() {
    let doc = r#"{"muscles": {"sol": {"fom_n": 3549, "lom_m": 0.05, "lst_m": 0.25, "alpha_deg": 25,
                     "vmax_lom_per_s": 10, "lmt_poly_m": [0.29139, 0.04535, -0.00752, -0.00633]}},
 "activation": {"tau_act_s": 0.015, "tau_deact_s": 0.05, "shape_a": 0.08},
 "curves": {"af": 0.25, "flen": 1.4, "gamma": 0.45, "kpe": 5, "e0m": 0.6, "e0t": 0.04, "damping": 0.1}}"#;
    assert_eq!(
        ModelParams::from_json_str(doc).unwrap(),
        ModelParams::nominal()
    );
    assert_eq!(
        ModelParams::from_json_str("{}").unwrap(),
        ModelParams::nominal()
    );
}

#[test]
fn partial_document_merges_over_nominal() {
    let p = ModelParams::from_json_str(
        r#"{"muscles": {"gm": {"lst_m": 0.4}}, "curves": {"flen": 1.6}}"#,
    )
    .unwrap();
    let n = ModelParams::nominal();
    assert_eq!(p.muscle(Muscle::Gm).lst_m, 0.4);
    assert_eq!(p.muscle(Muscle::Gm).fom_n, n.muscle(Muscle::Gm).fom_n);
    assert_eq!(p.muscle(Muscle::Sol), n.muscle(Muscle::Sol));
    assert_eq!(p.curves.flen, 1.6);
    assert_eq!(p.curves.af, 0.25);
    // round trip through serde
    let s = serde_json::to_string(&p).unwrap();
    let back: ModelParams = serde_json::from_str(&s).unwrap();
    assert_eq!(back, p);
    assert!(s.contains("\"lmt_poly_m\":[0.4507,"));
}

#[test]
fn errors_name_the_key() {
    let cases = [
        (r#"{"muscles": {"sol": {"lst": 0.25}}}"#, "muscles.sol.lst"),
        // a muscle other than sol, gm, gl is a fixed muscle and must give all its values
        (
            r#"{"muscles": {"ta": {"lst_m": 0.25}}}"#,
            "muscles.ta.fom_n",
        ),
        (r#"{"muscle": {}}"#, "muscle"),
        (r#"{"curves": {"beta": 0.1}}"#, "curves.beta"),
        (r#"{"activation": {"tau": 0.1}}"#, "activation.tau"),
        (r#"{"muscles": {"sol": {"lst_m": 0}}}"#, "muscles.sol.lst_m"),
        (r#"{"muscles": {"gm": {"fom_n": -5}}}"#, "muscles.gm.fom_n"),
        (
            r#"{"muscles": {"gl": {"lom_m": -0.01}}}"#,
            "muscles.gl.lom_m",
        ),
        (
            r#"{"muscles": {"gl": {"alpha_deg": 60}}}"#,
            "muscles.gl.alpha_deg",
        ),
        (
            r#"{"muscles": {"gl": {"alpha_deg": -1}}}"#,
            "muscles.gl.alpha_deg",
        ),
        (r#"{"activation": {"shape_a": 0.13}}"#, "activation.shape_a"),
        (
            r#"{"activation": {"shape_a": -0.01}}"#,
            "activation.shape_a",
        ),
        (
            r#"{"muscles": {"sol": {"lst_m": "long"}}}"#,
            "muscles.sol.lst_m",
        ),
        (
            r#"{"muscles": {"sol": {"lmt_poly_m": [1, 2, 3]}}}"#,
            "muscles.sol.lmt_poly_m",
        ),
        (r#"{"curves": {"damping": 0}}"#, "curves.damping"),
    ];
    for (doc, key) in cases {
        let err = ModelParams::from_json_str(doc).unwrap_err();
        let msg = err.to_string();
        assert_eq!(key_of(err), key, "{doc}");
        assert!(msg.contains(key), "{msg}");
    }
    // boundary values that are allowed
    assert!(ModelParams::from_json_str(r#"{"activation": {"shape_a": 0.12}}"#).is_ok());
    assert!(ModelParams::from_json_str(r#"{"activation": {"shape_a": 0}}"#).is_ok());
    assert!(ModelParams::from_json_str(r#"{"muscles": {"gl": {"alpha_deg": 0}}}"#).is_ok());
    assert!(matches!(
        ModelParams::from_json_str("{not json"),
        Err(ModelError::Json { .. })
    ));
}

#[test]
fn effects_json_strict_parse_and_round_trip() {
    let e = Effects::from_json_str(
        r#"{"electromechanical_delay": {"delay_ms": 41.0}, "gravity": {"moment_nm": 3}}"#,
    )
    .unwrap();
    assert_eq!(e.electromechanical_delay.unwrap().delay_ms, 41.0);
    let g = e.gravity.unwrap();
    assert_eq!((g.moment_nm, g.phase_deg), (3.0, 0.0));
    assert_eq!(
        e.enabled(),
        vec![EffectKind::Gravity, EffectKind::ElectromechanicalDelay]
    );
    let s = serde_json::to_string(&e).unwrap();
    let back: Effects = serde_json::from_str(&s).unwrap();
    assert_eq!(back, e);
    assert_eq!(Effects::from_json_str("{}").unwrap(), Effects::none());

    let cases = [
        (r#"{"delay": {"delay_ms": 4}}"#, "delay"),
        (
            r#"{"electromechanical_delay": {"delay": 4}}"#,
            "electromechanical_delay.delay",
        ),
        (
            r#"{"electromechanical_delay": {"delay_ms": 151}}"#,
            "electromechanical_delay.delay_ms",
        ),
        (
            r#"{"electromechanical_delay": {"delay_ms": -1}}"#,
            "electromechanical_delay.delay_ms",
        ),
        (
            r#"{"passive_joint_torque": {"stiffness_per_rad": 2}}"#,
            "passive_joint_torque.stiffness_per_rad",
        ),
        (
            r#"{"passive_joint_torque": {"scale_nm": -1}}"#,
            "passive_joint_torque.scale_nm",
        ),
        (r#"{"fatigue": {"rate_per_s": -0.1}}"#, "fatigue.rate_per_s"),
        (
            r#"{"antagonist_coactivation": {"gain_nm": -2}}"#,
            "antagonist_coactivation.gain_nm",
        ),
        (
            r#"{"eccentric_enhancement": {"flen": 2.5}}"#,
            "eccentric_enhancement.flen",
        ),
        (
            r#"{"eccentric_enhancement": {"flen": 0.9}}"#,
            "eccentric_enhancement.flen",
        ),
        (
            r#"{"torque_offset": {"offset_nm": "x"}}"#,
            "torque_offset.offset_nm",
        ),
        (r#"{"torque_offset": 3}"#, "torque_offset"),
    ];
    for (doc, key) in cases {
        let err = Effects::from_json_str(doc).unwrap_err();
        assert!(err.to_string().contains(key), "{err}");
        assert_eq!(key_of(err), key, "{doc}");
    }
}

#[test]
fn every_effect_has_named_parameters_with_null_inside_bounds() {
    for kind in EffectKind::ALL {
        assert_eq!(EffectKind::from_name(kind.name()), Some(kind));
        assert!(!kind.params().is_empty());
        for p in kind.params() {
            assert!(p.lower <= p.null && p.null <= p.upper, "{kind}.{}", p.name);
            let id = ParamId::parse(&format!("{}.{}", kind.name(), p.name)).unwrap();
            assert_eq!(id.name(), format!("{}.{}", kind.name(), p.name));
        }
        // enabling at null values then validating works
        Effects::none().with_null(kind).validate().unwrap();
    }
    let names: Vec<&str> = EffectKind::ALL.iter().map(|k| k.name()).collect();
    assert_eq!(
        names,
        [
            "torque_offset",
            "passive_joint_torque",
            "gravity",
            "electromechanical_delay",
            "fatigue",
            "antagonist_coactivation",
            "eccentric_enhancement",
            "viscous_damping",
            "inertia"
        ]
    );
}

#[test]
fn param_ids_parse_get_set() {
    let mut p = ModelParams::nominal();
    let mut e = Effects::none();
    for name in [
        "sol.lst_m",
        "gm.fom_n",
        "gl.alpha_deg",
        "sol.vmax_lom_per_s",
        "activation.shape_a",
        "curves.flen",
        "fatigue.rate_per_s",
    ] {
        let id = ParamId::parse(name).unwrap();
        assert_eq!(id.name(), name);
        let v = id.get(&p, &e);
        id.set(&mut p, &mut e, v * 0.5 + 0.01);
        assert_eq!(id.get(&p, &e), v * 0.5 + 0.01);
    }
    assert!(e.fatigue.is_some());
    for bad in ["sol", "sol.lst", "ta.lst_m", "gravity.mass", "curves.x", ""] {
        assert!(
            matches!(ParamId::parse(bad), Err(ModelError::UnknownParam { .. })),
            "{bad}"
        );
    }
    // eccentric_enhancement.flen defaults to the model's Flen
    let id = ParamId::parse("eccentric_enhancement.flen").unwrap();
    assert_eq!(id.get(&ModelParams::nominal(), &Effects::none()), 1.4);
    // identification bounds: LST ±5 %, F0 and α0 ±20 %
    let n = ModelParams::nominal();
    let b = ParamId::parse("sol.lst_m")
        .unwrap()
        .default_bounds(&n, &Effects::none());
    assert!((b.0 - 0.2375).abs() < 1e-12 && (b.1 - 0.2625).abs() < 1e-12);
    let b = ParamId::parse("gm.fom_n")
        .unwrap()
        .default_bounds(&n, &Effects::none());
    assert!((b.0 - 1246.4).abs() < 1e-9 && (b.1 - 1869.6).abs() < 1e-9);
    let b = ParamId::parse("gl.alpha_deg")
        .unwrap()
        .default_bounds(&n, &Effects::none());
    assert!((b.0 - 6.4).abs() < 1e-12 && (b.1 - 9.6).abs() < 1e-12);
    let b = ParamId::parse("electromechanical_delay.delay_ms")
        .unwrap()
        .default_bounds(&n, &Effects::none());
    assert_eq!(b, (0.0, 150.0));
}

#[test]
fn a_muscle_without_pennation_has_an_interval_and_others_keep_their_twenty_percent() {
    let alpha = ParamId::parse("gl.alpha_deg").unwrap();
    let at = |a: f64| {
        let mut p = ModelParams::nominal();
        p.muscles[2].alpha_deg = a;
        alpha.default_bounds(&p, &Effects::none())
    };
    // α0 = 0 (no pennation) is searched over [0°, 1°], not the empty [0°, 0°]
    assert_eq!(at(0.0), (0.0, 1.0));
    assert_eq!(at(2.0), (1.0, 3.0));
    // from 5° up, ±20 % of the value
    for a in [5.0, 8.0, 25.0] {
        let (lo, hi) = at(a);
        assert!(
            (lo - 0.8 * a).abs() < 1e-12 && (hi - 1.2 * a).abs() < 1e-12,
            "{a}: {lo} {hi}"
        );
    }
}

#[test]
fn the_activation_shape_has_an_interval_at_zero_and_keeps_its_relative_one_above_nominal() {
    let shape = ParamId::parse("activation.shape_a").unwrap();
    let at = |a: f64| {
        let mut p = ModelParams::nominal();
        p.activation.shape_a = a;
        shape.default_bounds(&p, &Effects::none())
    };
    // a linear activation (A = 0) is searched over [0, 0.016], not the empty [0, 0]
    let (lo, hi) = at(0.0);
    assert!(lo == 0.0 && (hi - 0.016).abs() < 1e-15, "{lo} {hi}");
    // below the nominal 0.08 the span is ±0.016
    let (lo, hi) = at(0.05);
    assert!(
        (lo - 0.034).abs() < 1e-15 && (hi - 0.066).abs() < 1e-15,
        "{lo} {hi}"
    );
    // from the nominal up, ±20 % of the value, capped at 0.12
    for a in [0.08, 0.09, 0.11] {
        let (lo, hi) = at(a);
        assert!((lo - 0.8 * a).abs() < 1e-15, "{a}: {lo}");
        assert!((hi - (1.2 * a).min(0.12)).abs() < 1e-15, "{a}: {hi}");
    }
}

#[test]
fn non_physiological_values_are_errors_naming_the_key() {
    for (json, key) in [
        (
            r#"{"muscles": {"sol": {"fom_n": 1e300}}}"#,
            "muscles.sol.fom_n",
        ),
        (r#"{"muscles": {"gm": {"lst_m": 10}}}"#, "muscles.gm.lst_m"),
        (
            r#"{"muscles": {"gl": {"lmt_poly_m": [0, 0, 0, 0]}}}"#,
            "muscles.gl.lmt_poly_m",
        ),
        (
            r#"{"activation": {"tau_act_s": 1e-12}}"#,
            "activation.tau_act_s",
        ),
        (r#"{"curves": {"e0t": 1e-12}}"#, "curves.e0t"),
    ] {
        let e = muscle_model::ModelParams::from_json_str(json).unwrap_err();
        assert!(e.to_string().contains(key), "{json}: {e}");
    }
    // the nominal values and twice the identification box stay valid
    let p = muscle_model::ModelParams::from_json_str(
        r#"{"muscles": {"sol": {"fom_n": 5000, "lst_m": 0.275}}}"#,
    )
    .unwrap();
    assert_eq!(p.muscle(muscle_model::Muscle::Sol).fom_n, 5000.0);
}

#[test]
fn a_further_muscle_is_fixed_and_round_trips() {
    let doc = r#"{"muscles": {"ta": {"fom_n": 905, "lom_m": 0.098, "lst_m": 0.223,
        "alpha_deg": 5, "lmt_poly_m": [0.33, -0.04, 0, 0]}}}"#;
    let p = ModelParams::from_json_str(doc).unwrap();
    assert_eq!(p.fixed.len(), 1);
    let ta = p.fixed.get("ta").unwrap();
    assert_eq!(ta.params.fom_n, 905.0);
    assert_eq!(ta.params.knee_moment_arm_m, 0.0);
    assert_eq!(ta.params.vmax_lom_per_s, 10.0);
    // the identified muscles keep their nominal values, the gastrocnemii cross the knee
    assert_eq!(p.muscles, ModelParams::nominal().muscles);
    assert_eq!(p.muscles[1].knee_moment_arm_m, 0.020);
    let back = ModelParams::from_json_str(&serde_json::to_string(&p).unwrap()).unwrap();
    assert_eq!(back, p);
    // a fixed muscle without a polynomial takes its geometry from each trial
    let series = ModelParams::from_json_str(
        r#"{"muscles": {"perlong": {"fom_n": 943, "lom_m": 0.049, "lst_m": 0.345, "alpha_deg": 10}}}"#,
    )
    .unwrap();
    assert!(series
        .fixed
        .get("perlong")
        .unwrap()
        .params
        .geometry_from_trial());
}
