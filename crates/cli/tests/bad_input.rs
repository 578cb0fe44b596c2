//! Bad input for every command that reads input, table-driven: each corrupted
//! trial, unloaded run, parameters / effects / truth JSON and bad option is run
//! through every command that takes it, and must give exit code 2, exactly one
//! line on standard error that names the file (with `:line:column` where that
//! applies), no panic, and no new or changed file anywhere in the working
//! folder (the `--out` folder is not even created).
//!
//! The corrupted files are built here from a valid base,
//! `tests/data/external_trial.csv` (1000 Hz, 2.5 s, seven columns, one `#`
//! comment line, so data rows start on physical line 3), so the corpus is not
//! stored in the repository. No test here runs a fit: every `identify` case
//! fails while its inputs are read.

mod common;

use common::snapshot;
use std::path::Path;
use std::process::{Command, Output};

/// The valid base trial every corrupted trial is made from.
const BASE: &str = include_str!("data/external_trial.csv");

/// Commands that read `--trial`.
const TRIAL_COMMANDS: &[&[&str]] = &[
    &["envelope"],
    &["simulate"],
    &["sensitivity"],
    &["identify", "--method", "sa", "--quiet"],
    &["identify", "--method", "mcmc", "--quiet"],
    &["diagnose", "--quiet"],
];

/// Commands that read `--params` and `--effects`.
const MODEL_COMMANDS: &[&[&str]] = &[
    &["simulate"],
    &["sensitivity"],
    &["identify", "--method", "sa", "--quiet"],
    &["identify", "--method", "mcmc", "--quiet"],
];

/// Commands that read `--unloaded`.
const UNLOADED_COMMANDS: &[&[&str]] = &[
    &["identify", "--method", "sa", "--quiet"],
    &["identify", "--method", "mcmc", "--quiet"],
    &["diagnose", "--quiet"],
];

/// Commands that read `--truth`.
const IDENTIFY_COMMANDS: &[&[&str]] = &[
    &["identify", "--method", "sa", "--quiet"],
    &["identify", "--method", "mcmc", "--quiet"],
];

/// Where every case asks for its output: must not exist afterwards.
const OUT: &str = "fresh_out";

/// One bad input: the files to create, the arguments that name them, and the
/// strings the one-line message must contain.
struct Bad {
    what: String,
    /// `(name, content)`; a name ending in `/` is created as an empty folder.
    files: Vec<(String, Vec<u8>)>,
    args: Vec<String>,
    needles: Vec<String>,
}

fn bad(what: &str, files: &[(&str, Vec<u8>)], args: &[&str], needles: &[&str]) -> Bad {
    Bad {
        what: what.to_string(),
        files: files
            .iter()
            .map(|(n, c)| ((*n).to_string(), c.clone()))
            .collect(),
        args: args.iter().map(|s| (*s).to_string()).collect(),
        needles: needles.iter().map(|s| (*s).to_string()).collect(),
    }
}

fn surae(args: &[String], cwd: &Path) -> Output {
    Command::new(env!("CARGO_BIN_EXE_surae"))
        .args(args)
        .current_dir(cwd)
        .output()
        .expect("the surae binary runs")
}

/// Runs `command` on `case` in a fresh folder; `Err` describes what is wrong.
fn check(command: &[&str], case: &Bad, with_out: bool) -> Result<(), String> {
    let dir = tempfile::tempdir().unwrap();
    for (name, content) in &case.files {
        let p = dir.path().join(name);
        if name.ends_with('/') {
            std::fs::create_dir_all(&p).unwrap();
        } else {
            std::fs::create_dir_all(p.parent().unwrap()).unwrap();
            std::fs::write(&p, content).unwrap();
        }
    }
    let before = snapshot(dir.path());
    let mut args: Vec<String> = command.iter().map(|s| (*s).to_string()).collect();
    args.extend(case.args.iter().cloned());
    if with_out {
        args.push("--out".into());
        args.push(OUT.into());
    }
    let o = surae(&args, dir.path());
    let err = String::from_utf8_lossy(&o.stderr).into_owned();
    let label = format!("{} [{}]", case.what, args.join(" "));
    let mut problems = common::refusal_problems(&o, &case.needles);
    let after = snapshot(dir.path());
    if after != before {
        let new: Vec<String> = after
            .keys()
            .filter(|k| before.get(*k) != after.get(*k))
            .map(|k| k.display().to_string())
            .collect();
        problems.push(format!("files were created or changed: {new:?}"));
    }
    if problems.is_empty() {
        Ok(())
    } else {
        Err(format!(
            "{label}: {} — stderr: {err:?}",
            problems.join("; ")
        ))
    }
}

/// Runs every case through every command and reports all failures at once.
fn run_all(commands: &[&[&str]], cases: &[Bad]) {
    let mut failures = Vec::new();
    let mut n = 0;
    for case in cases {
        for cmd in commands {
            n += 1;
            if let Err(e) = check(cmd, case, true) {
                failures.push(e);
            }
        }
    }
    assert!(
        failures.is_empty(),
        "{} of {n} bad-input runs misbehaved:\n{}",
        failures.len(),
        failures.join("\n")
    );
}

// ---------------------------------------------------------------------------------------------
// Building corrupted files from the base
// ---------------------------------------------------------------------------------------------

/// The base trial's physical lines (index 0 is physical line 1).
fn base_lines() -> Vec<String> {
    BASE.lines().map(str::to_string).collect()
}

fn join(lines: &[String]) -> Vec<u8> {
    let mut s = lines.join("\n");
    s.push('\n');
    s.into_bytes()
}

/// The base with `f` applied to its lines.
fn edited(f: impl FnOnce(&mut Vec<String>)) -> Vec<u8> {
    let mut l = base_lines();
    f(&mut l);
    join(&l)
}

/// Sets field `col` (1-based) of physical line `line` (1-based).
fn set_cell(lines: &mut [String], line: usize, col: usize, value: &str) {
    let mut f: Vec<String> = lines[line - 1].split(',').map(str::to_string).collect();
    f[col - 1] = value.to_string();
    lines[line - 1] = f.join(",");
}

/// Sets field `col` of every data row (physical line 3 on).
fn set_column(lines: &mut [String], col: usize, value: &str) {
    for line in 3..=lines.len() {
        set_cell(lines, line, col, value);
    }
}

/// Removes field `col` from every line but the comment.
fn drop_column(lines: &mut [String], col: usize) {
    for l in lines.iter_mut().skip(1) {
        let mut f: Vec<&str> = l.split(',').collect();
        f.remove(col - 1);
        *l = f.join(",");
    }
}

/// The time of physical line `line`.
fn time_of(lines: &[String], line: usize) -> String {
    lines[line - 1].split(',').next().unwrap().to_string()
}

/// Seeded junk bytes (xorshift), with a NUL so that it is never text.
fn junk(n: usize, seed: u64) -> Vec<u8> {
    let mut x = seed | 1;
    let mut v: Vec<u8> = (0..n)
        .map(|_| {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            (x >> 24) as u8
        })
        .collect();
    v[n / 3] = 0;
    v
}

/// The base as UTF-16LE with a byte-order mark (a spreadsheet's "Unicode text").
fn utf16(text: &str) -> Vec<u8> {
    let mut v = vec![0xFF, 0xFE];
    for u in text.encode_utf16() {
        v.extend_from_slice(&u.to_le_bytes());
    }
    v
}

/// The base's first three columns: a valid unloaded run with the trial's time base.
fn base_unloaded_lines() -> Vec<String> {
    base_lines()
        .iter()
        .enumerate()
        .map(|(i, l)| {
            if i == 0 {
                "# unloaded run made from the first three columns of external_trial.csv".into()
            } else {
                l.split(',').take(3).collect::<Vec<_>>().join(",")
            }
        })
        .collect()
}

fn unloaded_edited(f: impl FnOnce(&mut Vec<String>)) -> Vec<u8> {
    let mut l = base_unloaded_lines();
    f(&mut l);
    join(&l)
}

/// Corruptions of a CSV (trial or unloaded run) that apply to both, named
/// `name`, as `(what, content, needles)`. `lines` is the valid base.
fn csv_corruptions(name: &str, base: &[String]) -> Vec<(String, Vec<u8>, Vec<String>)> {
    let ncol = base[1].split(',').count();
    let ed = |f: &dyn Fn(&mut Vec<String>)| {
        let mut l = base.to_vec();
        f(&mut l);
        join(&l)
    };
    let n = |s: &str| s.replace("{F}", name);
    let mut v: Vec<(String, Vec<u8>, Vec<String>)> = Vec::new();
    let mut add = |what: &str, content: Vec<u8>, needles: &[&str]| {
        v.push((what.into(), content, needles.iter().map(|s| n(s)).collect()));
    };
    add("empty file", Vec::new(), &["{F}:", "empty"]);
    add(
        "only comments and blank lines",
        b"# nothing here\n\n#\n   \n".to_vec(),
        &["{F}:", "empty"],
    );
    add(
        "header only",
        ed(&|l| l.truncate(2)),
        &["{F}:2:", "header only"],
    );
    add(
        "header only, CRLF",
        ed(&|l| l.truncate(2))
            .iter()
            .flat_map(|&b| {
                if b == b'\n' {
                    vec![b'\r', b'\n']
                } else {
                    vec![b]
                }
            })
            .collect(),
        &["{F}:2:", "header only"],
    );
    add(
        "missing required column torque_nm",
        ed(&|l| drop_column(l, 3)),
        &["{F}:2:", "torque_nm"],
    );
    add(
        "renamed required column (Time_S)",
        ed(&|l| l[1] = l[1].replacen("time_s", "Time_S", 1)),
        &["{F}:2:1 ", "time_s"],
    );
    add(
        "renamed required column (torque)",
        ed(&|l| l[1] = l[1].replacen("torque_nm", "torque", 1)),
        &["{F}:2:", "torque_nm"],
    );
    add(
        "duplicate column",
        ed(&|l| l[1] = l[1].replacen("ankle_angle_deg", "time_s", 1)),
        &["{F}:2:2 ", "twice"],
    );
    add(
        "empty column name",
        ed(&|l| l[1] = l[1].replacen("torque_nm", "", 1)),
        &["{F}:2:3 ", "empty column name"],
    );
    add(
        "text in a numeric cell",
        ed(&|l| set_cell(l, 10, 3, "abc")),
        &["{F}:10:3 ", "torque_nm", "not a number"],
    );
    add(
        "NaN in a numeric cell",
        ed(&|l| set_cell(l, 11, 2, "NaN")),
        &["{F}:11:2 ", "ankle_angle_deg", "finite"],
    );
    add(
        "infinity in a numeric cell",
        ed(&|l| set_cell(l, 12, 1, "-inf")),
        &["{F}:12:1 ", "time_s", "finite"],
    );
    add(
        "empty cell",
        ed(&|l| set_cell(l, 13, 3, " ")),
        &["{F}:13:3 ", "empty cell"],
    );
    add(
        "a decimal comma in one cell",
        ed(&|l| {
            let t = l[13].clone();
            l[13] = t.replacen('.', ",", 2);
        }),
        &["{F}:14:", "too many fields"],
    );
    add(
        "time going backwards",
        ed(&|l| {
            let t = time_of(l, 98);
            set_cell(l, 100, 1, &t);
        }),
        &["{F}:100:1 ", "backwards"],
    );
    add(
        "time repeating",
        ed(&|l| {
            let t = time_of(l, 199);
            set_cell(l, 200, 1, &t);
        }),
        &["{F}:200:1 ", "does not increase"],
    );
    add(
        "a gap in time (10 rows missing)",
        ed(&|l| {
            l.drain(499..509);
        }),
        &["{F}:500:1 ", "gap"],
    );
    add(
        "non-uniform sampling",
        ed(&|l| {
            let t: f64 = time_of(l, 300).parse().unwrap();
            set_cell(l, 300, 1, &format!("{}", t + 2e-4));
        }),
        &["{F}:300:1 ", "non-uniform"],
    );
    add(
        "fewer than 1 s of samples (0.9 s)",
        ed(&|l| l.truncate(2 + 900)),
        &["{F}:", "too short"],
    );
    add(
        "a single row",
        ed(&|l| l.truncate(3)),
        &["{F}:", "too short"],
    );
    add(
        "a row with too few fields",
        ed(&|l| {
            let mut f: Vec<&str> = l[49].split(',').collect();
            f.pop();
            l[49] = f.join(",");
        }),
        &["{F}:50:", "too few fields"],
    );
    add(
        "a truncated last row",
        ed(&|l| {
            let last = l.len() - 1;
            let cut = l[last].find(',').unwrap() + 3;
            l[last].truncate(cut);
        }),
        &[&format!("{{F}}:{}:", base.len()), "too few fields"],
    );
    add(
        "a row with too many fields",
        ed(&|l| l[50].push_str(",1.5")),
        &["{F}:51:", "too many fields"],
    );
    add(
        "semicolon delimiter",
        ed(&|l| {
            for x in l.iter_mut() {
                *x = x.replace(',', ";");
            }
        }),
        &["{F}:2:", "delimiter"],
    );
    add(
        "tab delimiter",
        ed(&|l| {
            for x in l.iter_mut() {
                *x = x.replace(',', "\t");
            }
        }),
        &["{F}:2:", "delimiter"],
    );
    add(
        "semicolons and decimal commas",
        ed(&|l| {
            for x in l.iter_mut().skip(1) {
                *x = x.replace(',', ";").replace('.', ",");
            }
        }),
        &["{F}:2:", "delimiter"],
    );
    add("binary junk", junk(4096, 0x5eed), &["{F}:"]);
    add(
        "gzip data",
        [&[0x1f_u8, 0x8b, 0x08, 0x00][..], &junk(512, 7)].concat(),
        &["{F}:1:", "UTF-8"],
    );
    add(
        "UTF-16 text",
        utf16(&String::from_utf8(ed(&|_| {})).unwrap()),
        &["{F}:1:", "UTF-8"],
    );
    add(
        "Latin-1 byte in a comment",
        [&b"# Paciente Jo\xe3o\n"[..], &ed(&|_| {})].concat(),
        &["{F}:1:", "UTF-8"],
    );
    add(
        "NUL byte in a row",
        ed(&|l| l[19].insert(3, '\0')),
        &["{F}:20:", "control character"],
    );
    add(
        "a lone carriage return inside a row",
        ed(&|l| l[20].insert(4, '\r')),
        &["{F}:21:", "control character"],
    );
    assert!(ncol >= 3);
    v
}

/// Trial-only corruptions (EMG channels).
fn trial_only_corruptions() -> Vec<(String, Vec<u8>, Vec<String>)> {
    vec![
        (
            "EMG channel all zeros (emg_gm)".into(),
            edited(|l| set_column(l, 5, "0")),
            vec!["t.csv:".into(), "emg_gm".into(), "zeros".into()],
        ),
        (
            "EMG channel all signed zeros (emg_sol)".into(),
            edited(|l| set_column(l, 4, "-0.0")),
            vec!["t.csv:".into(), "emg_sol".into(), "zeros".into()],
        ),
        (
            "optional EMG channel all zeros (emg_ta)".into(),
            edited(|l| set_column(l, 7, "0e0")),
            vec!["t.csv:".into(), "emg_ta".into(), "zeros".into()],
        ),
    ]
}

// ---------------------------------------------------------------------------------------------
// The tests
// ---------------------------------------------------------------------------------------------

#[test]
fn the_base_files_are_valid_and_crlf_comments_and_a_bom_are_accepted() {
    // The corrupted files differ from a file that works: the base trial
    // simulates, and a CRLF copy with a byte-order mark, extra `#` comment
    // lines between rows and blank lines gives the same output byte for byte.
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("t.csv"), BASE).unwrap();
    let mut odd = String::from("\u{FEFF}# exported on a Windows machine\r\n");
    for (i, l) in BASE.lines().enumerate() {
        odd.push_str(l);
        odd.push_str("\r\n");
        if i % 500 == 7 {
            odd.push_str("# a comment between rows\r\n\r\n");
        }
    }
    std::fs::write(dir.path().join("crlf.csv"), odd).unwrap();
    let args = |t: &str, o: &str| -> Vec<String> {
        ["simulate", "--trial", t, "--out", o]
            .iter()
            .map(|s| (*s).to_string())
            .collect()
    };
    let a = surae(&args("t.csv", "a.csv"), dir.path());
    assert!(a.status.success(), "{}", String::from_utf8_lossy(&a.stderr));
    let b = surae(&args("crlf.csv", "b.csv"), dir.path());
    assert!(b.status.success(), "{}", String::from_utf8_lossy(&b.stderr));
    let ta = std::fs::read(dir.path().join("a.csv")).unwrap();
    assert_eq!(ta.iter().filter(|&&c| c == b'\n').count(), 2501);
    assert_eq!(ta, std::fs::read(dir.path().join("b.csv")).unwrap());
}

#[test]
fn valid_trial_and_unloaded_files_get_past_reading_in_identify() {
    // Positive control for the unloaded base (and a CRLF unloaded run): with a
    // bad truth file, the one error is about the truth, so the trial and the
    // unloaded run were read; no fit is run.
    let crlf: Vec<u8> = String::from_utf8(unloaded_edited(|_| {}))
        .unwrap()
        .replace('\n', "\r\n")
        .into_bytes();
    for unloaded in [unloaded_edited(|_| {}), crlf] {
        let case = bad(
            "valid trial and unloaded, bad truth",
            &[
                ("t.csv", BASE.as_bytes().to_vec()),
                ("u.csv", unloaded),
                (
                    "truth.json",
                    b"{\"muscles\": {\"sol\": {\"fom_n\": -1}}}".to_vec(),
                ),
            ],
            &[
                "--trial",
                "t.csv",
                "--unloaded",
                "u.csv",
                "--truth",
                "truth.json",
            ],
            &["truth.json", "fom_n"],
        );
        run_all(IDENTIFY_COMMANDS, &[case]);
    }
}

#[test]
fn bad_trials_exit_2_naming_file_line_and_column_in_every_command() {
    let base = base_lines();
    let mut cases: Vec<Bad> = csv_corruptions("t.csv", &base)
        .into_iter()
        .chain(trial_only_corruptions())
        .map(|(what, content, needles)| Bad {
            what,
            files: vec![("t.csv".into(), content)],
            args: vec!["--trial".into(), "t.csv".into()],
            needles,
        })
        .collect();
    cases.push(bad(
        "a path that does not exist",
        &[],
        &["--trial", "no/such/trial.csv"],
        &["no/such/trial.csv", "no such file"],
    ));
    cases.push(bad(
        "a folder instead of a file",
        &[("d.csv/", Vec::new())],
        &["--trial", "d.csv"],
        &["d.csv", "folder"],
    ));
    cases.push(bad(
        "a JSON file given as the trial",
        &[("t.csv", b"{\"muscles\": {}}\n".to_vec())],
        &["--trial", "t.csv"],
        &["t.csv:1:", "time_s"],
    ));
    run_all(TRIAL_COMMANDS, &cases);
}

#[test]
fn bad_unloaded_runs_exit_2_naming_file_line_and_column() {
    let base = base_unloaded_lines();
    let mut cases: Vec<Bad> = csv_corruptions("u.csv", &base)
        .into_iter()
        .map(|(what, content, needles)| Bad {
            what,
            files: vec![
                ("t.csv".into(), BASE.as_bytes().to_vec()),
                ("u.csv".into(), content),
            ],
            args: ["--trial", "t.csv", "--unloaded", "u.csv"]
                .iter()
                .map(|s| (*s).to_string())
                .collect(),
            needles,
        })
        .collect();
    cases.push(bad(
        "a path that does not exist",
        &[("t.csv", BASE.as_bytes().to_vec())],
        &["--trial", "t.csv", "--unloaded", "missing.csv"],
        &["missing.csv", "no such file"],
    ));
    cases.push(bad(
        "a bad unloaded run with the bundled trial",
        &[("u.csv", unloaded_edited(|l| set_cell(l, 40, 3, "1.2.3")))],
        &["--unloaded", "u.csv"],
        &["u.csv:40:3 ", "torque_nm"],
    ));
    run_all(UNLOADED_COMMANDS, &cases);
}

/// Bad parameters JSON documents as `(what, content, needles)`, file `p.json`.
fn bad_params() -> Vec<(&'static str, Vec<u8>, Vec<&'static str>)> {
    let j = |s: &str| s.as_bytes().to_vec();
    vec![
        ("empty file", Vec::new(), vec!["p.json"]),
        ("truncated JSON", j("{\"muscles\": "), vec!["p.json"]),
        (
            "trailing comma",
            j("{\"muscles\": {\"sol\": {\"fom_n\": 3000,}}}"),
            vec!["p.json"],
        ),
        ("not an object", j("[1, 2, 3]"), vec!["p.json"]),
        ("binary junk", junk(300, 3), vec!["p.json"]),
        (
            "a CSV instead of JSON",
            BASE.as_bytes().to_vec(),
            vec!["p.json"],
        ),
        (
            "unknown muscle",
            j(r#"{"muscles": {"soleus": {"fom_n": 3000}}}"#),
            vec!["p.json", "soleus"],
        ),
        (
            "unknown parameter",
            j(r#"{"muscles": {"sol": {"lst_mm": 0.25}}}"#),
            vec!["p.json", "lst_mm"],
        ),
        (
            "unknown section",
            j(r#"{"muscle": {"sol": {}}}"#),
            vec!["p.json", "muscle"],
        ),
        (
            "negative force",
            j(r#"{"muscles": {"gm": {"fom_n": -5}}}"#),
            vec!["p.json", "gm.fom_n"],
        ),
        (
            "zero optimal fibre length",
            j(r#"{"muscles": {"gl": {"lom_m": 0}}}"#),
            vec!["p.json", "gl.lom_m"],
        ),
        (
            "pennation of 90 degrees",
            j(r#"{"muscles": {"sol": {"alpha_deg": 90}}}"#),
            vec!["p.json", "alpha_deg"],
        ),
        (
            "negative tendon slack length",
            j(r#"{"muscles": {"sol": {"lst_m": -0.25}}}"#),
            vec!["p.json", "lst_m"],
        ),
        (
            "a number as a string",
            j(r#"{"muscles": {"sol": {"fom_n": "3549"}}}"#),
            vec!["p.json", "fom_n"],
        ),
        (
            "null value",
            j(r#"{"activation": {"tau_act_s": null}}"#),
            vec!["p.json", "tau_act_s"],
        ),
        (
            "a number too large for a double",
            j(r#"{"muscles": {"sol": {"fom_n": 1e400}}}"#),
            vec!["p.json"],
        ),
        (
            "lmt polynomial of the wrong length",
            j(r#"{"muscles": {"sol": {"lmt_poly_m": [0.29, 0.04]}}}"#),
            vec!["p.json", "lmt_poly_m"],
        ),
        (
            "negative activation time constant",
            j(r#"{"activation": {"tau_deact_s": -0.05}}"#),
            vec!["p.json", "tau_deact_s"],
        ),
        (
            "activation shape out of range",
            j(r#"{"activation": {"shape_a": 0.5}}"#),
            vec!["p.json", "shape_a"],
        ),
        (
            "Flen below 1",
            j(r#"{"curves": {"flen": 0.5}}"#),
            vec!["p.json", "flen"],
        ),
        (
            "negative tendon strain",
            j(r#"{"curves": {"e0t": -0.04}}"#),
            vec!["p.json", "e0t"],
        ),
    ]
}

#[test]
fn bad_parameter_files_exit_2_naming_file_and_key() {
    let mut cases: Vec<Bad> = bad_params()
        .into_iter()
        .map(|(what, content, needles)| {
            bad(
                what,
                &[("p.json", content)],
                &["--params", "p.json"],
                &needles,
            )
        })
        .collect();
    cases.push(bad(
        "a path that does not exist",
        &[],
        &["--params", "nope.json"],
        &["nope.json", "no such file"],
    ));
    run_all(MODEL_COMMANDS, &cases);
}

#[test]
fn malformed_json_names_line_and_column() {
    // A syntax error (a missing `:`) on line 3, column 21 of every kind of
    // JSON input. The truth file's message has the `file:line:column` form;
    // the parameters and effects files give "line 3 column 21" after the file.
    let text = b"{\n  \"muscles\": {\n    \"sol\": {\"fom_n\" 3549}\n  }\n}\n".to_vec();
    let mut cases = Vec::new();
    for flag in ["--params", "--effects"] {
        cases.push(bad(
            flag,
            &[("x.json", text.clone())],
            &[flag, "x.json"],
            &["x.json", "line 3 column 21"],
        ));
    }
    run_all(MODEL_COMMANDS, &cases);
    run_all(
        IDENTIFY_COMMANDS,
        &[bad(
            "--truth",
            &[("x.json", text)],
            &["--truth", "x.json"],
            &["x.json:3:21"],
        )],
    );
}

#[test]
fn bad_effect_files_exit_2_naming_file_effect_and_parameter() {
    let j = |s: &str| s.as_bytes().to_vec();
    let table: Vec<(&str, Vec<u8>, Vec<&str>)> = vec![
        ("empty file", Vec::new(), vec!["e.json"]),
        ("truncated JSON", j("{\"gravity\": {"), vec!["e.json"]),
        ("not an object", j("\"fatigue\""), vec!["e.json"]),
        (
            "unknown effect",
            j(r#"{"telepathy": {"gain": 1}}"#),
            vec!["e.json", "telepathy"],
        ),
        (
            "unknown effect parameter",
            j(r#"{"electromechanical_delay": {"delay_s": 0.04}}"#),
            vec!["e.json", "delay_s"],
        ),
        (
            "parameters not an object",
            j(r#"{"torque_offset": 5}"#),
            vec!["e.json", "torque_offset"],
        ),
        (
            "a number as a string",
            j(r#"{"torque_offset": {"offset_nm": "5"}}"#),
            vec!["e.json", "offset_nm"],
        ),
        (
            "delay above its range",
            j(r#"{"electromechanical_delay": {"delay_ms": 900}}"#),
            vec!["e.json", "delay_ms"],
        ),
        (
            "negative delay",
            j(r#"{"electromechanical_delay": {"delay_ms": -5}}"#),
            vec!["e.json", "delay_ms"],
        ),
        (
            "passive stiffness below its range",
            j(r#"{"passive_joint_torque": {"scale_nm": 1, "stiffness_per_rad": 2}}"#),
            vec!["e.json", "stiffness_per_rad"],
        ),
        (
            "negative passive scale",
            j(r#"{"passive_joint_torque": {"scale_nm": -1}}"#),
            vec!["e.json", "scale_nm"],
        ),
        (
            "negative fatigue rate",
            j(r#"{"fatigue": {"rate_per_s": -0.1}}"#),
            vec!["e.json", "rate_per_s"],
        ),
        (
            "negative antagonist gain",
            j(r#"{"antagonist_coactivation": {"gain_nm": -3}}"#),
            vec!["e.json", "gain_nm"],
        ),
        (
            "eccentric Flen above its range",
            j(r#"{"eccentric_enhancement": {"flen": 2.5}}"#),
            vec!["e.json", "flen"],
        ),
    ];
    let mut cases: Vec<Bad> = table
        .into_iter()
        .map(|(what, content, needles)| {
            bad(
                what,
                &[("e.json", content)],
                &["--effects", "e.json"],
                &needles,
            )
        })
        .collect();
    cases.push(bad(
        "a path that does not exist",
        &[],
        &["--effects", "nope.json"],
        &["nope.json", "no such file"],
    ));
    run_all(MODEL_COMMANDS, &cases);
}

#[test]
fn bad_truth_files_exit_2_naming_the_file() {
    let mut cases: Vec<Bad> = bad_params()
        .into_iter()
        .map(|(what, content, needles)| Bad {
            what: what.to_string(),
            files: vec![("truth.json".into(), content)],
            args: vec!["--truth".into(), "truth.json".into()],
            needles: needles
                .iter()
                .map(|n| n.replace("p.json", "truth.json"))
                .collect(),
        })
        .collect();
    cases.push(bad(
        "bad parameters under `params` (a fixture's truth.json)",
        &[(
            "truth.json",
            br#"{"seed": 1, "params": {"muscles": {"gm": {"alpha_deg": -3}}}, "effects": {}}"#
                .to_vec(),
        )],
        &["--truth", "truth.json"],
        &["truth.json", "alpha_deg"],
    ));
    cases.push(bad(
        "a path that does not exist",
        &[],
        &["--truth", "nope.json"],
        &["nope.json", "no such file"],
    ));
    run_all(IDENTIFY_COMMANDS, &cases);
}

#[test]
fn bad_options_exit_2_with_one_line() {
    let opt = |what: &str, args: &[&str], needles: &[&str]| bad(what, &[], args, needles);
    run_all(
        &[&["identify"]],
        &[
            opt("unknown --method", &["--method", "ga"], &["ga", "--method"]),
            opt("empty --method", &["--method", ""], &["--method"]),
            opt("--method in upper case", &["--method", "SA"], &["SA"]),
            opt(
                "--seed not a number",
                &["--method", "sa", "--seed", "abc"],
                &["abc"],
            ),
            opt("--seed negative", &["--method", "sa", "--seed=-1"], &["-1"]),
            opt(
                "the antagonist on a trial without a TA envelope",
                &["--method", "sa", "--with", "antagonist_coactivation"],
                &["antagonist_coactivation", "emg_ta"],
            ),
        ],
    );
    run_all(
        &[&["sensitivity"]],
        &[
            opt("--step 0", &["--step", "0"], &["--step"]),
            opt("--step negative", &["--step=-5"], &["--step"]),
            opt("--step NaN", &["--step", "NaN"], &["--step"]),
            opt("--step above --max-change", &["--step", "30"], &["--step"]),
            opt(
                "--max-change 150",
                &["--max-change", "150"],
                &["--max-change"],
            ),
            opt("--max-change text", &["--max-change", "lots"], &["lots"]),
        ],
    );
    run_all(
        &[&["envelope"]],
        &[
            opt("--mvc without a value", &["--mvc", "emg_sol"], &["--mvc"]),
            opt("--mvc unknown channel", &["--mvc", "emg_xx=1"], &["emg_xx"]),
            opt("--mvc negative", &["--mvc", "sol=-1"], &["--mvc"]),
            opt("--mvc text", &["--mvc", "gm=abc"], &["abc"]),
            opt(
                "--mvc for a channel the bundled trial lacks",
                &["--mvc", "emg_ta=0.5"],
                &["emg_ta"],
            ),
        ],
    );
    run_all(
        TRIAL_COMMANDS,
        &[opt(
            "misspelled option",
            &["--trail", "t.csv"],
            &["--trail"],
        )],
    );
}

#[test]
fn out_that_is_a_file_or_an_input_is_refused_and_folders_are_created() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path();
    std::fs::write(p.join("t.csv"), BASE).unwrap();
    std::fs::write(p.join("afile"), b"not a folder").unwrap();
    std::fs::write(p.join("p.json"), b"{}").unwrap();
    let run = |args: &[&str]| {
        surae(
            &args.iter().map(|s| (*s).to_string()).collect::<Vec<_>>(),
            p,
        )
    };
    let refused = |args: &[&str], needle: &str| {
        let before = snapshot(p);
        let o = run(args);
        let err = String::from_utf8_lossy(&o.stderr).into_owned();
        assert_eq!(o.status.code(), Some(2), "{args:?}: {err}");
        assert_eq!(err.trim_end().lines().count(), 1, "{args:?}: {err}");
        assert!(err.contains(needle), "{args:?}: {err} lacks {needle}");
        assert!(!err.contains("panicked"), "{err}");
        assert_eq!(snapshot(p), before, "{args:?} changed files");
    };
    // an existing file where a folder is expected
    refused(&["envelope", "--trial", "t.csv", "--out", "afile"], "afile");
    refused(&["simulate", "--out", "afile"], "afile");
    refused(
        &["simulate", "--params", "p.json", "--out", "p.json"],
        "p.json",
    );
    refused(
        &["identify", "--method", "sa", "--quiet", "--out", "afile"],
        "afile",
    );
    refused(
        &[
            "identify",
            "--method",
            "sa",
            "--quiet",
            "--out",
            "afile/sub",
        ],
        "afile",
    );
    // the output file would be an input (same name, or through a folder)
    std::fs::write(p.join("envelope.csv"), BASE).unwrap();
    std::fs::write(p.join("simulate.csv"), BASE).unwrap();
    refused(
        &["envelope", "--trial", "envelope.csv", "--out", "."],
        "envelope.csv",
    );
    refused(
        &["envelope", "--trial", "t.csv", "--out", "./t.csv"],
        "t.csv",
    );
    refused(
        &["simulate", "--trial", "simulate.csv", "--out", "."],
        "simulate.csv",
    );
    refused(&["simulate", "--trial", "t.csv", "--out", "t.csv"], "t.csv");
    #[cfg(unix)]
    {
        std::os::unix::fs::symlink(p.join("t.csv"), p.join("link.csv")).unwrap();
        refused(
            &["envelope", "--trial", "t.csv", "--out", "link.csv"],
            "link.csv",
        );
    }

    // folders (several levels) are created
    let o = run(&["envelope", "--trial", "t.csv", "--out", "a/b/c/env.csv"]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(p.join("a/b/c/env.csv").is_file());
    let o = run(&["simulate", "--trial", "t.csv", "--out", "x/y"]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(p.join("x/y/simulate.csv").is_file());
    // and no temporary file is left behind anywhere
    let stray: Vec<_> = snapshot(p)
        .into_keys()
        .filter(|k| k.to_string_lossy().contains(".tmp"))
        .collect();
    assert!(stray.is_empty(), "{stray:?}");
}

#[test]
fn a_missing_required_option_is_named() {
    // clap puts the missing argument's name on the line after "the following
    // required arguments were not provided:"; the one-line message must keep it.
    run_all(
        &[&["identify"]],
        &[bad("no --method", &[], &["--quiet"], &["--method"])],
    );
}

#[test]
fn trials_sampled_too_slowly_for_the_emg_filters_name_the_file() {
    // 500 Hz (every other row of the base): the 10–350 Hz band-pass cannot be
    // designed below 700 Hz. The message must name the trial file in every
    // command, not a placeholder.
    let slow = edited(|l| {
        let kept: Vec<String> = l
            .iter()
            .enumerate()
            .filter(|(i, _)| *i < 2 || (i - 2) % 2 == 0)
            .map(|(_, s)| s.clone())
            .collect();
        *l = kept;
    });
    let two_rows =
        b"time_s,ankle_angle_deg,torque_nm,emg_sol,emg_gm,emg_gl\n0,1,2,0.1,0.2,0.3\n1,1,2,0.3,0.1,0.2\n"
            .to_vec();
    run_all(
        TRIAL_COMMANDS,
        &[
            bad(
                "500 Hz trial",
                &[("t.csv", slow)],
                &["--trial", "t.csv"],
                &["t.csv", "500 Hz"],
            ),
            bad(
                "two rows 1 s apart (1 Hz)",
                &[("t.csv", two_rows)],
                &["--trial", "t.csv"],
                &["t.csv", "1 Hz"],
            ),
        ],
    );
}

#[test]
fn a_refused_output_leaves_no_other_output_behind() {
    // The input is named like the command's second or later output file in the
    // `--out` folder: the command must refuse before writing anything, not
    // after writing the files that come first.
    for name in ["sensitivity.json", "report.html"] {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path();
        std::fs::create_dir(p.join("d")).unwrap();
        std::fs::write(p.join("d").join(name), BASE).unwrap();
        let before = snapshot(p);
        let args: Vec<String> = [
            "sensitivity",
            "--trial",
            &format!("d/{name}"),
            "--out",
            "d",
            "--step",
            "20",
        ]
        .iter()
        .map(|s| (*s).to_string())
        .collect();
        let o = surae(&args, p);
        let err = String::from_utf8_lossy(&o.stderr).into_owned();
        assert_eq!(o.status.code(), Some(2), "{err}");
        assert!(err.contains(name), "{err}");
        let after = snapshot(p);
        let new: Vec<_> = after.keys().filter(|k| !before.contains_key(*k)).collect();
        assert!(new.is_empty(), "{name}: refused, but wrote {new:?}");
        assert_eq!(after, before);
    }
}
