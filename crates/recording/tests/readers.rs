//! The readers one by one: delimited text (delimiter, quotes, units, decimal comma, Latin-1,
//! preamble, trailing delimiter, missing and bad cells), OpenSim storage (versions 1 and 2,
//! `inDegrees`, `nRows` / `nColumns`, files joined on time), the assembly onto one clock (two
//! rates and the documented interpolation bound, the overlap, a clock in ms, a clock regular
//! only to its text's rounding, a channel's own rate, geometry pairs) and the map's errors;
//! then seeded random bytes and mutated valid files through every text reader: no panic, and
//! every error is one line that starts with the file's name.

use std::path::{Path, PathBuf};

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use recording::{
    parse_delimited, parse_map, parse_storage, read_trial_recording, read_unloaded_recording,
    DelimitedOptions, MappedRecording, RecordingError, RecordingFormat, RecordingMap,
    RecordingTable,
};
use serde_json::{json, Value};

// ---------------------------------------------------------------------------------------------
// helpers
// ---------------------------------------------------------------------------------------------

fn delimited_with(text: &[u8], opts: DelimitedOptions) -> Result<RecordingTable, RecordingError> {
    parse_delimited(text, Path::new("x.csv"), &opts)
}

fn delimited(text: &str) -> RecordingTable {
    delimited_with(text.as_bytes(), DelimitedOptions::default()).unwrap_or_else(|e| panic!("{e}"))
}

fn delimited_err(text: &[u8]) -> RecordingError {
    match delimited_with(text, DelimitedOptions::default()) {
        Ok(t) => panic!("accepted: {t:?}"),
        Err(e) => e,
    }
}

fn labels(t: &RecordingTable) -> Vec<&str> {
    t.channels.iter().map(|c| c.label.as_str()).collect()
}

fn values<'a>(t: &'a RecordingTable, label: &str) -> &'a [f64] {
    &t.channel(label)
        .unwrap_or_else(|| panic!("no column {label}"))
        .values
}

fn delimiter_of(t: &RecordingTable) -> (char, bool) {
    match t.format {
        RecordingFormat::Delimited {
            delimiter,
            decimal_comma,
        } => (delimiter, decimal_comma),
        ref f => panic!("not delimited: {f:?}"),
    }
}

/// One line, non-empty, starting with `name`.
fn assert_one_line(e: &RecordingError, name: &str) {
    let m = e.to_string();
    assert!(
        !m.contains('\n') && !m.contains('\r'),
        "multi-line message: {m:?}"
    );
    assert!(
        m.starts_with(name),
        "message does not start with {name}: {m:?}"
    );
    assert!(m.len() > name.len() + 2, "message says nothing: {m:?}");
}

/// Rows of numbers joined by `sep`, each number in Rust's shortest round-trip form.
fn rows(sep: &str, header: &[&str], data: impl IntoIterator<Item = Vec<f64>>) -> String {
    let mut s = header.join(sep);
    s.push('\n');
    for r in data {
        let cells: Vec<String> = r.iter().map(|x| format!("{x}")).collect();
        s.push_str(&cells.join(sep));
        s.push('\n');
    }
    s
}

/// A raw-EMG-like signal that is never all zeros.
fn emg(i: usize, k: usize) -> f64 {
    (((i * 7919 + k * 104_729) % 401) as f64 - 200.0) / 8.0 + 0.25
}

/// Writes `files` into a fresh folder with the map `map` (JSON) and reads it.
fn read_mapped(
    files: &[(&str, &str)],
    map: &Value,
) -> (tempfile::TempDir, Result<MappedRecording, RecordingError>) {
    let dir = tempfile::tempdir().unwrap();
    for (name, text) in files {
        std::fs::write(dir.path().join(name), text).unwrap();
    }
    let r = parse_map(&map.to_string(), &dir.path().join("map.json"))
        .and_then(|m| read_trial_recording(&m));
    (dir, r)
}

fn ok(r: Result<MappedRecording, RecordingError>) -> MappedRecording {
    r.unwrap_or_else(|e| panic!("{e}"))
}

fn err(r: Result<MappedRecording, RecordingError>) -> RecordingError {
    match r {
        Ok(m) => panic!("accepted; notes: {:?}", m.notes),
        Err(e) => e,
    }
}

/// The five required channels, all from `file` under their surae names.
fn plain_channels() -> Value {
    json!({
        "ankle_angle_deg": {"column": "angle"},
        "torque_nm": {"column": "torque"},
        "emg_sol": {"column": "sol"},
        "emg_gm": {"column": "gm"},
        "emg_gl": {"column": "gl"}
    })
}

/// A whole trial in one comma-separated file: `time,angle,torque,sol,gm,gl`, `n` rows at
/// `rate` Hz from t = 0.
fn whole_trial(n: usize, rate: f64) -> String {
    rows(
        ",",
        &["time", "angle", "torque", "sol", "gm", "gl"],
        (0..n).map(|i| {
            let t = i as f64 / rate;
            vec![t, 15.0 - 10.0 * t, 2.0 * t, emg(i, 0), emg(i, 1), emg(i, 2)]
        }),
    )
}

/// The one-line message of a failed read, with the temporary folder taken out of it.
fn message_of(dir: &tempfile::TempDir, r: Result<MappedRecording, RecordingError>) -> String {
    let e = err(r);
    assert_one_line(&e, e.path());
    e.to_string()
        .replace(&format!("{}/", dir.path().display()), "")
}

// ---------------------------------------------------------------------------------------------
// delimited text
// ---------------------------------------------------------------------------------------------

#[test]
fn the_delimiter_is_the_most_frequent_one_in_the_header() {
    let t = delimited("a,b,c\n1,2,3\n");
    assert_eq!(delimiter_of(&t), (',', false));
    assert_eq!(labels(&t), ["a", "b", "c"]);
    assert_eq!(values(&t, "c"), [3.0]);

    let t = delimited("a;b;c\n1;2;3\n4;5;6\n");
    assert_eq!(delimiter_of(&t).0, ';');
    assert_eq!(values(&t, "b"), [2.0, 5.0]);

    let t = delimited("a\tb\tc\n1\t2\t3\n");
    assert_eq!(delimiter_of(&t).0, '\t');
    assert_eq!(values(&t, "a"), [1.0]);

    // a tie goes to ';' over ','
    let t = delimited("a,b;c\n1;2\n");
    assert_eq!(delimiter_of(&t).0, ';');
    assert_eq!(labels(&t), ["a,b", "c"]);

    // one column: no delimiter at all
    let t = delimited("time\n0\n0.5\n");
    assert_eq!(labels(&t), ["time"]);
    assert_eq!(values(&t, "time"), [0.0, 0.5]);
}

#[test]
fn quoted_headers_keep_their_commas_and_quotes() {
    // commas inside quotes are not counted: the file is comma-separated with 2 fields
    let t = delimited("\"Time,s\",\"ANGLE,deg\"\n0,1\n0.5,2\n");
    assert_eq!(delimiter_of(&t).0, ',');
    assert_eq!(labels(&t), ["Time,s", "ANGLE,deg"]);
    assert_eq!(values(&t, "ANGLE,deg"), [1.0, 2.0]);
    assert_eq!(t.time_label.as_deref(), Some("Time,s"));

    // semicolons outside the quotes, commas inside (the Noraxon habit)
    let t = delimited("\"Time,s\";\"ANGLE,deg\";\"TORQUE,mV\"\n0;1;2\n");
    assert_eq!(delimiter_of(&t).0, ';');
    assert_eq!(labels(&t), ["Time,s", "ANGLE,deg", "TORQUE,mV"]);

    // a doubled quote is a quote
    let t = delimited("\"say \"\"hi\"\"\",b\n1,2\n");
    assert_eq!(labels(&t), ["say \"hi\"", "b"]);
}

#[test]
fn units_are_read_from_the_label_tail() {
    let t = delimited(
        "Time,s\t\"LT SOLEUS,uV\"\tankle angle [deg]\ttorque (Nm)\tsoleus\tbad [two words]\n\
         0\t1\t2\t3\t4\t5\n",
    );
    assert_eq!(delimiter_of(&t).0, '\t');
    let units: Vec<Option<&str>> = t.channels.iter().map(|c| c.unit.as_deref()).collect();
    assert_eq!(
        units,
        [Some("s"), Some("uV"), Some("deg"), Some("Nm"), None, None]
    );
    // the label stays the whole cell
    assert_eq!(labels(&t)[2], "ankle angle [deg]");
    assert_eq!(recording::unit_of_label("GM (mV)"), Some("mV".into()));
    assert_eq!(recording::unit_of_label("GM"), None);
}

#[test]
fn a_decimal_comma_is_found_in_semicolon_and_tab_files() {
    let t = delimited("t;x\n0;1,5\n0,001;-2,25\n");
    assert_eq!(delimiter_of(&t), (';', true));
    assert_eq!(values(&t, "x"), [1.5, -2.25]);
    assert_eq!(values(&t, "t"), [0.0, 0.001]);

    let t = delimited("t\tx\n0\t1,5e3\n");
    assert_eq!(delimiter_of(&t), ('\t', true));
    assert_eq!(values(&t, "x"), [1500.0]);

    // dots in a semicolon file: no decimal comma
    let t = delimited("t;x\n0;1.5\n");
    assert_eq!(delimiter_of(&t), (';', false));
    assert_eq!(values(&t, "x"), [1.5]);

    // a decimal comma that first shows after many whole numbers is still found
    let mut text = String::from("t;x\n");
    for i in 0..40 {
        text.push_str(&format!("{i};{}\n", 10 + i));
    }
    text.push_str("40;7,5\n");
    let t = delimited(&text);
    assert_eq!(delimiter_of(&t), (';', true));
    assert_eq!(values(&t, "x")[40], 7.5);

    // the map may force it or forbid it
    let forced = delimited_with(
        b"t;x\n0;1\n",
        DelimitedOptions {
            decimal_comma: Some(true),
            ..DelimitedOptions::default()
        },
    )
    .unwrap();
    assert_eq!(delimiter_of(&forced), (';', true));
    let e = delimited_with(
        b"t;x\n0;1,5\n",
        DelimitedOptions {
            decimal_comma: Some(false),
            ..DelimitedOptions::default()
        },
    )
    .unwrap_err();
    assert!(
        matches!(&e, RecordingError::Cell { line: 2, column: 2, name, .. } if name == "x"),
        "{e:?}"
    );
    assert!(
        !e.to_string().contains("comma-separated"),
        "wrong hint for a ';' file: {e}"
    );

    // a point in a decimal-comma file is a bad cell
    let e = delimited_err(b"t;x\n0;1,5\n1;2.5\n");
    assert!(
        matches!(
            &e,
            RecordingError::Cell {
                line: 3,
                column: 2,
                ..
            }
        ),
        "{e:?}"
    );

    // a decimal comma in a comma-separated file splits the number: a hint says so
    let e = delimited_err(b"t,x\n0,\"1,5\"\n");
    assert!(e.to_string().contains("decimal comma"), "{e}");
}

#[test]
fn latin1_and_a_byte_order_mark_are_read() {
    let t = delimited_with(
        b"time\tEMG [\xB5V]\n0\t1\n0.001\t2\n",
        DelimitedOptions::default(),
    )
    .unwrap();
    assert_eq!(labels(&t), ["time", "EMG [\u{b5}V]"]);
    assert_eq!(t.channels[1].unit.as_deref(), Some("\u{b5}V"));
    assert_eq!(values(&t, "EMG [\u{b5}V]"), [1.0, 2.0]);

    let t = delimited("\u{feff}time,x\n0,1\n");
    assert_eq!(labels(&t), ["time", "x"]);
    assert_eq!(t.time_label.as_deref(), Some("time"));
}

#[test]
fn header_line_skips_a_preamble_and_rows_keep_their_lines() {
    let text = "Noraxon MR3 export\nSubject: S01, date 2024-05-01\n\nTime,s\tA,mV\n0\t1\n0.5\t2\n";
    let t = delimited_with(
        text.as_bytes(),
        DelimitedOptions {
            header_line: Some(4),
            ..DelimitedOptions::default()
        },
    )
    .unwrap();
    assert_eq!(labels(&t), ["Time,s", "A,mV"]);
    assert_eq!(t.row_lines, [5, 6]);
    assert_eq!(values(&t, "A,mV"), [1.0, 2.0]);
    // without it the preamble is taken for the header and the file does not read
    assert!(delimited_with(text.as_bytes(), DelimitedOptions::default()).is_err());
    // past the end
    let e = delimited_with(
        text.as_bytes(),
        DelimitedOptions {
            header_line: Some(40),
            ..DelimitedOptions::default()
        },
    )
    .unwrap_err();
    assert!(e.to_string().starts_with("x.csv: header_line 40"), "{e}");

    // comments and blank lines before the header; blank lines and CRLF between rows
    let t = delimited("# exported\n\n# by hand\ntime,x\r\n0,1\r\n\r\n0.5,2\r\n\n1,3\n");
    assert_eq!(t.row_lines, [5, 7, 9]);
    assert_eq!(values(&t, "x"), [1.0, 2.0, 3.0]);
    assert_eq!(t.locate(2), "line 9");
    // a lone CR after the header ends a row and a line
    let t = delimited("time,x\n0,1\r0.5,2\r\n1,3\n");
    assert_eq!(t.row_lines, [2, 3, 4]);
    assert_eq!(values(&t, "x"), [1.0, 2.0, 3.0]);
}

#[test]
fn a_trailing_delimiter_is_not_a_column() {
    let t = delimited("time\tx\t\n0\t1\t\n0.5\t2\t\n");
    assert_eq!(labels(&t), ["time", "x"]);
    assert_eq!(values(&t, "x"), [1.0, 2.0]);
    // rows with a trailing delimiter under a header without one
    let t = delimited("time,x\n0,1,\n0.5,2\n");
    assert_eq!(values(&t, "x"), [1.0, 2.0]);
    // but a real extra value is an error
    let e = delimited_err(b"time,x\n0,1,7\n");
    assert!(
        matches!(&e, RecordingError::Line { line: 2, reason, .. } if reason.starts_with("too many")),
        "{e:?}"
    );
    let e = delimited_err(b"time,x,y\n0,1,2\n0.5,1\n");
    assert!(
        matches!(&e, RecordingError::Line { line: 3, reason, .. } if reason.starts_with("too few")),
        "{e:?}"
    );
}

#[test]
fn empty_cells_and_nan_are_missing_samples() {
    let t = delimited("time,x,y\n0,,3\n0.5,NaN,4\n1,nan,\n");
    let x = values(&t, "x");
    assert!(x.iter().all(|v| v.is_nan()), "{x:?}");
    let y = values(&t, "y");
    assert_eq!(&y[..2], [3.0, 4.0]);
    assert!(y[2].is_nan());
    // a whole row of empty cells is a blank line
    let t = delimited("time,x\n0,1\n,\n0.5,2\n");
    assert_eq!(t.row_lines, [2, 4]);
}

#[test]
fn a_bad_cell_names_line_column_and_label() {
    let e = delimited_err(b"time;ANGLE,deg\n0;1\n0.001;abc\n");
    assert_eq!(
        e,
        RecordingError::Cell {
            path: "x.csv".into(),
            line: 3,
            column: 2,
            name: "ANGLE,deg".into(),
            reason: "'abc' is not a number".into(),
        }
    );
    assert_eq!(
        e.to_string(),
        "x.csv:3:2 (ANGLE,deg): 'abc' is not a number"
    );

    // the line counts comments, blank lines and CRLF
    let e = delimited_err(b"# c\ntime,x\r\n0,1\r\n\r\n0.001,oops\r\n");
    assert!(
        matches!(
            &e,
            RecordingError::Cell {
                line: 5,
                column: 2,
                ..
            }
        ),
        "{e:?}"
    );
    // a long cell is shortened
    let long = "z".repeat(100);
    let e = delimited_err(format!("time,x\n0,{long}\n").as_bytes());
    assert!(e.to_string().len() < 120, "{e}");

    // a quoted cell with a line break inside: still a one-line message
    let e = delimited_err(b"time,x\n0,\"1\n2\"\n");
    assert!(matches!(&e, RecordingError::Cell { line: 2, .. }), "{e:?}");
    assert_one_line(&e, "x.csv:2:2");
    // a quoted label with a line break inside
    let e = delimited_err(b"time,\"a\nb\"\n0,1\n");
    assert_one_line(&e, "x.csv:1");
}

#[test]
fn bad_headers_and_empty_files_are_errors() {
    let e = delimited_err(b"time,x,x\n0,1,2\n");
    assert!(
        matches!(&e, RecordingError::Cell { line: 1, column: 3, reason, .. } if reason.contains("twice")),
        "{e:?}"
    );
    let e = delimited_err(b"time,,x\n0,1,2\n");
    assert!(
        matches!(
            &e,
            RecordingError::Cell {
                line: 1,
                column: 2,
                ..
            }
        ),
        "{e:?}"
    );
    let e = delimited_err(b"");
    assert!(e.to_string().starts_with("x.csv: empty file"), "{e}");
    let e = delimited_err(b"# only\n\n");
    assert!(e.to_string().contains("empty file"), "{e}");
    let e = delimited_err(b"time,x\n\n");
    assert_eq!(
        e.to_string(),
        "x.csv:1: header only: the file has no data rows"
    );
    let e = delimited_err(b"\x00\x01\x02PK\x03\x04");
    assert!(
        matches!(&e, RecordingError::Line { line: 1, reason, .. } if reason.contains("control character")),
        "{e:?}"
    );
}

// ---------------------------------------------------------------------------------------------
// OpenSim storage
// ---------------------------------------------------------------------------------------------

fn storage(text: &str, name: &str) -> Result<RecordingTable, RecordingError> {
    parse_storage(text.as_bytes(), Path::new(name))
}

const STO_V1: &str = "ik\nversion=1\nnRows=3\nnColumns=2\ninDegrees=yes\nendheader\n\
                      time\tankle_angle_r\n0\t10\n0.01\t11\n0.02\t12\n";

#[test]
fn storage_versions_1_and_2_are_read() {
    let t = storage(STO_V1, "ik.mot").unwrap();
    assert_eq!(
        t.format,
        RecordingFormat::Storage {
            version: 1,
            in_degrees: Some(true),
            title: Some("ik".into()),
        }
    );
    assert_eq!(t.time_label.as_deref(), Some("time"));
    assert_eq!(labels(&t), ["time", "ankle_angle_r"]);
    assert_eq!(values(&t, "ankle_angle_r"), [10.0, 11.0, 12.0]);
    assert_eq!(t.row_lines, [8, 9, 10]);

    let t = storage(
        "version=2\nOpenSimVersion=4.5\nDataType=double\ninDegrees=no\nendheader\n\
         time\tknee_angle_r\tankle_angle_r\n\n0\t0.1\t0.2\n0.5\t0.3\tNaN\n",
        "v2.sto",
    )
    .unwrap();
    assert_eq!(
        t.format,
        RecordingFormat::Storage {
            version: 2,
            in_degrees: Some(false),
            title: None,
        }
    );
    assert_eq!(t.row_lines, [8, 9]);
    assert!(values(&t, "ankle_angle_r")[1].is_nan());
    assert_eq!(t.locate(1), "line 9");
}

#[test]
fn wrong_counts_in_a_storage_header_are_errors_naming_the_line() {
    let e = storage(&STO_V1.replace("nRows=3", "nRows=4"), "ik.mot").unwrap_err();
    assert_one_line(&e, "ik.mot:3:");
    assert!(e.to_string().contains("nRows=4"), "{e}");
    let e = storage(&STO_V1.replace("nColumns=2", "nColumns=3"), "ik.mot").unwrap_err();
    assert_one_line(&e, "ik.mot:4:");
    assert!(e.to_string().contains("nColumns=3"), "{e}");
    let e = storage(&STO_V1.replace("endheader", "end"), "ik.mot").unwrap_err();
    assert_one_line(&e, "ik.mot");
    assert!(e.to_string().contains("endheader"), "{e}");
    let e = storage(&STO_V1.replace("\t11", "\televen"), "ik.mot").unwrap_err();
    assert_one_line(&e, "ik.mot:9:");
    assert!(e.to_string().contains("ankle_angle_r"), "{e}");
    let e = storage(&STO_V1.replace("0.02\t12\n", ""), "ik.mot").unwrap_err();
    assert!(e.to_string().contains("nRows=3"), "{e}");
    let e = parse_storage(
        b"version=1\nendheader\ntime\tx\n0\t\x001\n",
        Path::new("b.sto"),
    )
    .unwrap_err();
    assert_one_line(&e, "b.sto");
    // a lone carriage return inside a label is not let into messages
    let e = storage("endheader\ntime\ta\rb\ta\rb\n0\t1\t2\n", "cr.sto").unwrap_err();
    assert_one_line(&e, "cr.sto");
}

/// `emg.sto`, `ik.mot` (angle in radians, `inDegrees=no`) and `id.sto` at 200 Hz over 0–2 s
/// (ik.mot from `ik_from` s), and the angle in degrees at each row.
fn opensim_files(ik_from: usize) -> (String, String, String, Vec<f64>) {
    let n = 401;
    let t = |i: usize| i as f64 / 200.0;
    let deg = |i: usize| 15.0 - 12.5 * t(i);
    let emg_sto = format!(
        "version=2\ninDegrees=yes\nendheader\n{}",
        rows(
            "\t",
            &["time", "soleus_r", "med_gas_r", "lat_gas_r"],
            (0..n).map(|i| vec![t(i), emg(i, 0), emg(i, 1), emg(i, 2)])
        )
    );
    let ik = format!(
        "ik\nversion=1\nnRows={}\nnColumns=3\ninDegrees=no\nendheader\n{}",
        n - ik_from,
        rows(
            "\t",
            &["time", "ankle_angle_r", "knee_angle_r"],
            (ik_from..n).map(|i| vec![t(i), deg(i).to_radians(), 0.5])
        )
    );
    let id = format!(
        "id\nversion=1\nnRows={n}\nnColumns=2\ninDegrees=no\nendheader\n{}",
        rows(
            "\t",
            &["time", "ankle_angle_r_moment"],
            (0..n).map(|i| vec![t(i), -(1.0 + t(i))])
        )
    );
    (emg_sto, ik, id, (0..n).map(deg).collect())
}

fn opensim_map() -> Value {
    json!({"channels": {
        "ankle_angle_deg": {"file": "ik.mot", "column": "ankle_angle_r"},
        "knee_angle_deg": {"file": "ik.mot", "column": "knee_angle_r"},
        "torque_nm": {"file": "id.sto", "column": "ankle_angle_r_moment", "sign": -1},
        "emg_sol": {"file": "emg.sto", "column": "soleus_r"},
        "emg_gm": {"file": "emg.sto", "column": "med_gas_r"},
        "emg_gl": {"file": "emg.sto", "column": "lat_gas_r"}}})
}

#[test]
fn storage_files_are_joined_on_time_and_radians_become_degrees() {
    let (emg_sto, ik, id, deg) = opensim_files(0);
    let (_d, r) = read_mapped(
        &[("emg.sto", &emg_sto), ("ik.mot", &ik), ("id.sto", &id)],
        &opensim_map(),
    );
    let rec = ok(r);
    let t = &rec.trial;
    assert_eq!(t.len(), 401);
    assert_eq!(t.time_s[200], 1.0);
    for (i, (a, d)) in t.ankle_angle_deg.iter().zip(&deg).enumerate() {
        assert!((a - d).abs() <= 1e-12, "row {i}: {a} against {d}");
    }
    // the knee too (an angle), the moment not (inDegrees says nothing about moments)
    let knee = t.knee_angle_deg.as_ref().unwrap();
    assert!((knee[0] - 0.5f64.to_degrees()).abs() < 1e-12);
    assert_eq!(t.torque_nm[200], 2.0);
    assert_eq!(t.emg_gl[7], emg(7, 2));
    assert!(
        rec.notes
            .iter()
            .any(|n| n.contains("ik.mot") && n.contains("inDegrees=no")),
        "{:?}",
        rec.notes
    );
    // identical time columns: nothing interpolated
    assert!(
        rec.sources.iter().all(|s| !s.resampled),
        "{:?}",
        rec.sources
    );

    // ik.mot starting later: the grid starts there
    let (emg_sto, ik, id, _) = opensim_files(40);
    let (_d, r) = read_mapped(
        &[("emg.sto", &emg_sto), ("ik.mot", &ik), ("id.sto", &id)],
        &opensim_map(),
    );
    let rec = ok(r);
    assert_eq!(rec.trial.time_s[0], 0.2);
    assert_eq!(rec.trial.len(), 361);
    assert_eq!(rec.trial.emg_sol[0], emg(40, 0));
}

// ---------------------------------------------------------------------------------------------
// assembly onto one clock
// ---------------------------------------------------------------------------------------------

/// Acceleration of the ramps of the isokinetic sweep (°/s²), its speed (°/s), the ramps'
/// length (s), and when the sweep starts and stops.
const ACC: f64 = 600.0;
const SPEED: f64 = 30.0;
const RAMP: f64 = 0.05;
const T_START: f64 = 0.5;
const T_STOP: f64 = 1.5;

/// The ankle angle of a 30 °/s sweep from 15° with 50 ms ramps (|q''| ≤ 600 °/s²): exact.
fn sweep(t: f64) -> f64 {
    let ramp = 0.5 * ACC * RAMP * RAMP;
    let s = if t < T_START {
        0.0
    } else if t < T_START + RAMP {
        0.5 * ACC * (t - T_START).powi(2)
    } else if t < T_STOP {
        ramp + SPEED * (t - T_START - RAMP)
    } else {
        let s_b = ramp + SPEED * (T_STOP - T_START - RAMP);
        if t < T_STOP + RAMP {
            s_b + SPEED * (t - T_STOP) - 0.5 * ACC * (t - T_STOP).powi(2)
        } else {
            s_b + ramp
        }
    };
    15.0 - s
}

/// A parabola: x'' = 10.
fn parabola(t: f64) -> f64 {
    5.0 * t * t + 1.0
}

/// EMG at 1000 Hz in a tab file, the dynamometer at 100 Hz in a comma file (from `from` to
/// `to` s).
fn two_rate_files(from: usize, to: usize) -> (String, String) {
    let fast = rows(
        "\t",
        &["time", "sol", "gm", "gl"],
        (0..=3000).map(|i| vec![i as f64 / 1000.0, emg(i, 0), emg(i, 1), emg(i, 2)]),
    );
    let slow = rows(
        ",",
        &["time", "angle", "torque"],
        (from..=to).map(|i| {
            let t = i as f64 / 100.0;
            vec![t, sweep(t), parabola(t)]
        }),
    );
    (fast, slow)
}

fn two_rate_map() -> Value {
    json!({"channels": {
        "ankle_angle_deg": {"file": "slow.csv", "column": "angle"},
        "torque_nm": {"file": "slow.csv", "column": "torque"},
        "emg_sol": {"file": "fast.tsv", "column": "sol"},
        "emg_gm": {"file": "fast.tsv", "column": "gm"},
        "emg_gl": {"file": "fast.tsv", "column": "gl"}}})
}

#[test]
fn a_slower_channel_is_interpolated_within_the_documented_bound() {
    let (fast, slow) = two_rate_files(0, 300);
    let (_d, r) = read_mapped(&[("fast.tsv", &fast), ("slow.csv", &slow)], &two_rate_map());
    let rec = ok(r);
    let t = &rec.trial;
    assert_eq!(t.len(), 3001);
    // the grid is the EMG's clock and the EMG is carried as written
    for (i, &x) in t.time_s.iter().enumerate() {
        assert_eq!(x, i as f64 / 1000.0);
    }
    assert!(t
        .emg_sol
        .iter()
        .enumerate()
        .all(|(i, &x)| x.to_bits() == emg(i, 0).to_bits()));
    let h: f64 = 0.01; // the slower channel's step
    for (name, got, exact, x2) in [
        ("angle", &t.ankle_angle_deg, sweep as fn(f64) -> f64, ACC),
        ("torque", &t.torque_nm, parabola as fn(f64) -> f64, 10.0),
    ] {
        let bound = h * h * x2 / 8.0;
        let worst = got
            .iter()
            .zip(&t.time_s)
            .map(|(g, &s)| (g - exact(s)).abs())
            .fold(0.0, f64::max);
        assert!(
            worst <= bound * (1.0 + 1e-9) + 1e-12,
            "{name}: error {worst} over the bound {bound}"
        );
        // the bound is reached (at the midpoints inside a ramp / of the parabola): it is the
        // right one, and the channel was indeed interpolated
        assert!(worst >= 0.9 * bound, "{name}: error {worst}, bound {bound}");
        // and at the slow channel's own samples it is exact
        for k in (0..=3000).step_by(10) {
            assert!((got[k] - exact(t.time_s[k])).abs() < 1e-9, "{name} at {k}");
        }
    }
    // the module's example: 0.0075° for the sweep
    assert!((h * h * ACC / 8.0 - 0.0075).abs() < 1e-15);
    let src = |target: &str| rec.sources.iter().find(|s| s.target == target).unwrap();
    assert!(src("ankle_angle_deg").resampled && src("torque_nm").resampled);
    assert!(!src("emg_sol").resampled);
    assert!((src("torque_nm").rate_hz - 100.0).abs() < 1e-9);
    assert!((src("emg_gl").rate_hz - 1000.0).abs() < 1e-9);
    assert!(
        rec.notes
            .iter()
            .any(|n| n.starts_with("ankle_angle_deg") && n.contains("interpolated linearly")),
        "{:?}",
        rec.notes
    );
}

#[test]
fn the_grid_is_cut_to_the_time_every_channel_covers() {
    let (fast, slow) = two_rate_files(25, 275);
    let (_d, r) = read_mapped(&[("fast.tsv", &fast), ("slow.csv", &slow)], &two_rate_map());
    let rec = ok(r);
    let t = &rec.trial;
    assert_eq!(t.time_s[0], 0.25);
    assert_eq!(t.time_s[t.len() - 1], 2.75);
    assert_eq!(t.len(), 2501);
    assert_eq!(t.emg_gm[0], emg(250, 1));
    assert!((t.ankle_angle_deg[0] - sweep(0.25)).abs() < 1e-9);
    assert!(rec.notes.iter().any(|n| n.contains("grid is cut")));

    // less than a second shared: an error naming the channel that starts last and its file
    let (fast, slow) = two_rate_files(220, 300);
    let (d, r) = read_mapped(&[("fast.tsv", &fast), ("slow.csv", &slow)], &two_rate_map());
    let m = message_of(&d, r);
    assert!(m.contains("share only 0.800 s"), "{m}");
    assert!(m.contains("slow.csv") && m.contains("angle"), "{m}");
}

#[test]
fn a_time_column_in_milliseconds_is_scaled_by_the_map() {
    let text = rows(
        ",",
        &["time_ms", "angle", "torque", "sol", "gm", "gl"],
        (0..=1500).map(|i| {
            vec![
                i as f64,
                10.0,
                i as f64 / 100.0,
                emg(i, 0),
                emg(i, 1),
                emg(i, 2),
            ]
        }),
    );
    let mut channels = plain_channels();
    channels["time_s"] = json!({"column": "time_ms", "scale": 0.001});
    let (_d, r) = read_mapped(
        &[("ms.csv", &text)],
        &json!({"file": "ms.csv", "channels": channels}),
    );
    let rec = ok(r);
    assert_eq!(rec.trial.len(), 1501);
    for (k, &x) in rec.trial.time_s.iter().enumerate() {
        assert_eq!(x, 0.001 * k as f64, "sample {k}");
    }
    assert_eq!(rec.trial.torque_nm[1500], 15.0);

    // without the time_s channel a map rate_hz contradicts the column (1 sample per unit)
    let (_d, r) = read_mapped(
        &[("ms.csv", &text)],
        &json!({"file": "ms.csv", "rate_hz": 1000, "channels": plain_channels()}),
    );
    let e = err(r);
    assert!(
        matches!(&e, RecordingError::Map { key, reason, .. }
            if key == "rate_hz" && reason.contains("'time_ms'") && reason.contains("ms.csv")),
        "{e:?}"
    );
}

/// A whole trial at 1500 Hz whose time column is written with `decimals` decimals.
fn rounded_clock(decimals: usize) -> (String, Vec<f64>) {
    let mut s = String::from("time,angle,torque,sol,gm,gl\n");
    let mut written = Vec::new();
    for i in 0..=1800 {
        let t = format!("{:.*}", decimals, i as f64 / 1500.0);
        written.push(t.parse::<f64>().unwrap());
        s.push_str(&format!(
            "{t},10,1,{},{},{}\n",
            emg(i, 0),
            emg(i, 1),
            emg(i, 2)
        ));
    }
    (s, written)
}

#[test]
fn a_clock_uniform_only_to_its_rounding_is_made_exact() {
    let (text, written) = rounded_clock(7);
    let map = json!({"file": "r.csv", "channels": plain_channels()});
    let (_d, r) = read_mapped(&[("r.csv", &text)], &map);
    let rec = ok(r);
    let t = &rec.trial.time_s;
    let n = written.len();
    let step = (written[n - 1] - written[0]) / (n - 1) as f64;
    assert_ne!(t, &written, "the clock was not regularised");
    for (i, (&a, &w)) in t.iter().zip(&written).enumerate() {
        assert_eq!(a, written[0] + i as f64 * step, "sample {i}");
        // moved by no more than the rounding (5e-8 each way)
        assert!((a - w).abs() <= 1e-7 + 1e-15, "sample {i}: {a} from {w}");
    }
    assert!(
        rec.notes
            .iter()
            .any(|n| n.contains("r.csv") && n.contains("uniform only to its text's rounding")),
        "{:?}",
        rec.notes
    );

    // exactly uniform (shortest round-trip text): kept bit for bit, no note
    let (_d, r) = read_mapped(&[("r.csv", &whole_trial(1500, 1000.0))], &map);
    let rec = ok(r);
    assert!(rec.notes.is_empty(), "{:?}", rec.notes);
    assert!(rec
        .trial
        .time_s
        .iter()
        .enumerate()
        .all(|(i, &x)| x == i as f64 / 1000.0));

    // rounded too coarsely (5 decimals at 1500 Hz): not uniform, an error naming the column
    let (text, _) = rounded_clock(5);
    let (d, r) = read_mapped(&[("r.csv", &text)], &map);
    let m = message_of(&d, r);
    assert!(m.starts_with("r.csv: column 'time': line "), "{m}");
    assert!(m.contains("non-uniform clock"), "{m}");
}

#[test]
fn a_gap_or_a_backward_step_in_the_clock_names_the_line() {
    let text = whole_trial(2000, 1000.0);
    // drop physical lines 500..=509 (rows at t = 0.498 … 0.507)
    let gapped: String = text
        .lines()
        .enumerate()
        .filter(|(i, _)| !(499..509).contains(i))
        .map(|(_, l)| format!("{l}\n"))
        .collect();
    let map = json!({"file": "g.csv", "channels": plain_channels()});
    let (d, r) = read_mapped(&[("g.csv", &gapped)], &map);
    let m = message_of(&d, r);
    assert!(
        m.starts_with("g.csv: column 'time': line 500: non-uniform clock"),
        "{m}"
    );

    let mut lines: Vec<String> = text.lines().map(str::to_string).collect();
    lines.swap(100, 101);
    let swapped = lines.join("\n") + "\n";
    let (d, r) = read_mapped(&[("g.csv", &swapped)], &map);
    let m = message_of(&d, r);
    assert!(
        m.starts_with("g.csv: column 'time': line 102: time does not increase"),
        "{m}"
    );
}

#[test]
fn missing_and_flat_samples_are_errors_naming_column_and_line() {
    let map = json!({"file": "m.csv", "channels": plain_channels()});
    let base = whole_trial(1500, 1000.0);
    let edit = |f: &dyn Fn(usize, &mut Vec<String>)| -> String {
        let mut out = String::new();
        for (i, l) in base.lines().enumerate() {
            let mut cells: Vec<String> = l.split(',').map(str::to_string).collect();
            if i > 0 {
                f(i + 1, &mut cells);
            }
            out.push_str(&cells.join(","));
            out.push('\n');
        }
        out
    };
    // one missing sample on physical line 101
    let one = edit(&|line, c| {
        if line == 101 {
            c[4].clear();
        }
    });
    let (d, r) = read_mapped(&[("m.csv", &one)], &map);
    let m = message_of(&d, r);
    assert_eq!(
        m,
        "m.csv: column 'gm': emg_gm: line 101: missing sample (NaN or infinite)"
    );
    // a column of empty cells
    let none = edit(&|_, c| c[3].clear());
    let (d, r) = read_mapped(&[("m.csv", &none)], &map);
    let m = message_of(&d, r);
    assert!(m.starts_with("m.csv: column 'sol': emg_sol: "), "{m}");
    assert!(m.contains("all NaN"), "{m}");
    // an EMG channel of zeros
    let zeros = edit(&|_, c| c[5] = "0".into());
    let (d, r) = read_mapped(&[("m.csv", &zeros)], &map);
    let m = message_of(&d, r);
    assert!(
        m.starts_with("m.csv: column 'gl': emg_gl is all zeros"),
        "{m}"
    );
    // a missing time
    let no_time = edit(&|line, c| {
        if line == 700 {
            c[0].clear();
        }
    });
    let (d, r) = read_mapped(&[("m.csv", &no_time)], &map);
    let m = message_of(&d, r);
    assert!(m.starts_with("m.csv: column 'time': line 700"), "{m}");
}

#[test]
fn a_channel_rate_gives_the_clock_of_a_file_without_time() {
    // EMG at 1000 Hz (the map's rate_hz), angle and torque at 100 Hz in the same file: their
    // cells end early, the rest of their column is empty; `empty` has a single sample
    let mut text = String::from("sol\tgm\tgl\tangle\ttorque\tempty\n");
    for i in 0..=2000 {
        let slow = if i <= 200 {
            let t = i as f64 / 100.0;
            format!("{}\t{}", 10.0 + 2.0 * t, 3.0 * t)
        } else {
            "\t".to_string()
        };
        let single = if i == 0 { "1" } else { "" };
        text.push_str(&format!(
            "{}\t{}\t{}\t{slow}\t{single}\n",
            emg(i, 0),
            emg(i, 1),
            emg(i, 2)
        ));
    }
    let mut channels = plain_channels();
    channels["ankle_angle_deg"]["rate_hz"] = json!(100);
    channels["torque_nm"]["rate_hz"] = json!(100);
    let (_d, r) = read_mapped(
        &[("n.tsv", &text)],
        &json!({"file": "n.tsv", "rate_hz": 1000, "channels": channels}),
    );
    let rec = ok(r);
    let t = &rec.trial;
    assert_eq!(t.len(), 2001);
    assert_eq!(t.time_s[1000], 1.0);
    for (k, &s) in t.time_s.iter().enumerate() {
        assert!(
            (t.ankle_angle_deg[k] - (10.0 + 2.0 * s)).abs() < 1e-9,
            "{k}"
        );
        assert!((t.torque_nm[k] - 3.0 * s).abs() < 1e-9, "{k}");
    }
    let src = rec
        .sources
        .iter()
        .find(|s| s.target == "torque_nm")
        .unwrap();
    assert!(
        src.resampled && (src.rate_hz - 100.0).abs() < 1e-9,
        "{src:?}"
    );

    // a file with a time column takes no channel rate
    let mut channels = plain_channels();
    channels["torque_nm"]["rate_hz"] = json!(100);
    let (_d, r) = read_mapped(
        &[("w.csv", &whole_trial(1500, 1000.0))],
        &json!({"file": "w.csv", "channels": channels}),
    );
    let e = err(r);
    assert!(
        matches!(&e, RecordingError::Map { key, .. } if key == "channels.torque_nm.rate_hz"),
        "{e:?}"
    );

    // no time column and no rate: no clock
    let (d, r) = read_mapped(
        &[("n.tsv", &text)],
        &json!({"file": "n.tsv", "channels": plain_channels()}),
    );
    let m = message_of(&d, r);
    assert!(m.starts_with("n.tsv: no clock"), "{m}");

    // a channel whose own rate leaves it fewer than two samples
    let mut channels = plain_channels();
    channels["torque_nm"] = json!({"column": "empty", "rate_hz": 100});
    let (d, r) = read_mapped(
        &[("n.tsv", &text)],
        &json!({"file": "n.tsv", "rate_hz": 1000, "channels": channels}),
    );
    let m = message_of(&d, r);
    assert!(m.starts_with("n.tsv: column 'empty': "), "{m}");
}

#[test]
fn geometry_series_come_in_pairs() {
    let text = rows(
        ",",
        &["time", "angle", "torque", "sol", "gm", "gl", "L", "R"],
        (0..1200).map(|i| {
            let t = i as f64 / 1000.0;
            vec![
                t,
                10.0,
                1.0,
                emg(i, 0),
                emg(i, 1),
                emg(i, 2),
                0.3 + t / 100.0,
                0.05,
            ]
        }),
    );
    let mut channels = plain_channels();
    channels["lmt_sol_m"] = json!({"column": "L"});
    channels["ma_sol_m"] = json!({"column": "R"});
    let (_d, r) = read_mapped(
        &[("g.csv", &text)],
        &json!({"file": "g.csv", "channels": channels.clone()}),
    );
    let rec = ok(r);
    assert_eq!(rec.geometry.len(), 1);
    assert_eq!(rec.geometry[0].muscle, "sol");
    assert_eq!(rec.geometry[0].lmt_m[1000], 0.3 + 1.0 / 100.0);
    assert_eq!(rec.geometry[0].moment_arm_m.len(), 1200);

    let mut only_l = channels.clone();
    only_l.as_object_mut().unwrap().remove("ma_sol_m");
    let (_d, r) = read_mapped(
        &[("g.csv", &text)],
        &json!({"file": "g.csv", "channels": only_l}),
    );
    let e = err(r);
    assert!(
        matches!(&e, RecordingError::Map { key, reason, .. }
            if key == "channels.lmt_sol_m" && reason.contains("ma_sol_m")),
        "{e:?}"
    );
    let mut only_r = channels;
    only_r.as_object_mut().unwrap().remove("lmt_sol_m");
    let (_d, r) = read_mapped(
        &[("g.csv", &text)],
        &json!({"file": "g.csv", "channels": only_r}),
    );
    let e = err(r);
    assert!(
        matches!(&e, RecordingError::Map { key, reason, .. }
            if key == "channels.ma_sol_m" && reason.contains("lmt_sol_m")),
        "{e:?}"
    );
}

#[test]
fn required_channels_columns_and_files_are_named() {
    let text = whole_trial(1500, 1000.0);
    let mut channels = plain_channels();
    channels.as_object_mut().unwrap().remove("emg_gl");
    let (_d, r) = read_mapped(
        &[("a.csv", &text)],
        &json!({"file": "a.csv", "channels": channels}),
    );
    let e = err(r);
    assert!(
        matches!(&e, RecordingError::Map { key, reason, .. }
            if key == "channels" && reason.starts_with("no emg_gl")),
        "{e:?}"
    );

    let mut channels = plain_channels();
    channels["torque_nm"]["column"] = json!("Torque");
    let (d, r) = read_mapped(
        &[("a.csv", &text)],
        &json!({"file": "a.csv", "channels": channels}),
    );
    let m = message_of(&d, r);
    assert!(
        m.contains("channels.torque_nm.column")
            && m.contains("'Torque'")
            && m.contains("a.csv")
            && m.contains("torque"),
        "{m}"
    );

    // a channel with no file in a map with none
    let (_d, r) = read_mapped(&[("a.csv", &text)], &json!({"channels": plain_channels()}));
    let e = err(r);
    assert!(
        matches!(&e, RecordingError::Map { key, reason, .. }
            if key.starts_with("channels.") && reason.starts_with("no file")),
        "{e:?}"
    );

    // a file that is not there: the message names it and the map's key
    let (d, r) = read_mapped(
        &[("a.csv", &text)],
        &json!({"file": "b.csv", "channels": plain_channels()}),
    );
    let m = message_of(&d, r);
    assert!(m.contains("b.csv") && m.contains("no such file"), "{m}");
    assert!(m.starts_with("map.json: file: no such file b.csv"), "{m}");
    let mut channels = plain_channels();
    channels["emg_gm"]["file"] = json!("sub/gm.csv");
    let (d, r) = read_mapped(
        &[("a.csv", &text)],
        &json!({"file": "a.csv", "channels": channels}),
    );
    let m = message_of(&d, r);
    assert!(
        m.contains("channels.emg_gm.file") && m.contains("gm.csv") && m.contains("no such file"),
        "{m}"
    );
}

#[test]
fn an_unloaded_run_needs_angle_and_torque_and_ignores_emg() {
    let text = whole_trial(1500, 1000.0);
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("u.csv"), &text).unwrap();
    let read = |channels: Value| {
        let m = parse_map(
            &json!({"file": "u.csv", "channels": channels}).to_string(),
            &dir.path().join("u.json"),
        )?;
        read_unloaded_recording(&m)
    };
    let u = read(plain_channels()).unwrap();
    assert_eq!(u.len(), 1500);
    assert_eq!(u.torque_nm[1000], 2.0);
    // EMG not needed (and a bad EMG column is not even looked at)
    let u = read(
        json!({"ankle_angle_deg": {"column": "angle"}, "torque_nm": {"column": "torque"},
                        "emg_sol": {"column": "nothing"}}),
    )
    .unwrap();
    assert_eq!(u.ankle_angle_deg[0], 15.0);
    let e = read(json!({"ankle_angle_deg": {"column": "angle"}})).unwrap_err();
    assert!(
        matches!(&e, RecordingError::Map { key, reason, .. }
            if key == "channels" && reason.contains("no torque_nm") && reason.contains("unloaded")),
        "{e:?}"
    );
}

// ---------------------------------------------------------------------------------------------
// the map
// ---------------------------------------------------------------------------------------------

fn map_err(text: &str) -> RecordingError {
    match parse_map(text, Path::new("dir/map.json")) {
        Ok(m) => panic!("accepted: {m:?}"),
        Err(e) => {
            assert_one_line(&e, "dir/map.json");
            e
        }
    }
}

#[test]
fn an_unknown_key_or_bad_json_names_line_and_column() {
    let text = "{\n  \"file\": \"x.csv\",\n  \"channels\": {\n    \"torque_nm\": {\"column\": \"T\", \"scal\": 2}\n  }\n}\n";
    let e = map_err(text);
    let RecordingError::Line { line, reason, .. } = &e else {
        panic!("{e:?}")
    };
    assert_eq!(*line, 4);
    assert!(reason.contains("`scal`"), "{reason}");
    let col: usize = reason
        .strip_prefix("column ")
        .and_then(|r| r.split(':').next())
        .and_then(|c| c.parse().ok())
        .unwrap_or_else(|| panic!("no column in {reason}"));
    let start = text.lines().nth(3).unwrap().find("\"scal\"").unwrap() + 1;
    assert!(
        (start..=start + 7).contains(&col),
        "column {col} not at the key (from {start})"
    );

    let e = map_err("{\"file\": \"x.csv\", \"rate\": 1000, \"channels\": {}}");
    assert!(e.to_string().contains("`rate`"), "{e}");

    let e = map_err("{\n  \"file\": \"x.csv\"\n  \"channels\": {}\n}");
    assert!(
        matches!(&e, RecordingError::Line { line: 3, reason, .. } if reason.starts_with("column 3")),
        "{e:?}"
    );
    let e = map_err("");
    assert!(matches!(&e, RecordingError::Line { .. }), "{e:?}");
    // a wrong type names the key's value
    let e = map_err("{\"channels\": {\"torque_nm\": {\"column\": \"T\", \"offset\": \"a\"}}}");
    assert!(e.to_string().contains("invalid type"), "{e}");
    // a newline inside a key does not break the message
    let e = map_err("{\"channels\": {}, \"a\\nb\": 1}");
    assert!(e.to_string().contains("a\\nb"), "{e}");
}

#[test]
fn bad_values_are_named_by_their_key_path() {
    let with =
        |channel: Value| json!({"file": "x.csv", "channels": {"torque_nm": channel}}).to_string();
    let key_of = |text: &str| match map_err(text) {
        RecordingError::Map { key, .. } => key,
        e => panic!("{e:?}"),
    };
    assert_eq!(
        key_of(&with(json!({"column": "T", "sign": 2}))),
        "channels.torque_nm.sign"
    );
    assert_eq!(
        key_of(&with(json!({"column": "T", "scale": 0}))),
        "channels.torque_nm.scale"
    );
    assert_eq!(
        key_of(&with(json!({"column": "T", "rate_hz": 0}))),
        "channels.torque_nm.rate_hz"
    );
    assert_eq!(
        key_of(&with(json!({"column": " "}))),
        "channels.torque_nm.column"
    );
    assert_eq!(
        key_of(&json!({"rate_hz": -5, "channels": {"torque_nm": {"column": "T"}}}).to_string()),
        "rate_hz"
    );
    assert_eq!(
        key_of(&json!({"header_line": 0, "channels": {"torque_nm": {"column": "T"}}}).to_string()),
        "header_line"
    );
    assert_eq!(key_of(&json!({"channels": {}}).to_string()), "channels");
    for bad in [
        "torque",
        "emg_Sol",
        "emg_",
        "lmt_sol",
        "ma__m",
        "knee_angle",
        "emg_sol x",
    ] {
        assert_eq!(
            key_of(&json!({"channels": {bad: {"column": "T"}}}).to_string()),
            format!("channels.{bad}"),
            "{bad}"
        );
    }
    let e = map_err(&json!({"channels": {"Torque": {"column": "T"}}}).to_string());
    assert!(e.to_string().contains("not a channel of a trial"), "{e}");
    // a JSON number too large for an f64 is a JSON error
    let e = map_err("{\"channels\": {\"torque_nm\": {\"column\": \"T\", \"scale\": 1e999}}}");
    assert!(matches!(&e, RecordingError::Line { line: 1, .. }), "{e:?}");

    // the targets a map may name
    for good in [
        "time_s",
        "knee_angle_deg",
        "emg_ta",
        "emg_tibant_r",
        "lmt_gm_m",
        "ma_x2_m",
    ] {
        let text = json!({"channels": {good: {"column": "T"}}}).to_string();
        parse_map(&text, Path::new("m.json")).unwrap_or_else(|e| panic!("{good}: {e}"));
    }
}

#[test]
fn a_map_reads_back_what_it_writes() {
    let text = json!({
        "comment": ["a", "b"], "file": "x.tsv", "rate_hz": 1500, "header_line": 3,
        "decimal_comma": true, "emg_is_envelope": true,
        "channels": {"torque_nm": {"column": "T,mV", "scale": 0.07, "offset": 0.5, "sign": -1},
                     "emg_sol": {"column": "S", "file": "y.sto", "rate_hz": 1000}}})
    .to_string();
    let m: RecordingMap = parse_map(&text, Path::new("a/map.json")).unwrap();
    assert_eq!(m.base_dir(), PathBuf::from("a"));
    assert_eq!(m.channels["torque_nm"].apply(10.0), -(0.07 * 10.0 + 0.5));
    let again = parse_map(&m.to_json_text(), Path::new("a/map.json")).unwrap();
    assert_eq!(again, m);
}

// ---------------------------------------------------------------------------------------------
// random bytes
// ---------------------------------------------------------------------------------------------

/// Bytes drawn mostly from what text recordings are made of.
fn text_like(rng: &mut ChaCha8Rng, n: usize) -> Vec<u8> {
    const ALPHABET: &[u8] =
        b"0123456789012345678901234567890123456789.,;\t\t\n\n\n\r\"\"-+eE #timeNa[]()=\xB5\x00 endheadrvsionRwC";
    (0..n)
        .map(|_| {
            if rng.random_range(0..50) == 0 {
                rng.random()
            } else {
                ALPHABET[rng.random_range(0..ALPHABET.len())]
            }
        })
        .collect()
}

/// `base` with a few random edits (replace, insert, delete, duplicate a stretch).
fn mutate(rng: &mut ChaCha8Rng, base: &[u8]) -> Vec<u8> {
    let mut v = base.to_vec();
    for _ in 0..rng.random_range(1..6) {
        if v.is_empty() {
            break;
        }
        let at = rng.random_range(0..v.len());
        match rng.random_range(0..4) {
            0 => v[at] = text_like(rng, 1)[0],
            1 => {
                let k = rng.random_range(1..8);
                let ins = text_like(rng, k);
                v.splice(at..at, ins);
            }
            2 => {
                let end = (at + rng.random_range(1..20)).min(v.len());
                v.drain(at..end);
            }
            _ => {
                let end = (at + rng.random_range(1..40)).min(v.len());
                let piece = v[at..end].to_vec();
                v.splice(at..at, piece);
            }
        }
    }
    v
}

/// `base` with a few digits changed or added next to a digit (mostly still readable).
fn mutate_digits(rng: &mut ChaCha8Rng, base: &[u8]) -> Vec<u8> {
    let mut v = base.to_vec();
    let digits: Vec<usize> = (0..v.len()).filter(|&i| v[i].is_ascii_digit()).collect();
    if digits.is_empty() {
        return v;
    }
    for _ in 0..rng.random_range(1..4) {
        let at = digits[rng.random_range(0..digits.len())];
        let d = b'0' + rng.random_range(0..10u8);
        if rng.random() {
            v[at] = d;
        } else {
            v.insert(at, d);
        }
    }
    v
}

/// What a reader accepted is consistent.
fn check_table(t: &RecordingTable, text: bool) {
    let n = t.rows();
    assert!(n > 0);
    for c in &t.channels {
        assert_eq!(c.values.len(), n, "{}", c.label);
        assert!(
            !c.label.contains(['\n', '\r']),
            "a label with a line break: {:?}",
            c.label
        );
    }
    if text {
        assert_eq!(t.row_lines.len(), n);
        assert!(t.row_lines.windows(2).all(|w| w[1] > w[0]));
    }
    if let Some(l) = &t.time_label {
        assert!(t.channel(l).is_some());
    }
    for (j, c) in t.channels.iter().enumerate() {
        assert!(t.channels[..j].iter().all(|d| d.label != c.label));
    }
}

#[test]
fn random_and_mutated_bytes_never_panic_and_errors_are_one_line_naming_the_file() {
    let mut rng = ChaCha8Rng::seed_from_u64(20_240_501);
    let csv = whole_trial(30, 1000.0).into_bytes();
    let semicolon = b"\"Time,s\";\"A [deg]\";B\n0;1,5;2\n0,001;2,5;\n# x\n".to_vec();
    let (emg_sto, ik, _, _) = opensim_files(390);
    let map = json!({"file": "x.csv", "rate_hz": 1000, "header_line": 2,
                     "channels": {"torque_nm": {"column": "T", "sign": -1, "scale": 2},
                                  "lmt_sol_m": {"column": "L", "file": "l.sto"}}})
    .to_string()
    .into_bytes();
    let bases: [&[u8]; 5] = [&csv, &semicolon, emg_sto.as_bytes(), ik.as_bytes(), &map];
    // accepted, rejected: by delimited, storage, map
    let (mut accepted, mut rejected) = ([0usize; 3], [0usize; 3]);
    for round in 0..3000 {
        let base = bases[rng.random_range(0..bases.len())];
        let bytes = match round % 4 {
            0 => {
                let n = rng.random_range(0..200);
                text_like(&mut rng, n)
            }
            1 => mutate_digits(&mut rng, base),
            _ => mutate(&mut rng, base),
        };
        let opts = DelimitedOptions {
            header_line: match rng.random_range(0..4) {
                0 => Some(rng.random_range(1..5)),
                _ => None,
            },
            decimal_comma: match rng.random_range(0..4) {
                0 => Some(true),
                1 => Some(false),
                _ => None,
            },
        };
        match parse_delimited(&bytes, Path::new("r.csv"), &opts) {
            Ok(t) => {
                check_table(&t, true);
                accepted[0] += 1;
            }
            Err(e) => {
                assert_one_line(&e, "r.csv");
                rejected[0] += 1;
            }
        }
        match parse_storage(&bytes, Path::new("r.sto")) {
            Ok(t) => {
                check_table(&t, true);
                accepted[1] += 1;
            }
            Err(e) => {
                assert_one_line(&e, "r.sto");
                rejected[1] += 1;
            }
        }
        let text = String::from_utf8_lossy(&bytes);
        match parse_map(&text, Path::new("r.json")) {
            Ok(m) => {
                m.validate().unwrap();
                accepted[2] += 1;
            }
            Err(e) => {
                assert_one_line(&e, "r.json");
                rejected[2] += 1;
            }
        }
    }
    // both outcomes were exercised in every reader
    eprintln!("accepted {accepted:?}, rejected {rejected:?}");
    assert!(
        accepted.iter().all(|&n| n >= 10) && rejected.iter().all(|&n| n >= 1000),
        "accepted {accepted:?}, rejected {rejected:?}"
    );
}
