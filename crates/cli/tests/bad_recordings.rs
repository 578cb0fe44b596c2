//! Bad input in a lab's formats, read through a recording map (or given where a map is needed):
//! each case is run through `surae simulate --trial`, `surae identify --method sa --trial` and,
//! where the argument is a map, `surae inspect`, and must give exit code 2, exactly one line on
//! standard error starting `error: ` that names the file and the column or the map's key, no
//! panic, and no new or changed file in its folder (the `--out` folder, inside it, is not
//! created).
//!
//! The bad files are made here from the example files of `fixtures/formats/` (a Noraxon-style
//! tab export at 2048 Hz with a `Time,s` column, OpenSim `.sto`/`.mot` files, a C3D), so the
//! corpus is not stored; a positive control shows that each base reads.

mod common;

use common::snapshot;
use std::path::Path;
use std::process::{Command, Output};

use serde_json::{json, Value};

/// Where every run asks for its output: must not exist afterwards.
const OUT: &str = "fresh_out";

/// Files of a case: `(name, content)`.
type Files = Vec<(&'static str, Vec<u8>)>;

fn fixture(rel: &str) -> Vec<u8> {
    let p = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../fixtures/formats")
        .join(rel);
    std::fs::read(&p).unwrap_or_else(|e| panic!("{}: {e}", p.display()))
}

fn fixture_text(rel: &str) -> String {
    String::from_utf8(fixture(rel)).unwrap()
}

fn fixture_map(rel: &str) -> Value {
    serde_json::from_slice(&fixture(rel)).unwrap()
}

fn pretty(v: &Value) -> Vec<u8> {
    let mut s = serde_json::to_string_pretty(v).unwrap();
    s.push('\n');
    s.into_bytes()
}

fn surae(args: &[String], cwd: &Path) -> Output {
    Command::new(env!("CARGO_BIN_EXE_surae"))
        .args(args)
        .current_dir(cwd)
        .output()
        .expect("the surae binary runs")
}

/// One bad input: its files, the runs (arguments before `--out`) and the strings the one-line
/// message must contain.
struct Bad {
    what: String,
    /// `(name, content)`; a name ending in `/` is an empty folder.
    files: Vec<(String, Vec<u8>)>,
    runs: Vec<Vec<String>>,
    needles: Vec<String>,
}

fn strings(s: &[&str]) -> Vec<String> {
    s.iter().map(|x| (*x).to_string()).collect()
}

fn owned(files: Vec<(&str, Vec<u8>)>) -> Vec<(String, Vec<u8>)> {
    files.into_iter().map(|(n, c)| (n.to_string(), c)).collect()
}

/// `--trial <trial>` through simulate and identify.
fn trial_runs(trial: &str) -> Vec<Vec<String>> {
    vec![
        strings(&["simulate", "--trial", trial]),
        strings(&["identify", "--method", "sa", "--quiet", "--trial", trial]),
    ]
}

/// A map given as `--trial` (simulate, identify) and inspected.
fn mapped(what: &str, files: Vec<(&str, Vec<u8>)>, needles: &[&str]) -> Bad {
    let mut runs = trial_runs("map.json");
    runs.push(strings(&["inspect", "map.json"]));
    Bad {
        what: what.into(),
        files: owned(files),
        runs,
        needles: strings(needles),
    }
}

/// A file given as `--trial` to simulate and identify.
fn direct(what: &str, files: Vec<(&str, Vec<u8>)>, trial: &str, needles: &[&str]) -> Bad {
    Bad {
        what: what.into(),
        files: owned(files),
        runs: trial_runs(trial),
        needles: strings(needles),
    }
}

fn write_files(dir: &Path, files: &[(String, Vec<u8>)]) {
    for (name, content) in files {
        let p = dir.join(name);
        if name.ends_with('/') {
            std::fs::create_dir_all(&p).unwrap();
        } else {
            std::fs::create_dir_all(p.parent().unwrap()).unwrap();
            std::fs::write(&p, content).unwrap();
        }
    }
}

/// Runs every run of `case` in one fresh folder; the descriptions of what went wrong.
fn check(case: &Bad) -> Vec<String> {
    let dir = tempfile::tempdir().unwrap();
    write_files(dir.path(), &case.files);
    let before = snapshot(dir.path());
    let mut problems = Vec::new();
    for run in &case.runs {
        let mut args = run.clone();
        args.extend(strings(&["--out", OUT]));
        let o = surae(&args, dir.path());
        let err = String::from_utf8_lossy(&o.stderr).into_owned();
        let mut p = common::refusal_problems(&o, &case.needles);
        let after = snapshot(dir.path());
        if after != before {
            let changed: std::collections::BTreeSet<String> = after
                .keys()
                .chain(before.keys())
                .filter(|k| before.get(*k) != after.get(*k))
                .map(|k| k.display().to_string())
                .collect();
            p.push(format!("files were created or changed: {changed:?}"));
            // put the folder back for the next run
            for k in after.keys().filter(|k| !before.contains_key(*k)) {
                let path = dir.path().join(k);
                if path.is_dir() {
                    let _ = std::fs::remove_dir_all(&path);
                } else {
                    let _ = std::fs::remove_file(&path);
                }
            }
            write_files(
                dir.path(),
                &case
                    .files
                    .iter()
                    .filter(|(n, _)| !n.ends_with('/'))
                    .cloned()
                    .collect::<Vec<_>>(),
            );
        }
        if !p.is_empty() {
            problems.push(format!(
                "{} [{}]: {} — stderr: {err:?}",
                case.what,
                args.join(" "),
                p.join("; ")
            ));
        }
    }
    problems
}

fn run_all(cases: &[Bad]) {
    let runs: usize = cases.iter().map(|c| c.runs.len()).sum();
    let failures: Vec<String> = cases.iter().flat_map(check).collect();
    assert!(
        failures.is_empty(),
        "{} of {runs} bad-recording runs misbehaved:\n{}",
        failures.len(),
        failures.join("\n")
    );
}

// ---------------------------------------------------------------------------------------------
// The bases and how they are corrupted
// ---------------------------------------------------------------------------------------------

/// The Noraxon-style export's cells, line by line (index 0 is the header, physical line 1).
fn noraxon_cells() -> Vec<Vec<String>> {
    fixture_text("noraxon/export.tsv")
        .lines()
        .map(|l| l.split('\t').map(str::to_string).collect())
        .collect()
}

/// The index of the column labelled `label` (quotes aside).
fn column_index(cells: &[Vec<String>], label: &str) -> usize {
    cells[0]
        .iter()
        .position(|c| c.trim_matches('"') == label)
        .unwrap_or_else(|| panic!("no column {label}"))
}

fn tsv(cells: &[Vec<String>]) -> Vec<u8> {
    let mut s = String::new();
    for r in cells {
        s.push_str(&r.join("\t"));
        s.push('\n');
    }
    s.into_bytes()
}

/// The export with `f` applied to its cells.
fn noraxon_edited(f: impl FnOnce(&mut Vec<Vec<String>>)) -> Vec<u8> {
    let mut c = noraxon_cells();
    f(&mut c);
    tsv(&c)
}

/// Sets the cells of column `label` on every data line for which `which(physical line)`.
fn set_cells(cells: &mut [Vec<String>], label: &str, which: impl Fn(usize) -> bool, v: &str) {
    let j = column_index(cells, label);
    for (i, r) in cells.iter_mut().enumerate().skip(1) {
        if which(i + 1) {
            r[j] = v.to_string();
        }
    }
}

fn noraxon_map() -> Value {
    fixture_map("noraxon/map.json")
}

/// The Noraxon export and its map, with `f` applied to the map.
fn noraxon_with_map(f: impl FnOnce(&mut Value)) -> Files {
    let mut m = noraxon_map();
    f(&mut m);
    vec![
        ("export.tsv", fixture("noraxon/export.tsv")),
        ("map.json", pretty(&m)),
    ]
}

/// The export with its cells edited, and the fixture's map.
fn noraxon_with_cells(f: impl FnOnce(&mut Vec<Vec<String>>)) -> Files {
    vec![
        ("export.tsv", noraxon_edited(f)),
        ("map.json", pretty(&noraxon_map())),
    ]
}

/// The export split in two files without time columns: the EMG at 2048 Hz, angle and torque
/// every 20th row (102.4 Hz); the map gives the EMG's rate, and the dynamometer channels their
/// own when `dyn_rate` is set.
fn split_without_time(dyn_rate: Option<f64>) -> Files {
    let cells = noraxon_cells();
    let pick = |labels: &[&str], step: usize| -> Vec<u8> {
        let js: Vec<usize> = labels.iter().map(|l| column_index(&cells, l)).collect();
        let rows: Vec<Vec<String>> = cells
            .iter()
            .enumerate()
            .filter(|(i, _)| *i == 0 || (i - 1) % step == 0)
            .map(|(_, r)| js.iter().map(|&j| r[j].clone()).collect())
            .collect();
        tsv(&rows)
    };
    let emg = pick(
        &["LT SOLEUS,uV", "LT MED. GASTRO,uV", "LT LAT. GASTRO,uV"],
        1,
    );
    let dynamometer = pick(&["CN ANGLE,mV", "CN TORQUE,mV"], 20);
    let mut m = noraxon_map();
    m["file"] = json!("emg.tsv");
    for k in ["ankle_angle_deg", "torque_nm"] {
        m["channels"][k]["file"] = json!("dyn.tsv");
        if let Some(r) = dyn_rate {
            m["channels"][k]["rate_hz"] = json!(r);
        }
    }
    vec![
        ("emg.tsv", emg),
        ("dyn.tsv", dynamometer),
        ("map.json", pretty(&m)),
    ]
}

/// A fixture's lines with `f` applied.
fn lines_edited(rel: &str, f: impl FnOnce(&mut Vec<String>)) -> Vec<u8> {
    let mut l: Vec<String> = fixture_text(rel).lines().map(str::to_string).collect();
    f(&mut l);
    (l.join("\n") + "\n").into_bytes()
}

/// The OpenSim files and their map, with `ik.mot` and `emg.sto` edited line by line.
fn opensim_with(ik: impl FnOnce(&mut Vec<String>), emg: impl FnOnce(&mut Vec<String>)) -> Files {
    vec![
        ("ik.mot", lines_edited("opensim/ik.mot", ik)),
        ("emg.sto", lines_edited("opensim/emg.sto", emg)),
        ("id.sto", fixture("opensim/id.sto")),
        ("map.json", fixture("opensim/map.json")),
    ]
}

/// The physical line (1-based) of the first line of `text` that contains `what`.
fn line_of(text: &[u8], what: &str) -> usize {
    String::from_utf8_lossy(text)
        .lines()
        .position(|l| l.contains(what))
        .unwrap_or_else(|| panic!("no {what}"))
        + 1
}

// ---------------------------------------------------------------------------------------------
// The tests
// ---------------------------------------------------------------------------------------------

#[test]
fn the_bases_read_and_simulate() {
    // positive control: what the cases corrupt reads, so that each case fails for its fault
    let bases: Vec<(&str, Files)> = vec![
        ("noraxon", noraxon_with_map(|_| {})),
        ("noraxon rewritten", noraxon_with_cells(|_| {})),
        (
            "split, with the dynamometer's rate",
            split_without_time(Some(102.4)),
        ),
        ("opensim", opensim_with(|_| {}, |_| {})),
        (
            "c3d",
            vec![
                ("trial.c3d", fixture("c3d/trial.c3d")),
                ("map.json", fixture("c3d/map.json")),
            ],
        ),
    ];
    for (what, files) in bases {
        let dir = tempfile::tempdir().unwrap();
        write_files(dir.path(), &owned(files));
        let o = surae(
            &strings(&["simulate", "--trial", "map.json", "--out", "ok.csv"]),
            dir.path(),
        );
        assert!(
            o.status.success(),
            "{what}: {}",
            String::from_utf8_lossy(&o.stderr)
        );
        let text = std::fs::read_to_string(dir.path().join("ok.csv")).unwrap();
        assert!(text.lines().count() > 6000, "{what}");
    }
}

#[test]
fn bad_data_files_behind_a_map_name_the_file_and_the_column() {
    let c3d = fixture("c3d/trial.c3d");
    let c3d_map = fixture("c3d/map.json");
    let cases = vec![
        mapped(
            "a C3D cut in half",
            vec![
                ("trial.c3d", c3d[..c3d.len() / 2].to_vec()),
                ("map.json", c3d_map.clone()),
            ],
            &["trial.c3d", "truncated"],
        ),
        mapped(
            "a text file named .c3d",
            vec![
                ("trial.c3d", fixture("noraxon/export.tsv")),
                ("map.json", c3d_map),
            ],
            &["trial.c3d", "not a C3D file"],
        ),
        mapped(
            "a wrong nRows in a .mot",
            opensim_with(|l| l[2] = "nRows=6000".into(), |_| {}),
            &["ik.mot:3:", "nRows=6000"],
        ),
        mapped(
            "a wrong nColumns in a .mot",
            opensim_with(|l| l[3] = "nColumns=3".into(), |_| {}),
            &["ik.mot:4:", "nColumns=3"],
        ),
        mapped(
            "a channel of empty cells",
            noraxon_with_cells(|c| set_cells(c, "LT SOLEUS,uV", |_| true, "")),
            &["export.tsv", "'LT SOLEUS,uV'", "emg_sol", "all NaN"],
        ),
        mapped(
            "one empty cell",
            noraxon_with_cells(|c| set_cells(c, "LT SOLEUS,uV", |l| l == 101, "")),
            &[
                "export.tsv",
                "'LT SOLEUS,uV'",
                "emg_sol",
                "line 101",
                "missing sample",
            ],
        ),
        mapped(
            "one NaN in a .sto",
            opensim_with(
                |_| {},
                |l| {
                    let mut f: Vec<&str> = l[99].split('\t').collect();
                    f[1] = "NaN";
                    l[99] = f.join("\t");
                },
            ),
            &["emg.sto", "'soleus_r'", "line 100", "missing sample"],
        ),
        mapped(
            "a cell that is not a number",
            noraxon_with_cells(|c| set_cells(c, "CN TORQUE,mV", |l| l == 50, "4O.5")),
            &["export.tsv:50:7 (CN TORQUE,mV)", "'4O.5' is not a number"],
        ),
        mapped(
            "a gap in the clock",
            noraxon_with_cells(|c| {
                c.drain(500..510);
            }),
            &["export.tsv", "'Time,s'", "line 501", "non-uniform clock"],
        ),
        mapped(
            "an EMG channel of zeros",
            noraxon_with_cells(|c| set_cells(c, "LT MED. GASTRO,uV", |_| true, "0")),
            &["export.tsv", "'LT MED. GASTRO,uV'", "emg_gm is all zeros"],
        ),
        mapped(
            "files that share 0.83 s",
            opensim_with(
                |l| {
                    // keep the rows from 2.5 s on (2.5 s is row 5120 at 2048 Hz)
                    let rows: Vec<String> = l.drain(7..).skip(5120).collect();
                    l[2] = format!("nRows={}", rows.len());
                    l.extend(rows);
                },
                |_| {},
            ),
            &[
                "map.json",
                "share only 0.833 s",
                "ankle_angle_deg ('ankle_angle_r' in ik.mot) starts at 2.500 s",
            ],
        ),
    ];
    run_all(&cases);
}

#[test]
fn clocks_that_are_missing_or_contradict_the_map_are_named() {
    let cases = vec![
        mapped(
            "no time column and no rate_hz",
            {
                let mut m = noraxon_map();
                m.as_object_mut().unwrap().remove("rate_hz");
                vec![
                    (
                        "export.tsv",
                        noraxon_edited(|c| {
                            let j = column_index(c, "Time,s");
                            for r in c.iter_mut() {
                                r.remove(j);
                            }
                        }),
                    ),
                    ("map.json", pretty(&m)),
                ]
            },
            &["export.tsv", "no clock", "rate_hz"],
        ),
        mapped(
            "a map rate_hz that contradicts the time column",
            noraxon_with_map(|m| m["rate_hz"] = json!(1000)),
            &[
                "map.json",
                "rate_hz",
                "1000 Hz",
                "'Time,s'",
                "export.tsv",
                "2048.000 Hz",
            ],
        ),
        mapped(
            "two files without time at different rates, one rate_hz",
            split_without_time(None),
            &["map.json", "share only", "'CN ANGLE,mV' in dyn.tsv"],
        ),
        mapped(
            "a channel rate_hz in a file with a time column",
            noraxon_with_map(|m| m["channels"]["torque_nm"]["rate_hz"] = json!(100)),
            &[
                "map.json",
                "channels.torque_nm.rate_hz",
                "'Time,s'",
                "export.tsv",
            ],
        ),
    ];
    run_all(&cases);
}

#[test]
fn bad_maps_name_the_key_or_the_line_and_column() {
    let scal = {
        let mut m = noraxon_map();
        let t = m["channels"]["torque_nm"].as_object_mut().unwrap();
        let v = t.remove("scale").unwrap();
        t.insert("scal".into(), v);
        pretty(&m)
    };
    let scal_line = format!("map.json:{}: column ", line_of(&scal, "\"scal\""));
    let cases = vec![
        mapped(
            "an unknown key",
            vec![
                ("export.tsv", fixture("noraxon/export.tsv")),
                ("map.json", scal),
            ],
            &[&scal_line, "`scal`"],
        ),
        mapped(
            "a JSON syntax error",
            vec![
                ("export.tsv", fixture("noraxon/export.tsv")),
                (
                    "map.json",
                    b"{\n  \"file\": \"export.tsv\"\n  \"channels\": {}\n}\n".to_vec(),
                ),
            ],
            &["map.json:3: column 3", "not a recording map"],
        ),
        mapped(
            "a map that is not UTF-8",
            vec![("map.json", b"{\"file\": \"\xFF\"}".to_vec())],
            &["map.json", "not UTF-8"],
        ),
        mapped(
            "a sign of 2",
            noraxon_with_map(|m| m["channels"]["torque_nm"]["sign"] = json!(2)),
            &["map.json", "channels.torque_nm.sign", "1 or -1"],
        ),
        mapped(
            "a scale of 0",
            noraxon_with_map(|m| m["channels"]["ankle_angle_deg"]["scale"] = json!(0)),
            &["map.json", "channels.ankle_angle_deg.scale", "non-zero"],
        ),
        mapped(
            "an unknown target",
            noraxon_with_map(|m| {
                m["channels"]["torque"] = json!({"column": "CN TORQUE,mV"});
            }),
            &["map.json", "channels.torque:", "not a channel of a trial"],
        ),
        mapped(
            "a required channel missing",
            noraxon_with_map(|m| {
                m["channels"].as_object_mut().unwrap().remove("emg_gl");
            }),
            &["map.json", "channels", "no emg_gl"],
        ),
        mapped(
            "a column the file lacks",
            noraxon_with_map(|m| m["channels"]["torque_nm"]["column"] = json!("CN TORQUE,V")),
            &[
                "map.json",
                "channels.torque_nm.column",
                "no column 'CN TORQUE,V' in export.tsv",
            ],
        ),
        mapped(
            "a data file that does not exist",
            noraxon_with_map(|m| m["file"] = json!("S01_iso30.tsv")),
            &["map.json", "file", "no such file S01_iso30.tsv"],
        ),
        mapped(
            "a channel's file that does not exist",
            noraxon_with_map(|m| m["channels"]["emg_gm"]["file"] = json!("emg/gm.tsv")),
            &[
                "map.json",
                "channels.emg_gm.file",
                "no such file emg/gm.tsv",
            ],
        ),
        mapped(
            "a map naming another map",
            noraxon_with_map(|m| m["file"] = json!("other.json"))
                .into_iter()
                .chain([("other.json", b"{}".to_vec())])
                .collect(),
            &["other.json", "cannot name another map"],
        ),
        direct(
            "geometry series in a map given as --trial",
            noraxon_with_map(|m| {
                m["channels"]["lmt_sol_m"] = json!({"column": "RT SOLEUS,uV", "scale": 0.001});
                m["channels"]["ma_sol_m"] = json!({"column": "RT SOLEUS,uV", "scale": 0.0001});
            }),
            "map.json",
            &["map.json", "lmt_<muscle>_m", "session"],
        ),
    ];
    run_all(&cases);
}

#[test]
fn data_files_given_where_a_map_is_needed_are_refused() {
    let cases = vec![
        direct(
            "a C3D as --trial",
            vec![("trial.c3d", fixture("c3d/trial.c3d"))],
            "trial.c3d",
            &[
                "trial.c3d",
                "a C3D file",
                "recording map",
                "surae inspect trial.c3d",
            ],
        ),
        direct(
            "a .sto as --trial",
            vec![("emg.sto", fixture("opensim/emg.sto"))],
            "emg.sto",
            &["emg.sto", "OpenSim storage file", "surae inspect emg.sto"],
        ),
        direct(
            "a .mot renamed .txt as --trial (found by its endheader)",
            vec![("ik.txt", fixture("opensim/ik.mot"))],
            "ik.txt",
            &["ik.txt", "OpenSim storage file", "surae inspect ik.txt"],
        ),
        direct(
            "a CEINMS-like folder missing its files",
            vec![("S01/emg.txt", b"garbage\n".to_vec())],
            "S01",
            &["S01/lmt.txt", "missing", "CEINMS trial folder"],
        ),
        direct(
            "a CEINMS-like folder with a bad emg.txt",
            vec![
                ("S01/emg.txt", b"Time\tsol_r\n0\t0.1\n".to_vec()),
                ("S01/lmt.txt", b"\n".to_vec()),
                ("S01/R_ankle_feMa.txt", b"\n".to_vec()),
                ("S01/R_ankle_feTorque.txt", b"\n".to_vec()),
            ],
            "S01",
            &["S01/emg.txt:1:", "datacolumns"],
        ),
        Bad {
            what: "a C3D as --unloaded".into(),
            files: owned(
                noraxon_with_map(|_| {})
                    .into_iter()
                    .chain([("u.c3d", fixture("c3d/trial.c3d"))])
                    .collect(),
            ),
            runs: vec![strings(&[
                "identify",
                "--method",
                "sa",
                "--quiet",
                "--trial",
                "map.json",
                "--unloaded",
                "u.c3d",
            ])],
            needles: strings(&["u.c3d", "recording map"]),
        },
    ];
    run_all(&cases);
}

#[test]
fn a_bad_unloaded_map_is_named() {
    let unloaded = |what: &str, channels: Value, needles: &[&str]| {
        let mut files = noraxon_with_map(|_| {});
        let mut m = noraxon_map();
        m["channels"] = channels;
        files.push(("umap.json", pretty(&m)));
        Bad {
            what: what.into(),
            files: owned(files),
            runs: vec![strings(&[
                "identify",
                "--method",
                "sa",
                "--quiet",
                "--trial",
                "map.json",
                "--unloaded",
                "umap.json",
            ])],
            needles: strings(needles),
        }
    };
    let angle = json!({"column": "CN ANGLE,mV", "scale": 0.125, "offset": -35.25});
    run_all(&[
        unloaded(
            "an unloaded map without torque",
            json!({"ankle_angle_deg": angle}),
            &["umap.json", "channels", "no torque_nm", "unloaded run"],
        ),
        unloaded(
            "an unloaded map with a torque column the file lacks",
            json!({"ankle_angle_deg": angle, "torque_nm": {"column": "TORQUE"}}),
            &[
                "umap.json",
                "channels.torque_nm.column",
                "'TORQUE'",
                "export.tsv",
            ],
        ),
    ]);
}

#[test]
fn inspecting_a_bad_data_file_creates_nothing() {
    let c3d = fixture("c3d/trial.c3d");
    let inspect = |what: &str, files: Vec<(&str, Vec<u8>)>, arg: &str, needles: &[&str]| Bad {
        what: what.into(),
        files: owned(files),
        runs: vec![strings(&["inspect", arg])],
        needles: strings(needles),
    };
    run_all(&[
        inspect(
            "a C3D cut in half",
            vec![("trial.c3d", c3d[..c3d.len() / 2].to_vec())],
            "trial.c3d",
            &["trial.c3d", "truncated"],
        ),
        inspect(
            "a CEINMS-like folder missing its files",
            vec![("S01/emg.txt", b"garbage\n".to_vec())],
            "S01",
            &["S01/lmt.txt", "missing"],
        ),
        inspect(
            "a tab export with a bad cell",
            vec![(
                "export.tsv",
                noraxon_edited(|c| set_cells(c, "CN TORQUE,mV", |l| l == 50, "x")),
            )],
            "export.tsv",
            &["export.tsv:50:7 (CN TORQUE,mV)"],
        ),
    ]);
}
