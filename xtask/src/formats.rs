//! `fixtures/formats/`: one synthetic trial written in every format a lab's recording may come
//! in, each with the recording map that reads it, so that the tests can check that every
//! format gives the same trial.
//!
//! The trial is the seed fixture's with its EMG in µV and its angle, torque and EMG rounded to
//! `f32` (a C3D stores `f32`), so that every format carries its numbers exactly. Where a map
//! scales a channel (the Noraxon-style export's dynamometer channels in mV), the calibration
//! is a binary fraction (0.125 °/mV, 0.0625 N·m/mV) and each raw number written is the one
//! whose `sign·(scale·raw + offset)` gives the trial's number back bit for bit: the formats
//! then agree bitwise, not only within rounding. (With a decimal calibration such as
//! 0.0749 N·m/mV a mapped number can differ from the original in its last bit; the tests
//! measure what that does.)

use anyhow::{bail, Context, Result};
use experiment::{format_f64, format_trial, format_unloaded, Trial, Unloaded};
use opensim_files::StoTable;
use recording::ChannelMap;
use serde_json::json;

/// The next `f64` towards `+∞` (`up`) or `−∞`.
fn step(x: f64, up: bool) -> f64 {
    if x == 0.0 {
        let tiny = f64::from_bits(1);
        return if up { tiny } else { -tiny };
    }
    let b = x.to_bits();
    let away = (x > 0.0) == up;
    f64::from_bits(if away { b + 1 } else { b - 1 })
}

/// The raw number whose mapped value is `v` exactly.
fn raw_for(v: f64, ch: &ChannelMap) -> Result<f64> {
    let guess = (v * ch.sign - ch.offset) / ch.scale;
    let (mut lo, mut hi) = (guess, guess);
    for _ in 0..4096 {
        #[allow(clippy::float_cmp)]
        if ch.apply(lo) == v {
            return Ok(lo);
        }
        #[allow(clippy::float_cmp)]
        if ch.apply(hi) == v {
            return Ok(hi);
        }
        lo = step(lo, false);
        hi = step(hi, true);
    }
    bail!(
        "no raw number maps to {v} with scale {}, offset {}",
        ch.scale,
        ch.offset
    )
}

fn round_f32(v: &[f64]) -> Vec<f64> {
    v.iter().map(|&x| f64::from(x as f32)).collect()
}

fn map_text(v: &serde_json::Value) -> Result<String> {
    Ok(serde_json::to_string_pretty(v)? + "\n")
}

fn channel(column: &str, scale: f64, offset: f64, sign: f64) -> ChannelMap {
    ChannelMap {
        file: None,
        column: column.into(),
        scale,
        offset,
        sign,
        rate_hz: None,
    }
}

/// A storage table of `time` and the given columns.
fn sto(name: &str, time: &[f64], cols: Vec<(&str, Vec<f64>)>) -> Result<String> {
    let mut labels = vec!["time".to_string()];
    let mut columns = vec![time.to_vec()];
    for (l, c) in cols {
        labels.push(l.into());
        columns.push(c);
    }
    let t = StoTable {
        name: name.into(),
        version: 1,
        in_degrees: Some(true),
        labels,
        columns,
    };
    opensim_files::write_sto(&t).map_err(|e| anyhow::anyhow!("{e}"))
}

/// The files of a fixture folder: path inside it and contents.
type Files = Vec<(String, Vec<u8>)>;

/// The files of `fixtures/formats/` from the seed fixture's trial and unloaded run.
pub fn render(seed_trial: &Trial, seed_unloaded: &Unloaded) -> Result<Files> {
    let t = formats_trial(seed_trial);
    let mut u = seed_unloaded.clone();
    u.comments = vec![format!(
        " the seed fixture's unloaded run, made by `{}`",
        crate::GENERATOR
    )];
    let mut out: Files = vec![
        ("trial.csv".into(), format_trial(&t)?.into_bytes()),
        ("unloaded.csv".into(), format_unloaded(&u)?.into_bytes()),
    ];
    // the sampling rate a C3D and the Noraxon map state
    let rate = t.sample_rate_hz().round();
    out.extend(opensim_files(&t)?);
    out.extend(c3d_files(&t, rate)?);
    out.extend(noraxon_files(&t, rate)?);
    out.extend(semicolon_files(&t)?);
    Ok(out)
}

/// The seed trial as every format carries it: EMG in µV, and angle, torque and EMG rounded to
/// `f32` (what a C3D stores), so that every file holds the same numbers exactly.
fn formats_trial(seed_trial: &Trial) -> Trial {
    let mut t = seed_trial.clone();
    t.ankle_angle_deg = round_f32(&t.ankle_angle_deg);
    t.torque_nm = round_f32(&t.torque_nm);
    let micro = |v: &[f64]| round_f32(&v.iter().map(|x| 1000.0 * x).collect::<Vec<_>>());
    t.emg_sol = micro(&t.emg_sol);
    t.emg_gm = micro(&t.emg_gm);
    t.emg_gl = micro(&t.emg_gl);
    t.comments = vec![format!(
        " surae fixture `formats`: the seed fixture's trial with its EMG in µV and angle, torque \
         and EMG rounded to f32, made by `{}`; the same numbers are in every file of this folder",
        crate::GENERATOR
    )];
    t
}

/// OpenSim: EMG in a version 2 .sto, the angle in a .mot, the moment (OpenSim's sign) in a .sto.
fn opensim_files(t: &Trial) -> Result<Files> {
    let emg = sto(
        "emg",
        &t.time_s,
        vec![
            ("soleus_r", t.emg_sol.clone()),
            ("med_gas_r", t.emg_gm.clone()),
            ("lat_gas_r", t.emg_gl.clone()),
        ],
    )?;
    // the same table under a version 2 header (no table name, no row and column counts), so
    // that both header versions are read
    let body = emg
        .split_once("endheader\n")
        .map(|(_, b)| b)
        .context("storage text without endheader")?;
    let emg_v2 =
        format!("version=2\nOpenSimVersion=4.5\nDataType=double\ninDegrees=yes\nendheader\n{body}");
    let ik = sto(
        "ik",
        &t.time_s,
        vec![("ankle_angle_r", t.ankle_angle_deg.clone())],
    )?;
    let moment: Vec<f64> = t.torque_nm.iter().map(|x| -x).collect();
    let id = sto("id", &t.time_s, vec![("ankle_angle_r_moment", moment)])?;
    let map = map_text(&json!({
        "comment": "OpenSim files joined on their time columns; OpenSim's moment is positive towards dorsiflexion",
        "channels": {
            "ankle_angle_deg": {"file": "ik.mot", "column": "ankle_angle_r"},
            "torque_nm": {"file": "id.sto", "column": "ankle_angle_r_moment", "sign": -1},
            "emg_sol": {"file": "emg.sto", "column": "soleus_r"},
            "emg_gm": {"file": "emg.sto", "column": "med_gas_r"},
            "emg_gl": {"file": "emg.sto", "column": "lat_gas_r"}}
    }))?;
    Ok(vec![
        ("opensim/emg.sto".into(), emg_v2.into_bytes()),
        ("opensim/ik.mot".into(), ik.into_bytes()),
        ("opensim/id.sto".into(), id.into_bytes()),
        ("opensim/map.json".into(), map.into_bytes()),
    ])
}

/// C3D analog channels (f32, scale 1, offset 0) at `rate` Hz.
fn c3d_files(t: &Trial, rate: f64) -> Result<Files> {
    let c3d = recording::c3d::format_c3d_analog(
        rate,
        &[
            ("Angle", "deg", &t.ankle_angle_deg),
            ("Torque", "Nm", &t.torque_nm),
            ("Soleus", "uV", &t.emg_sol),
            ("GasMed", "uV", &t.emg_gm),
            ("GasLat", "uV", &t.emg_gl),
        ],
    )
    .map_err(|e| anyhow::anyhow!("{e}"))?;
    let map = map_text(&json!({
        "file": "trial.c3d",
        "channels": {
            "ankle_angle_deg": {"column": "Angle"},
            "torque_nm": {"column": "Torque"},
            "emg_sol": {"column": "Soleus"},
            "emg_gm": {"column": "GasMed"},
            "emg_gl": {"column": "GasLat"}}
    }))?;
    Ok(vec![
        ("c3d/trial.c3d".into(), c3d),
        ("c3d/map.json".into(), map.into_bytes()),
    ])
}

/// A Noraxon-style export of a Humac Norm test: tab separated, quoted headers, EMG in µV,
/// the dynamometer in mV, both legs' EMG, the left leg's torque sign flipped; sampled at `rate` Hz.
fn noraxon_files(t: &Trial, rate: f64) -> Result<Files> {
    let angle = channel("CN ANGLE,mV", 0.125, -35.25, 1.0);
    let torque = channel("CN TORQUE,mV", 0.0625, 0.6875, -1.0);
    let uv = |c: &str| channel(c, 1.0, 0.0, 1.0);
    let cols: Vec<(ChannelMap, Vec<f64>)> = vec![
        (uv("LT MED. GASTRO,uV"), t.emg_gm.clone()),
        (uv("LT LAT. GASTRO,uV"), t.emg_gl.clone()),
        (uv("LT SOLEUS,uV"), t.emg_sol.clone()),
        // the other leg, at rest: a fifth of the left soleus, in µV
        (
            uv("RT SOLEUS,uV"),
            t.emg_sol.iter().map(|x| 0.2 * x).collect(),
        ),
        (angle.clone(), t.ankle_angle_deg.clone()),
        (torque.clone(), t.torque_nm.clone()),
    ];
    let tsv = noraxon_tsv(&t.time_s, &cols)?;
    let map = map_text(&json!({
        "comment": "Humac Norm angle and torque recorded in mV by the EMG system (this lab's calibration: 0.125 deg/mV and 0.0625 N·m/mV with their zeros); the left leg, so the torque's sign is flipped",
        "file": "export.tsv",
        "rate_hz": rate,
        "channels": {
            "ankle_angle_deg": {"column": angle.column, "scale": angle.scale, "offset": angle.offset},
            "torque_nm": {"column": torque.column, "scale": torque.scale, "offset": torque.offset, "sign": -1},
            "emg_sol": {"column": "LT SOLEUS,uV"},
            "emg_gm": {"column": "LT MED. GASTRO,uV"},
            "emg_gl": {"column": "LT LAT. GASTRO,uV"}}
    }))?;
    Ok(vec![
        ("noraxon/export.tsv".into(), tsv.into_bytes()),
        ("noraxon/map.json".into(), map.into_bytes()),
    ])
}

/// The export's text: a quoted header of the channels' columns, then per sample the time and
/// each channel's raw number (the one its map turns back into the trial's number exactly).
fn noraxon_tsv(time_s: &[f64], cols: &[(ChannelMap, Vec<f64>)]) -> Result<String> {
    let mut raws = Vec::with_capacity(cols.len());
    for (ch, v) in cols {
        let r: Vec<f64> = v.iter().map(|&x| raw_for(x, ch)).collect::<Result<_>>()?;
        raws.push(r);
    }
    let mut tsv = String::from("\"Time,s\"");
    for (ch, _) in cols {
        tsv.push_str(&format!("\t\"{}\"", ch.column));
    }
    tsv.push('\n');
    for (i, &time) in time_s.iter().enumerate() {
        tsv.push_str(&format_f64(time));
        for r in &raws {
            tsv.push('\t');
            tsv.push_str(&format_f64(r[i]));
        }
        tsv.push('\n');
    }
    Ok(tsv)
}

/// A spreadsheet export: semicolons and decimal commas.
fn semicolon_files(t: &Trial) -> Result<Files> {
    let mut sc = String::from(
        "time [s];ankle angle [deg];torque [Nm];soleus [uV];gastrocnemius medialis [uV];gastrocnemius lateralis [uV]\n",
    );
    for i in 0..t.len() {
        let row = [
            t.time_s[i],
            t.ankle_angle_deg[i],
            t.torque_nm[i],
            t.emg_sol[i],
            t.emg_gm[i],
            t.emg_gl[i],
        ]
        .iter()
        .map(|&x| format_f64(x).replace('.', ","))
        .collect::<Vec<_>>()
        .join(";");
        sc.push_str(&row);
        sc.push('\n');
    }
    let map = map_text(&json!({
        "file": "export.csv",
        "channels": {
            "ankle_angle_deg": {"column": "ankle angle [deg]"},
            "torque_nm": {"column": "torque [Nm]"},
            "emg_sol": {"column": "soleus [uV]"},
            "emg_gm": {"column": "gastrocnemius medialis [uV]"},
            "emg_gl": {"column": "gastrocnemius lateralis [uV]"}}
    }))?;
    Ok(vec![
        ("semicolon/export.csv".into(), sc.into_bytes()),
        ("semicolon/map.json".into(), map.into_bytes()),
    ])
}
