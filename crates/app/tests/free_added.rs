//! `--free +name`: parameters added to the set a session calibrates by default keep that
//! set's bounds (a recording's defaults included), so an extension is judged against the
//! same calibration; a mix of added and plain names is refused.

use std::path::{Path, PathBuf};

fn fixtures() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../fixtures")
}

fn load(p: &Path, free: Option<&[&str]>) -> Result<surae_app::LoadedSession, String> {
    let free: Option<Vec<String>> = free.map(|f| f.iter().map(|s| s.to_string()).collect());
    surae_app::load_session(
        p,
        &Default::default(),
        free.as_deref(),
        &surae_app::Reporter::silent(),
    )
    .map_err(|e| e.to_string())
}

fn bounds(s: &surae_app::LoadedSession) -> Vec<(String, (f64, f64))> {
    let p = &s.trials[0].problem;
    p.names()
        .iter()
        .cloned()
        .zip(p.bounds().iter().copied())
        .collect()
}

#[test]
fn added_names_keep_a_recordings_defaults_and_their_bounds() {
    let walk = fixtures().join("walk36/session.json");
    let plain = load(&walk, None).unwrap();
    assert!(plain.recording_defaults);
    let added = load(&walk, Some(&["+curves.e0t", "+activation.tau_deact_s"])).unwrap();
    assert!(added.recording_defaults, "the recording annealing is kept");
    let (b0, b1) = (bounds(&plain), bounds(&added));
    assert_eq!(b1.len(), b0.len() + 2);
    assert_eq!(&b1[..b0.len()], &b0[..], "the default set keeps its bounds");
    assert_eq!(b1[b0.len()].0, "curves.e0t");
    assert_eq!(b1[b0.len() + 1].0, "activation.tau_deact_s");
    // the same names given plainly replace the set, and the recording defaults go with it
    let replaced = load(&walk, Some(&["curves.e0t"])).unwrap();
    assert!(!replaced.recording_defaults);
    assert_eq!(bounds(&replaced).len(), 1);
    // a name already calibrated is not added twice
    let again = load(&walk, Some(&["+electromechanical_delay.delay_ms"])).unwrap();
    assert_eq!(bounds(&again), b0);
}

#[test]
fn added_names_extend_a_dynamometer_sessions_nine_and_a_mix_is_refused() {
    let dir = std::env::temp_dir().join(format!("surae_free_added_{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let fx = fixtures().join("session3");
    let m = dir.join("s.json");
    std::fs::write(
        &m,
        format!(
            r#"{{"trials": [{{"name": "k0", "trial": {:?}, "unloaded": {:?}}}]}}"#,
            fx.join("knee0_30.csv").display().to_string(),
            fx.join("knee0_30_unloaded.csv").display().to_string()
        ),
    )
    .unwrap();
    let plain = load(&m, None).unwrap();
    assert!(!plain.recording_defaults);
    assert_eq!(bounds(&plain).len(), 9);
    let added = load(&m, Some(&["+activation.shape_a"])).unwrap();
    let (b0, b1) = (bounds(&plain), bounds(&added));
    assert_eq!(&b1[..9], &b0[..]);
    assert_eq!(b1[9].0, "activation.shape_a");
    let err = load(&m, Some(&["+activation.shape_a", "sol.lst_m"]))
        .err()
        .expect("a mix is refused");
    assert!(err.contains("leading +"), "{err}");
    let err = load(&m, Some(&["+sol.lst"]))
        .err()
        .expect("an unknown name");
    assert!(err.contains("--free sol.lst"), "{err}");
    std::fs::remove_dir_all(&dir).ok();
}
