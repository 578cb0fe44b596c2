//! Protocols (docs/formats.md, "Synthetic trials"): durations, kinematics, phases and events.

use experiment::{ErrorKind, MotionPhase, MotionSettings, Protocol};

const FS: f64 = 2048.0;
/// One sweep: 35° at 30 °/s plus one 50 ms ramp.
const SWEEP: f64 = 35.0 / 30.0 + 0.05;

fn close(a: f64, b: f64, tol: f64) -> bool {
    (a - b).abs() <= tol
}

#[test]
fn seed_protocol_durations_angles_velocity_and_events() {
    let tr = Protocol::Seed.trace().unwrap();
    let total = 0.5 + 2.0 * SWEEP + 0.4;
    assert!(close(tr.duration_s(), total, 1e-12));
    assert_eq!(tr.len(), (total * FS).floor() as usize + 1);
    assert_eq!(tr.len(), 6827);
    assert_eq!(tr.sample_rate_hz, FS);
    for (i, &t) in tr.time_s.iter().enumerate() {
        assert_eq!(t, i as f64 / FS);
    }
    // Angles within [−20, 15], both ends reached.
    let amin = tr.angle_deg.iter().copied().fold(f64::INFINITY, f64::min);
    let amax = tr
        .angle_deg
        .iter()
        .copied()
        .fold(f64::NEG_INFINITY, f64::max);
    assert!(close(amax, 15.0, 1e-12) && (-20.0 - 1e-12..-20.0 + 1e-5).contains(&amin));
    // Peak speed 30 °/s, reached in both directions; acceleration ±600 °/s² or 0.
    let vmin = tr
        .velocity_deg_s
        .iter()
        .copied()
        .fold(f64::INFINITY, f64::min);
    let vmax = tr
        .velocity_deg_s
        .iter()
        .copied()
        .fold(f64::NEG_INFINITY, f64::max);
    assert!(close(vmin, -30.0, 1e-12) && close(vmax, 30.0, 1e-12));
    for &a in &tr.acceleration_deg_s2 {
        assert!(a == 0.0 || close(a.abs(), 600.0, 1e-9), "acc {a}");
    }
    // Events.
    assert_eq!(tr.events.starts, vec![0.5]);
    assert_eq!(tr.events.reversals.len(), 1);
    assert!(close(tr.events.reversals[0], 0.5 + SWEEP, 1e-12));
    assert_eq!(tr.events.stops.len(), 1);
    assert!(close(tr.events.stops[0], 0.5 + 2.0 * SWEEP, 1e-12));
    // Holds at +15° and at rest velocity; the concentric sweep decreases the angle.
    for i in 0..tr.len() {
        let t = tr.time_s[i];
        match tr.phase[i] {
            MotionPhase::Hold => {
                assert!(!(0.5..0.5 + 2.0 * SWEEP).contains(&t));
                assert_eq!((tr.angle_deg[i], tr.velocity_deg_s[i]), (15.0, 0.0));
            }
            MotionPhase::Concentric => {
                assert!((0.5..0.5 + SWEEP).contains(&t));
                assert!(tr.velocity_deg_s[i] <= 0.0);
            }
            MotionPhase::Eccentric => {
                assert!((0.5 + SWEEP..0.5 + 2.0 * SWEEP).contains(&t));
                assert!(tr.velocity_deg_s[i] >= 0.0);
            }
        }
    }
    // Active: the ramp-up hold and the sweeps, not the final hold.
    assert!(tr.active[0] && tr.active[2000] && !tr.active[tr.len() - 1]);
    // Cruise lasts 35/30 − 0.05 s per sweep: count samples at |v| = 30.
    let cruise = tr.velocity_deg_s.iter().filter(|v| v.abs() == 30.0).count() as f64 / FS;
    assert!(
        close(cruise, 2.0 * (35.0 / 30.0 - 0.05), 2.0 / FS),
        "cruise {cruise}"
    );
}

#[test]
fn analytic_derivatives_match_finite_differences() {
    let tr = Protocol::Relaxed { cycles: 2 }.trace().unwrap();
    let dt = tr.dt();
    let mut max_v = 0.0f64;
    let mut max_x = 0.0f64;
    for i in 1..tr.len() {
        // Trapezoidal integration of velocity reproduces the angle step exactly in cruise/hold
        // and to O(a·dt²) in the ramps.
        let dx = tr.angle_deg[i] - tr.angle_deg[i - 1];
        let vint = 0.5 * (tr.velocity_deg_s[i] + tr.velocity_deg_s[i - 1]) * dt;
        max_x = max_x.max((dx - vint).abs());
        let dv = tr.velocity_deg_s[i] - tr.velocity_deg_s[i - 1];
        let aint = 0.5 * (tr.acceleration_deg_s2[i] + tr.acceleration_deg_s2[i - 1]) * dt;
        max_v = max_v.max((dv - aint).abs());
    }
    // Bounds: position error ≤ a·dt²/4, velocity error ≤ a·dt (at an acceleration jump).
    assert!(max_x <= 600.0 * dt * dt / 4.0 + 1e-12, "angle {max_x}");
    assert!(max_v <= 600.0 * dt + 1e-9, "velocity {max_v}");
}

#[test]
fn relaxed_protocol_structure_and_events() {
    let tr = Protocol::Relaxed { cycles: 2 }.trace().unwrap();
    let t1 = 0.5 + 2.0 * SWEEP + 0.5; // start of the first maximal cycle
    let total = t1 + 4.0 * SWEEP + 0.4;
    assert!(close(tr.duration_s(), total, 1e-12));
    let starts = &tr.events.starts;
    assert_eq!(starts.len(), 2);
    assert!(close(starts[0], 0.5, 1e-12) && close(starts[1], t1, 1e-12));
    let rev = &tr.events.reversals;
    let expect = [0.5 + SWEEP, t1 + SWEEP, t1 + 2.0 * SWEEP, t1 + 3.0 * SWEEP];
    assert_eq!(rev.len(), expect.len());
    for (a, b) in rev.iter().zip(expect) {
        assert!(close(*a, b, 1e-12), "{a} vs {b}");
    }
    assert_eq!(tr.events.stops.len(), 2);
    assert!(close(tr.events.stops[0], 0.5 + 2.0 * SWEEP, 1e-12));
    assert!(close(tr.events.stops[1], t1 + 4.0 * SWEEP, 1e-12));
    assert_eq!(tr.events.all().len(), 8);
    // The relaxed cycle is inactive, the hold before the maximal cycles active.
    let at = |t: f64| (t * FS).round() as usize;
    assert!(!tr.active[at(0.2)] && !tr.active[at(1.0)] && !tr.active[at(2.5)]);
    assert!(tr.active[at(t1 - 0.2)] && tr.active[at(t1 + 1.0)] && tr.active[at(t1 + 4.0)]);
    assert!(!tr.active[tr.len() - 1]);
    // Segments: hold, C, E, hold, C, E, C, E, hold; contiguous.
    let phases: Vec<MotionPhase> = tr.segments.iter().map(|s| s.phase).collect();
    use MotionPhase::{Concentric as C, Eccentric as E, Hold as H};
    assert_eq!(phases, vec![H, C, E, H, C, E, C, E, H]);
    for w in tr.segments.windows(2) {
        assert_eq!(w[0].end_s, w[1].start_s);
    }
    let cycles: Vec<Option<usize>> = tr.segments.iter().map(|s| s.cycle).collect();
    assert_eq!(
        cycles,
        vec![
            None,
            Some(0),
            Some(0),
            None,
            Some(1),
            Some(1),
            Some(2),
            Some(2),
            None
        ]
    );
}

#[test]
fn unloaded_motion_is_three_back_to_back_cycles() {
    let tr = Protocol::unloaded().trace().unwrap();
    assert!(close(tr.duration_s(), 0.5 + 6.0 * SWEEP + 0.4, 1e-12));
    assert_eq!(tr.events.starts, vec![0.5]);
    assert_eq!(tr.events.reversals.len(), 5);
    assert_eq!(tr.events.stops.len(), 1);
    // At the reversal at +15° between cycles the velocity passes through zero.
    let k = (tr.events.reversals[1] * FS).round() as usize;
    assert!(tr.velocity_deg_s[k].abs() < 600.0 / FS + 1e-12);
    assert!(close(tr.angle_deg[k], 15.0, 1e-3));
}

#[test]
fn protocol_strings_parse_and_print() {
    assert_eq!("seed".parse::<Protocol>().unwrap(), Protocol::Seed);
    assert_eq!(
        "relaxed+2".parse::<Protocol>().unwrap(),
        Protocol::Relaxed { cycles: 2 }
    );
    assert_eq!(
        " cycles+3 ".parse::<Protocol>().unwrap(),
        Protocol::unloaded()
    );
    for p in [
        Protocol::Seed,
        Protocol::Relaxed { cycles: 7 },
        Protocol::Cycles { cycles: 3 },
    ] {
        assert_eq!(p.to_string().parse::<Protocol>().unwrap(), p);
    }
    for bad in [
        "",
        "Seed",
        "relaxed",
        "relaxed+",
        "relaxed+0",
        "relaxed+x",
        "relaxed+101",
        "walk+2",
        "relaxed+-1",
    ] {
        let e = bad.parse::<Protocol>().unwrap_err();
        assert_eq!(e.kind(), ErrorKind::InvalidProtocol, "{bad}");
        assert!(e.to_string().starts_with("invalid protocol: "), "{e}");
    }
    assert_eq!(
        Protocol::Cycles { cycles: 0 }.trace().unwrap_err().kind(),
        ErrorKind::InvalidProtocol
    );
}

#[test]
fn motion_settings_are_validated() {
    let m = MotionSettings {
        ramp_s: 2.0,
        ..MotionSettings::default()
    };
    assert_eq!(
        Protocol::Seed.trace_with(&m).unwrap_err().kind(),
        ErrorKind::InvalidSettings
    );
    let m = MotionSettings {
        sample_rate_hz: f64::NAN,
        ..MotionSettings::default()
    };
    assert!(Protocol::Seed.trace_with(&m).is_err());
    // A different rate changes only the sampling.
    let m = MotionSettings {
        sample_rate_hz: 1000.0,
        ..MotionSettings::default()
    };
    let tr = Protocol::Seed.trace_with(&m).unwrap();
    assert_eq!(
        tr.len(),
        ((0.9 + 2.0 * SWEEP) * 1000.0).floor() as usize + 1
    );
}
