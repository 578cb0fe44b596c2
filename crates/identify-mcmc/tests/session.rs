//! Joint MCMC over a session: a session of one trial is the single-trial sampler bit for bit;
//! trials that do not share free parameters or bounds are refused; a 3-trial session
//! (knee0@30, knee90@30, knee0@60) converges and identifies the soleus.

use std::ops::ControlFlow;

use experiment::{synthesize, SynthConfig};
use identify_mcmc::{
    identify_session, McmcError, McmcIdentification, McmcIdentifySettings, NoiseKind, NoiseSpec,
    SessionTrialLikelihood,
};
use muscle_model::Problem;

mod common;
use common::synthetic_session::{SyntheticSession, THREE_TRIALS};

fn run(
    trials: &[SessionTrialLikelihood<'_>],
    settings: &McmcIdentifySettings,
) -> Result<McmcIdentification, McmcError> {
    identify_session(trials, settings, |_| ControlFlow::Continue(()))
}

/// An order-sensitive fingerprint of every kept draw and log-likelihood.
fn fingerprint(m: &McmcIdentification) -> u64 {
    let mut h: u64 = 0;
    let mut add = |v: f64| h = h.wrapping_mul(1_000_003).wrapping_add(v.to_bits());
    for per in &m.run.draws {
        for chain in per {
            chain.iter().copied().for_each(&mut add);
        }
    }
    for chain in &m.run.log_density {
        chain.iter().copied().for_each(&mut add);
    }
    h
}

/// The reference numbers are those of the single-trial sampler on synthetic seed-protocol trial
/// 5 with these short settings (cap 400 iterations); a session of one must reproduce them
/// exactly, with the noise from the unloaded run and with the noise fitted to the residual.
#[test]
fn a_session_of_one_is_the_single_trial_sampler_bit_for_bit() {
    let syn = synthesize(&SynthConfig::new("seed".parse().unwrap(), 5)).unwrap();
    let problem = Problem::standard(syn.inputs.clone(), syn.trial.torque_nm.clone()).unwrap();
    let mut settings = McmcIdentifySettings::fast(3);
    settings.nelder_mead_evaluations = 200;
    settings.mcmc.warmup_min = 200;
    settings.mcmc.block = 100;
    settings.mcmc.max_total = 400;
    let cases = [
        (
            NoiseSpec::from_unloaded(&syn.trial, &syn.unloaded, NoiseKind::Ar1White).unwrap(),
            0xab33_e7aa_0751_d42e_u64,
            4017,
            0x4005_0328_197d_5c32_u64,
            0x3ff6_275d_2b84_824d_u64,
        ),
        (
            NoiseSpec::from_residual(NoiseKind::Ar1White),
            0xc7ab_09fe_db7e_5937,
            5027,
            0x400d_f3c1_7132_1e20,
            0x400d_f3c1_7132_1e20,
        ),
    ];
    for (noise, hash, evaluations, rms, rms_corrected) in cases {
        let trial = SessionTrialLikelihood {
            problem: &problem,
            noise: &noise,
        };
        let m = run(&[trial], &settings).unwrap();
        assert_eq!(fingerprint(&m), hash);
        assert_eq!(m.evaluations, evaluations);
        assert_eq!(m.rms_nm.to_bits(), rms);
        assert_eq!(m.rms_corrected_nm.to_bits(), rms_corrected);
        assert_eq!(m.trials.len(), 1);
        assert_eq!(m.trials[0].rms_nm, m.rms_nm);
        assert_eq!(m.trials[0].noise, m.noise);
        // identify() is the same session of one
        let single =
            identify_mcmc::identify(&problem, &noise, &settings, |_| ControlFlow::Continue(()))
                .unwrap();
        assert_eq!(single.run.draws, m.run.draws);
        assert_eq!(single.posterior, m.posterior);
    }
}

#[test]
fn trials_must_share_free_parameters_and_bounds() {
    let session = SyntheticSession::new(&THREE_TRIALS[..2], 7);
    let settings = McmcIdentifySettings::fast(1);
    assert_eq!(run(&[], &settings).unwrap_err(), McmcError::EmptySession);
    let mut bounds = session.problems[1].bounds().to_vec();
    bounds[0].1 *= 1.01;
    let other_bounds = session.problems[1].clone().with_bounds(bounds).unwrap();
    let free = session.problems[1].free()[..8].to_vec();
    let other_free = Problem::new(
        session.problems[1].inputs().clone(),
        session.problems[1].measured().to_vec(),
        *session.problems[1].base_params(),
        *session.problems[1].base_effects(),
        free,
    )
    .unwrap();
    for (other, what) in [(&other_bounds, "bounds"), (&other_free, "free parameters")] {
        let trials = [
            SessionTrialLikelihood {
                problem: &session.problems[0],
                noise: &session.noises[0],
            },
            SessionTrialLikelihood {
                problem: other,
                noise: &session.noises[1],
            },
        ];
        assert_eq!(
            run(&trials, &settings).unwrap_err(),
            McmcError::SessionMismatch { trial: 1, what }
        );
    }
}

#[test]
fn three_trial_session_converges_and_identifies_the_soleus() {
    let session = SyntheticSession::new(&THREE_TRIALS, 1);
    let truth = session.true_values();
    let mut settings = McmcIdentifySettings::default();
    settings.mcmc.seed = 1;
    let m = run(&session.trials(), &settings).unwrap();
    assert!(m.converged, "stopped by {:?}", m.stop);
    for p in &m.posterior {
        assert!(
            p.rhat < 1.01 && p.ess_bulk >= 400.0,
            "{}: R̂ {} ESS {}",
            p.name,
            p.rhat,
            p.ess_bulk
        );
    }
    for (k, p) in m.posterior.iter().enumerate().take(3) {
        assert!(p.identifiable, "{} not identifiable", p.name);
        assert!(
            p.covers(truth[k]),
            "{}: truth {} outside [{}, {}]",
            p.name,
            truth[k],
            p.q05,
            p.q95
        );
    }
    // Each trial's own fit, corrected by its own unloaded run: the residual is the dynamometer's
    // random error (marginal sd ≈ 1.3 N·m), far below the torque's scale.
    assert_eq!(m.trials.len(), 3);
    for t in &m.trials {
        assert!(t.corrected);
        assert!(
            t.rms_corrected_nm > 0.8 && t.rms_corrected_nm < 2.0,
            "{}",
            t.rms_corrected_nm
        );
        assert!(t.rms_nm > t.rms_corrected_nm);
    }
    // The full correlation matrix of the kept draws.
    let c = &m.posterior_correlation;
    assert_eq!(c.len(), 9);
    for (i, row) in c.iter().enumerate() {
        assert_eq!(row.len(), 9);
        assert!((row[i] - 1.0).abs() < 1e-12);
        for (j, v) in row.iter().enumerate() {
            assert!((v - c[j][i]).abs() < 1e-12 && v.abs() <= 1.0 + 1e-12);
        }
    }
    let strongest = &m.correlations[0];
    let (i, j) = (
        m.names.iter().position(|n| *n == strongest.a).unwrap(),
        m.names.iter().position(|n| *n == strongest.b).unwrap(),
    );
    assert!((c[i][j] - strongest.r).abs() < 1e-12);
}

/// A trial measured only where its weights are positive (a moment file shorter than the EMG):
/// its noise, fitted to its residual, comes from those samples alone, whatever the torque
/// holds elsewhere.
#[test]
fn the_residual_noise_of_a_weighted_trial_ignores_the_unmeasured_samples() {
    let session = SyntheticSession::new(&THREE_TRIALS[..1], 3);
    let p = &session.problems[0];
    let n = p.measured().len();
    let cut = n / 5;
    let weights: Vec<f64> = (0..n).map(|i| if i < cut { 0.0 } else { 1.0 }).collect();
    let mut garbage = p.measured().to_vec();
    for (i, v) in garbage.iter_mut().take(cut).enumerate() {
        *v = if i % 2 == 0 { 100.0 } else { -100.0 };
    }
    let weighted = |measured: Vec<f64>| {
        Problem::new(
            p.inputs().clone(),
            measured,
            *p.base_params(),
            *p.base_effects(),
            p.free().to_vec(),
        )
        .unwrap()
        .with_weights(weights.clone())
        .unwrap()
    };
    let clean = weighted(p.measured().to_vec());
    let spoiled = weighted(garbage);
    let noise = NoiseSpec::from_residual(NoiseKind::Ar1White);
    let mut settings = McmcIdentifySettings::fast(2);
    settings.nelder_mead_evaluations = 150;
    settings.mode_starts = 2;
    settings.mcmc.warmup_min = 200;
    settings.mcmc.block = 100;
    settings.mcmc.max_total = 300;
    let sd = |problem: &Problem| {
        let trial = SessionTrialLikelihood {
            problem,
            noise: &noise,
        };
        run(&[trial], &settings).unwrap().trials[0]
            .noise
            .marginal_sd()
    };
    let (a, b) = (sd(&clean), sd(&spoiled));
    assert!(a < 5.0, "marginal sd {a} N·m");
    assert_eq!(a, b, "the unmeasured samples changed the noise model");
}
