//! The diagnostics against R's `posterior` on Stan's "blocker" chains
//! (tests/data/README.md): all 48 quantities, relative error ≤ 1e-8.

use std::collections::HashMap;

use identify_mcmc::diagnostics;

/// Columns of a Stan CSV (comment lines skipped), by name.
fn stan_csv(text: &str) -> HashMap<String, Vec<f64>> {
    let mut lines = text
        .lines()
        .filter(|l| !l.starts_with('#') && !l.trim().is_empty());
    let header: Vec<String> = lines
        .next()
        .expect("header")
        .split(',')
        .map(|s| s.trim().to_string())
        .collect();
    let mut cols = vec![Vec::new(); header.len()];
    for line in lines {
        for (k, v) in line.split(',').enumerate() {
            cols[k].push(v.trim().parse::<f64>().expect("number"));
        }
    }
    header.into_iter().zip(cols).collect()
}

struct Reference {
    columns: Vec<String>,
    rows: Vec<(String, Vec<f64>)>,
}

fn reference() -> Reference {
    let text = include_str!("data/reference_posterior.csv");
    let mut lines = text.lines();
    let columns: Vec<String> = lines
        .next()
        .unwrap()
        .split(',')
        .map(|s| s.trim_matches('"').to_string())
        .collect();
    let rows = lines
        .filter(|l| !l.trim().is_empty())
        .map(|l| {
            let mut parts = l.split(',');
            let name = parts.next().unwrap().trim_matches('"').to_string();
            let vals = parts.map(|v| v.parse::<f64>().unwrap()).collect();
            (name, vals)
        })
        .collect();
    Reference { columns, rows }
}

fn check(stat: &str, f: impl Fn(&[&[f64]]) -> f64) -> f64 {
    let c1 = stan_csv(include_str!("data/blocker.1.csv"));
    let c2 = stan_csv(include_str!("data/blocker.2.csv"));
    let reference = reference();
    let col = reference
        .columns
        .iter()
        .position(|c| c == stat)
        .expect("statistic column")
        - 1;
    assert_eq!(reference.rows.len(), 48);
    let mut worst: f64 = 0.0;
    for (name, vals) in &reference.rows {
        let a = &c1[name];
        let b = &c2[name];
        assert_eq!(a.len(), 1000);
        assert_eq!(b.len(), 1000);
        let got = f(&[a, b]);
        let want = vals[col];
        let rel = ((got - want) / want).abs();
        assert!(
            rel <= 1e-8,
            "{stat} of {name}: got {got:.15}, posterior {want:.15} (rel {rel:.2e})"
        );
        worst = worst.max(rel);
    }
    eprintln!("{stat}: worst relative error over 48 quantities {worst:.2e}");
    worst
}

#[test]
fn rhat_rank_matches_posterior() {
    check("rhat_rank", diagnostics::rhat);
}

#[test]
fn rhat_raw_matches_classic_gelman_rubin() {
    check("rhat_raw", diagnostics::rhat_classic);
}

#[test]
fn ess_bulk_matches_posterior() {
    check("ess_bulk", diagnostics::ess_bulk);
}

#[test]
fn ess_tail_matches_posterior() {
    check("ess_tail", diagnostics::ess_tail);
}

#[test]
fn ess_mean_matches_posterior() {
    check("ess_mean", diagnostics::ess_mean);
}

#[test]
fn ess_raw_matches_unsplit_ess() {
    check("ess_raw", diagnostics::ess_unsplit);
}

#[test]
fn ess_median_and_quantiles_match_posterior() {
    check("ess_median", diagnostics::ess_median);
    check("ess_quantile01", |c| diagnostics::ess_quantile(c, 0.01));
    check("ess_quantile10", |c| diagnostics::ess_quantile(c, 0.1));
    check("ess_quantile30", |c| diagnostics::ess_quantile(c, 0.3));
}
