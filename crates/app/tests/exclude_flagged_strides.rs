//! A session manifest's `exclude_flagged_strides`: the strides the recording checks flag on the
//! bundled gait trial are weighted 0 in the session's problem, every other sample keeps its
//! weight, and a session without the key fits every stride.

use std::path::{Path, PathBuf};

fn manifest(dir: &Path, exclude: Option<bool>) -> PathBuf {
    let map = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../fixtures/walk36/map.json");
    let extra = exclude.map_or(String::new(), |e| {
        format!(r#", "exclude_flagged_strides": {e}"#)
    });
    let text = format!(
        r#"{{"trials": [{{"name": "walk36", "recording": {:?}}}]{extra}}}"#,
        map.display().to_string()
    );
    let p = dir.join(format!("session_{exclude:?}.json"));
    std::fs::write(&p, text).unwrap();
    p
}

fn load(p: &Path) -> surae_app::LoadedSession {
    surae_app::load_session(p, &Default::default(), None, &surae_app::Reporter::silent()).unwrap()
}

#[test]
fn flagged_strides_are_weighted_zero_only_when_asked() {
    let dir = std::env::temp_dir().join(format!("surae_exclude_{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let excluded = load(&manifest(&dir, Some(true)));
    let t = &excluded.trials[0];
    let flagged = &t.checks.as_ref().unwrap().strides.as_ref().unwrap().flagged;
    assert!(!flagged.is_empty(), "walk36 has strides the checks flag");
    let w = t.problem.weights().expect("weights");
    let times = t.problem.inputs().times();
    let mut zeros = 0;
    for (ti, wi) in times.iter().zip(w) {
        let inside = flagged.iter().any(|f| f.start_s <= *ti && *ti < f.end_s);
        assert_eq!(*wi, if inside { 0.0 } else { 1.0 }, "t = {ti}");
        zeros += usize::from(inside);
    }
    // strides of 0.9–2.3 s at 100 Hz (a flagged stride may span a missed foot strike)
    let n = flagged.len();
    assert!(
        zeros > n * 85 && zeros < n * 235,
        "{zeros} samples in {n} strides"
    );
    // the trial's fit is judged without them: a prediction wrong only inside them is perfect
    let mut wrong = t.problem.measured().to_vec();
    for (x, wi) in wrong.iter_mut().zip(w) {
        if *wi == 0.0 {
            *x += 50.0;
        }
    }
    let (rms, _) = t.fit_of(&wrong).unwrap();
    assert_eq!(rms, 0.0);
    for keep in [None, Some(false)] {
        let s = load(&manifest(&dir, keep));
        assert!(s.trials[0].problem.weights().is_none(), "{keep:?}");
    }
    std::fs::remove_dir_all(&dir).unwrap();
}
