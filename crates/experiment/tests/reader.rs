//! Reader and writer of trial / unloaded CSV files: rejections, accepted variants, round trips.

use experiment::{
    format_f64, format_trial, parse_trial, parse_trial_bytes, parse_unloaded, parse_unloaded_bytes,
    read_trial, read_unloaded, write_trial, write_unloaded, ErrorKind, ExperimentError, Trial,
    Unloaded,
};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

const HEADER: &str = "time_s,ankle_angle_deg,torque_nm,emg_sol,emg_gm,emg_gl";

/// A valid trial text at `fs` Hz with `n` rows (no comments), one row per line after the header.
fn rows(n: usize, fs: f64) -> Vec<String> {
    (0..n)
        .map(|i| {
            let t = i as f64 / fs;
            format!(
                "{},{},{},{},{},{}",
                format_f64(t),
                format_f64(15.0 - 10.0 * t),
                format_f64(50.0 * (3.0 * t).sin()),
                format_f64(0.1 * (377.0 * t).sin()),
                format_f64(0.2 * (411.0 * t).cos()),
                format_f64(-0.05 * (233.0 * t).sin())
            )
        })
        .collect()
}

fn join(header: &str, rows: &[String]) -> String {
    let mut s = String::from(header);
    s.push('\n');
    for r in rows {
        s.push_str(r);
        s.push('\n');
    }
    s
}

fn valid() -> String {
    join(HEADER, &rows(151, 100.0)) // 1.5 s at 100 Hz
}

/// Replaces field `col` (1-based) of data row `row` (0-based) by `cell`.
fn with_cell(row: usize, col: usize, cell: &str) -> String {
    let mut r = rows(151, 100.0);
    let mut f: Vec<String> = r[row].split(',').map(String::from).collect();
    f[col - 1] = cell.to_string();
    r[row] = f.join(",");
    join(HEADER, &r)
}

fn with_row(row: usize, line: &str) -> String {
    let mut r = rows(151, 100.0);
    r[row] = line.to_string();
    join(HEADER, &r)
}

struct Case {
    what: &'static str,
    bytes: Vec<u8>,
    kind: ErrorKind,
    line: Option<usize>,
    column: Option<usize>,
    /// Substring the one-line message must contain.
    says: &'static str,
}

fn case(
    what: &'static str,
    text: impl Into<Vec<u8>>,
    kind: ErrorKind,
    line: Option<usize>,
    column: Option<usize>,
    says: &'static str,
) -> Case {
    Case {
        what,
        bytes: text.into(),
        kind,
        line,
        column,
        says,
    }
}

fn cases() -> Vec<Case> {
    let r = rows(151, 100.0);
    let mut gap = r.clone();
    gap.remove(40); // row 40 missing: old row 41 is now data row 40, on line 42
    let zero_gl: Vec<String> = r
        .iter()
        .map(|l| {
            let mut f: Vec<&str> = l.split(',').collect();
            f[5] = "0";
            f.join(",")
        })
        .collect();
    let mut jitter = r.clone();
    jitter[30] = {
        let mut f: Vec<String> = jitter[30].split(',').map(String::from).collect();
        f[0] = format_f64(0.30 + 1e-6); // dt deviates 1e-4 relative
        f.join(",")
    };
    vec![
        case("empty file", "", ErrorKind::Empty, None, None, "empty file"),
        case(
            "only comments",
            "# subject 1\n\n# no data\n",
            ErrorKind::Empty,
            None,
            None,
            "only comment lines",
        ),
        case(
            "header only",
            format!("# c\n{HEADER}\n"),
            ErrorKind::HeaderOnly,
            Some(2),
            None,
            "header only",
        ),
        case(
            "missing column",
            join(
                "time_s,ankle_angle_deg,torque_nm,emg_sol,emg_gl",
                &r.iter()
                    .map(|l| l.rsplit_once(',').unwrap().0.to_string())
                    .collect::<Vec<_>>(),
            ),
            ErrorKind::MissingColumn,
            Some(1),
            None,
            "missing required column 'emg_gm'",
        ),
        case(
            "renamed column",
            join(
                "time_s,ankle_angle_deg,torque_nm,emg_sol,emg_medial,emg_gl",
                &r,
            ),
            ErrorKind::MissingColumn,
            Some(1),
            None,
            "'emg_gm'",
        ),
        case(
            "column in capitals",
            join("time_s,ankle_angle_deg,torque_nm,emg_sol,EMG_GM,emg_gl", &r),
            ErrorKind::MisspelledColumn,
            Some(1),
            Some(5),
            "looks like 'emg_gm'",
        ),
        case(
            "duplicate column",
            join(
                "time_s,ankle_angle_deg,torque_nm,emg_sol,emg_gm,emg_sol",
                &r,
            ),
            ErrorKind::DuplicateColumn,
            Some(1),
            Some(6),
            "appears twice",
        ),
        case(
            "empty column name",
            join(
                "time_s,ankle_angle_deg,torque_nm,emg_sol,emg_gm,emg_gl,",
                &r,
            ),
            ErrorKind::EmptyColumnName,
            Some(1),
            Some(7),
            "empty column name",
        ),
        case(
            "text in a cell",
            with_cell(10, 2, "abc"),
            ErrorKind::NotANumber,
            Some(12),
            Some(2),
            "'abc' is not a number",
        ),
        case(
            "NaN in a cell",
            with_cell(3, 3, "NaN"),
            ErrorKind::NotFinite,
            Some(5),
            Some(3),
            "'NaN' is not a finite number",
        ),
        case(
            "infinity in a cell",
            with_cell(3, 4, "-inf"),
            ErrorKind::NotFinite,
            Some(5),
            Some(4),
            "not a finite number",
        ),
        case(
            "empty cell",
            with_cell(7, 6, " "),
            ErrorKind::EmptyCell,
            Some(9),
            Some(6),
            "empty cell",
        ),
        case(
            "decimal comma",
            with_cell(7, 3, "1,5"),
            ErrorKind::FieldCount,
            Some(9),
            None,
            "too many fields: expected 6, found 7",
        ),
        case(
            "time goes backwards",
            with_cell(20, 1, "0.1"),
            ErrorKind::TimeNotIncreasing,
            Some(22),
            Some(1),
            "time goes backwards",
        ),
        case(
            "time repeats",
            with_cell(20, 1, "0.19"),
            ErrorKind::TimeNotIncreasing,
            Some(22),
            Some(1),
            "does not increase",
        ),
        case(
            "gap in time",
            join(HEADER, &gap),
            ErrorKind::TimeGap,
            Some(42),
            Some(1),
            "gap in time",
        ),
        case(
            "jittered time",
            join(HEADER, &jitter),
            ErrorKind::NonUniformTime,
            Some(32),
            Some(1),
            "non-uniform sampling",
        ),
        case(
            "less than 1 s",
            join(HEADER, &r[..100]),
            ErrorKind::TooShort,
            None,
            None,
            "at least 1 s",
        ),
        case(
            "too few fields",
            with_row(5, "0.05,14.5,3"),
            ErrorKind::FieldCount,
            Some(7),
            None,
            "too few fields: expected 6, found 3",
        ),
        case(
            "too many fields",
            with_row(5, &format!("{},9", r[5])),
            ErrorKind::FieldCount,
            Some(7),
            None,
            "too many fields",
        ),
        case(
            "semicolon delimiter",
            join(
                &HEADER.replace(',', ";"),
                &r.iter().map(|l| l.replace(',', ";")).collect::<Vec<_>>(),
            ),
            ErrorKind::WrongDelimiter,
            Some(1),
            None,
            "';'",
        ),
        case(
            "tab delimiter",
            join(
                &HEADER.replace(',', "\t"),
                &r.iter().map(|l| l.replace(',', "\t")).collect::<Vec<_>>(),
            ),
            ErrorKind::WrongDelimiter,
            Some(1),
            None,
            "tab",
        ),
        case(
            "semicolon in a row",
            with_row(2, &r[2].replace(',', ";")),
            ErrorKind::FieldCount,
            Some(4),
            None,
            "contains ';'",
        ),
        case(
            "binary junk",
            {
                let mut b = valid().into_bytes();
                b.splice(200..200, [0u8, 1, 2, 0xff - 0x80, 7]);
                b
            },
            ErrorKind::Binary,
            Some(4),
            None,
            "control character",
        ),
        case(
            "invalid UTF-8",
            {
                let mut b = valid().into_bytes();
                b.splice(120..120, [0xC3u8, 0x28, 0xFF, 0xFE]);
                b
            },
            ErrorKind::InvalidUtf8,
            Some(3),
            None,
            "invalid UTF-8",
        ),
        case(
            "EMG channel all zeros",
            join(HEADER, &zero_gl),
            ErrorKind::ZeroChannel,
            None,
            Some(6),
            "emg_gl",
        ),
    ]
}

fn one_line(e: &ExperimentError) -> String {
    let s = e.to_string();
    assert!(
        !s.contains('\n') && !s.contains('\r'),
        "multi-line error: {s:?}"
    );
    s
}

#[test]
fn reader_rejects_each_malformed_input_with_file_line_and_column() {
    let cs = cases();
    assert!(cs.len() >= 25);
    for c in &cs {
        let err = match parse_trial_bytes(&c.bytes, "trial.csv") {
            Ok(_) => panic!("{}: accepted", c.what),
            Err(e) => e,
        };
        let msg = one_line(&err);
        assert_eq!(err.kind(), c.kind, "{}: {msg}", c.what);
        assert_eq!(err.line(), c.line, "{}: {msg}", c.what);
        assert_eq!(err.column(), c.column, "{}: {msg}", c.what);
        assert_eq!(err.path(), Some("trial.csv"), "{}", c.what);
        assert!(msg.starts_with("trial.csv"), "{}: {msg}", c.what);
        assert!(
            msg.contains(c.says),
            "{}: {msg:?} lacks {:?}",
            c.what,
            c.says
        );
        if let (Some(l), Some(col)) = (c.line, c.column) {
            assert!(
                msg.starts_with(&format!("trial.csv:{l}:{col} (")),
                "{}: {msg}",
                c.what
            );
        }
    }
}

#[test]
fn cell_error_display_is_file_line_column_name_reason() {
    let text = format!("# subject 3\n{}", with_cell(10, 2, "abc"));
    let e = parse_trial(&text, "trial.csv").unwrap_err();
    assert_eq!(
        e.to_string(),
        "trial.csv:13:2 (ankle_angle_deg): 'abc' is not a number"
    );
    match e {
        ExperimentError::Cell {
            path,
            line,
            column,
            name,
            kind,
            ..
        } => {
            assert_eq!(
                (path.as_str(), line, column, name.as_str(), kind),
                ("trial.csv", 13, 2, "ankle_angle_deg", ErrorKind::NotANumber)
            );
        }
        other => panic!("wrong variant {other:?}"),
    }
    let z = parse_trial(
        &join(
            "emg_sol,time_s,ankle_angle_deg,torque_nm,emg_gm,emg_gl",
            &rows(151, 100.0)
                .iter()
                .map(|l| {
                    let f: Vec<&str> = l.split(',').collect();
                    format!("0,{},{},{},{},{}", f[0], f[1], f[2], f[4], f[5])
                })
                .collect::<Vec<_>>(),
        ),
        "t.csv",
    )
    .unwrap_err();
    assert_eq!(
        z.to_string(),
        "t.csv: column 1 (emg_sol): EMG channel is all zeros (disconnected electrode?)"
    );
}

#[test]
fn unloaded_reader_rejections() {
    let r: Vec<String> = rows(151, 100.0)
        .iter()
        .map(|l| l.splitn(4, ',').take(3).collect::<Vec<_>>().join(","))
        .collect();
    let ok = join("time_s,ankle_angle_deg,torque_nm", &r);
    let u = parse_unloaded(&ok, "u.csv").unwrap();
    assert_eq!(u.len(), 151);
    assert!((u.sample_rate_hz() - 100.0).abs() < 1e-9);

    let missing = join(
        "time_s,ankle_angle_deg",
        &r.iter()
            .map(|l| l.rsplit_once(',').unwrap().0.to_string())
            .collect::<Vec<_>>(),
    );
    let e = parse_unloaded(&missing, "u.csv").unwrap_err();
    assert_eq!(e.kind(), ErrorKind::MissingColumn);
    assert!(e.to_string().contains("'torque_nm'"), "{e}");

    let e = parse_unloaded_bytes(b"\x00\x01\x02", "u.csv").unwrap_err();
    assert_eq!(e.kind(), ErrorKind::Binary);
    let e = parse_unloaded("", "u.csv").unwrap_err();
    assert_eq!(e.kind(), ErrorKind::Empty);
    // A trial file is a valid unloaded file with the EMG columns ignored.
    let u = parse_unloaded(&valid(), "u.csv").unwrap();
    assert_eq!(u.ignored_columns, vec!["emg_sol", "emg_gm", "emg_gl"]);
}

#[test]
fn missing_path_is_named() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("nope.csv");
    let e = read_trial(&p).unwrap_err();
    assert_eq!(e.kind(), ErrorKind::NotFound);
    assert_eq!(e.to_string(), format!("{}: no such file", p.display()));
    let e = read_unloaded(&p).unwrap_err();
    assert_eq!(e.kind(), ErrorKind::NotFound);
    let e = read_trial(dir.path()).unwrap_err();
    assert_eq!(e.kind(), ErrorKind::Io);
}

#[test]
fn crlf_comments_blank_lines_bom_and_spaces_are_accepted() {
    let plain = parse_trial(&valid(), "a.csv").unwrap();
    assert_eq!(plain.len(), 151);
    assert!((plain.dt() - 0.01).abs() < 1e-12);

    let r = rows(151, 100.0);
    let mut text = String::from("\u{FEFF}# exported by Biodex\r\n#subject=3\r\n\r\n");
    text.push_str(&HEADER.replace(',', ", "));
    text.push_str("\r\n");
    for (i, l) in r.iter().enumerate() {
        if i == 50 {
            text.push_str("  # marker: start\r\n\r\n");
        }
        text.push_str(&l.replace(',', " , "));
        text.push_str("\r\n");
    }
    let t = parse_trial(&text, "b.csv").unwrap();
    assert_eq!(t.time_s, plain.time_s);
    assert_eq!(t.torque_nm, plain.torque_nm);
    assert_eq!(t.emg_gl, plain.emg_gl);
    assert_eq!(
        t.comments,
        vec![" exported by Biodex", "subject=3", " marker: start"]
    );
    // Line numbers count comment and blank lines: row 60 is on line 60 + 1 + 3 + 1 + 2 = 67.
    let bad = text.replacen(&r[60].replace(',', " , "), "x , 1 , 2 , 3 , 4 , 5", 1);
    let e = parse_trial(&bad, "b.csv").unwrap_err();
    assert_eq!(e.line(), Some(67), "{e}");
}

#[test]
fn columns_in_any_order_optional_and_unknown_columns() {
    let r = rows(151, 100.0);
    let re: Vec<String> = r
        .iter()
        .enumerate()
        .map(|(i, l)| {
            let f: Vec<&str> = l.split(',').collect();
            format!(
                "{},{},{},{},{},{},{},{},{}",
                f[5],
                f[4],
                f[3],
                i,
                f[2],
                f[1],
                f[0],
                0.01 * i as f64 + 0.5,
                0
            )
        })
        .collect();
    let t = parse_trial(
        &join(
            "emg_gl,emg_gm,emg_sol,sample,torque_nm,ankle_angle_deg,time_s,emg_ta,knee_angle_deg",
            &re,
        ),
        "c.csv",
    )
    .unwrap();
    let plain = parse_trial(&valid(), "a.csv").unwrap();
    assert_eq!(t.time_s, plain.time_s);
    assert_eq!(t.emg_sol, plain.emg_sol);
    assert_eq!(t.ignored_columns, vec!["sample"]);
    assert_eq!(t.emg_ta.as_ref().map(Vec::len), Some(151));
    assert_eq!(t.knee_angle_deg, Some(vec![0.0; 151]));
    assert_eq!(t.emg_channels().len(), 4);
    // Written back in canonical order, without the unknown column.
    let text = format_trial(&t).unwrap();
    assert!(text.starts_with(
        "time_s,ankle_angle_deg,torque_nm,emg_sol,emg_gm,emg_gl,emg_ta,knee_angle_deg\n"
    ));
}

fn awkward_trial() -> Trial {
    let n = 2100;
    let mut rng = ChaCha8Rng::seed_from_u64(11);
    let mut col = |scale: f64| -> Vec<f64> {
        (0..n)
            .map(|_| {
                let x: f64 = rng.random::<f64>() - 0.5;
                scale * x * 10f64.powi(rng.random_range(-12..12))
            })
            .collect()
    };
    let mut ta = col(1.0);
    ta[3] = -0.0;
    ta[4] = 5e-324;
    ta[5] = f64::MAX;
    ta[6] = 1e15;
    ta[7] = 1e-5;
    ta[8] = 0.1 + 0.2;
    Trial {
        time_s: (0..n).map(|i| 3.25 + i as f64 / 2048.0).collect(),
        // awkward digits, but inside the ankle's range (the reader checks it)
        ankle_angle_deg: col(20.0)
            .into_iter()
            .map(|x| x.clamp(-89.5, 89.5))
            .collect(),
        torque_nm: col(100.0),
        emg_sol: col(1.0),
        emg_gm: col(1.0),
        emg_gl: col(1.0),
        emg_ta: Some(ta),
        emg_other: vec![("perlong".into(), col(0.5))],
        knee_angle_deg: Some(vec![0.0; n]),
        grf_vertical_n: None,
        comments: vec![" generated".into(), "seed=11, a, b".into()],
        ignored_columns: Vec::new(),
    }
}

#[test]
fn write_read_write_is_byte_identical_and_exact() {
    let dir = tempfile::tempdir().unwrap();
    let p1 = dir.path().join("t1.csv");
    let p2 = dir.path().join("t2.csv");
    let t = awkward_trial();
    write_trial(&p1, &t).unwrap();
    let back = read_trial(&p1).unwrap();
    assert_eq!(back, t, "read(write(t)) != t");
    let ta = back.emg_ta.as_ref().unwrap();
    assert!(ta[3] == 0.0 && ta[3].is_sign_negative());
    write_trial(&p2, &back).unwrap();
    let (b1, b2) = (std::fs::read(&p1).unwrap(), std::fs::read(&p2).unwrap());
    assert_eq!(b1, b2);
    assert!(String::from_utf8(b1).unwrap().contains("\n-0,") || format_f64(-0.0) == "-0");
    // Only the two files: no temporary file left behind.
    let names: Vec<_> = std::fs::read_dir(dir.path()).unwrap().collect();
    assert_eq!(names.len(), 2);

    let u = Unloaded {
        time_s: t.time_s.clone(),
        ankle_angle_deg: t.ankle_angle_deg.clone(),
        torque_nm: t.torque_nm.clone(),
        comments: vec!["unloaded".into()],
        ignored_columns: Vec::new(),
    };
    let pu = dir.path().join("u.csv");
    write_unloaded(&pu, &u).unwrap();
    let ub = read_unloaded(&pu).unwrap();
    assert_eq!(ub, u);
    let pu2 = dir.path().join("u2.csv");
    write_unloaded(&pu2, &ub).unwrap();
    assert_eq!(std::fs::read(&pu).unwrap(), std::fs::read(&pu2).unwrap());
}

#[test]
fn float_format_is_shortest_round_trip() {
    for (x, s) in [
        (0.1, "0.1"),
        (-0.0, "-0"),
        (0.0, "0"),
        (1.0 / 2048.0, "0.00048828125"),
        (3.0e-7, "3e-7"),
        (1e15, "1e15"),
        (123456.5, "123456.5"),
        (0.1 + 0.2, "0.30000000000000004"),
    ] {
        assert_eq!(format_f64(x), s);
        assert_eq!(s.parse::<f64>().unwrap().to_bits(), x.to_bits());
    }
}

#[test]
fn writer_rejects_invalid_data_and_leaves_no_file() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("bad.csv");
    let mut t = awkward_trial();
    t.torque_nm[100] = f64::NAN;
    let e = write_trial(&p, &t).unwrap_err();
    assert_eq!(e.kind(), ErrorKind::NotFinite);
    assert_eq!(e.line(), Some(104)); // 2 comments + header, then row 100 (0-based) on line 104
    let mut t2 = awkward_trial();
    t2.emg_gm.pop();
    assert_eq!(
        write_trial(&p, &t2).unwrap_err().kind(),
        ErrorKind::LengthMismatch
    );
    let mut t3 = awkward_trial();
    t3.comments.push("two\nlines".into());
    assert_eq!(write_trial(&p, &t3).unwrap_err().kind(), ErrorKind::Binary);
    assert!(!p.exists());
    assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 0);
}

/// Feeds random bytes, random printable text and randomly corrupted valid files to both
/// parsers: they must return (never panic) and every error must be one line.
#[test]
fn parser_never_panics_on_random_input() {
    let mut rng = ChaCha8Rng::seed_from_u64(2024);
    let alphabet: Vec<u8> = b"0123456789.,-+eE#;\t \r\n\r\nabcxyzNaninf_time_s,emg_sol,".to_vec();
    let base = valid().into_bytes();
    let mut errors = 0usize;
    let mut oks = 0usize;
    let mut check = |b: &[u8]| {
        for r in [
            parse_trial_bytes(b, "f.csv").map(|_| ()),
            parse_unloaded_bytes(b, "f.csv").map(|_| ()),
        ] {
            match r {
                Ok(()) => oks += 1,
                Err(e) => {
                    one_line(&e);
                    errors += 1;
                }
            }
        }
    };
    for _ in 0..1500 {
        let n = rng.random_range(0..400);
        let b: Vec<u8> = (0..n).map(|_| rng.random::<u8>()).collect();
        check(&b);
    }
    for _ in 0..1500 {
        let n = rng.random_range(0..600);
        let b: Vec<u8> = (0..n)
            .map(|_| alphabet[rng.random_range(0..alphabet.len())])
            .collect();
        check(&b);
    }
    for _ in 0..1500 {
        let mut b = base.clone();
        for _ in 0..rng.random_range(1..4) {
            let pos = rng.random_range(0..b.len());
            match rng.random_range(0..4) {
                0 => b[pos] = alphabet[rng.random_range(0..alphabet.len())],
                1 => {
                    b.remove(pos);
                }
                2 => b.insert(pos, rng.random::<u8>()),
                _ => b.truncate(pos),
            }
        }
        check(&b);
    }
    // Corrupted files are mostly rejected, but some single-character edits keep them valid.
    assert!(errors > 8000, "errors {errors}");
    assert!(oks > 0, "no corrupted file was still valid");
}

#[test]
fn angles_beyond_the_joint_range_are_rejected_with_line_and_column() {
    let mut text = String::from("time_s,ankle_angle_deg,torque_nm,emg_sol,emg_gm,emg_gl\n");
    for i in 0..2100 {
        let angle = if i == 7 { 1.0e6 } else { 10.0 };
        text.push_str(&format!("{},{angle},1,0.1,-0.2,0.3\n", i as f64 / 2048.0));
    }
    let e = parse_trial(&text, "t.csv").unwrap_err();
    assert_eq!(e.kind(), ErrorKind::OutOfRange);
    assert_eq!((e.line(), e.column()), (Some(9), Some(2)));
    assert!(
        e.to_string().starts_with("t.csv:9:2 (ankle_angle_deg): "),
        "{e}"
    );
    // the range's edges are accepted
    let ok = text.replace(",1000000,", ",-90,");
    assert!(parse_trial(&ok, "t.csv").is_ok());
}
