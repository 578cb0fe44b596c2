//! Diagnoses trials hiding effects outside the catalogue (`diagnose::scenarios::Uncatalogued`)
//! and prints one line per trial: what was hidden, the causes named, what the structure
//! depends on and the extension's held-out gain.
//!
//! `cargo run --release -p diagnose --example uncatalogued -- TRIALS BASE [EFFECT…]`
//! (trial `i` of effect slot `s` has seed `BASE + 1000·s + i`; effects by name, default all).

use diagnose::scenarios::{uncatalogued_trial, Uncatalogued};
use diagnose::{no_observer, DiagnoseSettings};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let trials: u64 = args.first().map_or(Ok(3), |s| s.parse())?;
    let base: u64 = args.get(1).map_or(Ok(7_100_000), |s| s.parse())?;
    let kinds: Vec<Uncatalogued> = if args.len() > 2 {
        args[2..]
            .iter()
            .map(|n| {
                Uncatalogued::ALL
                    .into_iter()
                    .find(|k| k.name() == n)
                    .ok_or_else(|| format!("unknown effect {n}"))
            })
            .collect::<Result<_, _>>()?
    } else {
        Uncatalogued::ALL.to_vec()
    };
    let settings = DiagnoseSettings::default();
    for (slot, kind) in Uncatalogued::ALL.iter().enumerate() {
        if !kinds.contains(kind) {
            continue;
        }
        for i in 0..trials {
            let seed = base + 1000 * slot as u64 + i;
            let t = uncatalogued_trial(*kind, seed)?;
            let s = &t.hidden.synthetic;
            let d = diagnose::run(&s.trial, Some(&s.unloaded), &settings, &mut no_observer)?;
            let (dep, gain, ranking) = match &d.unexplained {
                Some(u) => (
                    u.depends_on
                        .iter()
                        .map(|v| v.name())
                        .collect::<Vec<_>>()
                        .join("+"),
                    u.extension
                        .as_ref()
                        .map_or(f64::NAN, |e| e.heldout_rms_reduction_pct),
                    u.ranking
                        .iter()
                        .map(|r| format!("{} {:.0}", r.variable.name(), r.heldout_deviance_gain))
                        .collect::<Vec<_>>()
                        .join(", "),
                ),
                None => (String::new(), f64::NAN, String::new()),
            };
            let replaced: Vec<String> = d
                .unexplained
                .iter()
                .flat_map(|u| {
                    u.replaced
                        .iter()
                        .map(|r| format!("{}→{}", r.effect, r.variable.name()))
                })
                .collect();
            if std::env::var("SURAE_SHOW_TERMS").is_ok() {
                if let Some(e) = d.unexplained.as_ref().and_then(|u| u.extension.as_ref()) {
                    println!("{}", serde_json::to_string(&e.terms)?);
                }
            }
            let emg = d.emg_correction.as_ref().map_or(String::new(), |c| {
                format!(
                    " emg {} z {:.0} f̂ {:.3} {:.2}→{:.2} N·m ({:+.0})",
                    c.channels.join("+"),
                    d.emg_crosstalk.first().map_or(f64::NAN, |x| x.z),
                    d.emg_crosstalk.first().map_or(f64::NAN, |x| x.fraction),
                    c.heldout_rms_uncorrected_nm,
                    c.heldout_rms_nm,
                    c.heldout_deviance_gain
                )
            });
            println!(
                "{seed} {:<18} {:<44} causes {:?}{emg} structure p {:.1e} depends_on [{dep}] gain {gain:.1} % replaced {replaced:?} | {ranking} | {:.1} s",
                kind.name(),
                t.description,
                d.causes,
                d.residual_analysis.structure_p_value,
                d.wall_s
            );
        }
    }
    Ok(())
}
