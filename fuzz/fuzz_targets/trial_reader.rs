//! Fuzz target: the trial and unloaded-run readers never panic on any bytes,
//! and every error they return displays as exactly one line naming the file.
#![no_main]

use libfuzzer_sys::fuzz_target;

/// The message must be one non-empty line that names the file.
fn check_message(e: &experiment::ExperimentError) {
    let msg = e.to_string();
    assert!(!msg.is_empty(), "empty error message");
    assert!(
        !msg.contains('\n') && !msg.contains('\r'),
        "multi-line error: {msg:?}"
    );
    assert!(
        msg.starts_with("fuzz.csv"),
        "error does not name the file: {msg:?}"
    );
}

fuzz_target!(|data: &[u8]| {
    match experiment::parse_trial_bytes(data, "fuzz.csv") {
        Ok(t) => {
            // what was accepted is consistent: equal columns, uniform time, ≥ 1 s
            assert!(t.len() >= 2);
            for c in [
                &t.ankle_angle_deg,
                &t.torque_nm,
                &t.emg_sol,
                &t.emg_gm,
                &t.emg_gl,
            ] {
                assert_eq!(c.len(), t.len());
            }
            assert!(t.time_s.windows(2).all(|w| w[1] > w[0]));
        }
        Err(e) => check_message(&e),
    }
    match experiment::parse_unloaded_bytes(data, "fuzz.csv") {
        Ok(u) => {
            assert!(u.len() >= 2);
            assert_eq!(u.torque_nm.len(), u.len());
        }
        Err(e) => check_message(&e),
    }
});
