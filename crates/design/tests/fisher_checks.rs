//! Checks of the design's numbers: the Jacobian is stable under a halving of the difference
//! step, the EMG realisations' mean is stable from one set of seeds to another, and the
//! Fisher sds match the spread of least-squares estimates over repeated noise draws.

use design::{
    fisher_information, posterior_sds, torque_jacobian, trial_informations, trial_inputs,
    uncertainty_of, DesignNoise, DesignProtocol, DesignSettings, JacobianSettings, OffsetTreatment,
    TrialInformation,
};
use experiment::{random_error, DynamometerSettings, Recording, SynthProtocol};
use muscle_model::{simulate, Effects, ModelParams, ParamId, SimSettings};
use numerics::lm::{levenberg_marquardt, FiniteDifferences, LevenbergMarquardtSettings};
use rayon::prelude::*;

fn knee0() -> SynthProtocol {
    "knee0@30".parse().unwrap()
}

fn rel_diff(a: &[f64], b: &[f64]) -> f64 {
    let num: f64 = a.iter().zip(b).map(|(x, y)| (x - y).powi(2)).sum();
    let den: f64 = a.iter().map(|x| x * x).sum();
    (num / den).sqrt()
}

#[test]
fn jacobian_is_stable_when_the_step_is_halved() {
    let inputs = trial_inputs(&knee0(), 1).unwrap();
    let params = ModelParams::nominal();
    let s = JacobianSettings::default();
    let half = JacobianSettings {
        rel_step: s.rel_step / 2.0,
        ..s
    };
    let j1 = torque_jacobian("knee0@30", &inputs, &params, &s).unwrap();
    let j2 = torque_jacobian("knee0@30", &inputs, &params, &half).unwrap();
    let noise = DesignNoise::synthetic().at(j1.dt_s).unwrap();
    for (k, (a, b)) in j1.columns.iter().zip(&j2.columns).enumerate() {
        let d = rel_diff(a, b);
        eprintln!("{}: column change {:.2e}", j1.params[k], d);
        assert!(d < 2e-3, "{}: column changed by {d:.2e}", j1.params[k]);
    }
    // The marginal sds (near-collinear directions amplify column errors) move by < 2 %.
    let sd = |j: &design::TorqueJacobian| {
        let info = TrialInformation::new(j, &noise);
        let f = fisher_information(&[&info], OffsetTreatment::Known).unwrap();
        posterior_sds(&f, &[0.0; 9], "knee0@30").unwrap()
    };
    let (a, b) = (sd(&j1), sd(&j2));
    for k in 0..9 {
        let r = b[k] / a[k];
        eprintln!("{}: sd ratio {r:.4}", j1.params[k]);
        assert!((r - 1.0).abs() < 0.02, "{}: sd ratio {r}", j1.params[k]);
    }
}

#[test]
fn mean_over_emg_realisations_is_stable_across_seeds() {
    let p: DesignProtocol = "knee0@30".parse().unwrap();
    let params = ModelParams::nominal();
    let noise = DesignNoise::synthetic();
    let run = |seed: u64| {
        let settings = DesignSettings {
            emg_seed: seed,
            ..DesignSettings::default()
        };
        let infos =
            trial_informations(std::slice::from_ref(&p), &params, &noise, &settings).unwrap();
        uncertainty_of(&p, &infos, &params, settings.offset).unwrap()
    };
    let (a, b) = (run(1), run(1 + design::DEFAULT_EMG_DRAWS as u64));
    let mut worst: f64 = 0.0;
    for (x, y) in a.params.iter().zip(&b.params) {
        let r = y.sd_pct / x.sd_pct;
        eprintln!("{}: {:.3} vs {:.3} ({r:.3})", x.name, x.sd_pct, y.sd_pct);
        worst = worst.max((r - 1.0).abs());
    }
    eprintln!(
        "largest change between two sets of seeds: {:.1} %",
        100.0 * worst
    );
    assert!(worst < 0.15, "largest change {worst}");
}

/// The Fisher sds of the soleus's three parameters (gastrocnemii at their true values, offset
/// known) against the spread of generalised least-squares fits (Levenberg–Marquardt on the
/// whitened residual) to the true torque plus 60 independent draws of the dynamometer's
/// AR(1)+white noise. With 60 draws the sample sd has a relative sd of about 9 %, so ±30 % is a
/// 3σ margin; the mean estimate lies within half an sd of the truth.
#[test]
fn fisher_sds_match_least_squares_over_noise_draws() {
    let inputs = trial_inputs(&knee0(), 1).unwrap();
    let truth = ModelParams::nominal();
    let tight = SimSettings::tight();
    let tau0 = simulate(&inputs, &truth, &Effects::none(), &tight)
        .unwrap()
        .torque;
    let jac = torque_jacobian("knee0@30", &inputs, &truth, &JacobianSettings::default()).unwrap();
    let noise = DesignNoise::synthetic().at(jac.dt_s).unwrap();
    let info = TrialInformation::new(&jac, &noise);
    let f9 = fisher_information(&[&info], OffsetTreatment::Known).unwrap();
    let idx = [0usize, 1, 2];
    let f9 = &f9;
    let f3: Vec<f64> = idx
        .iter()
        .flat_map(|&i| idx.iter().map(move |&j| f9[i * 9 + j]))
        .collect();
    let fisher_sd = posterior_sds(&f3, &[0.0; 3], "knee0@30").unwrap();

    let ids: Vec<ParamId> = idx.iter().map(|&i| ParamId::identified()[i]).collect();
    let none = Effects::none();
    let x0: Vec<f64> = ids.iter().map(|id| id.get(&truth, &none)).collect();
    let bounds: Vec<(f64, f64)> = ids
        .iter()
        .map(|id| id.default_bounds(&truth, &none))
        .collect();
    let n = tau0.len();
    let plan = noise.plan(n, None);
    let dyn_settings = DynamometerSettings::default();
    let lm = LevenbergMarquardtSettings {
        differences: FiniteDifferences::Central,
        fd_step: 4e-3,
        ftol_rel: 1e-10,
        ..LevenbergMarquardtSettings::default()
    };
    let draws = 60u64;
    let estimates: Vec<Vec<f64>> = (0..draws)
        .into_par_iter()
        .map(|d| {
            let e = random_error(n, jac.dt_s, &dyn_settings, 5000 + d, Recording::Trial).unwrap();
            let y: Vec<f64> = tau0.iter().zip(&e).map(|(t, e)| t + e).collect();
            let residuals = |x: &[f64], _: &mut (), out: &mut Vec<f64>| {
                let mut p = truth;
                let mut eff = Effects::none();
                for (id, v) in ids.iter().zip(x) {
                    id.set(&mut p, &mut eff, *v);
                }
                let Ok(sim) = simulate(&inputs, &p, &eff, &tight) else {
                    return false;
                };
                let r: Vec<f64> = y.iter().zip(&sim.torque).map(|(a, b)| a - b).collect();
                out.resize(n, 0.0);
                plan.whiten(&r, out);
                true
            };
            levenberg_marquardt(&residuals, &x0, &bounds, &lm, |_| {})
                .unwrap()
                .x
        })
        .collect();
    for k in 0..3 {
        let v: Vec<f64> = estimates.iter().map(|x| x[k]).collect();
        let mean = v.iter().sum::<f64>() / v.len() as f64;
        let sd = (v.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (v.len() - 1) as f64).sqrt();
        let ratio = sd / fisher_sd[k];
        let bias = (mean - x0[k]) / fisher_sd[k];
        eprintln!(
            "{}: least-squares sd {sd:.3e}, Fisher sd {:.3e}, ratio {ratio:.3}, bias {bias:.2} sd",
            ids[k], fisher_sd[k]
        );
        assert!((0.7..1.3).contains(&ratio), "{}: ratio {ratio}", ids[k]);
        assert!(bias.abs() < 0.5, "{}: bias {bias} sd", ids[k]);
    }
}
