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

struct McCheck {
    ratio: f64,
    bias: f64,
    apart: f64,
}

/// The Fisher sds of the parameters `idx` (the others at their true values, offsets known)
/// of the protocol's trials (EMG seed 1) against the spread of generalised least-squares fits
/// (Levenberg–Marquardt on the whitened residuals of every trial) to the true torques plus
/// `draws` independent draws of the dynamometer's AR(1)+white noise per trial. Returns, per
/// parameter, the ratio of the fits' sd to the Fisher sd, the fits' mean bias and the RMS
/// distance between each fit and the linearised estimate of the same draw (in Fisher sds).
fn least_squares_against_fisher(protocol: &str, idx: &[usize], draws: u64) -> Vec<McCheck> {
    let p: DesignProtocol = protocol.parse().unwrap();
    let truth = ModelParams::nominal();
    let tight = SimSettings::tight();
    let none = Effects::none();
    let mut trials = Vec::new();
    let mut infos = Vec::new();
    for t in &p.trials {
        let inputs = trial_inputs(t, 1).unwrap();
        let tau0 = simulate(&inputs, &truth, &none, &tight).unwrap().torque;
        let jac = torque_jacobian(protocol, &inputs, &truth, &JacobianSettings::default()).unwrap();
        let noise = DesignNoise::synthetic().at(jac.dt_s).unwrap();
        infos.push(TrialInformation::new(&jac, &noise));
        let plan = noise.plan(tau0.len(), None);
        let wj: Vec<Vec<f64>> = idx
            .iter()
            .map(|&i| {
                let mut o = vec![0.0; tau0.len()];
                plan.whiten(&jac.columns[i], &mut o);
                o
            })
            .collect();
        trials.push((inputs, tau0, plan, jac.dt_s, wj));
    }
    let refs: Vec<&TrialInformation> = infos.iter().collect();
    let f9 = fisher_information(&refs, OffsetTreatment::Known).unwrap();
    let f9 = &f9;
    let m = idx.len();
    let fsub: Vec<f64> = idx
        .iter()
        .flat_map(|&i| idx.iter().map(move |&j| f9[i * 9 + j]))
        .collect();
    let fisher_sd = posterior_sds(&fsub, &vec![0.0; m], protocol).unwrap();
    let cov = numerics::cholesky::spd_inverse(&fsub, m).unwrap();

    let ids: Vec<ParamId> = idx.iter().map(|&i| ParamId::identified()[i]).collect();
    let x0: Vec<f64> = ids.iter().map(|id| id.get(&truth, &none)).collect();
    let bounds: Vec<(f64, f64)> = ids
        .iter()
        .map(|id| id.default_bounds(&truth, &none))
        .collect();
    let dyn_settings = DynamometerSettings::default();
    let lm = LevenbergMarquardtSettings {
        differences: FiniteDifferences::Central,
        fd_step: 4e-3,
        ftol_rel: 1e-12,
        max_iterations: 200,
        ..LevenbergMarquardtSettings::default()
    };
    // Per draw: the nonlinear fit and the linearised (one Gauss–Newton step) estimate
    // `θ₀ + F⁻¹·Σ (WJ)ᵀ(We)`.
    let estimates: Vec<(Vec<f64>, Vec<f64>)> = (0..draws)
        .into_par_iter()
        .map(|d| {
            let ys: Vec<Vec<f64>> = trials
                .iter()
                .enumerate()
                .map(|(k, (_, tau0, _, dt, _))| {
                    let seed = 5000 + 100 * d + k as u64;
                    let e = random_error(tau0.len(), *dt, &dyn_settings, seed, Recording::Trial)
                        .unwrap();
                    tau0.iter().zip(&e).map(|(t, e)| t + e).collect()
                })
                .collect();
            let residuals = |x: &[f64], _: &mut (), out: &mut Vec<f64>| {
                let mut p = truth;
                let mut eff = Effects::none();
                for (id, v) in ids.iter().zip(x) {
                    id.set(&mut p, &mut eff, *v);
                }
                out.clear();
                for ((inputs, _, plan, _, _), y) in trials.iter().zip(&ys) {
                    let Ok(sim) = simulate(inputs, &p, &eff, &tight) else {
                        return false;
                    };
                    let r: Vec<f64> = y.iter().zip(&sim.torque).map(|(a, b)| a - b).collect();
                    let mut w = vec![0.0; r.len()];
                    plan.whiten(&r, &mut w);
                    out.extend_from_slice(&w);
                }
                true
            };
            let fit = levenberg_marquardt(&residuals, &x0, &bounds, &lm, |_| {})
                .unwrap()
                .x;
            let mut g = vec![0.0; m];
            for ((_, tau0, plan, _, wj), y) in trials.iter().zip(&ys) {
                let e: Vec<f64> = y.iter().zip(tau0).map(|(a, b)| a - b).collect();
                let mut we = vec![0.0; e.len()];
                plan.whiten(&e, &mut we);
                for (gk, col) in g.iter_mut().zip(wj) {
                    *gk += col.iter().zip(&we).map(|(a, b)| a * b).sum::<f64>();
                }
            }
            let linear: Vec<f64> = (0..m)
                .map(|i| x0[i] + (0..m).map(|j| cov[i * m + j] * g[j]).sum::<f64>())
                .collect();
            (fit, linear)
        })
        .collect();
    (0..m)
        .map(|k| {
            let v: Vec<f64> = estimates.iter().map(|x| x.0[k]).collect();
            let mean = v.iter().sum::<f64>() / v.len() as f64;
            let sd =
                (v.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (v.len() - 1) as f64).sqrt();
            let apart = (estimates
                .iter()
                .map(|x| (x.0[k] - x.1[k]).powi(2))
                .sum::<f64>()
                / v.len() as f64)
                .sqrt()
                / fisher_sd[k];
            let (ratio, bias) = (sd / fisher_sd[k], (mean - x0[k]) / fisher_sd[k]);
            eprintln!(
                "{protocol} {}: least-squares sd {sd:.3e}, Fisher sd {:.3e}, ratio {ratio:.3}, \
                 bias {bias:.2} sd, fit − linearised estimate {apart:.3} sd RMS",
                ids[k], fisher_sd[k]
            );
            McCheck { ratio, bias, apart }
        })
        .collect()
}

/// The soleus's three parameters on one trial. With 60 draws the sample sd has a relative sd
/// of about 9 %, so ±30 % is a 3σ margin; the mean estimate lies within half an sd of the
/// truth (its standard error is 0.13 sd). Each nonlinear fit lies within 0.1 sd of the
/// linearised estimate of its own draw: the linearisation, not the sampling, is what is tested.
#[test]
fn fisher_sds_match_least_squares_over_noise_draws() {
    for c in least_squares_against_fisher("knee0@30", &[0, 1, 2], 60) {
        assert!((0.7..1.3).contains(&c.ratio), "ratio {}", c.ratio);
        assert!(c.bias.abs() < 0.5, "bias {} sd", c.bias);
        assert!(c.apart < 0.1, "fit − linearised {} sd", c.apart);
    }
}

/// Every tendon slack length and F0 on three trials (their information summed), 60 draws:
/// about 6 minutes on two cores. Here the fits depart from the linearised estimates of their
/// draws by 0.14 (sol LST) to 0.65 sd (gm and gl LST) RMS: with the knee flexed the
/// gastrocnemii work near their tendons' slack length, where the torque bends sharply with
/// LST. Their scatter stays within 0.8–1.1 Fisher sds, which is what is asserted.
#[test]
#[ignore = "about 6 minutes; the one-trial version runs by default"]
fn fisher_sds_match_least_squares_on_three_trials() {
    let r = least_squares_against_fisher("knee0@30,knee90@30,knee0@60", &[0, 1, 3, 4, 6, 7], 60);
    for c in r {
        assert!((0.7..1.3).contains(&c.ratio), "ratio {}", c.ratio);
        assert!(c.bias.abs() < 0.5, "bias {} sd", c.bias);
    }
}

/// The whitening describes the synthetic dynamometer's noise: over 1000 draws of its AR(1) +
/// white error, the generalised least-squares estimate of the linearised model,
/// `F⁻¹·(WJ)ᵀ(We)`, scatters with the Fisher sds of all nine parameters (the sample sd's
/// relative sd is 2.2 %, so ±8 % is a 3.5σ margin).
#[test]
fn linearised_estimates_scatter_with_the_fisher_sds() {
    let inputs = trial_inputs(&knee0(), 1).unwrap();
    let jac = torque_jacobian(
        "knee0@30",
        &inputs,
        &ModelParams::nominal(),
        &JacobianSettings::default(),
    )
    .unwrap();
    let noise = DesignNoise::synthetic().at(jac.dt_s).unwrap();
    let info = TrialInformation::new(&jac, &noise);
    let f = fisher_information(&[&info], OffsetTreatment::Known).unwrap();
    let sd = posterior_sds(&f, &[0.0; 9], "knee0@30").unwrap();
    // Inverse through the unit-diagonal scaling, as posterior_sds does.
    let d: Vec<f64> = (0..9).map(|i| f[i * 10].sqrt()).collect();
    let scaled: Vec<f64> = (0..81).map(|k| f[k] / (d[k / 9] * d[k % 9])).collect();
    let inv = numerics::cholesky::spd_inverse(&scaled, 9).unwrap();
    let n = jac.columns[0].len();
    let plan = noise.plan(n, None);
    let wj: Vec<Vec<f64>> = jac
        .columns
        .iter()
        .map(|c| {
            let mut o = vec![0.0; n];
            plan.whiten(c, &mut o);
            o
        })
        .collect();
    let draws = 1000u64;
    let est: Vec<Vec<f64>> = (0..draws)
        .into_par_iter()
        .map(|k| {
            let e = random_error(
                n,
                jac.dt_s,
                &DynamometerSettings::default(),
                20_000 + k,
                Recording::Trial,
            )
            .unwrap();
            let mut we = vec![0.0; n];
            plan.whiten(&e, &mut we);
            let g: Vec<f64> = wj
                .iter()
                .zip(&d)
                .map(|(c, di)| c.iter().zip(&we).map(|(a, b)| a * b).sum::<f64>() / di)
                .collect();
            (0..9)
                .map(|i| (0..9).map(|j| inv[i * 9 + j] * g[j]).sum::<f64>() / d[i])
                .collect()
        })
        .collect();
    for i in 0..9 {
        let v: Vec<f64> = est.iter().map(|x| x[i]).collect();
        let mean = v.iter().sum::<f64>() / v.len() as f64;
        let s = (v.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (v.len() - 1) as f64).sqrt();
        let r = s / sd[i];
        eprintln!("{}: scatter / Fisher sd {r:.3}", jac.params[i]);
        assert!((0.92..1.08).contains(&r), "{}: {r}", jac.params[i]);
    }
}
