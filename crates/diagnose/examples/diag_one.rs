//! Diagnoses one synthetic trial (relaxed+2 unless `--protocol NAME`):
//! `diag_one SEED [EFFECTS_JSON] [--ta] [--hidden kind+kind [--above-limits]] [--protocol seed] [--exact-jacobian]`
//! (`--above-limits`: the hidden effects drawn at or above their documented detection limits,
//! as `confusion --above-limits` draws them).
//!
//! `SURAE_LM_ITERS=N` changes the Levenberg–Marquardt iteration cap; `SURAE_SHOW_FITS=1` prints
//! the baseline and extended fits (parameters, uncertainties) as JSON; `SURAE_CANDIDATES=a,b`
//! restricts the candidate effects; `SURAE_CV=cycles` holds out whole cycles even when the
//! trial has fewer than three.
use experiment::{random_params, synthesize, Protocol, SynthConfig};
use muscle_model::{Effects, ModelParams};
use rand::SeedableRng;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().collect();
    let seed: u64 = args.get(1).map_or(Ok(1), |s| s.parse())?;
    let effects = match args.get(2) {
        Some(s) => Effects::from_json_str(s)?,
        None => Effects::none(),
    };
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
    let params = random_params(&mut rng, &ModelParams::nominal());
    let protocol = match args.iter().position(|a| a == "--protocol") {
        Some(i) => args
            .get(i + 1)
            .ok_or("--protocol needs a name")?
            .parse::<Protocol>()?,
        None => "relaxed+2".parse::<Protocol>()?,
    };
    let mut cfg = SynthConfig::new(protocol, seed)
        .with_params(params)
        .with_effects(effects);
    if args.iter().any(|a| a == "--ta") {
        cfg.emg.include_ta = true;
    }
    let syn = if let Some(i) = args.iter().position(|a| a == "--hidden") {
        let kinds: Vec<muscle_model::EffectKind> = args[i + 1]
            .split('+')
            .filter_map(muscle_model::EffectKind::from_name)
            .collect();
        let ta = cfg.emg.include_ta;
        let t = if args.iter().any(|a| a == "--above-limits") {
            diagnose::scenarios::hidden_trial_above_limits(&kinds, ta, seed)?
        } else {
            diagnose::scenarios::hidden_trial(&kinds, ta, seed)?
        };
        println!("hidden: {}", serde_json::to_string(&t.effects)?);
        t.synthetic
    } else {
        synthesize(&cfg)?
    };
    let mut settings = diagnose::DiagnoseSettings {
        exact_jacobian: args.iter().any(|a| a == "--exact-jacobian"),
        ..diagnose::DiagnoseSettings::default()
    };
    if std::env::var("SURAE_CV").is_ok_and(|v| v == "cycles") {
        settings.cv_folds = diagnose::CvFolds::Cycles;
    }
    if let Ok(v) = std::env::var("SURAE_CANDIDATES") {
        settings.candidates = v
            .split(',')
            .map(|n| muscle_model::EffectKind::from_name(n).ok_or(format!("unknown effect {n}")))
            .collect::<Result<_, _>>()?;
    }
    if let Ok(v) = std::env::var("SURAE_LM_ITERS") {
        settings.lm.max_iterations = v.parse()?;
    }
    let d = diagnose::run(
        &syn.trial,
        Some(&syn.unloaded),
        &settings,
        &mut diagnose::no_observer,
    )?;
    if std::env::var("SURAE_SHOW_FITS").is_ok() {
        println!("baseline {}", serde_json::to_string(&d.baseline)?);
        println!("extended {}", serde_json::to_string(&d.extended)?);
    }
    for l in d.summary_lines() {
        println!("{l}");
    }
    if args.iter().any(|a| a == "--json") {
        println!("{}", d.to_json());
    }
    println!(
        "truth params: {}",
        serde_json::to_string(&syn.truth_json["params"]["muscles"])?
    );
    println!("fitted: {:?}", d.extended.params);
    Ok(())
}
