//! OpenSim storage files: version 1 and 2 headers, round trips, and errors with positions.

use opensim_files::{read_sto, write_sto, OpenSimError, StoTable};

fn table() -> StoTable {
    StoTable {
        name: "simulate".into(),
        version: 1,
        in_degrees: Some(true),
        labels: vec!["time".into(), "ankle_angle_r".into(), "m".into()],
        columns: vec![
            vec![0.0, 0.001, 0.002],
            vec![-20.0, -19.987654321012345, 1e-300],
            vec![0.1 + 0.2, -3.5e7, f64::MIN_POSITIVE],
        ],
    }
}

#[test]
fn written_files_have_a_version_1_header_and_read_back_exactly() {
    let t = table();
    let text = write_sto(&t).unwrap();
    let lines: Vec<&str> = text.lines().collect();
    assert_eq!(
        &lines[..7],
        &[
            "simulate",
            "version=1",
            "nRows=3",
            "nColumns=3",
            "inDegrees=yes",
            "endheader",
            "time\tankle_angle_r\tm"
        ]
    );
    assert_eq!(lines.len(), 10);
    let back = read_sto(&text, "x.sto").unwrap();
    assert_eq!(back, t);
    assert_eq!(back.time().unwrap(), &t.columns[0][..]);
    assert_eq!(
        back.column("m").unwrap()[0].to_bits(),
        (0.1f64 + 0.2).to_bits()
    );
    assert_eq!(back.rows(), 3);
}

#[test]
fn version_2_headers_and_space_separated_labels_are_read() {
    let text = "version=2\nOpenSimVersion=4.5\nDataType=double\ninDegrees=no\nendheader\n\
                time\tankle_angle_r\tknee_angle_r\n0\t-0.3\t0.1\n0.01\t-0.29\t0.1\n\n";
    let t = read_sto(text, "ik.mot").unwrap();
    assert_eq!(t.version, 2);
    assert_eq!(t.in_degrees, Some(false));
    assert_eq!(t.name, "");
    assert_eq!(t.column("ankle_angle_r").unwrap(), &[-0.3, -0.29]);
    assert_eq!(t.column("hip"), None);

    let text = "old\nnRows=1\nnColumns=2\nendheader\ntime  emg_sol\n  0.5   1e-3\n";
    let t = read_sto(text, "emg.sto").unwrap();
    assert_eq!(t.labels, vec!["time", "emg_sol"]);
    assert_eq!(t.column("emg_sol").unwrap(), &[1e-3]);
    assert_eq!(t.in_degrees, None);
    assert_eq!(t.name, "old");
}

fn err(text: &str) -> String {
    read_sto(text, "f.sto").unwrap_err().to_string()
}

#[test]
fn bad_files_name_the_line_and_column() {
    assert_eq!(
        err("x\nversion=1\ntime\n0\n"),
        "f.sto: no `endheader` line: not an OpenSim storage file"
    );
    assert_eq!(
        err("endheader\ntime\ta\n0\t1\n0.1\tx1\n"),
        "f.sto:4:5: column `a`: `x1` is not a number"
    );
    assert_eq!(
        err("endheader\ntime\ta\n0\t1\t2\n"),
        "f.sto:3:1: 3 values but 2 columns"
    );
    assert_eq!(
        err("nRows=3\nendheader\ntime\ta\n0\t1\n"),
        "f.sto:1:1: nRows=3 but the file has 1 rows"
    );
    assert_eq!(
        err("nColumns=3\nendheader\ntime\ta\n0\t1\n"),
        "f.sto:1:1: nColumns=3 but the file has 2 columns"
    );
    assert_eq!(
        err("endheader\nt\ta\n0\t1\n"),
        "f.sto:2:1: no `time` column"
    );
    assert_eq!(
        err("endheader\ntime\ta\ta\n"),
        "f.sto:2:8: column `a` appears twice"
    );
    assert_eq!(
        err("inDegrees=maybe\nendheader\ntime\n"),
        "f.sto:1:1: inDegrees=`maybe`: expected yes or no"
    );
    assert_eq!(
        err("endheader\n\n"),
        "f.sto: no column labels after `endheader`"
    );
}

#[test]
fn the_writer_refuses_inconsistent_tables() {
    let mut t = table();
    t.columns[1].pop();
    assert!(matches!(write_sto(&t), Err(OpenSimError::File { .. })));
    let mut t = table();
    t.labels[1] = "ankle angle".into();
    assert!(write_sto(&t)
        .unwrap_err()
        .to_string()
        .contains("white space"));
    let mut t = table();
    t.labels[0] = "t".into();
    assert!(write_sto(&t)
        .unwrap_err()
        .to_string()
        .contains("no `time` column"));
    let mut t = table();
    t.in_degrees = Some(false);
    assert!(write_sto(&t).unwrap().contains("\ninDegrees=no\n"));
}
