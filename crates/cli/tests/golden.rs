//! The JSON every job writes, compared with recorded copies (`tests/golden/*.json`): the
//! command line and the library under it may be rearranged, but what a user gets must not
//! move. The copies are the files as the program wrote them; every `wall_s` (a measured time)
//! is left out of the comparison, and everything else must be equal, number for number.
//!
//! After a change that is meant to move the results, record them again with
//! `SURAE_RECORD_GOLDEN=1 cargo test --release -p cli --test golden` and say why in the commit.

mod common;

use common::{ok, surae};
use serde_json::Value;
use std::path::{Path, PathBuf};

fn repo_root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

/// `v` without any member named `wall_s`, at any depth.
fn without_wall_time(v: &Value) -> Value {
    match v {
        Value::Object(m) => Value::Object(
            m.iter()
                .filter(|(k, _)| k.as_str() != "wall_s")
                .map(|(k, v)| (k.clone(), without_wall_time(v)))
                .collect(),
        ),
        Value::Array(a) => Value::Array(a.iter().map(without_wall_time).collect()),
        other => other.clone(),
    }
}

/// The first path at which `got` and `want` differ, for the failure message.
fn first_difference(got: &Value, want: &Value, at: &str) -> Option<String> {
    match (got, want) {
        (Value::Object(g), Value::Object(w)) => {
            for k in w.keys().chain(g.keys()) {
                match (g.get(k), w.get(k)) {
                    (Some(a), Some(b)) => {
                        if let Some(d) = first_difference(a, b, &format!("{at}/{k}")) {
                            return Some(d);
                        }
                    }
                    (None, _) => return Some(format!("{at}/{k}: missing")),
                    (_, None) => return Some(format!("{at}/{k}: not in the recorded copy")),
                }
            }
            None
        }
        (Value::Array(g), Value::Array(w)) if g.len() == w.len() => g
            .iter()
            .zip(w)
            .enumerate()
            .find_map(|(i, (a, b))| first_difference(a, b, &format!("{at}[{i}]"))),
        _ if got == want => None,
        _ => Some(format!("{at}: {got} (recorded {want})")),
    }
}

/// Runs `args` from the repository's root with `--out` in a fresh folder, and compares the
/// JSON files `files` (relative to that folder) with `tests/golden/<name>.<file>`.
fn check(name: &str, args: &[&str], files: &[&str]) {
    let root = repo_root();
    let out = tempfile::tempdir().unwrap();
    let out_arg = out.path().display().to_string();
    let mut full: Vec<&str> = args.to_vec();
    full.extend(["--out", &out_arg]);
    // simulate prints a short summary and has no --quiet
    if args[0] != "simulate" {
        full.push("--quiet");
    }
    let o = surae(&full, &root);
    ok(&o);
    let record = std::env::var_os("SURAE_RECORD_GOLDEN").is_some();
    for file in files {
        let got = without_wall_time(&common::json(&out.path().join(file)));
        let golden = Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("tests/golden")
            .join(format!("{name}.{}", file.replace('/', ".")));
        if record {
            // the file as written, so that both sides of a later comparison are parsed from
            // numbers the program printed (serde_json's parser is exact only on such text)
            std::fs::copy(out.path().join(file), &golden).unwrap();
            continue;
        }
        let want = without_wall_time(&common::json(&golden));
        if let Some(d) = first_difference(&got, &want, "") {
            panic!(
                "surae {}: {file} differs from {}: {d}",
                args.join(" "),
                golden.display()
            );
        }
    }
}

#[test]
fn bundled_identify_sa() {
    check(
        "identify_sa",
        &["identify", "--method", "sa"],
        &["identify.json"],
    );
}

#[test]
fn bundled_identify_mcmc() {
    check(
        "identify_mcmc",
        &["identify", "--method", "mcmc"],
        &["identify.json"],
    );
}

#[test]
fn bundled_diagnose() {
    check("diagnose", &["diagnose"], &["diagnosis.json"]);
}

#[test]
fn session3_identify_sa() {
    check(
        "session3_identify_sa",
        &[
            "identify",
            "--method",
            "sa",
            "--session",
            "fixtures/session3/session.json",
        ],
        &["identify.json"],
    );
}

#[test]
fn session3_identify_mcmc() {
    check(
        "session3_identify_mcmc",
        &[
            "identify",
            "--method",
            "mcmc",
            "--session",
            "fixtures/session3/session.json",
        ],
        &["identify.json"],
    );
}

#[test]
fn session3_diagnose() {
    check(
        "session3_diagnose",
        &["diagnose", "--session", "fixtures/session3/session.json"],
        &[
            "diagnosis_session.json",
            "knee0_30/diagnosis.json",
            "knee0_60/diagnosis.json",
            "knee90_30/diagnosis.json",
        ],
    );
}

#[test]
fn design_two_protocols() {
    check(
        "design",
        &[
            "design",
            "--protocol",
            "knee0@30",
            "--protocol",
            "knee0@30,knee90@30,knee0@60",
        ],
        &["design.json"],
    );
}

#[test]
fn inspect_a_recording_map() {
    check(
        "inspect_map",
        &["inspect", "fixtures/formats/noraxon/map.json"],
        &["inspect.json"],
    );
}

#[test]
fn session3_simulate() {
    check(
        "session3_simulate",
        &["simulate", "--session", "fixtures/session3/session.json"],
        &["simulate.json"],
    );
}
