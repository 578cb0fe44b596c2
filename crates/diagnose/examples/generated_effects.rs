//! Diagnoses trials hiding effects drawn by `diagnose::scenarios::generated_trial` (shapes
//! outside the catalogue: smooth, stepped and periodic functions of one state variable,
//! products of two, an EMG gain that changes mid-trial), one line per trial, then the rates
//! with 95 % Wilson intervals:
//!
//! * **misnamed**: a catalogued cause was named (none is hidden);
//! * **false story**: a misnamed trial whose named causes do not account for the effect: the
//!   baseline with those causes, fitted to the noise-free torque, leaves a whitened misfit
//!   `λ ≥ 3.84` ([`diagnose::power::noncentrality`] under the true noise). At `λ = 3.84` (the
//!   95 % point of χ²₁) even a test that knew the remainder's exact shape would find it at 5 %
//!   only half the time; below it, on this protocol, the effect *is* the named cause (a smooth
//!   function of the velocity on a trial with three velocities is a damping and an offset);
//! * **flagged**: the verdict is not `adequate`;
//! * **depends_on right**: of the flagged trials with `unexplained`, those whose `depends_on`
//!   is led by a variable the effect lives in;
//! * **failed**: the diagnosis returned an error (such a trial is in no other count).
//!
//! `cargo run --release -p diagnose --example generated_effects -- TRIALS BASE [--at-detection F,…]`
//! (trial `i` has seed `BASE + i`; draw BASE afresh for a measurement).
//!
//! `SURAE_SHOW_SUMMARY=1` prints the diagnosis's summary under each trial;
//! `SURAE_SHOW_RANKING=1` prints, under each trial, the flexible terms' ranking behind
//! `depends_on` (held-out RMS and its fall, held-out deviance gain, ΔBIC, coefficients).
//!
//! With `--at-detection F,…` each torque disturbance is diagnosed at each factor `F` times its
//! detection size (one table per factor), and the EMG-gain trials are skipped. The detection size is
//! that of the catalogued limits for a term of exactly the disturbance's shape, in the same
//! subject and noise without it ([`disturbance_detection_size`]).

use diagnose::power::{disturbance_detection_size, noncentrality, true_noise, wilson_interval};
use diagnose::scenarios::generated_trial;
use diagnose::{no_observer, DiagnoseSettings, Verdict};
use experiment::DynamometerSettings;
use muscle_model::EffectKind;
use std::collections::BTreeMap;

/// The 95 % point of χ²₁: a remainder with a smaller noncentrality is found, at a 5 % false
/// alarm rate, less than half the time by a test that knows its exact shape.
const UNDETECTABLE_LAMBDA: f64 = 3.84;

#[derive(Default)]
struct Tally {
    trials: usize,
    misnamed: usize,
    false_story: usize,
    flagged: usize,
    with_unexplained: usize,
    depends_right: usize,
    failed: usize,
}

fn rate(k: usize, n: usize) -> String {
    if n == 0 {
        return "-".into();
    }
    let (lo, hi) = wilson_interval(k, n, 0.05);
    format!(
        "{k}/{n} = {:.0} % [{:.0}, {:.0}]",
        100.0 * k as f64 / n as f64,
        100.0 * lo,
        100.0 * hi
    )
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let trials: u64 = args.first().map_or(Ok(20), |s| s.parse())?;
    let base: u64 = args.get(1).map_or(Ok(9_100_000), |s| s.parse())?;
    // the sizes diagnosed: as drawn (`None`), or these multiples of the detection size
    let factors: Vec<Option<f64>> = match args.get(2).map(String::as_str) {
        None => vec![None],
        Some("--at-detection") => args
            .get(3)
            .ok_or("--at-detection needs factors, such as 2 or 2,4,8")?
            .split(',')
            .map(|f| f.parse().map(Some))
            .collect::<Result<_, _>>()?,
        Some(other) => return Err(format!("unknown argument {other}").into()),
    };
    let settings = DiagnoseSettings::default();
    let mut tallies: Vec<(Tally, BTreeMap<String, Tally>)> = factors
        .iter()
        .map(|_| (Tally::default(), BTreeMap::new()))
        .collect();
    for i in 0..trials {
        let seed = base + i;
        let drawn = generated_trial(seed)?;
        let noise = true_noise(
            &DynamometerSettings::default(),
            drawn.hidden.synthetic.trial.sample_rate_hz(),
        )?;
        // the detection size in the same subject and noise without the disturbance
        let mut without = drawn.hidden.synthetic.trial.clone();
        let detection = match (&factors[0], &drawn.disturbance_nm) {
            (None, _) => None,
            (Some(_), None) => continue,
            (Some(_), Some(d)) => {
                for (y, a) in without.torque_nm.iter_mut().zip(d) {
                    *y -= a;
                }
                Some(disturbance_detection_size(
                    &without,
                    Some(&drawn.hidden.synthetic.unloaded),
                    d,
                    &settings,
                )?)
            }
        };
        for (factor, (all, by_family)) in factors.iter().zip(tallies.iter_mut()) {
            let mut trial = drawn.hidden.synthetic.trial.clone();
            let mut scaled = String::new();
            let mut ratio = 1.0;
            if let (Some(f), Some(det), Some(d)) = (factor, detection, &drawn.disturbance_nm) {
                ratio = f * det / drawn.size.abs();
                trial.torque_nm = without
                    .torque_nm
                    .iter()
                    .zip(d)
                    .map(|(y, a)| y + a * ratio)
                    .collect();
                scaled = format!(" [detection {det:.2} N·m, ×{f} = {:.2}]", f * det);
            }
            let t = &drawn;
            // a diagnosis that fails is a result of the study, not the end of it
            let d = match diagnose::run(
                &trial,
                Some(&t.hidden.synthetic.unloaded),
                &settings,
                &mut no_observer,
            ) {
                Ok(d) => d,
                Err(e) => {
                    println!(
                        "{seed} {:<22} {:<52}{scaled} FAILED: {e}",
                        t.effect.family(),
                        t.description
                    );
                    all.failed += 1;
                    by_family.entry(t.effect.family()).or_default().failed += 1;
                    continue;
                }
            };
            let flagged = d.verdict != Verdict::Adequate;
            let depends: Vec<&str> = d
                .unexplained
                .as_ref()
                .map(|u| u.depends_on.iter().map(|v| v.name()).collect())
                .unwrap_or_default();
            let right = d
                .unexplained
                .as_ref()
                .and_then(|u| u.depends_on.first())
                .is_some_and(|v| t.effect.lives_in(*v));
            // do the named causes account for the effect? (module docs, "false story")
            let story = if d.causes.is_empty() {
                None
            } else {
                let kinds: Vec<EffectKind> = d
                    .causes
                    .iter()
                    .filter_map(|c| EffectKind::from_name(c))
                    .collect();
                let clean = clean_torque(t, ratio);
                let alone = noncentrality(&trial, &clean, &[], &noise, &settings)?.lambda;
                let named = noncentrality(&trial, &clean, &kinds, &noise, &settings)?.lambda;
                Some((alone, named))
            };
            let story_words = story.map_or(String::new(), |(alone, named)| {
                format!(
                    " λ {alone:.1} → {named:.1} with the causes{}",
                    if named >= UNDETECTABLE_LAMBDA {
                        " (false story)"
                    } else {
                        " (the effect is the causes here)"
                    }
                )
            });
            println!(
                "{seed} {:<22} {:<52}{scaled} {:<10} causes {:?} depends_on {:?}{}{story_words}",
                t.effect.family(),
                t.description,
                format!("{:?}", d.verdict),
                d.causes,
                depends,
                if d.unexplained.is_some() && !right {
                    " (wrong variable)"
                } else {
                    ""
                }
            );
            // SURAE_SHOW_SUMMARY=1: the diagnosis's own summary
            if std::env::var_os("SURAE_SHOW_SUMMARY").is_some() {
                for line in d.summary_lines() {
                    println!("    | {line}");
                }
            }
            // SURAE_SHOW_RANKING=1: the vocabulary's ranking behind `depends_on`
            if std::env::var_os("SURAE_SHOW_RANKING").is_some() {
                for g in d.unexplained.iter().flat_map(|u| &u.ranking) {
                    println!(
                        "    {:<12} held-out RMS {:.3} N·m (−{:>5.1} %)  deviance gain {:>8.1}  ΔBIC {:>8.1}  {} coefficients{}",
                        g.variable.name(),
                        g.heldout_rms_nm,
                        g.heldout_rms_reduction_pct,
                        g.heldout_deviance_gain,
                        g.delta_bic,
                        g.parameters,
                        if g.by_direction { ", by direction" } else { "" }
                    );
                }
            }
            let family = t.effect.family();
            for tally in [&mut *all, by_family.entry(family).or_default()] {
                tally.trials += 1;
                tally.misnamed += usize::from(!d.causes.is_empty());
                tally.false_story +=
                    usize::from(story.is_some_and(|(_, named)| named >= UNDETECTABLE_LAMBDA));
                tally.flagged += usize::from(flagged);
                if flagged && d.unexplained.is_some() {
                    tally.with_unexplained += 1;
                    tally.depends_right += usize::from(right);
                }
            }
        }
    }
    for (factor, (all, by_family)) in factors.iter().zip(&tallies) {
        match factor {
            Some(f) => println!("\nat {f} × the detection size"),
            None => println!("\nat the drawn sizes"),
        }
        println!("family | trials | misnamed | false story | flagged | depends_on right | failed");
        for (name, t) in by_family.iter().chain([(&"all".to_string(), all)]) {
            println!(
                "{name} | {} | {} | {} | {} | {} | {}",
                t.trials,
                rate(t.misnamed, t.trials),
                rate(t.false_story, t.trials),
                rate(t.flagged, t.trials),
                rate(t.depends_right, t.with_unexplained),
                t.failed
            );
        }
    }
    Ok(())
}

/// The noise-free torque of `t`'s true model, its torque disturbance scaled by `ratio`. An
/// EMG gain changes the recorded EMG, not the torque the true model made from the EMG the
/// muscles had.
fn clean_torque(t: &diagnose::scenarios::GeneratedTrial, ratio: f64) -> Vec<f64> {
    let m = &t.hidden.synthetic.model_torque;
    match &t.disturbance_nm {
        Some(d) => m.iter().zip(d).map(|(m, a)| m + a * ratio).collect(),
        None => m.clone(),
    }
}
