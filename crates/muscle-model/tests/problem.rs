//! Identification problem (`docs/model.md` section 5), noise models and the sensitivity sweep (Fig. 6).

#![allow(clippy::needless_range_loop)] // index-parallel arrays read clearer in tests

mod common;

use muscle_model::{
    sensitivity, simulate, synthetic, Ar1Gaussian, EffectKind, Effects, GaussianIid, ModelError,
    ModelParams, NoiseLikelihood, ParamId, Problem, ProblemWorkspace, SensitivitySettings,
    SimSettings,
};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

const FS: f64 = 1024.0;

fn truth_problem() -> (Problem, Vec<f64>) {
    let tr = synthetic::seed_like_trial(FS).unwrap();
    let x_true = vec![0.255, 3300.0, 27.0, 0.385, 1700.0, 16.0, 0.39, 650.0, 8.5];
    let base = Problem::standard(tr.clone(), vec![0.0; tr.len()]).unwrap();
    let (p, e) = base.params_from_vector(&x_true).unwrap();
    let measured = simulate(&tr, &p, &e, &SimSettings::default())
        .unwrap()
        .torque;
    (Problem::standard(tr, measured).unwrap(), x_true)
}

#[test]
fn standard_problem_names_bounds_and_vectors() {
    let (pb, x_true) = truth_problem();
    assert_eq!(pb.dim(), 9);
    assert_eq!(
        pb.names(),
        [
            "sol.lst_m",
            "sol.fom_n",
            "sol.alpha_deg",
            "gm.lst_m",
            "gm.fom_n",
            "gm.alpha_deg",
            "gl.lst_m",
            "gl.fom_n",
            "gl.alpha_deg"
        ]
    );
    let b = pb.bounds();
    assert!((b[0].0 - 0.2375).abs() < 1e-12 && (b[0].1 - 0.2625).abs() < 1e-12);
    assert!((b[1].0 - 2839.2).abs() < 1e-9 && (b[1].1 - 4258.8).abs() < 1e-9);
    assert!((b[2].0 - 20.0).abs() < 1e-12 && (b[2].1 - 30.0).abs() < 1e-12);
    assert!(pb.in_bounds(&x_true));
    let x0 = pb.base_vector();
    assert_eq!(
        x0,
        [0.25, 3549.0, 25.0, 0.39, 1558.0, 17.0, 0.38, 683.0, 8.0]
    );
    let (p, e) = pb.params_from_vector(&x_true).unwrap();
    assert_eq!(pb.vector_from(&p, &e), x_true);
    assert_eq!(e, Effects::none());
}

#[test]
fn cost_is_zero_at_the_truth_and_positive_elsewhere() {
    let (pb, x_true) = truth_problem();
    assert_eq!(pb.sse(&x_true).unwrap(), 0.0);
    let x0 = pb.base_vector();
    let sse = pb.sse(&x0).unwrap();
    let rms = pb.rms(&x0).unwrap();
    assert!(sse > 0.0);
    assert!((rms - (sse / pb.inputs().len() as f64).sqrt()).abs() < 1e-12);
    println!("RMS at nominal vs truth: {rms:.3} N·m");
    assert!(rms > 1.0 && rms < 50.0);
    // predict == simulate
    let pred = pb.predict(&x0).unwrap();
    let sim = simulate(
        pb.inputs(),
        &ModelParams::nominal(),
        &Effects::none(),
        &SimSettings::default(),
    )
    .unwrap();
    assert_eq!(pred, sim.torque);
}

#[test]
fn failures_are_errors_not_nan() {
    let (pb, x_true) = truth_problem();
    let mut x = x_true.clone();
    x[2] = 70.0; // α0 beyond 60°
    assert!(matches!(pb.sse(&x), Err(ModelError::InvalidValue { .. })));
    x[2] = f64::NAN;
    assert!(pb.sse(&x).is_err());
    let mut x = x_true.clone();
    x[1] = -10.0;
    assert!(matches!(pb.sse(&x), Err(ModelError::InvalidValue { .. })));
    assert!(matches!(
        pb.sse(&x_true[..8]),
        Err(ModelError::Length { .. })
    ));
    let noise = GaussianIid::new(2.0).unwrap();
    assert!(pb.log_likelihood(&x, &noise).is_err());
}

#[test]
fn weights_mask_samples() {
    let (pb, _) = truth_problem();
    let n = pb.inputs().len();
    let x0 = pb.base_vector();
    let full = pb.predict(&x0).unwrap();
    let w: Vec<f64> = (0..n).map(|i| if i < n / 2 { 0.0 } else { 1.0 }).collect();
    let pbw = pb.clone().with_weights(w).unwrap();
    let want: f64 = (n / 2..n)
        .map(|i| (pb.measured()[i] - full[i]).powi(2))
        .sum();
    let got = pbw.sse(&x0).unwrap();
    assert!((got - want).abs() < 1e-9 * want);
    assert!((pbw.rms(&x0).unwrap() - (want / (n - n / 2) as f64).sqrt()).abs() < 1e-9);
    // Gaussian log-likelihood over the kept half only
    let noise = GaussianIid::new(3.0).unwrap();
    let resid: Vec<f64> = (n / 2..n).map(|i| pb.measured()[i] - full[i]).collect();
    let ll = pbw.log_likelihood(&x0, &noise).unwrap();
    assert!((ll - noise.log_likelihood(&resid)).abs() < 1e-9 * ll.abs());
    assert!(pb.clone().with_weights(vec![0.0; n]).is_err());
    assert!(pb.clone().with_weights(vec![1.0; 3]).is_err());
}

#[test]
fn gaussian_log_likelihood_closed_form() {
    let (pb, _) = truth_problem();
    let x0 = pb.base_vector();
    let pred = pb.predict(&x0).unwrap();
    let sigma = 4.0;
    let n = pred.len() as f64;
    let ss: f64 = pred
        .iter()
        .zip(pb.measured())
        .map(|(p, m)| (m - p).powi(2))
        .sum();
    let want =
        -0.5 * n * (2.0 * std::f64::consts::PI * sigma * sigma).ln() - ss / (2.0 * sigma * sigma);
    let got = pb
        .log_likelihood(&x0, &GaussianIid::new(sigma).unwrap())
        .unwrap();
    assert!((got - want).abs() < 1e-9 * want.abs(), "{got} vs {want}");
    // the SSE and the iid likelihood are one monotone map of each other
    assert!(
        (got - (-0.5 * n * (2.0 * std::f64::consts::PI * 16.0).ln() - pb.sse(&x0).unwrap() / 32.0))
            .abs()
            < 1e-6
    );
}

/// Multivariate normal log-density with covariance `c` (dense, via Cholesky).
fn mvn_logpdf(x: &[f64], c: &[Vec<f64>]) -> f64 {
    let n = x.len();
    let mut l = vec![vec![0.0; n]; n];
    for i in 0..n {
        for j in 0..=i {
            let mut s = c[i][j];
            for k in 0..j {
                s -= l[i][k] * l[j][k];
            }
            l[i][j] = if i == j { s.sqrt() } else { s / l[j][j] };
        }
    }
    let mut z = vec![0.0; n];
    for i in 0..n {
        let mut s = x[i];
        for k in 0..i {
            s -= l[i][k] * z[k];
        }
        z[i] = s / l[i][i];
    }
    let logdet: f64 = (0..n).map(|i| 2.0 * l[i][i].ln()).sum();
    -0.5 * (n as f64 * (2.0 * std::f64::consts::PI).ln()
        + logdet
        + z.iter().map(|v| v * v).sum::<f64>())
}

#[test]
fn ar1_likelihood_is_the_exact_gaussian_density() {
    let e = [0.3, -1.2, 0.8, 2.1, -0.4, 0.05, 1.3];
    for &(phi, s) in &[(0.0, 1.0), (0.6, 0.7), (-0.4, 2.0), (0.95, 1.5)] {
        let ar = Ar1Gaussian::new(phi, s).unwrap();
        let n = e.len();
        let var = s * s / (1.0 - phi * phi);
        let c: Vec<Vec<f64>> = (0..n)
            .map(|i| {
                (0..n)
                    .map(|j| var * f64::powi(phi, (i as i32 - j as i32).abs()))
                    .collect()
            })
            .collect();
        let want = mvn_logpdf(&e, &c);
        let got = ar.log_likelihood(&e);
        assert!((got - want).abs() < 1e-10, "φ {phi}: {got} vs {want}");
    }
    // φ = 0 is the iid model
    let iid = GaussianIid::new(1.3).unwrap();
    let ar0 = Ar1Gaussian::new(0.0, 1.3).unwrap();
    assert!((iid.log_likelihood(&e) - ar0.log_likelihood(&e)).abs() < 1e-12);
    // from the marginal sd
    let m = Ar1Gaussian::from_marginal(0.8, 2.0).unwrap();
    assert!((m.sigma_innov - 1.2).abs() < 1e-12);
    assert!(Ar1Gaussian::new(1.0, 1.0).is_err());
    assert!(GaussianIid::new(0.0).is_err());
}

#[test]
fn ar1_estimate_recovers_the_coefficient() {
    let mut rng = ChaCha8Rng::seed_from_u64(3);
    let (phi, s) = (0.9, 0.5);
    let mut e = vec![0.0; 50_000];
    for i in 1..e.len() {
        // sum of 12 uniforms − 6: unit-variance, near-Gaussian innovations
        let w: f64 = (0..12).map(|_| rng.random::<f64>()).sum::<f64>() - 6.0;
        e[i] = phi * e[i - 1] + s * w;
    }
    let est = Ar1Gaussian::estimate(&e).unwrap();
    assert!((est.phi - phi).abs() < 0.01, "{}", est.phi);
    assert!((est.sigma_innov - s).abs() < 0.01, "{}", est.sigma_innov);
    let g = GaussianIid::estimate(&e).unwrap();
    assert!(
        (g.sigma - s / (1.0f64 - phi * phi).sqrt()).abs() < 0.1,
        "{}",
        g.sigma
    );
}

#[test]
fn problem_is_usable_from_several_threads() {
    fn assert_sync<T: Sync + Send>() {}
    assert_sync::<Problem>();
    let (pb, x_true) = truth_problem();
    let mut rng = ChaCha8Rng::seed_from_u64(5);
    let xs: Vec<Vec<f64>> = (0..6)
        .map(|_| {
            pb.bounds()
                .iter()
                .map(|(lo, hi)| rng.random_range(*lo..*hi))
                .collect()
        })
        .collect();
    let serial: Vec<f64> = xs.iter().map(|x| pb.sse(x).unwrap()).collect();
    let parallel: Vec<f64> = std::thread::scope(|s| {
        let handles: Vec<_> = xs
            .chunks(3)
            .map(|chunk| {
                let pb = &pb;
                s.spawn(move || {
                    let mut ws = ProblemWorkspace::new();
                    chunk
                        .iter()
                        .map(|x| pb.sse_with(x, &mut ws).unwrap())
                        .collect::<Vec<_>>()
                })
            })
            .collect();
        handles
            .into_iter()
            .flat_map(|h| h.join().unwrap())
            .collect()
    });
    assert_eq!(serial, parallel);
    assert_eq!(pb.sse(&x_true).unwrap(), 0.0);
}

#[test]
fn effect_parameters_can_be_free() {
    let tr = synthetic::seed_like_trial(FS).unwrap();
    let mut truth = Effects::none();
    truth
        .set_param(EffectKind::ElectromechanicalDelay, "delay_ms", 40.0)
        .unwrap();
    let measured = simulate(
        &tr,
        &ModelParams::nominal(),
        &truth,
        &SimSettings::default(),
    )
    .unwrap()
    .torque;
    let free = vec![
        ParamId::parse("sol.lst_m").unwrap(),
        ParamId::parse("electromechanical_delay.delay_ms").unwrap(),
    ];
    let pb = Problem::new(tr, measured, ModelParams::nominal(), Effects::none(), free).unwrap();
    assert_eq!(
        pb.names(),
        ["sol.lst_m", "electromechanical_delay.delay_ms"]
    );
    assert_eq!(pb.bounds()[1], (0.0, 150.0));
    assert_eq!(pb.base_vector(), [0.25, 0.0]);
    assert_eq!(pb.sse(&[0.25, 40.0]).unwrap(), 0.0);
    assert!(pb.sse(&[0.25, 0.0]).unwrap() > pb.sse(&[0.25, 30.0]).unwrap());
    // out-of-range effect value: an error, not a panic or NaN
    assert!(pb.sse(&[0.25, 200.0]).is_err());
    // duplicates rejected
    let tr = synthetic::seed_like_trial(256.0).unwrap();
    let n = tr.len();
    let dup = vec![ParamId::identified()[0]; 2];
    assert!(Problem::new(
        tr,
        vec![0.0; n],
        ModelParams::nominal(),
        Effects::none(),
        dup
    )
    .is_err());
}

#[test]
fn sensitivity_sweep_ranks_the_parameters() {
    let tr = synthetic::seed_like_trial(512.0).unwrap();
    let settings = SensitivitySettings::default();
    let table = sensitivity(&tr, &ModelParams::nominal(), &Effects::none(), &settings).unwrap();
    println!("{}", table.summary());
    assert_eq!(table.rows.len(), 9 * 8);
    assert_eq!(table.failures(), 0);
    assert_eq!(table.ranking.len(), 9);
    assert!(table
        .ranking
        .windows(2)
        .all(|w| w[0].max_rms_change_nm >= w[1].max_rms_change_nm));
    // the soleus slack length dominates (tendon strain is a few % of LST)
    assert_eq!(table.ranking[0].param, "sol.lst_m");
    assert!(table.important().contains(&"sol.lst_m"));
    assert!(table.important().contains(&"sol.fom_n"));
    // the RMS change grows with the size of the change, on both sides
    for name in ["sol.lst_m", "sol.fom_n", "gm.lst_m"] {
        let rows: Vec<_> = table.rows.iter().filter(|r| r.param == name).collect();
        let at = |p: f64| {
            rows.iter()
                .find(|r| r.change_pct == p)
                .unwrap()
                .rms_change_nm
                .unwrap()
        };
        assert!(at(5.0) < at(10.0) && at(10.0) < at(20.0), "{name}");
        assert!(at(-5.0) < at(-10.0) && at(-10.0) < at(-20.0), "{name}");
    }
    // F0 scales the muscle torque exactly (the dynamics are in normalised force): +20 % soleus
    // F0 changes the torque by exactly 20 % of the soleus torque
    let sim = simulate(
        &tr,
        &ModelParams::nominal(),
        &Effects::none(),
        &SimSettings::default(),
    )
    .unwrap();
    let sol_rms =
        (sim.muscles[0].torque.iter().map(|t| t * t).sum::<f64>() / tr.len() as f64).sqrt();
    let r = table
        .rows
        .iter()
        .find(|r| r.param == "sol.fom_n" && r.change_pct == 20.0)
        .unwrap();
    let rel = r.rms_change_nm.unwrap() / sol_rms;
    assert!((rel - 0.2).abs() < 1e-9, "{rel}");
    // CSV: header + one line per row
    let csv = table.to_csv();
    assert_eq!(csv.lines().count(), 73);
    assert!(csv.starts_with("param,change_pct,value,rms_change_nm,max_abs_change_nm,error\n"));
    let json: serde_json::Value = serde_json::from_str(&table.to_json_string()).unwrap();
    assert_eq!(json["rows"].as_array().unwrap().len(), 72);
}

#[test]
fn sensitivity_of_all_muscle_parameters_runs_without_failures() {
    let tr = synthetic::seed_like_trial(512.0).unwrap();
    let settings = SensitivitySettings {
        params: ParamId::all_muscle(),
        ..SensitivitySettings::default()
    };
    let table = sensitivity(&tr, &ModelParams::nominal(), &Effects::none(), &settings).unwrap();
    println!("{}", table.summary());
    assert_eq!(table.rows.len(), 15 * 8);
    assert_eq!(table.failures(), 0);
}
