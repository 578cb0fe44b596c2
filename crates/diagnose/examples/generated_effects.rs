//! Diagnoses trials hiding effects drawn by `diagnose::scenarios::generated_trial` (shapes
//! outside the catalogue: smooth, stepped and periodic functions of one state variable,
//! products of two, an EMG gain that changes mid-trial), one line per trial, then the rates
//! with 95 % Wilson intervals:
//!
//! * **misnamed**: a catalogued cause was named (none is hidden: every name is a false story);
//! * **flagged**: the verdict is not `adequate`;
//! * **depends_on right**: of the flagged trials with `unexplained`, those whose `depends_on`
//!   is led by a variable the effect lives in.
//!
//! `cargo run --release -p diagnose --example generated_effects -- TRIALS BASE`
//! (trial `i` has seed `BASE + i`; draw BASE afresh for a measurement).

use diagnose::power::wilson_interval;
use diagnose::scenarios::generated_trial;
use diagnose::{no_observer, DiagnoseSettings, Verdict};
use std::collections::BTreeMap;

#[derive(Default)]
struct Tally {
    trials: usize,
    misnamed: usize,
    flagged: usize,
    with_unexplained: usize,
    depends_right: usize,
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
    let settings = DiagnoseSettings::default();
    let mut all = Tally::default();
    let mut by_family: BTreeMap<String, Tally> = BTreeMap::new();
    for i in 0..trials {
        let seed = base + i;
        let t = generated_trial(seed)?;
        let s = &t.hidden.synthetic;
        let d = diagnose::run(&s.trial, Some(&s.unloaded), &settings, &mut no_observer)?;
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
        println!(
            "{seed} {:<22} {:<52} {:<10} causes {:?} depends_on {:?}{}",
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
        let family = t.effect.family();
        for tally in [&mut all, by_family.entry(family).or_default()] {
            tally.trials += 1;
            tally.misnamed += usize::from(!d.causes.is_empty());
            tally.flagged += usize::from(flagged);
            if flagged && d.unexplained.is_some() {
                tally.with_unexplained += 1;
                tally.depends_right += usize::from(right);
            }
        }
    }
    println!("\nfamily | trials | misnamed | flagged | depends_on right");
    for (name, t) in by_family.iter().chain([(&"all".to_string(), &all)]) {
        println!(
            "{name} | {} | {} | {} | {}",
            t.trials,
            rate(t.misnamed, t.trials),
            rate(t.flagged, t.trials),
            rate(t.depends_right, t.with_unexplained)
        );
    }
    Ok(())
}
