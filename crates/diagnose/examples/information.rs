//! The information limit of the detection-limit and confusion studies (module
//! `diagnose::power`): for each trial, the noncentrality `λ` of its hidden effect under the
//! true dynamometer noise (the default
//! settings, docs/dynamometer.md), and from it the most often the ΔBIC rule (margin −10) and any test with
//! a false-alarm rate of 10⁻³ could name the effect.
//!
//! `cargo run --release -p diagnose --example information -- [N] [BASE_SEED] [--scenarios] [--effects a,b] [--against c,d] [--protocol P] [--sizes x,y]`
//!
//! Without `--scenarios`: the sizes of `confusion --limits`, trial `i` of an effect with seed
//! `BASE_SEED + 1000·kind + i` (the same trials as `confusion -- N BASE_SEED --limits`). With
//! `--scenarios`: the single-effect scenarios of `confusion -- N BASE_SEED` (seed
//! `BASE_SEED + 100000·scenario + i`, magnitudes drawn in the realistic ranges). Each row gives
//! the median and smallest `λ` and the expected number of trials (out of N) each bound allows.
//! `--against c,d` puts those effects in the null model (e.g. `--effects gravity --against
//! torque_offset`: what a gravity term adds to an offset). `--protocol relaxed+8` makes the
//! detection-limit trials on another protocol (the same seeds draw the same parameters and
//! effects); `--sizes x,y` replaces each effect's sizes.
use diagnose::power::{noncentrality, rule_power, test_power, true_noise};
use diagnose::scenarios::{hidden_trial, hidden_trial_sized_on, limit_sizes, HiddenTrial};
use diagnose::DiagnoseSettings;
use experiment::DynamometerSettings;
use experiment::Protocol;
use muscle_model::EffectKind;

/// `λ` of one trial and the two bounds.
fn bounds(
    t: &HiddenTrial,
    kind: EffectKind,
    null: &[EffectKind],
    settings: &DiagnoseSettings,
) -> Result<(f64, f64, f64), Box<dyn std::error::Error>> {
    let noise = true_noise(
        &DynamometerSettings::default(),
        t.synthetic.trial.sample_rate_hz(),
    )?;
    let info = noncentrality(
        &t.synthetic.trial,
        &t.synthetic.model_torque,
        null,
        &noise,
        settings,
    )?;
    // the parameters the effect adds to the null model (a gravity term adds one to an offset)
    let k = kind
        .params()
        .len()
        .saturating_sub(null.iter().map(|n| n.params().len()).sum::<usize>())
        .max(1);
    Ok((
        info.lambda,
        rule_power(info.lambda, k, info.n_obs, settings.max_delta_bic),
        test_power(info.lambda, k, 1e-3),
    ))
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().collect();
    let n: u64 = args.get(1).map_or(Ok(10), |s| s.parse())?;
    let base: u64 = args.get(2).map_or(Ok(900), |s| s.parse())?;
    let scenarios = args.iter().any(|a| a == "--scenarios");
    let only: Option<Vec<String>> = args
        .iter()
        .position(|a| a == "--effects")
        .and_then(|i| args.get(i + 1))
        .map(|s| s.split(',').map(str::to_string).collect());
    let against: Vec<EffectKind> = match args.iter().position(|a| a == "--against") {
        Some(i) => args
            .get(i + 1)
            .ok_or("--against needs effect names")?
            .split(',')
            .map(|n| EffectKind::from_name(n).ok_or(format!("unknown effect {n}")))
            .collect::<Result<_, _>>()?,
        None => Vec::new(),
    };
    let protocol: Protocol = match args.iter().position(|a| a == "--protocol") {
        Some(i) => args
            .get(i + 1)
            .ok_or("--protocol needs a protocol")?
            .parse()?,
        None => "relaxed+2".parse()?,
    };
    let sizes: Option<Vec<f64>> = match args.iter().position(|a| a == "--sizes") {
        Some(i) => Some(
            args.get(i + 1)
                .ok_or("--sizes needs numbers")?
                .split(',')
                .map(str::parse)
                .collect::<Result<_, _>>()?,
        ),
        None => None,
    };
    if scenarios && (protocol != "relaxed+2".parse()? || sizes.is_some()) {
        return Err("--protocol and --sizes apply to the detection-limit trials only".into());
    }
    let settings = DiagnoseSettings::default();
    let rows: Vec<(EffectKind, Option<f64>)> = if scenarios {
        EffectKind::ALL.iter().map(|k| (*k, None)).collect()
    } else {
        limit_sizes()
            .into_iter()
            .flat_map(|(k, own)| {
                let list = sizes.clone().unwrap_or(own);
                list.into_iter().map(move |s| (k, Some(s)))
            })
            .collect()
    };
    println!("effect | size | median λ | min λ | ΔBIC rule at best (of {n}) | any test at α = 10⁻³ (of {n})");
    for (kind, size) in rows {
        if only
            .as_ref()
            .is_some_and(|o| !o.iter().any(|e| e == kind.name()))
        {
            continue;
        }
        let mut lambdas = Vec::new();
        let (mut rule, mut test) = (0.0, 0.0);
        for i in 0..n {
            let t = match size {
                Some(s) => hidden_trial_sized_on(kind, s, base + 1000 * kind as u64 + i, protocol)?,
                // the confusion study's scenario index: none, none+ta, then the effects in order
                None => hidden_trial(&[kind], false, base + 100_000 * (2 + kind as u64) + i)?,
            };
            let (l, r, p) = bounds(&t, kind, &against, &settings)?;
            lambdas.push(l);
            rule += r;
            test += p;
        }
        lambdas.sort_by(f64::total_cmp);
        let median = lambdas[lambdas.len() / 2];
        println!(
            "{} | {} | {median:.1} | {:.1} | {rule:.1} | {test:.1}",
            kind.name(),
            size.map_or("range".to_string(), |s| s.to_string()),
            lambdas[0],
        );
    }
    Ok(())
}
