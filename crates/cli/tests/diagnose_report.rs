//! `surae diagnose`'s report: it ends with the command line that identifies the muscle
//! parameters with the named causes (the baseline's when none is named), printed again as the
//! last line of the terminal summary; a trial with structure no catalogued effect explains
//! gets the "Beyond the catalogue" section with the flexible terms' figure, and a figure an
//! earlier run left in the folder that this run does not draw is removed.
//!
//! The trial hiding a 40 ms electromechanical delay is synthesised here (relaxed+2 protocol,
//! seed 11); the uncatalogued one is `diagnose::scenarios::uncatalogued_trial` (Coulomb
//! friction, seed 7 100 000). Set `DIAGNOSE_REPORT_KEEP=DIR` to keep the friction trial's
//! files and report in `DIR` (e.g. for `cargo xtask render-check DIR/out/report.html`).

mod common;

use common::{json, ok, surae};
use std::path::Path;

/// The report's last section: from its last `<h2>` to the end of the page.
fn last_section(html: &str) -> &str {
    let at = html.rfind("<h2>").expect("the report has sections");
    &html[at..]
}

/// Standard output's last non-empty line.
fn last_line(o: &std::process::Output) -> String {
    String::from_utf8_lossy(&o.stdout)
        .lines()
        .rev()
        .find(|l| !l.trim().is_empty())
        .unwrap_or_default()
        .to_string()
}

/// Writes a synthetic trial's `trial.csv` and `unloaded.csv` into `dir`.
fn write_trial(dir: &Path, s: &experiment::Synthetic) {
    experiment::write_trial(dir.join("trial.csv"), &s.trial).unwrap();
    experiment::write_unloaded(dir.join("unloaded.csv"), &s.unloaded).unwrap();
}

#[test]
fn bundled_trial_ends_with_the_baseline_command_and_stale_figures_go() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out");
    std::fs::create_dir_all(&out).unwrap();
    // a figure an earlier run may have left: this run does not draw it
    std::fs::write(out.join("flexible_terms.svg"), "<svg/>").unwrap();
    let o = surae(&["diagnose", "--out", "out"], dir.path());
    ok(&o);
    let d = json(&out.join("diagnosis.json"));
    assert!(
        d["causes"].as_array().unwrap().is_empty(),
        "{}",
        d["causes"]
    );
    assert!(d.get("unexplained").is_none());
    let html = std::fs::read_to_string(out.join("report.html")).unwrap();
    let end = last_section(&html);
    assert!(end.contains("surae identify --method mcmc"), "{end}");
    assert!(!end.contains("--with"), "{end}");
    assert!(end.contains("identifies the baseline model"), "{end}");
    assert!(!html.contains("Beyond the catalogue"));
    let last = last_line(&o);
    assert!(
        last.contains("`surae identify --method mcmc`") && !last.contains("--with"),
        "{last}"
    );
    assert!(
        !out.join("flexible_terms.svg").exists(),
        "the flexible terms of an earlier run left in place"
    );
    assert!(out.join("candidates.svg").is_file());
}

#[test]
fn hidden_delay_ends_with_the_command_that_identifies_it() {
    let dir = tempfile::tempdir().unwrap();
    let effects =
        muscle_model::Effects::from_json_str(r#"{"electromechanical_delay": {"delay_ms": 40}}"#)
            .unwrap();
    let s = experiment::synthesize(
        &experiment::SynthConfig::new("relaxed+2".parse().unwrap(), 11).with_effects(effects),
    )
    .unwrap();
    write_trial(dir.path(), &s);
    let o = surae(
        &[
            "diagnose",
            "--trial",
            "trial.csv",
            "--unloaded",
            "unloaded.csv",
            "--out",
            "out",
        ],
        dir.path(),
    );
    ok(&o);
    let d = json(&dir.path().join("out/diagnosis.json"));
    assert_eq!(d["causes"], serde_json::json!(["electromechanical_delay"]));
    let command = "surae identify --method mcmc --trial trial.csv --unloaded unloaded.csv \
                   --with electromechanical_delay";
    let html = std::fs::read_to_string(dir.path().join("out/report.html")).unwrap();
    let end = last_section(&html);
    assert!(
        end.contains("Identify the muscle parameters with the named causes:"),
        "{end}"
    );
    let pre = end
        .split("<pre>")
        .nth(1)
        .and_then(|p| p.split("</pre>").next())
        .expect("the command in a <pre> block");
    assert_eq!(pre, command);
    let last = last_line(&o);
    assert!(last.ends_with(command), "{last}");
}

#[test]
fn uncatalogued_friction_gets_the_flexible_terms() {
    let keep = std::env::var_os("DIAGNOSE_REPORT_KEEP").map(std::path::PathBuf::from);
    let tmp = tempfile::tempdir().unwrap();
    let dir = keep.as_deref().unwrap_or(tmp.path());
    std::fs::create_dir_all(dir).unwrap();
    let t = diagnose::scenarios::uncatalogued_trial(
        diagnose::scenarios::Uncatalogued::CoulombFriction,
        7_100_000,
    )
    .unwrap();
    write_trial(dir, &t.hidden.synthetic);
    let o = surae(
        &[
            "diagnose",
            "--trial",
            "trial.csv",
            "--unloaded",
            "unloaded.csv",
            "--out",
            "out",
        ],
        dir,
    );
    ok(&o);
    let out = dir.join("out");
    let d = json(&out.join("diagnosis.json"));
    let u = &d["unexplained"];
    assert!(u.is_object(), "no unexplained structure: {d}");
    assert!(
        u["extension"].is_object(),
        "no flexible extension: {}",
        u["extension"]
    );
    let html = std::fs::read_to_string(out.join("report.html")).unwrap();
    assert!(html.contains("<h2>Beyond the catalogue</h2>"));
    assert!(html.contains("held-out deviance gain"));
    let first = u["depends_on"][0].as_str().unwrap();
    assert!(
        html.contains(&format!("depends on {first} (held-out deviance gain")),
        "{first}"
    );
    let svg = std::fs::read_to_string(out.join("flexible_terms.svg")).unwrap();
    let s = report::check_svg(&svg).expect("well-formed SVG");
    assert!(s.has_text(&format!("{first} term (N·m)")), "{:?}", s.texts);
    assert!(html.contains("The flexible term"));
    // the report and the summary still end with the command line
    let end = last_section(&html);
    assert!(end.contains("surae identify --method mcmc --trial trial.csv"));
    assert!(last_line(&o).contains("surae identify --method mcmc --trial trial.csv"));
}
