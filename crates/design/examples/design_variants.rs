//! The expected posterior sds (% of nominal) of five protocols under variants of the
//! design's assumptions (offset, drive level, sample window, noise, differencing, EMG seed):
//! `cargo run --release -p design --example design_variants`.

use std::collections::BTreeMap;

use design::{
    torque_jacobian, trial_inputs, trial_name, uncertainty_of, DesignNoise, DesignProtocol,
    DesignSettings, OffsetTreatment, TrialInformation,
};
use muscle_model::{Ar1White, ModelParams, SimSettings, TrialInputs};

const PROTOCOLS: [&str; 5] = [
    "knee0@30",
    "knee0@30x2",
    "knee0@30,knee90@30",
    "knee0@30,knee0@60",
    "knee0@30,knee90@30,knee0@60",
];

#[derive(Clone, Copy)]
struct Variant {
    label: &'static str,
    offset: OffsetTreatment,
    /// Every channel normalised by its own trial maximum (the flexed knee's gastrocnemius
    /// input as high as the extended knee's) instead of over the session.
    per_trial_normalisation: bool,
    /// Only the samples where the ankle moves count.
    moving_only: bool,
    /// White noise of the same marginal sd instead of AR(1)+white.
    white: bool,
    /// Default (fast) integration and this step (share of the bound width) instead of tight
    /// integration and the default step.
    jittery: Option<f64>,
    emg_seed: u64,
    emg_draws: usize,
}

fn per_trial_inputs(t: &experiment::SynthProtocol, seed: u64) -> TrialInputs {
    experiment::synthesize(&experiment::SynthConfig::for_protocol(*t, seed))
        .expect("the design trials synthesise")
        .inputs
}

fn main() -> Result<(), design::DesignError> {
    let protocols: Vec<DesignProtocol> = PROTOCOLS
        .iter()
        .map(|s| s.parse())
        .collect::<Result<_, _>>()?;
    let params = ModelParams::nominal();
    let base = Variant {
        label: "design default (offset prior sd 0.5 N·m)",
        offset: OffsetTreatment::Prior { sd_nm: 0.5 },
        per_trial_normalisation: false,
        moving_only: false,
        white: false,
        jittery: None,
        emg_seed: design::DEFAULT_EMG_SEED,
        emg_draws: design::DEFAULT_EMG_DRAWS,
    };
    let variants = [
        base,
        Variant {
            label: "offset known",
            offset: OffsetTreatment::Known,
            ..base
        },
        Variant {
            label: "offset free",
            offset: OffsetTreatment::Free,
            ..base
        },
        Variant {
            label: "EMG normalised per trial (gastrocnemius input at knee 90 not lowered)",
            per_trial_normalisation: true,
            ..base
        },
        Variant {
            label: "moving samples only",
            moving_only: true,
            ..base
        },
        Variant {
            label: "white noise of the same sd",
            white: true,
            ..base
        },
        Variant {
            label: "fast integration, step 1e-3 of the width",
            jittery: Some(1e-3),
            ..base
        },
        Variant {
            label: "fast integration, step 1e-5 of the width",
            jittery: Some(1e-5),
            ..base
        },
        Variant {
            label: "EMG seeds 17-32",
            emg_seed: 17,
            ..base
        },
        Variant {
            label: "EMG seed 1 alone",
            emg_draws: 1,
            ..base
        },
        Variant {
            label: "EMG seed 2 alone",
            emg_seed: 2,
            emg_draws: 1,
            ..base
        },
    ];
    let noise = DesignNoise::synthetic();
    for v in variants {
        let mut settings = DesignSettings {
            emg_seed: v.emg_seed,
            emg_draws: v.emg_draws,
            offset: v.offset,
            ..DesignSettings::default()
        };
        if let Some(step) = v.jittery {
            settings.jacobian.sim = SimSettings::default();
            settings.jacobian.rel_step = step;
        }
        let mut infos = BTreeMap::new();
        for t in protocols.iter().flat_map(|p| &p.trials) {
            let name = trial_name(t);
            if infos.contains_key(&name) {
                continue;
            }
            let mut draws = Vec::new();
            for k in 0..v.emg_draws as u64 {
                let inputs = if v.per_trial_normalisation {
                    per_trial_inputs(t, settings.emg_seed + k)
                } else {
                    trial_inputs(t, settings.emg_seed + k)?
                };
                let jac = torque_jacobian(&name, &inputs, &params, &settings.jacobian)?;
                let mut model = noise.at(jac.dt_s)?;
                if v.white {
                    model = Ar1White::new(0.0, 0.0, noise.ar1_sd_nm.hypot(noise.white_sd_nm))
                        .expect("valid noise");
                }
                let mask: Option<Vec<bool>> = v
                    .moving_only
                    .then(|| inputs.velocity().iter().map(|w| w.abs() > 1e-9).collect());
                draws.push(TrialInformation::observed(&jac, &model, mask.as_deref()));
            }
            infos.insert(name, TrialInformation::mean(&draws)?);
        }
        println!("{}", v.label);
        for p in &protocols {
            let u = uncertainty_of(p, &infos, &params, settings.offset)?;
            let cells: Vec<String> = u
                .params
                .iter()
                .map(|q| format!("{:>7}", report_num(q.sd_pct)))
                .collect();
            println!("  {:<28} {}", p.text, cells.join(""));
        }
    }
    Ok(())
}

fn report_num(x: f64) -> String {
    if x >= 100.0 {
        format!("{x:.0}")
    } else if x >= 10.0 {
        format!("{x:.1}")
    } else {
        format!("{x:.2}")
    }
}
