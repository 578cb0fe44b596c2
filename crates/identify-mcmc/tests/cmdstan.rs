//! The CmdStan-format chain files: read back by a minimal reader written here, every draw is
//! recovered bit for bit, the column means equal the reported posterior means, and `lp__` is
//! the log-likelihood plus the uniform prior's log density.

use std::ops::ControlFlow;

use experiment::{synthesize, SynthConfig};
use identify_mcmc::cmdstan::{cmdstan_column, uniform_log_prior};
use identify_mcmc::{identify, write_cmdstan_chain, McmcIdentifySettings, NoiseKind, NoiseSpec};
use muscle_model::Problem;

/// Comment lines, column names and rows of a CmdStan CSV, the way CmdStan's readers split it.
fn read(text: &str) -> (Vec<String>, Vec<String>, Vec<Vec<f64>>) {
    let mut comments = Vec::new();
    let mut header = None;
    let mut rows = Vec::new();
    for line in text.lines() {
        if let Some(c) = line.strip_prefix('#') {
            comments.push(c.to_string());
        } else if header.is_none() {
            header = Some(line.split(',').map(str::to_string).collect::<Vec<_>>());
        } else if !line.is_empty() {
            rows.push(line.split(',').map(|v| v.parse::<f64>().unwrap()).collect());
        }
    }
    (comments, header.expect("a header line"), rows)
}

/// The value of a `key = value` configuration comment.
fn config<'a>(comments: &'a [String], key: &str) -> Option<&'a str> {
    comments.iter().find_map(|c| {
        let (k, v) = c.split_once('=')?;
        (k.trim() == key).then(|| v.trim())
    })
}

#[test]
fn chains_read_back_exactly_with_cmdstan_columns() {
    let syn = synthesize(&SynthConfig::new("seed".parse().unwrap(), 5)).unwrap();
    let problem = Problem::standard(syn.inputs.clone(), syn.trial.torque_nm.clone()).unwrap();
    let noise = NoiseSpec::from_unloaded(&syn.trial, &syn.unloaded, NoiseKind::Ar1White).unwrap();
    let mut settings = McmcIdentifySettings::fast(3);
    settings.nelder_mead_evaluations = 200;
    settings.mcmc.warmup_min = 200;
    settings.mcmc.block = 100;
    settings.mcmc.max_total = 400;
    let m = identify(&problem, &noise, &settings, |_| ControlFlow::Continue(())).unwrap();
    let n_chains = m.run.log_density.len();
    assert!(n_chains >= 2);
    let log_prior = uniform_log_prior(&m.bounds);
    assert!(log_prior.is_finite());

    let mut pooled = vec![Vec::new(); m.names.len()];
    for c in 0..n_chains {
        let mut buf = Vec::new();
        write_cmdstan_chain(&m, c, 3, &["test chain"], &mut buf).unwrap();
        let (comments, header, rows) = read(std::str::from_utf8(&buf).unwrap());
        assert_eq!(comments[0].trim(), "test chain");
        assert_eq!(config(&comments, "method"), Some("sample"));
        assert_eq!(config(&comments, "save_warmup"), Some("0"));
        assert_eq!(config(&comments, "thin"), Some("1"));
        assert_eq!(
            config(&comments, "num_warmup"),
            Some(m.warmup_iterations.to_string().as_str())
        );
        assert_eq!(config(&comments, "id"), Some((c + 1).to_string().as_str()));
        assert_eq!(config(&comments, "seed"), Some("3"));

        let mut expected = vec!["lp__".to_string()];
        expected.extend(m.names.iter().map(|n| cmdstan_column(n)));
        expected.push("log_lik.1".into());
        assert_eq!(header, expected);
        assert!(header.contains(&"sol_lst_m".to_string()));

        assert_eq!(rows.len(), m.run.log_density[c].len());
        for (k, row) in rows.iter().enumerate() {
            assert_eq!(row.len(), header.len());
            let ll = m.run.log_density[c][k];
            assert_eq!(row[header.len() - 1].to_bits(), ll.to_bits());
            assert_eq!(row[0].to_bits(), (log_prior + ll).to_bits());
            for (p, draws) in m.run.draws.iter().enumerate() {
                assert_eq!(row[1 + p].to_bits(), draws[c][k].to_bits());
                pooled[p].push(row[1 + p]);
            }
        }
    }
    for (p, post) in m.posterior.iter().enumerate() {
        let mean = pooled[p].iter().sum::<f64>() / pooled[p].len() as f64;
        assert!(
            (mean - post.mean).abs() <= 1e-12 * post.mean.abs(),
            "{}: {mean} vs {}",
            post.name,
            post.mean
        );
    }

    let mut buf = Vec::new();
    assert!(write_cmdstan_chain(&m, n_chains, 3, &[], &mut buf).is_err());
}
