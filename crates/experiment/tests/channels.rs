//! Further `emg_<name>` columns and the knee angle: what the reader accepts and rejects, how
//! the writer writes them, and how they reach the model inputs (envelopes by name, knee
//! flexion from the column or a constant).

use experiment::{
    format_f64, format_trial, model_inputs, model_inputs_named, parse_trial, ErrorKind,
    ExperimentError, InputOptions, Trial,
};

/// A trial text at 1000 Hz, 1.5 s, with the required columns, then `extra` columns (name, and
/// value at row `i`), one row per line after the header.
fn text_with(extra: &[(&str, &dyn Fn(usize) -> f64)]) -> String {
    let fs = 1000.0;
    let mut s = String::from("time_s,ankle_angle_deg,torque_nm,emg_sol,emg_gm,emg_gl");
    for (name, _) in extra {
        s.push(',');
        s.push_str(name);
    }
    s.push('\n');
    for i in 0..1500 {
        let t = i as f64 / fs;
        let cells = [
            t,
            15.0 - 10.0 * t,
            50.0 * (3.0 * t).sin(),
            0.1 * (377.0 * t).sin(),
            0.2 * (411.0 * t).cos(),
            -0.05 * (233.0 * t).sin(),
        ];
        let mut row: Vec<String> = cells.iter().map(|&x| format_f64(x)).collect();
        for (_, f) in extra {
            row.push(format_f64(f(i)));
        }
        s.push_str(&row.join(","));
        s.push('\n');
    }
    s
}

fn perlong(i: usize) -> f64 {
    0.3 * (0.29 * i as f64).sin() * (1.0 + (0.004 * i as f64).sin())
}

fn knee(_: usize) -> f64 {
    60.0
}

#[test]
fn further_emg_columns_are_read_in_file_order_and_written_after_emg_ta() {
    let text = text_with(&[
        ("emg_perlong", &perlong),
        ("knee_angle_deg", &knee),
        ("emg_ta", &|i| 0.02 * (0.7 * i as f64).cos()),
        ("emg_tibpost_r", &|i| 0.01 * (0.41 * i as f64).sin()),
        ("notes", &|_| 1.0),
    ]);
    let t = parse_trial(&text, "t.csv").unwrap();
    let names: Vec<&str> = t.emg_other.iter().map(|(n, _)| n.as_str()).collect();
    assert_eq!(names, ["perlong", "tibpost_r"]);
    assert_eq!(t.emg_named("perlong").unwrap()[1], perlong(1));
    assert!(t.emg_named("ta").is_none(), "ta has its own field");
    assert_eq!(t.knee_angle_deg, Some(vec![60.0; 1500]));
    assert_eq!(t.ignored_columns, ["notes"]);
    let channels: Vec<String> = t.emg_channels().into_iter().map(|(n, _)| n).collect();
    assert_eq!(
        channels,
        [
            "emg_sol",
            "emg_gm",
            "emg_gl",
            "emg_ta",
            "emg_perlong",
            "emg_tibpost_r"
        ]
    );
    // canonical order: required, emg_ta, the further channels, knee_angle_deg
    let written = format_trial(&t).unwrap();
    assert_eq!(
        written.lines().next().unwrap(),
        "time_s,ankle_angle_deg,torque_nm,emg_sol,emg_gm,emg_gl,emg_ta,emg_perlong,\
         emg_tibpost_r,knee_angle_deg"
    );
    let back = parse_trial(&written, "t.csv").unwrap();
    assert_eq!(back.emg_other, t.emg_other);
    assert_eq!(format_trial(&back).unwrap(), written);
}

fn err_of(text: &str) -> ExperimentError {
    parse_trial(text, "t.csv").unwrap_err()
}

#[test]
fn bad_further_emg_columns_are_one_line_errors_naming_line_and_column() {
    // a channel name that is not lower case would be silently dropped if ignored
    let e = err_of(&text_with(&[("EMG_PerLong", &perlong)]));
    assert_eq!(e.kind(), ErrorKind::MisspelledColumn);
    assert_eq!((e.line(), e.column()), (Some(1), Some(7)));
    assert!(e.to_string().contains("'EMG_PerLong'"), "{e}");
    // the same channel twice
    let e = err_of(&text_with(&[
        ("emg_perlong", &perlong),
        ("emg_perlong", &perlong),
    ]));
    assert_eq!(e.kind(), ErrorKind::DuplicateColumn);
    assert_eq!(e.column(), Some(8));
    // a disconnected electrode
    let e = err_of(&text_with(&[("emg_perlong", &|_| 0.0)]));
    assert_eq!(e.kind(), ErrorKind::ZeroChannel);
    assert_eq!(
        e.to_string(),
        "t.csv: column 7 (emg_perlong): EMG channel is all zeros (disconnected electrode?)"
    );
    // a bad cell names the channel
    let text = text_with(&[("emg_perlong", &perlong)]).replacen(
        &format!(",{}\n", format_f64(perlong(3))),
        ",abc\n",
        1,
    );
    let e = err_of(&text);
    assert_eq!(e.kind(), ErrorKind::NotANumber);
    assert_eq!((e.line(), e.column()), (Some(5), Some(7)));
    assert!(e.to_string().contains("(emg_perlong)"), "{e}");
    // a knee angle no knee reaches
    let e = err_of(&text_with(&[("knee_angle_deg", &|_| 200.0)]));
    assert_eq!(e.kind(), ErrorKind::OutOfRange);
    assert_eq!((e.line(), e.column()), (Some(2), Some(7)));
}

#[test]
fn a_file_without_the_new_columns_reads_as_it_always_did() {
    let text = text_with(&[("emg_", &perlong), ("xemg_foo", &perlong)]);
    let t = parse_trial(&text, "t.csv").unwrap();
    assert!(t.emg_other.is_empty());
    assert_eq!(t.ignored_columns, ["emg_", "xemg_foo"]);
    assert_eq!(t.knee_angle_deg, None);
    let inputs = model_inputs(&t, &InputOptions::default()).unwrap();
    assert_eq!(inputs.knee_angle(), None);
}

/// A further channel goes through exactly the envelope pipeline of the others: the same raw
/// signal gives the same envelope as `emg_gm`.
#[test]
fn a_further_channel_becomes_the_envelope_of_its_name() {
    let mut t = parse_trial(&text_with(&[]), "t.csv").unwrap();
    t.emg_other.push(("perlong".into(), t.emg_gm.clone()));
    let inputs = model_inputs(&t, &InputOptions::default()).unwrap();
    let gm = inputs.envelope(muscle_model::Muscle::Gm);
    assert_eq!(inputs.envelope_named("perlong").unwrap(), gm);
    // as envelopes: only the clamp
    t.emg_other[0].1 = (0..t.len()).map(|i| 0.001 * i as f64 - 0.2).collect();
    let opts = InputOptions {
        emg_is_envelope: true,
        ..InputOptions::default()
    };
    t.emg_sol = vec![0.5; t.len()];
    t.emg_gm = vec![0.5; t.len()];
    t.emg_gl = vec![0.5; t.len()];
    let inputs = model_inputs(&t, &opts).unwrap();
    let env = inputs.envelope_named("perlong").unwrap();
    assert_eq!(env[0], 0.0);
    assert_eq!(env[700], 0.001 * 700.0 - 0.2);
    assert_eq!(env[1499], 1.0);
}

#[test]
fn a_further_channel_with_nothing_in_the_emg_band_is_an_error_naming_it() {
    let mut t = parse_trial(&text_with(&[]), "t.csv").unwrap();
    t.emg_ta = Some(t.emg_sol.clone());
    t.emg_other.push(("perlong".into(), vec![0.25; t.len()]));
    let e = model_inputs_named(&t, &InputOptions::default(), "t.csv").unwrap_err();
    assert_eq!(e.kind(), ErrorKind::ZeroChannel);
    // canonical position: after emg_ta (7)
    assert_eq!(e.column(), Some(8));
    assert!(
        e.to_string().starts_with("t.csv: column 8 (emg_perlong): "),
        "{e}"
    );
}

fn trial_with_knee(k: Option<Vec<f64>>) -> Trial {
    let mut t = parse_trial(&text_with(&[]), "t.csv").unwrap();
    t.knee_angle_deg = k;
    t
}

#[test]
fn the_knee_angle_comes_from_the_column_or_the_constant() {
    // the column, in radians
    let col: Vec<f64> = (0..1500).map(|i| 30.0 + 0.02 * i as f64).collect();
    let t = trial_with_knee(Some(col.clone()));
    let inputs = model_inputs(&t, &InputOptions::default()).unwrap();
    let want: Vec<f64> = col.iter().map(|d| d.to_radians()).collect();
    assert_eq!(inputs.knee_angle().unwrap(), want.as_slice());
    // the constant, for a trial without a column
    let t = trial_with_knee(None);
    let opts = InputOptions::default().with_knee_angle_deg(90.0);
    let inputs = model_inputs(&t, &opts).unwrap();
    let k = inputs.knee_angle().unwrap();
    assert_eq!(k.len(), t.len());
    assert!(k.iter().all(|&x| x == std::f64::consts::FRAC_PI_2));
    // a column holding the same constant agrees (within 1e-6°)
    let t = trial_with_knee(Some(vec![90.0 + 5e-7; 1500]));
    let inputs = model_inputs(&t, &opts).unwrap();
    assert_eq!(
        inputs.knee_angle().unwrap()[0],
        (90.0f64 + 5e-7).to_radians()
    );
    // the extended knee is 0, not absent, when the constant says so
    let inputs = model_inputs(
        &trial_with_knee(None),
        &InputOptions::default().with_knee_angle_deg(0.0),
    )
    .unwrap();
    assert!(inputs.knee_angle().unwrap().iter().all(|&x| x == 0.0));
}

#[test]
fn a_constant_that_disagrees_with_the_column_is_a_conflict_naming_the_column() {
    let mut col = vec![90.0; 1500];
    col[700] = 85.0;
    let t = trial_with_knee(Some(col));
    let opts = InputOptions::default().with_knee_angle_deg(90.0);
    let e = model_inputs_named(&t, &opts, "t.csv").unwrap_err();
    assert_eq!(e.kind(), ErrorKind::Conflict);
    assert_eq!(e.column(), Some(7));
    let msg = e.to_string();
    assert!(
        msg.starts_with(
            "t.csv: column 7 (knee_angle_deg): the trial's knee angle (85° at sample 700)"
        ),
        "{msg}"
    );
    assert!(!msg.contains('\n'));
}

#[test]
fn an_impossible_constant_knee_angle_is_an_error() {
    let t = trial_with_knee(None);
    for k in [f64::NAN, f64::INFINITY, -31.0, 180.5] {
        let e = model_inputs(&t, &InputOptions::default().with_knee_angle_deg(k)).unwrap_err();
        assert_eq!(e.kind(), ErrorKind::InvalidSettings, "{k}");
        assert!(e.to_string().contains("knee angle"), "{e}");
    }
}
