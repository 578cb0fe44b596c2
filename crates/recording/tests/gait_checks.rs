//! The checks of a gait trial: what the trial is, which checks apply, and the per-stride
//! checks on synthetic walking with planted bad strides (a foot on both belts, an impact
//! spike, a moment in swing, a force blip); an impact spike that the EMG shows too is not
//! flagged.

use std::f64::consts::PI;

use experiment::Trial;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use recording::checks::{
    check_trial_in_context, CheckSettings, GaitCheck, TrialChecks, TrialContext, TrialKind,
};

const FS: f64 = 100.0;

/// A standard normal draw (Box–Muller).
fn gauss(rng: &mut ChaCha8Rng) -> f64 {
    let u1: f64 = rng.random::<f64>().max(1e-300);
    let u2: f64 = rng.random();
    (-2.0 * u1.ln()).sqrt() * (2.0 * PI * u2).cos()
}

/// A walking trial at 100 Hz: `strides` cycles of about 1.1 s (sd 1.5 %), 64 % stance, the
/// first beginning 0.35 s in; an M-shaped vertical force of about 600 N, a heel-strike
/// dorsiflexion dip and an 80 N·m push-off moment, smooth envelopes peaking at push-off.
struct Walk {
    trial: Trial,
    grf: Vec<f64>,
    /// The first sample of each stance.
    stance_starts: Vec<usize>,
    /// The first sample of each swing.
    swing_starts: Vec<usize>,
}

fn walk(strides: usize, seed: u64) -> Walk {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut bounds = Vec::new(); // (stance start, swing start, end) in seconds
    let mut t = 0.35;
    let mut gains = Vec::new();
    for _ in 0..strides {
        let d = 1.1 * (1.0 + 0.015 * gauss(&mut rng));
        let stance = d * 0.64 * (1.0 + 0.01 * gauss(&mut rng));
        bounds.push((t, t + stance, t + d));
        gains.push((1.0 + 0.03 * gauss(&mut rng), 1.0 + 0.04 * gauss(&mut rng)));
        t += d;
    }
    let n = ((t + 0.5) * FS) as usize;
    let mut time = Vec::with_capacity(n);
    let (mut grf, mut tq, mut ang) = (vec![0.0; n], vec![0.0; n], vec![0.0; n]);
    // envelopes at rest: 0.05 with a little noise (a flat floor would read as clipped)
    let mut env: Vec<Vec<f64>> = (0..3)
        .map(|_| {
            (0..n)
                .map(|_| 0.05 + 0.002 * gauss(&mut rng).abs())
                .collect()
        })
        .collect();
    for i in 0..n {
        let ti = i as f64 / FS;
        time.push(ti);
        let Some(k) = bounds.iter().position(|b| ti >= b.0 && ti < b.2) else {
            tq[i] = 0.3 * gauss(&mut rng);
            continue;
        };
        let (a, b, c) = bounds[k];
        let phi = (ti - a) / (c - a);
        ang[i] = 5.0 * (2.0 * PI * phi).sin() - 15.0 * (-((phi - 0.62) / 0.06).powi(2)).exp();
        if ti < b {
            let p = (ti - a) / (b - a);
            grf[i] = 600.0 * gains[k].0 * ((PI * p).sin() + 0.25 * (3.0 * PI * p).sin());
            let dip = if p < 0.12 {
                -6.0 * (PI * p / 0.12).sin()
            } else {
                0.0
            };
            tq[i] = dip
                + 80.0 * gains[k].1 * (-((p - 0.72) / 0.14).powi(2)).exp() * (PI * p).sin()
                + 0.3 * gauss(&mut rng);
            for (m, e) in env.iter_mut().enumerate() {
                e[i] += (0.6 - 0.1 * m as f64) * (-((p - 0.65) / 0.18).powi(2)).exp();
            }
        } else {
            tq[i] = 0.3 * gauss(&mut rng);
        }
    }
    let sample = |s: f64| (s * FS).ceil() as usize;
    Walk {
        trial: Trial {
            time_s: time,
            ankle_angle_deg: ang,
            torque_nm: tq,
            emg_sol: env[0].clone(),
            emg_gm: env[1].clone(),
            emg_gl: env[2].clone(),
            ..Trial::default()
        },
        grf,
        stance_starts: bounds.iter().map(|b| sample(b.0)).collect(),
        swing_starts: bounds.iter().map(|b| sample(b.1)).collect(),
    }
}

/// The other foot on this belt from when stance `k` unloads below 70 N until stance `k + 1`
/// loads past it: the force never falls below the threshold between them.
fn both_belts(w: &mut Walk, k: usize) {
    let mut i = w.swing_starts[k];
    while w.grf[i - 1] < 70.0 {
        i -= 1;
    }
    while i < w.stance_starts[k + 1] || w.grf[i] < 70.0 {
        w.grf[i] = w.grf[i].max(70.0);
        i += 1;
    }
}

/// The walk's trial with `grf` as its ground force.
fn with_force(w: &Walk, grf: Option<&[f64]>) -> Trial {
    Trial {
        grf_vertical_n: grf.map(<[f64]>::to_vec),
        ..w.trial.clone()
    }
}

/// The checks of the walk with its force, its EMG taken as envelopes.
fn checks(w: &Walk) -> TrialChecks {
    check_trial_in_context(
        &with_force(w, Some(&w.grf)),
        None,
        &TrialContext {
            emg_is_envelope: true,
            ..TrialContext::default()
        },
        &CheckSettings::default(),
    )
}

fn gait(c: &TrialChecks) -> &GaitCheck {
    c.strides.as_ref().expect("a gait trial's stride check")
}

/// The detected stride holding sample `i`.
fn stride_at(g: &GaitCheck, i: usize) -> usize {
    g.cycles
        .iter()
        .position(|s| s.start <= i && i < s.end)
        .unwrap()
}

/// `(stride, measures)` of every flagged stride.
fn flagged(g: &GaitCheck) -> Vec<(usize, Vec<&'static str>)> {
    g.flagged
        .iter()
        .map(|f| (f.stride, f.reasons.iter().map(|r| r.measure).collect()))
        .collect()
}

#[test]
fn a_clean_walk_is_gait_with_no_flagged_stride() {
    let w = walk(40, 1);
    let c = checks(&w);
    assert_eq!(c.kind, TrialKind::Gait);
    assert!(
        c.kind_reason.contains("ground reaction force"),
        "{}",
        c.kind_reason
    );
    assert!(c.motion.is_none(), "no isokinetic check for gait");
    let g = gait(&c);
    assert_eq!(g.strides, 39, "40 stances: 39 strides");
    assert!(g.compared && g.error.is_none());
    assert!(g.flagged.is_empty(), "{:#?}", g.flagged);
    assert!(c.is_clean(), "{:#?}", c.warnings);
    assert!((g.median_stride_s.unwrap() - 1.1).abs() < 0.03);
    assert!((g.median_stance_s.unwrap() - 0.70).abs() < 0.03);
    // The applied checks: no isokinetic, EMG rate or power line (envelopes).
    assert_eq!(
        c.applied,
        vec!["angle", "strides", "saturation", "emg_flat"]
    );
    assert_eq!(
        c.applied_text(),
        "angle range, strides, saturation, flat EMG"
    );
    let lines = c.summary_lines();
    assert!(
        lines.iter().any(|l| l.starts_with("trial: gait (")),
        "{lines:#?}"
    );
    assert!(
        lines.iter().any(|l| l.starts_with(
            "strides: 39 from the ground force (stance above 20 N): median stride 1.1"
        ) && l.ends_with("none flagged")),
        "{lines:#?}"
    );
    assert!(
        !lines
            .iter()
            .any(|l| l.contains("isokinetic") || l.contains("plateau")),
        "{lines:#?}"
    );
    assert!(lines
        .iter()
        .any(|l| l
            .starts_with("emg: 3 envelope channels (none flat; rate and power line not checked)")));
    let v = serde_json::to_value(&c).unwrap();
    assert_eq!(v["kind"], "gait");
    assert!(v["motion"].is_null());
    assert_eq!(v["strides"]["strides"], 39);
    assert_eq!(v["strides"]["measures"].as_array().unwrap().len(), 39);
    assert!(v["strides"]["flagged"].as_array().unwrap().is_empty());
    assert!(v["emg"][0]["power_line_ratio"].is_null());
    assert!(v["strides"].get("cycles").is_none());
}

#[test]
fn raw_emg_at_100_hz_keeps_the_rate_warning_and_an_envelope_does_not() {
    let w = walk(12, 2);
    let raw = check_trial_in_context(
        &with_force(&w, Some(&w.grf)),
        None,
        &TrialContext::default(),
        &CheckSettings::default(),
    );
    assert!(
        raw.warnings
            .iter()
            .any(|w| w.starts_with("time_s: sampled at 100 Hz, below the 700 Hz")),
        "{:#?}",
        raw.warnings
    );
    assert!(raw.applied.contains(&"power_line"));
    let env = checks(&w);
    assert!(
        !env.warnings.iter().any(|w| w.contains("700 Hz")),
        "{:#?}",
        env.warnings
    );
}

#[test]
fn a_foot_on_both_belts_is_flagged_by_its_stance_and_stride() {
    let mut w = walk(40, 3);
    // The other foot on this belt through the swings after stances 10, 25 and 30: the force
    // stays at 70 N, each two stances read as one.
    let mut planted = Vec::new();
    for k in [10, 25, 30] {
        both_belts(&mut w, k);
        planted.push(w.stance_starts[k] + 5);
    }
    let c = checks(&w);
    let g = gait(&c);
    assert_eq!(g.strides, 36);
    let want: Vec<usize> = planted.iter().map(|&i| stride_at(g, i)).collect();
    let got = flagged(g);
    assert_eq!(
        got.iter().map(|f| f.0).collect::<Vec<_>>(),
        want,
        "{:#?}",
        g.flagged
    );
    for (_, measures) in &got {
        assert_eq!(measures, &vec!["duration_s", "stance_s"]);
    }
    let f = &g.flagged[0];
    assert!((f.end_s - f.start_s - 2.2).abs() < 0.1, "{f:?}");
    assert!(
        f.reasons[1].text.contains("the other foot on this belt?"),
        "{f:?}"
    );
    assert!(f.reasons[0].robust_z.unwrap() > 10.0);
    // one warning per flagged stride, naming it and its times
    let lines: Vec<&String> = c
        .warnings
        .iter()
        .filter(|w| w.starts_with("stride "))
        .collect();
    assert_eq!(lines.len(), 3, "{:#?}", c.warnings);
    assert!(
        lines[0].starts_with(&format!("stride {} (", want[0])),
        "{lines:?}"
    );
    // excluded on request: the flagged strides are not in the kept mask
    let (strides, keep) = g.strides_kept();
    assert_eq!(keep.iter().filter(|k| !**k).count(), 3);
    let mask = strides.mask_of(&keep, w.trial.len());
    assert!(!mask[planted[0]] && mask[w.stance_starts[5] + 5]);
}

#[test]
fn an_impact_spike_is_flagged_unless_the_emg_jumps_with_it() {
    let mut w = walk(30, 4);
    let spike = w.stance_starts[12] + 4;
    let burst = w.stance_starts[20] + 4;
    for i in [spike, spike + 1, burst, burst + 1] {
        w.trial.torque_nm[i] += 35.0;
    }
    // at the burst every envelope jumps too: a real contraction
    for e in [
        &mut w.trial.emg_sol,
        &mut w.trial.emg_gm,
        &mut w.trial.emg_gl,
    ] {
        for x in &mut e[burst..burst + 2] {
            *x += 0.8;
        }
    }
    let c = checks(&w);
    let g = gait(&c);
    assert_eq!(
        flagged(g),
        vec![(stride_at(g, spike), vec!["moment_jump_nm_s"])],
        "{:#?}",
        g.flagged
    );
    let r = &g.flagged[0].reasons[0];
    assert!(
        r.value > 3000.0 && r.text.contains("no EMG envelope jumps"),
        "{r:?}"
    );
    // without the EMG's jump the burst's stride is flagged as well
    let mut w2 = walk(30, 4);
    for i in [spike, spike + 1, burst, burst + 1] {
        w2.trial.torque_nm[i] += 35.0;
    }
    let g2 = checks(&w2);
    let ids: Vec<usize> = flagged(gait(&g2)).into_iter().map(|f| f.0).collect();
    assert_eq!(
        ids,
        vec![stride_at(gait(&g2), spike), stride_at(gait(&g2), burst)]
    );
}

#[test]
fn a_moment_in_swing_is_flagged() {
    let mut w = walk(30, 5);
    // a smooth 25 N·m bump in the swing of stride 8: the force of the other foot on this one
    let a = w.swing_starts[8] + 5;
    for j in 0..15 {
        w.trial.torque_nm[a + j] += 25.0 * (PI * j as f64 / 14.0).sin().powi(2);
    }
    let c = checks(&w);
    let g = gait(&c);
    assert_eq!(
        flagged(g),
        vec![(stride_at(g, a), vec!["swing_moment_nm"])],
        "{:#?}",
        g.flagged
    );
    assert!(g.flagged[0].reasons[0]
        .text
        .contains("in swing, the foot off the ground"));
}

#[test]
fn a_force_blip_makes_a_stride_too_short() {
    let mut w = walk(30, 6);
    // 30 ms above the threshold 0.15 s before stance 15's strike
    let b = w.stance_starts[15] - 15;
    for x in &mut w.grf[b..b + 3] {
        *x = 100.0;
    }
    let c = checks(&w);
    let g = gait(&c);
    let short = stride_at(g, b);
    let got = flagged(g);
    assert!(got.contains(&(short, vec!["too_short"])), "{got:?}");
    // the stride the blip cut is flagged too, as short against the others
    assert!(got.contains(&(short - 1, vec!["duration_s"])), "{got:?}");
    assert_eq!(got.len(), 2, "{got:?}");
    assert!(g
        .flagged
        .iter()
        .any(|f| f.reasons[0].text.contains("shorter than the 0.2 s")));
}

#[test]
fn many_flagged_strides_are_summarised() {
    let mut w = walk(40, 7);
    for k in (2..38).step_by(4) {
        both_belts(&mut w, k);
    }
    let c = checks(&w);
    let g = gait(&c);
    assert_eq!(g.flagged.len(), 9, "{:#?}", flagged(g));
    let stride_lines = c
        .warnings
        .iter()
        .filter(|w| w.starts_with("stride "))
        .count();
    assert_eq!(stride_lines, 5);
    assert!(
        c.warnings
            .iter()
            .any(|w| w.starts_with("and 4 more of the 30 strides flagged")),
        "{:#?}",
        c.warnings
    );
    let line = c
        .summary_lines()
        .into_iter()
        .find(|l| l.starts_with("strides:"))
        .unwrap();
    assert!(
        line.contains("9 flagged: ") && line.contains("(1 more)"),
        "{line}"
    );
    // no line of the summary is long
    assert!(
        c.summary_lines().iter().all(|l| l.chars().count() < 160),
        "{:#?}",
        c.summary_lines()
    );
}

#[test]
fn no_stride_and_too_few_strides_are_warnings_not_errors() {
    let w = walk(3, 8);
    let c = checks(&w);
    let g = gait(&c);
    assert!(!g.compared && g.flagged.is_empty());
    assert!(
        c.warnings.iter().any(|x| x.contains("too few to compare")),
        "{:#?}",
        c.warnings
    );
    let flat = vec![0.0; w.trial.len()];
    let c = check_trial_in_context(
        &with_force(&w, Some(&flat)),
        None,
        &TrialContext {
            emg_is_envelope: true,
            ..TrialContext::default()
        },
        &CheckSettings::default(),
    );
    assert!(gait(&c).error.as_ref().unwrap().contains("no foot strike"));
    assert!(
        c.warnings
            .iter()
            .any(|x| x.starts_with("invalid grf_vertical_n: no foot strike")),
        "{:#?}",
        c.warnings
    );
    let mut nan = w.grf.clone();
    nan[40] = f64::NAN;
    let short = &w.grf[..100];
    for f in [&nan[..], short] {
        let c = check_trial_in_context(
            &with_force(&w, Some(f)),
            None,
            &TrialContext {
                emg_is_envelope: true,
                ..TrialContext::default()
            },
            &CheckSettings::default(),
        );
        assert!(gait(&c).error.is_some(), "{:#?}", c.strides);
        serde_json::to_string(&c).unwrap();
    }
}

#[test]
fn a_given_kind_overrides_the_inference() {
    let w = walk(12, 9);
    let c = check_trial_in_context(
        &with_force(&w, Some(&w.grf)),
        None,
        &TrialContext {
            kind: Some(TrialKind::Dynamometer),
            emg_is_envelope: true,
        },
        &CheckSettings::default(),
    );
    assert_eq!(c.kind, TrialKind::Dynamometer);
    assert_eq!(c.kind_reason, "given by the caller");
    assert!(c.motion.is_some() && c.strides.is_none());
    // gait given without a force: no stride check, said so
    let c = check_trial_in_context(
        &with_force(&w, None),
        None,
        &TrialContext {
            kind: Some(TrialKind::Gait),
            emg_is_envelope: true,
        },
        &CheckSettings::default(),
    );
    assert!(c.motion.is_none() && c.strides.is_none());
    assert!(c
        .summary_lines()
        .iter()
        .any(|l| l.contains("strides: not checked (no ground force)")));
}
