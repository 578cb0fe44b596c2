//! `surae identify --method nuts`: the No-U-Turn sampler behind the command, its report and
//! CmdStan chains, and its refusal of a free set it has no exact gradient for.

mod common;
use common::{json, ok, stderr_of, surae};
use std::path::Path;

fn repo_root() -> &'static Path {
    Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/../.."))
}

#[test]
fn nuts_writes_its_report_and_cmdstan_chains_with_the_sampler_columns() {
    // a short run (10 warm-up + 10 draws per chain): the plumbing, not convergence
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("nuts");
    let o = surae(
        &[
            "identify",
            "--method",
            "nuts",
            "--max-iterations",
            "20",
            "--seed",
            "3",
            "--out",
            out.to_str().unwrap(),
        ],
        repo_root(),
    );
    ok(&o);
    let stdout = String::from_utf8_lossy(&o.stdout);
    assert!(stdout.contains("identify (nuts)"), "{stdout}");
    assert!(
        stdout.contains("NOT converged"),
        "20 iterations are reported as such: {stdout}"
    );
    assert!(
        stdout.contains("leapfrog steps per draw") && stdout.contains("gradient evaluations"),
        "{stdout}"
    );
    let v = json(&out.join("identify.json"));
    assert_eq!(v["method"], "nuts");
    let nuts = &v["nuts"];
    assert_eq!(
        nuts["step_size"].as_array().map(Vec::len),
        Some(4),
        "{nuts}"
    );
    assert_eq!(nuts["dense_metric"], true);
    let gradients = nuts["gradient_evaluations"].as_u64().unwrap();
    assert!(
        gradients >= 4 * 20,
        "one gradient per iteration at least: {nuts}"
    );
    assert!(nuts["mean_leapfrog"].as_f64().unwrap() >= 1.0, "{nuts}");
    assert!(nuts["gradients_per_effective_draw"].as_f64().unwrap() > 0.0);
    let chain = std::fs::read_to_string(out.join("chains/chain_1.csv")).unwrap();
    assert!(
        chain.contains("engine = nuts") && chain.contains("metric = dense_e"),
        "{chain}"
    );
    let header = chain.lines().find(|l| l.starts_with("lp__")).unwrap();
    assert!(
        header.starts_with(
            "lp__,accept_stat__,stepsize__,treedepth__,n_leapfrog__,divergent__,energy__,"
        ),
        "{header}"
    );
    let rows = chain
        .lines()
        .filter(|l| !l.starts_with('#') && !l.starts_with("lp__"))
        .count();
    assert_eq!(rows, 10);
    assert!(out.join("chains/chain_4.csv").exists());
}

#[test]
fn a_free_set_without_an_exact_gradient_is_refused_before_anything_is_written() {
    // the activation's time constants change the activation's own integration, which the
    // sensitivities do not cover (the shape and the delay they do)
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("tau");
    let o = surae(
        &[
            "identify",
            "--method",
            "nuts",
            "--session",
            "fixtures/session3/session.json",
            "--free",
            "+activation.tau_act_s",
            "--out",
            out.to_str().unwrap(),
        ],
        repo_root(),
    );
    assert_eq!(o.status.code(), Some(2), "{}", stderr_of(&o));
    let err = stderr_of(&o);
    assert!(
        err.contains("exact gradient") && err.contains("activation.tau_act_s"),
        "{err}"
    );
    assert_eq!(err.trim().lines().count(), 1, "{err}");
    assert!(!out.join("identify.json").exists());
}
