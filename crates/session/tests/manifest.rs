//! The session manifest: paths, defaults and every error naming its place.

use session::{
    parse_session_manifest, read_session_manifest, EmgNormalisationScope, SessionError, TrialSource,
};
use std::path::Path;

fn parse(text: &str) -> Result<session::SessionManifest, SessionError> {
    parse_session_manifest(text, Path::new("/data/S01/session.json"))
}

#[test]
fn paths_resolve_against_the_manifest_folder() {
    let m = parse(
        r#"{"subject": "S01", "params": "../models/s01.osim",
            "osim_muscles": {"sol": "soleus_l"},
            "mvc": ["mvc1.csv"],
            "free": ["sol.lst_m", "activation.shape_a"],
            "bounds": {"sol.lst_m": [0.2, 0.3]},
            "trials": [
              {"name": "knee0_30", "trial": "iso30.csv", "unloaded": "u30.csv"},
              {"name": "knee90_30", "trial": "iso30_k90.csv", "knee_angle_deg": 90},
              {"name": "walk", "recording": "walk"}]}"#,
    )
    .unwrap();
    assert_eq!(m.subject.as_deref(), Some("S01"));
    assert_eq!(
        m.params.as_deref(),
        Some(Path::new("/data/S01/../models/s01.osim"))
    );
    assert_eq!(m.osim_muscles["sol"], "soleus_l");
    assert_eq!(m.mvc, vec![Path::new("/data/S01/mvc1.csv").to_path_buf()]);
    assert_eq!(m.free.as_ref().unwrap().len(), 2);
    assert_eq!(m.bounds["sol.lst_m"], (0.2, 0.3));
    assert_eq!(m.emg_normalisation, EmgNormalisationScope::Session);
    assert_eq!(m.trials.len(), 3);
    assert_eq!(
        m.trials[0].source,
        TrialSource::Csv("/data/S01/iso30.csv".into())
    );
    assert_eq!(
        m.trials[0].unloaded.as_deref(),
        Some(Path::new("/data/S01/u30.csv"))
    );
    assert_eq!(m.trials[1].knee_angle_deg, Some(90.0));
    assert_eq!(m.trials[0].knee_angle_deg, None);
    assert_eq!(m.trials[2].source.path(), Path::new("/data/S01/walk"));
}

#[test]
fn bad_manifests_name_the_key_or_position() {
    let cases: &[(&str, &str)] = &[
        ("{", "session.json:1:"),
        (r#"{"trials": []}"#, "trials: lists no trial"),
        (r#"{"trails": []}"#, "unknown field `trails`"),
        (
            r#"{"trials": [{"name": "a", "trial": "a.csv", "knee": 90}]}"#,
            "unknown field `knee`",
        ),
        (r#"{"trials": [{"name": "a"}]}"#, "trials[0].trial: missing"),
        (
            r#"{"trials": [{"name": "a", "trial": "a.csv", "recording": "r"}]}"#,
            "trials[0].trial: give either",
        ),
        (
            r#"{"trials": [{"name": "a", "trial": "a.csv"}, {"name": "a", "trial": "b.csv"}]}"#,
            "trials[1].name: a names two trials",
        ),
        (
            r#"{"trials": [{"name": "a", "trial": "a.csv", "knee_angle_deg": -5}]}"#,
            "trials[0].knee_angle_deg",
        ),
        (
            r#"{"trials": [{"name": "a", "trial": "a.csv", "knee_angle_deg": "90"}]}"#,
            "session.json:1:",
        ),
        (
            r#"{"free": ["sol.lst"], "trials": [{"name": "a", "trial": "a.csv"}]}"#,
            "free[0]",
        ),
        (
            r#"{"free": ["sol.lst_m", "sol.lst_m"], "trials": [{"name": "a", "trial": "a.csv"}]}"#,
            "free[1]: sol.lst_m is listed twice",
        ),
        (
            r#"{"bounds": {"sol.fom_n": [5000, 2000]}, "trials": [{"name": "a", "trial": "a.csv"}]}"#,
            "bounds.sol.fom_n: [5000, 2000] is not an interval",
        ),
        (
            r#"{"bounds": {"sol.f0": [1, 2]}, "trials": [{"name": "a", "trial": "a.csv"}]}"#,
            "bounds.sol.f0",
        ),
        (
            r#"{"osim_muscles": {"ta": "tib_ant_r"}, "trials": [{"name": "a", "trial": "a.csv"}]}"#,
            "osim_muscles.ta",
        ),
        (
            r#"{"trials": [{"name": "a", "trial": "a.csv"}, {"name": "b", "trial": "b.csv", "condition": " "}]}"#,
            "trials[1].condition: is empty (trial b)",
        ),
        (
            r#"{"trials": [{"name": "a", "trial": "a.csv", "condition": 36}]}"#,
            "trials[0].condition: 36 is not a text label (trial a)",
        ),
        (
            r#"{"trials": [{"name": "a", "trial": "a.csv", "condition": ["slow"]}]}"#,
            "trials[0].condition: [\"slow\"] is not a text label (trial a)",
        ),
        (
            r#"{"emg_normalisation": "per_trial", "trials": [{"name": "a", "trial": "a.csv"}]}"#,
            "emg_normalisation: \"per_trial\" is neither \"session\" nor \"trial\"",
        ),
        (
            r#"{"emg_normalisation": "trial", "mvc": ["m.csv"], "trials": [{"name": "a", "trial": "a.csv"}]}"#,
            "emg_normalisation: \"trial\" divides each trial by its own peak",
        ),
    ];
    for (text, want) in cases {
        let err = parse(text).unwrap_err().to_string();
        assert!(err.contains(want), "{text}\n  gave: {err}\n  want: {want}");
        assert!(err.starts_with("/data/S01/session.json"), "{err}");
        assert!(!err.contains('\n'), "one line: {err}");
    }
}

#[test]
fn a_missing_manifest_is_an_io_error_naming_it() {
    let err = read_session_manifest(Path::new("/no/such/session.json")).unwrap_err();
    assert!(matches!(err, SessionError::Io { .. }));
    assert!(err.to_string().starts_with("/no/such/session.json: "));
}

#[test]
fn emg_normalisation_is_per_session_unless_the_manifest_says_trial() {
    let one = r#""trials": [{"name": "a", "trial": "a.csv"}]"#;
    for (key, want) in [
        ("", EmgNormalisationScope::Session),
        (
            r#""emg_normalisation": "session","#,
            EmgNormalisationScope::Session,
        ),
        (
            r#""emg_normalisation": "trial","#,
            EmgNormalisationScope::Trial,
        ),
    ] {
        let m = parse(&format!("{{{key}{one}}}")).unwrap();
        assert_eq!(m.emg_normalisation, want, "{key}");
    }
}
