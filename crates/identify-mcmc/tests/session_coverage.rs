//! The acceptance study of joint MCMC on 3-trial sessions (knee0@30, knee90@30, knee0@60), over
//! 20 replicates with random true parameters: every run converges (R̂ < 1.01, bulk ESS ≥ 400),
//! the 90 % intervals cover the truth at their nominal rate, the mean posterior sds agree within
//! ±40 % with the linearised sds of the same trials at the truth (the `design` crate's Fisher
//! information with the bounds' prior), and the soleus is identifiable. Slow (several minutes on
//! 2 cores): `cargo test --release -p identify-mcmc --test session_coverage -- --ignored`; the
//! same study with a printed table is the `session_coverage` example.

use std::ops::ControlFlow;

use identify_mcmc::{identify_session, McmcIdentifySettings};

mod common;
use common::synthetic_session::{nominal_values, SyntheticSession, THREE_TRIALS};

const REPLICATES: u64 = 20;

/// `P(X ≤ k)` for `X ~ Binomial(n, p)`.
fn binomial_cdf(k: u64, n: u64, p: f64) -> f64 {
    let mut term = (1.0 - p).powi(n as i32); // P(X = 0)
    let mut sum = term;
    for i in 1..=k {
        term *= (n - i + 1) as f64 / i as f64 * p / (1.0 - p);
        sum += term;
    }
    sum
}

#[test]
#[ignore = "statistical study: 20 three-trial identifications"]
fn three_trial_sessions_cover_the_truth_at_the_nominal_rate() {
    let nominal = nominal_values();
    let mut hits = [0u64; 9];
    let mut sd_sum = [0.0f64; 9];
    let mut lin_sum = [0.0f64; 9];
    for rep in 1..=REPLICATES {
        let session = SyntheticSession::new(&THREE_TRIALS, rep);
        let truth = session.true_values();
        for (acc, v) in lin_sum.iter_mut().zip(session.linearised_sds_pct()) {
            *acc += v;
        }
        let mut settings = McmcIdentifySettings::default();
        settings.mcmc.seed = rep;
        let m =
            identify_session(&session.trials(), &settings, |_| ControlFlow::Continue(())).unwrap();
        assert!(m.converged, "replicate {rep}: stopped by {:?}", m.stop);
        for (k, p) in m.posterior.iter().enumerate() {
            assert!(
                p.rhat < 1.01 && p.ess_bulk >= 400.0,
                "replicate {rep}, {}: R̂ {} ESS {}",
                p.name,
                p.rhat,
                p.ess_bulk
            );
            hits[k] += u64::from(p.covers(truth[k]));
            sd_sum[k] += 100.0 * p.sd / nominal[k];
            if k < 3 {
                assert!(
                    p.identifiable,
                    "replicate {rep}: {} not identifiable",
                    p.name
                );
            }
        }
    }
    // The band of a calibrated interval: at most 0.5 % of runs fall below `low` by chance, per
    // parameter.
    let low = (0..=REPLICATES)
        .find(|&k| binomial_cdf(k, REPLICATES, 0.9) > 0.005)
        .unwrap();
    for k in 0..9 {
        assert!(
            hits[k] >= low,
            "parameter {k}: {}/{REPLICATES} intervals hold the truth (at least {low} expected)",
            hits[k]
        );
        let (sd, lin) = (
            sd_sum[k] / REPLICATES as f64,
            lin_sum[k] / REPLICATES as f64,
        );
        assert!(
            (sd / lin - 1.0).abs() <= 0.4,
            "parameter {k}: mean posterior sd {sd:.3} % against the linearised {lin:.3} %"
        );
    }
    // Over all 180 intervals (not independent across parameters, so a wide band).
    let total: u64 = hits.iter().sum();
    assert!(
        (150..=175).contains(&total),
        "{total}/180 intervals hold the truth"
    );
}

#[test]
fn the_binomial_band_is_right() {
    // P(X ≤ 13) = 0.0024 and P(X ≤ 14) = 0.0113 for n = 20, p = 0.9.
    assert!((binomial_cdf(13, 20, 0.9) - 0.00239).abs() < 5e-5);
    assert!((binomial_cdf(14, 20, 0.9) - 0.01125).abs() < 5e-5);
    assert!((binomial_cdf(20, 20, 0.9) - 1.0).abs() < 1e-12);
}
