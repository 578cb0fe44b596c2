//! `surae diagnose`'s report: it ends with the command line that identifies the muscle
//! parameters with the named causes (the baseline's when none is named), printed again as the
//! last line of the terminal summary; a trial with structure no catalogued effect explains
//! gets the "Beyond the catalogue" section with the flexible terms' figure, and a figure an
//! earlier run left in the folder that this run does not draw is removed. The bundled
//! trial's summary is the one docs/diagnosis.md shows.
//!
//! The trial hiding a 40 ms electromechanical delay is synthesised here (relaxed+2 protocol,
//! seed 11); the uncatalogued ones are `diagnose::scenarios::uncatalogued_trial` (Coulomb
//! friction and TA crosstalk, seed 7 100 000): the crosstalk trial's report has the "EMG
//! crosstalk" section, and `surae identify` corrects the same channel by the same share, with
//! `--trial` and in a session. Set `DIAGNOSE_REPORT_KEEP=DIR` to keep the friction trial's
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
    summary_is_the_documented_one(&o);
}

/// The terminal summary docs/diagnosis.md shows for the bundled trial ("Reading the terminal
/// summary") is what `surae diagnose` prints, line by line, except the run time on the `work`
/// line and the output folder on the `wrote` line.
fn summary_is_the_documented_one(o: &std::process::Output) {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../docs/diagnosis.md");
    let doc = std::fs::read_to_string(&path).unwrap();
    let after = doc
        .split("On the bundled trial (`surae diagnose`):")
        .nth(1)
        .expect("docs/diagnosis.md shows the bundled trial's summary");
    let block = after
        .split("```text\n")
        .nth(1)
        .and_then(|b| b.split("```").next())
        .expect("a text block");
    let printed = String::from_utf8_lossy(&o.stdout);
    let printed: Vec<&str> = printed.lines().filter(|l| !l.trim().is_empty()).collect();
    let documented: Vec<&str> = block.lines().filter(|l| !l.trim().is_empty()).collect();
    assert_eq!(printed.len(), documented.len(), "{printed:#?}");
    // `work  11000 simulations, 4.3 s`: the simulations, not the time
    let untimed = |l: &str| l.split(", ").next().unwrap_or(l).to_string();
    for (p, d) in printed.iter().zip(&documented) {
        if d.starts_with("wrote ") {
            assert!(p.starts_with("wrote "), "{p}");
        } else if d.starts_with("work ") {
            assert_eq!(untimed(p), untimed(d));
        } else {
            assert_eq!(
                p, d,
                "docs/diagnosis.md shows another summary than the program prints"
            );
        }
    }
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

/// Writes the trial hiding `kind` (seed 7 100 000) and its unloaded run into `dir`, and runs
/// `surae diagnose` on them into `dir/out`.
fn diagnose_uncatalogued(
    kind: diagnose::scenarios::Uncatalogued,
    dir: &Path,
) -> (diagnose::scenarios::UncataloguedTrial, std::process::Output) {
    let t = diagnose::scenarios::uncatalogued_trial(kind, 7_100_000).unwrap();
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
    (t, o)
}

#[test]
fn uncatalogued_friction_gets_the_flexible_terms() {
    let keep = std::env::var_os("DIAGNOSE_REPORT_KEEP").map(std::path::PathBuf::from);
    let tmp = tempfile::tempdir().unwrap();
    let dir = keep.as_deref().unwrap_or(tmp.path());
    std::fs::create_dir_all(dir).unwrap();
    let (_, o) = diagnose_uncatalogued(diagnose::scenarios::Uncatalogued::CoulombFriction, dir);
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
    // a searched value of a term's shape (the friction's transition width) is in
    // diagnosis.json, the report and the summary
    let searched: Vec<(String, f64)> = u["extension"]["terms"]
        .as_array()
        .unwrap()
        .iter()
        .flat_map(|t| t["searched"].as_array().unwrap().clone())
        .map(|v| {
            (
                v["name"].as_str().unwrap().to_string(),
                v["value"].as_f64().unwrap(),
            )
        })
        .collect();
    assert!(
        searched.iter().any(|(n, _)| n == "transition_width"),
        "{searched:?}"
    );
    let summary = String::from_utf8_lossy(&o.stdout);
    for (name, value) in &searched {
        assert!(
            html.contains(&format!("{value:.2}")),
            "{name} {value} in the report"
        );
        assert!(
            summary.contains(&format!("{} {value:.3}", name.replace('_', " "))),
            "{name} {value} in the summary"
        );
    }
    // the report and the summary still end with the command line
    let end = last_section(&html);
    assert!(end.contains("surae identify --method mcmc --trial trial.csv"));
    assert!(last_line(&o).contains("surae identify --method mcmc --trial trial.csv"));
}

#[test]
fn emg_crosstalk_is_reported_and_corrected() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path();
    let (t, o) = diagnose_uncatalogued(diagnose::scenarios::Uncatalogued::EmgCrosstalk, dir);
    let stdout = String::from_utf8_lossy(&o.stdout);
    let line = stdout
        .lines()
        .find(|l| l.starts_with("crosstalk"))
        .unwrap_or_else(|| panic!("no crosstalk line:\n{stdout}"));
    assert!(line.contains("emg_sol carried"), "{line}");
    assert!(line.contains("removed before fitting"), "{line}");
    let d = json(&dir.join("out/diagnosis.json"));
    let checks = d["emg_crosstalk"].as_array().expect("emg_crosstalk[]");
    assert_eq!(checks.len(), 3);
    assert_eq!(checks[0]["channel"], "emg_sol");
    assert_eq!(checks[0]["corrected"], true);
    // the CSV's 4-decimal EMG keeps the share within 5 standard errors of the truth
    let f = checks[0]["fraction"].as_f64().unwrap();
    let se = checks[0]["fraction_se"].as_f64().unwrap();
    assert!((f - t.size).abs() < 5.0 * se, "{f} ± {se} for {}", t.size);
    let c = &d["emg_correction"];
    assert!(
        c["heldout_rms_nm"].as_f64().unwrap() < c["heldout_rms_uncorrected_nm"].as_f64().unwrap(),
        "{c}"
    );
    assert_eq!(d["verdict"], "deficient");
    assert_eq!(d["unexplained"]["depends_on"][0], "activation");
    assert_eq!(
        d["causes"].as_array().map(Vec::len),
        Some(0),
        "{}",
        d["causes"]
    );
    let html = std::fs::read_to_string(dir.join("out/report.html")).unwrap();
    assert!(html.contains("<h2>EMG crosstalk</h2>"));
    assert!(html.contains("emg_sol carried"));
    assert!(
        !html.contains("No state variable"),
        "the crosstalk section explains it"
    );
    // identify corrects the same channel by the same share, and its model then fits; a
    // session of this one trial is corrected as the trial is, so it identifies the same
    let trial = ["--trial", "trial.csv", "--unloaded", "unloaded.csv"];
    identify_with_crosstalk_line(dir, &trial, "identified", "crosstalk");
    let id = json(&dir.join("identified/identify.json"));
    assert_eq!(id["emg_crosstalk"], d["emg_crosstalk"]);
    assert!(id["adequacy"]["warning"].is_null(), "{}", id["adequacy"]);
    common::one_trial_session(dir, "xt");
    identify_with_crosstalk_line(
        dir,
        &["--session", "session.json"],
        "by_session",
        "xt: crosstalk",
    );
    let s = json(&dir.join("by_session/identify.json"));
    assert_eq!(s["trials"][0]["emg_crosstalk"], d["emg_crosstalk"]);
    assert_eq!(s["params"], id["params"]);
}

/// Runs `surae identify --method sa` on `source` into `out` in `dir` and asserts that its
/// summary has a line starting with `lead` that reports the soleus channel's correction.
fn identify_with_crosstalk_line(dir: &Path, source: &[&str], out: &str, lead: &str) {
    let mut args = vec!["identify", "--method", "sa"];
    args.extend_from_slice(source);
    args.extend(["--out", out]);
    let o = surae(&args, dir);
    ok(&o);
    let stdout = String::from_utf8_lossy(&o.stdout);
    assert!(
        stdout
            .lines()
            .any(|l| l.starts_with(lead) && l.contains("emg_sol carried")),
        "{stdout}"
    );
}

#[test]
fn antagonist_fixture_has_no_crosstalk() {
    let tmp = tempfile::tempdir().unwrap();
    let fx = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../fixtures/antagonist_coactivation");
    let o = surae(
        &[
            "diagnose",
            "--trial",
            fx.join("trial.csv").to_str().unwrap(),
            "--unloaded",
            fx.join("unloaded.csv").to_str().unwrap(),
            "--out",
            "out",
        ],
        tmp.path(),
    );
    ok(&o);
    let d = json(&tmp.path().join("out/diagnosis.json"));
    let checks = d["emg_crosstalk"].as_array().expect("emg_crosstalk[]");
    assert_eq!(checks.len(), 3);
    assert!(checks.iter().all(|c| c["corrected"] == false), "{checks:?}");
    assert!(d.get("emg_correction").is_none());
    let stdout = String::from_utf8_lossy(&o.stdout);
    assert!(
        stdout.contains("crosstalk    none from emg_ta in the raw EMG"),
        "{stdout}"
    );
}
