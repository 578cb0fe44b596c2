//! Determinism: `surae identify --method sa` and `surae diagnose` write the
//! same JSON for the same seed whatever the number of threads
//! (`RAYON_NUM_THREADS=1` and `=2`). The only field allowed to differ is
//! `wall_s`, a measured time (docs/robustness.md). `identify --method mcmc`
//! runs with `--max-iterations 3000` (a full run takes about a minute): the
//! capped run reports `"converged": false`, and its draws, summaries and
//! chains must still not depend on the thread count. The bundled trial has no
//! hidden effect, so the diagnosis on it must also be adequate with no cause.

use std::path::Path;
use std::process::Command;

/// Runs `surae ARGS --quiet` on the bundled trial with `threads` rayon threads (`identify`
/// with `--seed 7`; the diagnosis takes no seed) and returns the JSON file `file` it wrote.
fn run(args: &[&str], file: &str, threads: &str, dir: &Path) -> String {
    let out = dir.join(format!("{}-{threads}", args.join("-")));
    let seed: &[&str] = if args[0] == "identify" {
        &["--seed", "7"]
    } else {
        &[]
    };
    let o = Command::new(env!("CARGO_BIN_EXE_surae"))
        .args(args)
        .args(seed)
        .args(["--quiet", "--out", out.to_str().unwrap()])
        .env("RAYON_NUM_THREADS", threads)
        .current_dir(dir)
        .output()
        .expect("the surae binary runs");
    assert!(
        o.status.success(),
        "{args:?} with {threads} threads: {}",
        String::from_utf8_lossy(&o.stderr)
    );
    std::fs::read_to_string(out.join(file)).unwrap()
}

/// Asserts the two JSON texts are equal byte for byte but for `wall_s`.
fn assert_same_but_wall_time(one: &str, two: &str, what: &str) {
    let (a, b) = (without_wall_time(one), without_wall_time(two));
    if a != b {
        let diff: Vec<String> = a
            .lines()
            .zip(b.lines())
            .filter(|(x, y)| x != y)
            .map(|(x, y)| format!("1 thread: {x}\n2 threads: {y}"))
            .collect();
        panic!(
            "{what} differs between 1 and 2 threads ({} vs {} lines):\n{}",
            a.lines().count(),
            b.lines().count(),
            diff.join("\n")
        );
    }
}

/// The JSON text without its one `"wall_s"` line (a measured time).
fn without_wall_time(json: &str) -> String {
    let wall = json
        .lines()
        .filter(|l| l.trim_start().starts_with("\"wall_s\":"))
        .count();
    assert_eq!(wall, 1, "exactly one wall_s line in\n{json}");
    json.lines()
        .filter(|l| !l.trim_start().starts_with("\"wall_s\":"))
        .map(|l| format!("{l}\n"))
        .collect()
}

#[test]
fn identify_sa_json_is_byte_identical_with_one_and_two_threads() {
    let dir = tempfile::tempdir().unwrap();
    let args = ["identify", "--method", "sa"];
    let one = run(&args, "identify.json", "1", dir.path());
    let two = run(&args, "identify.json", "2", dir.path());
    let v: serde_json::Value = serde_json::from_str(&one).unwrap();
    assert_eq!(v["method"], "sa");
    assert_eq!(v["seed"], 7);
    assert_eq!(v["params"].as_object().map(|m| m.len()), Some(9));
    assert!(v["wall_s"].as_f64().is_some_and(|w| w > 0.0));
    assert_same_but_wall_time(&one, &two, "identify.json (sa)");
}

#[test]
fn diagnose_json_is_byte_identical_with_one_and_two_threads() {
    let dir = tempfile::tempdir().unwrap();
    let one = run(&["diagnose"], "diagnosis.json", "1", dir.path());
    let two = run(&["diagnose"], "diagnosis.json", "2", dir.path());
    let v: serde_json::Value = serde_json::from_str(&one).unwrap();
    // The bundled trial is `fixtures/seed`, generated with no effect: the baseline model is
    // the truth, so the diagnosis must find it adequate and name no cause.
    let truth: serde_json::Value = serde_json::from_str(
        &std::fs::read_to_string(
            Path::new(env!("CARGO_MANIFEST_DIR")).join("../../fixtures/seed/truth.json"),
        )
        .unwrap(),
    )
    .unwrap();
    assert_eq!(
        truth["effects"],
        serde_json::json!({}),
        "the bundled trial's effects"
    );
    assert_eq!(
        v["verdict"], "adequate",
        "verdict on a trial with no effect"
    );
    assert_eq!(
        v["causes"],
        serde_json::json!([]),
        "causes on a trial with no effect"
    );
    assert!(v["candidates"].as_array().is_some_and(|c| !c.is_empty()));
    // the final model, the baseline, carries 68 % profile intervals around its parameters
    let final_model = &v["baseline"];
    let ints = final_model["param_interval"]
        .as_object()
        .expect("param_interval");
    assert_eq!(ints.len(), 9);
    for (name, iv) in ints {
        let x = final_model["params"][name].as_f64().unwrap();
        let (lo, hi) = (iv["lower"].as_f64().unwrap(), iv["upper"].as_f64().unwrap());
        assert!(
            lo <= x && x <= hi && lo < hi,
            "{name}: {x} not in [{lo}, {hi}]"
        );
        assert!(
            (final_model["param_uncertainty"][name].as_f64().unwrap() - 0.5 * (hi - lo)).abs()
                < 1e-9
        );
    }
    let dir1 = dir.path().join("diagnose-1");
    let html = std::fs::read_to_string(dir1.join("report.html")).unwrap();
    assert!(
        html.contains("68 % profile-likelihood intervals"),
        "parameter table in report.html"
    );
    assert_same_but_wall_time(&one, &two, "diagnosis.json");
}

#[test]
fn identify_mcmc_json_and_chains_are_byte_identical_with_one_and_two_threads() {
    let dir = tempfile::tempdir().unwrap();
    let args = ["identify", "--method", "mcmc", "--max-iterations", "3000"];
    let one = run(&args, "identify.json", "1", dir.path());
    let two = run(&args, "identify.json", "2", dir.path());
    let v: serde_json::Value = serde_json::from_str(&one).unwrap();
    assert_eq!(v["method"], "mcmc");
    assert_eq!(v["posterior"].as_object().map(|m| m.len()), Some(9));
    assert_eq!(v["converged"], false, "a 3000-iteration cap is reported");
    assert_same_but_wall_time(&one, &two, "identify.json (mcmc)");
    let chains = |t: &str| {
        std::fs::read(
            dir.path()
                .join(format!("{}-{t}", args.join("-")))
                .join("chains.csv"),
        )
        .unwrap()
    };
    assert_eq!(chains("1"), chains("2"), "chains.csv differs");
}
