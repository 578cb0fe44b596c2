//! Confusion table and detection limits over random hidden-effect trials.
//!
//! `cargo run --release -p diagnose --example confusion -- [N] [BASE_SEED] [--above-limits] [--limits [--effects a,b:size] [--protocol P] [--null]] [--max-delta-bic X] [--exact-jacobian]`
//! prints, per scenario, how often the named causes equal the hidden ones, what was named
//! instead, the magnitude error, the time and how often the true effect parameters fall inside the
//! reported 68 % profile intervals (and within ±1 Laplace standard error), for the effect and
//! for the muscle parameters of the final model. `--above-limits` draws every hidden effect
//! at or above its documented detection limit (`diagnose::scenarios::draw_effect_above_limit`:
//! gravity 8–10 N·m, the antagonist 8–10 N·m, damping 4–8 N·m·s/rad, inertia 0.2–0.3 kg·m²;
//! the others over their whole realistic range), the trials on which the diagnosis claims to
//! name them. With `--limits`, the detection rate per effect
//! at sizes below and at the bottom of the realistic range (`--effects` keeps only the listed
//! effects, or with `:size` only that size; trial `i` of an effect uses seed `BASE_SEED + 1000·kind + i` at every size, so a
//! run split by `--effects` gives the same rows as one run). `--protocol relaxed+8` makes the
//! limit trials on another protocol (same seeds, parameters and effects); `--null` adds N
//! no-effect trials on it first (seed `BASE_SEED + i`, every odd one with `emg_ta`), counting
//! the trials where any cause was named. `SURAE_CONF_DUMP=FILE` appends
//! one JSON line per diagnosis (seed, hidden effects, causes, near ties, the candidates' ΔBIC
//! and held-out gains) to `FILE`.
use std::collections::BTreeMap;
use std::time::Instant;

use diagnose::scenarios::{
    align_to_fit, headline, hidden_trial, hidden_trial_above_limits, hidden_trial_on,
    hidden_trial_sized_on, limit_sizes,
};
use diagnose::{no_observer, run, DiagnoseSettings};
use experiment::Protocol;
use muscle_model::EffectKind;

/// Appends one JSON line per diagnosis to the file named by `SURAE_CONF_DUMP` (if set): the
/// seed, the hidden effects, the causes, the near ties and every refitted candidate's ΔBIC and
/// held-out gain, for studying the decision rule's margins offline.
fn dump(seed: u64, hidden: &[EffectKind], d: &diagnose::Diagnosis) -> std::io::Result<()> {
    use std::io::Write;
    let Ok(path) = std::env::var("SURAE_CONF_DUMP") else {
        return Ok(());
    };
    let cands: Vec<serde_json::Value> = d
        .candidates
        .iter()
        .map(|c| {
            serde_json::json!({"effect": c.effect, "delta_bic": c.delta_bic,
                "heldout_gain_pct": c.heldout_gain_pct,
                "heldout_dev_gain": c.heldout_dev_gain, "round": c.round,
                "accepted": c.accepted, "evidence": c.evidence})
        })
        .collect();
    let line = serde_json::json!({"seed": seed,
        "hidden": hidden.iter().map(|k| k.name()).collect::<Vec<_>>(),
        "causes": d.causes, "near_ties": d.near_ties, "candidates": cands,
        "wall_s": d.wall_s});
    let mut f = std::fs::OpenOptions::new()
        .create(true)
        .append(true)
        .open(path)?;
    writeln!(f, "{line}")
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().collect();
    let n: u64 = args.get(1).map_or(Ok(10), |s| s.parse())?;
    let base: u64 = args.get(2).map_or(Ok(10_000), |s| s.parse())?;
    let mut settings = DiagnoseSettings {
        exact_jacobian: args.iter().any(|a| a == "--exact-jacobian"),
        ..DiagnoseSettings::default()
    };
    if let Some(i) = args.iter().position(|a| a == "--max-delta-bic") {
        settings.max_delta_bic = args
            .get(i + 1)
            .ok_or("--max-delta-bic needs a value")?
            .parse()?;
    }
    if args.iter().any(|a| a == "--limits") {
        return limits(&args, n, base, &settings);
    }
    confusion_table(
        n,
        base,
        &settings,
        args.iter().any(|a| a == "--above-limits"),
    )
}

/// The detection rate per effect and size (`--limits`), after the no-effect trials with
/// `--null`.
fn limits(
    args: &[String],
    n: u64,
    base: u64,
    settings: &DiagnoseSettings,
) -> Result<(), Box<dyn std::error::Error>> {
    let sizes = limit_sizes();
    let only: Option<Vec<String>> = args
        .iter()
        .position(|a| a == "--effects")
        .and_then(|i| args.get(i + 1))
        .map(|s| s.split(',').map(str::to_string).collect());
    let protocol: Protocol = match args.iter().position(|a| a == "--protocol") {
        Some(i) => args
            .get(i + 1)
            .ok_or("--protocol needs a protocol")?
            .parse()?,
        None => "relaxed+2".parse()?,
    };
    let diagnose_trial = |t: &diagnose::scenarios::HiddenTrial| {
        run(
            &t.synthetic.trial,
            Some(&t.synthetic.unloaded),
            settings,
            &mut no_observer,
        )
    };
    if args.iter().any(|a| a == "--null") {
        let mut alarms = 0;
        for i in 0..n {
            let seed = base + i;
            let d = diagnose_trial(&hidden_trial_on(&[], i % 2 == 1, seed, protocol)?)?;
            dump(seed, &[], &d)?;
            if !d.causes.is_empty() {
                alarms += 1;
                eprintln!("seed {seed} none: named {:?}", d.causes);
            }
        }
        println!("none, -, {alarms}/{n} with a cause named");
    }
    println!("effect, size, detected/N, other named");
    for (kind, ss) in sizes {
        for s in ss {
            let wanted = only.as_ref().is_none_or(|o| {
                o.iter().any(|item| match item.split_once(':') {
                    Some((name, size)) => {
                        name == kind.name() && size.parse::<f64>().is_ok_and(|x| x == s)
                    }
                    None => item == kind.name(),
                })
            });
            if !wanted {
                continue;
            }
            let mut hit = 0;
            let mut other = 0;
            for i in 0..n {
                let seed = base + 1000 * (kind as u64) + i;
                let d = diagnose_trial(&hidden_trial_sized_on(kind, s, seed, protocol)?)?;
                dump(seed, &[kind], &d)?;
                if d.causes == vec![kind.name().to_string()] {
                    hit += 1;
                } else if d.causes.iter().any(|c| c != kind.name()) {
                    other += 1;
                    eprintln!("seed {seed} {} {s}: named {:?}", kind.name(), d.causes);
                }
            }
            println!("{}, {s}, {hit}/{n}, {other}", kind.name());
        }
    }
    Ok(())
}

/// The scenarios of the confusion table: name, hidden effects, whether the trial has `emg_ta`.
fn scenarios() -> Vec<(String, Vec<EffectKind>, bool)> {
    let mut scenarios: Vec<(String, Vec<EffectKind>, bool)> = vec![
        ("none".into(), vec![], false),
        ("none+ta".into(), vec![], true),
    ];
    for k in EffectKind::ALL {
        scenarios.push((k.name().into(), vec![k], false));
    }
    scenarios.push((
        "electromechanical_delay+torque_offset".into(),
        vec![EffectKind::ElectromechanicalDelay, EffectKind::TorqueOffset],
        false,
    ));
    scenarios.push((
        "fatigue+passive_joint_torque".into(),
        vec![EffectKind::Fatigue, EffectKind::PassiveJointTorque],
        false,
    ));
    scenarios
}

/// The confusion table: per scenario, the named causes against the hidden ones, the magnitude
/// error, the time and the coverage of the reported intervals.
fn confusion_table(
    n: u64,
    base: u64,
    settings: &DiagnoseSettings,
    above_limits: bool,
) -> Result<(), Box<dyn std::error::Error>> {
    let scenarios = scenarios();
    println!("scenario | correct/N | named instead (count) | mean |rel. err| of headline | held-out gain > 0 | max wall s | effect truth in 68 % profile interval | within ±1 Laplace SE | muscle truth in 68 % profile interval | within ±1 Laplace SE");
    for (si, (name, kinds, ta)) in scenarios.iter().enumerate() {
        let mut ok = 0;
        let mut named: BTreeMap<String, usize> = BTreeMap::new();
        let mut errs = Vec::new();
        let mut gain_pos = 0;
        let mut wall: f64 = 0.0;
        let (mut cov_n, mut cov_prof, mut cov_lap) = (0, 0, 0);
        let (mut mus_n, mut mus_prof, mut mus_lap) = (0, 0, 0);
        for i in 0..n {
            let seed = base + 100_000 * si as u64 + i;
            let t = if above_limits {
                hidden_trial_above_limits(kinds, *ta, seed)?
            } else {
                hidden_trial(kinds, *ta, seed)?
            };
            let t0 = Instant::now();
            let d = run(
                &t.synthetic.trial,
                Some(&t.synthetic.unloaded),
                settings,
                &mut no_observer,
            )?;
            wall = wall.max(t0.elapsed().as_secs_f64());
            dump(seed, kinds, &d)?;
            let mut want: Vec<String> = kinds.iter().map(|k| k.name().to_string()).collect();
            want.sort();
            let mut got = d.causes.clone();
            got.sort();
            if got == want {
                ok += 1;
            } else {
                *named.entry(format!("[{}]", got.join("+"))).or_default() += 1;
                eprintln!("seed {seed} {name}: named {:?}", d.causes);
            }
            if let Some(ints) = d.extended.param_interval.as_ref() {
                for id in muscle_model::ParamId::identified() {
                    if let Some(iv) = ints.get(&id.name()) {
                        let truth = id.get(&t.params, &t.effects);
                        let fit = d.extended.params[&id.name()];
                        mus_n += 1;
                        mus_prof += usize::from(iv.lower <= truth && truth <= iv.upper);
                        mus_lap += usize::from((fit - truth).abs() <= iv.laplace_se);
                    }
                }
            }
            if kinds.is_empty() || d.gain.heldout_rms_reduction_pct > 0.0 {
                gain_pos += 1;
            }
            for k in kinds {
                let truth = headline(*k, t.effects.values(*k).unwrap_or_default());
                // coverage of the reported 68 % intervals (profile) and of ±1 Laplace SE
                let mut truth_v = t.effects.values(*k).unwrap_or_default();
                if let Some(iv) = d
                    .extended
                    .effect_interval
                    .as_ref()
                    .and_then(|e| e.get(k.name()))
                {
                    let fitted = &d.extended.effects.as_ref().expect("effects")[k.name()];
                    let mut fv = k.null_values();
                    for (j, p) in k.params().iter().enumerate() {
                        fv[j] = fitted[p.name];
                    }
                    truth_v = align_to_fit(*k, truth_v, fv);
                    for (j, p) in k.params().iter().enumerate() {
                        if let Some(iv) = iv.get(p.name) {
                            cov_n += 1;
                            cov_prof +=
                                usize::from(iv.lower <= truth_v[j] && truth_v[j] <= iv.upper);
                            cov_lap +=
                                usize::from((fitted[p.name] - truth_v[j]).abs() <= iv.laplace_se);
                        }
                    }
                }
                if let Some(e) = d.extended.effects.as_ref().and_then(|e| e.get(k.name())) {
                    let ps = k.params();
                    let mut v = [0.0; 2];
                    for (j, p) in ps.iter().enumerate() {
                        v[j] = e.get(p.name).copied().unwrap_or(p.null);
                    }
                    let got = headline(*k, v);
                    let rel = if *k == EffectKind::EccentricEnhancement {
                        (got - truth).abs() / (truth - 1.4)
                    } else {
                        (got - truth).abs() / truth.abs()
                    };
                    errs.push(rel);
                }
            }
        }
        let me = if errs.is_empty() {
            f64::NAN
        } else {
            errs.iter().sum::<f64>() / errs.len() as f64
        };
        println!(
            "{name} | {ok}/{n} | {} | {:.1} % | {gain_pos}/{n} | {wall:.1} | {cov_prof}/{cov_n} | {cov_lap}/{cov_n} | {mus_prof}/{mus_n} | {mus_lap}/{mus_n}",
            named
                .iter()
                .map(|(k, v)| format!("{k}×{v}"))
                .collect::<Vec<_>>()
                .join(" "),
            100.0 * me
        );
    }
    Ok(())
}
