//! How often the diagnosis itself names an effect hidden at (a multiple of) the detection limit
//! it reported for the same subject (`candidates[].detection_limit`).
//!
//! `cargo run --release -p diagnose --example limit_rule -- N BASE_SEED [--factor F | --factor-range LO HI] [--effects a,b,…]`
//!
//! For `i < N`, subject `BASE_SEED + i`:
//!
//! 1. its no-effect trial (relaxed+2 with `emg_ta`, so that every effect is eligible:
//!    `scenarios::hidden_trial(&[], true, seed)`) is diagnosed; a *false alarm* is a cause
//!    named or unexplained structure flagged;
//! 2. for each listed effect (all by default), the limit `L` that diagnosis reports is hidden
//!    at `F·L` in the same subject and noise (`scenarios::hidden_trial_sized`, same seed: the
//!    same muscle parameters and dynamometer noise record; gravity's phase and the passive
//!    torque's stiffness are drawn as in the scenarios, φ ∈ ±30°, k ∈ 5–15/rad), and that trial
//!    is diagnosed. A *hit* is the named causes being exactly that effect. With
//!    `--factor-range LO HI`, `F` is drawn uniformly in `[LO, HI]` per subject and effect
//!    (ChaCha8 seeded from the subject's seed and the effect).
//!
//! It prints one line per diagnosis and then, per effect and pooled, the hits out of the
//! trials with a Wilson 95 % interval, and the false alarms of step 1 with theirs.
use std::io::Write;
use std::time::Instant;

use diagnose::power::wilson_interval;
use diagnose::scenarios::{hidden_trial, hidden_trial_sized};
use diagnose::{no_observer, run, DiagnoseSettings};
use muscle_model::EffectKind;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

fn rate(k: usize, n: usize) -> String {
    let (lo, hi) = wilson_interval(k, n, 0.05);
    format!("{k}/{n} [{lo:.2}, {hi:.2}]")
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let usage = "usage: N BASE_SEED [--factor F | --factor-range LO HI] [--effects a,b]";
    let n: u64 = args.first().ok_or(usage)?.parse()?;
    let base: u64 = args.get(1).ok_or(usage)?.parse()?;
    let value = |flag: &str, k: usize| -> Result<Option<f64>, Box<dyn std::error::Error>> {
        match args.iter().position(|a| a == flag) {
            Some(i) => Ok(Some(
                args.get(i + k)
                    .ok_or(format!("{flag} needs a value"))?
                    .parse()?,
            )),
            None => Ok(None),
        }
    };
    let factor = value("--factor", 1)?.unwrap_or(1.0);
    let range = match (value("--factor-range", 1)?, value("--factor-range", 2)?) {
        (Some(lo), Some(hi)) if lo <= hi => Some((lo, hi)),
        (None, None) => None,
        _ => return Err("--factor-range needs LO HI with LO ≤ HI".into()),
    };
    let kinds: Vec<EffectKind> = match args.iter().position(|a| a == "--effects") {
        Some(i) => args
            .get(i + 1)
            .ok_or("--effects needs a list")?
            .split(',')
            .map(|s| EffectKind::from_name(s).ok_or(format!("unknown effect {s}")))
            .collect::<Result<_, _>>()?,
        None => EffectKind::ALL.to_vec(),
    };
    let settings = DiagnoseSettings::default();
    let mut hits = vec![(0usize, 0usize); kinds.len()];
    let (mut alarms, mut nulls) = (0usize, 0usize);
    let t0 = Instant::now();
    let mut out = std::io::stdout();
    for i in 0..n {
        let seed = base + i;
        let t = hidden_trial(&[], true, seed)?;
        let d = run(
            &t.synthetic.trial,
            Some(&t.synthetic.unloaded),
            &settings,
            &mut no_observer,
        )?;
        nulls += 1;
        let alarm = !d.causes.is_empty() || d.unexplained_structure;
        alarms += usize::from(alarm);
        writeln!(
            out,
            "{seed} none: causes {:?}, structure {}{}",
            d.causes,
            d.unexplained_structure,
            if alarm { "  FALSE ALARM" } else { "" }
        )?;
        for (j, kind) in kinds.iter().enumerate() {
            let Some(limit) = d
                .candidates
                .iter()
                .find(|c| c.effect == kind.name())
                .and_then(|c| c.detection_limit)
            else {
                writeln!(out, "{seed} {}: no limit reported", kind.name())?;
                continue;
            };
            let f = match range {
                Some((lo, hi)) => {
                    let mut rng = ChaCha8Rng::seed_from_u64(seed ^ (0x5eed_0000 + *kind as u64));
                    lo + (hi - lo) * rng.random::<f64>()
                }
                None => factor,
            };
            let size = f * limit;
            let h = match hidden_trial_sized(*kind, size, seed) {
                Ok(h) => h,
                Err(e) => {
                    writeln!(out, "{seed} {}: size {size:.4} not drawn: {e}", kind.name())?;
                    continue;
                }
            };
            let dh = run(
                &h.synthetic.trial,
                Some(&h.synthetic.unloaded),
                &settings,
                &mut no_observer,
            )?;
            let ok = dh.causes == [kind.name().to_string()];
            // why a miss: the hidden effect's candidate (score evidence, ΔBIC of its refit,
            // fall of the held-out deviance)
            let why = dh
                .candidates
                .iter()
                .find(|c| c.effect == kind.name())
                .map(|c| {
                    format!(
                        "evidence {:.1}, ΔBIC {}, held-out dev gain {}",
                        c.evidence,
                        c.delta_bic.map_or("-".into(), |x| format!("{x:.1}")),
                        c.heldout_dev_gain.map_or("-".into(), |x| format!("{x:.1}"))
                    )
                })
                .unwrap_or_default();
            hits[j].1 += 1;
            hits[j].0 += usize::from(ok);
            writeln!(
                out,
                "{seed} {}: limit {limit:.4}, ×{f:.3} = {size:.4} (values {:?}): named {:?} {} ({why})",
                kind.name(),
                h.effects.values(*kind).unwrap_or_default(),
                dh.causes,
                if ok { "ok" } else { "MISS" }
            )?;
        }
        out.flush()?;
    }
    println!(
        "\nbase {base}, N {n}, factor {}, {:.0} s",
        range.map_or(format!("{factor}"), |(lo, hi)| format!("U[{lo}, {hi}]")),
        t0.elapsed().as_secs_f64()
    );
    println!("effect | named exactly | Wilson 95 %");
    let (mut k_all, mut n_all) = (0, 0);
    for (kind, (k, m)) in kinds.iter().zip(&hits) {
        k_all += k;
        n_all += m;
        println!("{} | {}", kind.name(), rate(*k, *m));
    }
    println!("all effects | {}", rate(k_all, n_all));
    println!("no effect: false alarms | {}", rate(alarms, nulls));
    Ok(())
}
