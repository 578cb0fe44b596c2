//! CEINMS trial folders and subject XML, written here from synthetic data (never from real
//! recordings), read back as the model's inputs and parameters.

use ceinms_files::{format_table, read_subject, read_trial_folder, DEFAULT_JOINT};
use experiment::{
    ceinms_model_params, ceinms_model_trial, ceinms_trial_dirs, least_squares, moment_fit,
    read_ceinms_trial, synthesize, ErrorKind, SynthConfig,
};
use muscle_model::{ModelParams, Muscle, TrialInputs};
use numerics::interpolate::resample_linear;
use std::path::Path;

const GEOMETRY_RATE_HZ: f64 = 256.0;
/// The 256 Hz files start this long after the EMG, as CEINMS's do (about 0.13 s).
const GEOMETRY_DELAY_S: f64 = 0.125;

fn write(dir: &Path, file: &str, names: &[&str], time: &[f64], cols: &[Vec<f64>]) {
    let cols: Vec<&[f64]> = cols.iter().map(Vec::as_slice).collect();
    std::fs::write(dir.join(file), format_table(names, time, &cols).unwrap()).unwrap();
}

/// Tibialis anterior and peroneus longus envelopes of the synthetic trial (smooth, in [0, 1]).
fn extra_envelopes(inputs: &TrialInputs) -> (Vec<f64>, Vec<f64>) {
    let t = inputs.times();
    (
        t.iter().map(|t| 0.2 + 0.1 * (3.0 * t).sin()).collect(),
        t.iter().map(|t| 0.3 + 0.2 * (2.0 * t).cos()).collect(),
    )
}

struct Written {
    inputs: TrialInputs,
    model_torque: Vec<f64>,
    geometry_times: Vec<f64>,
}

/// The seed protocol's synthetic trial as a CEINMS folder: EMG at the trial's 2048 Hz, the
/// triceps' polynomial geometry and a tibialis anterior and two peronei at 256 Hz starting
/// `GEOMETRY_DELAY_S` later, the model's torque as the measured moment, all in CEINMS's signs.
fn write_seed_folder(dir: &Path) -> Written {
    let syn = synthesize(&SynthConfig::new("seed".parse().unwrap(), 11)).unwrap();
    let inputs = syn.inputs;
    let t = inputs.times().to_vec();
    let (ta, pl) = extra_envelopes(&inputs);
    let env = |m: Muscle| inputs.envelope(m).to_vec();
    write(
        dir,
        "emg.txt",
        &["gaslat_r", "gasmed_r", "perlong_r", "sol_r", "tibant_r"],
        &t,
        &[env(Muscle::Gl), env(Muscle::Gm), pl, env(Muscle::Sol), ta],
    );
    let end = t[t.len() - 1] - 0.05;
    let gt: Vec<f64> = (0..)
        .map(|k| t[0] + GEOMETRY_DELAY_S + k as f64 / GEOMETRY_RATE_HZ)
        .take_while(|&s| s <= end)
        .collect();
    let p = ModelParams::nominal();
    let q: Vec<f64> = gt.iter().map(|&s| inputs.angle_value_at(s)).collect();
    let mut lmt = Vec::new();
    let mut ma = Vec::new();
    for m in [Muscle::Gl, Muscle::Gm] {
        lmt.push(q.iter().map(|&q| p.muscle(m).lmt(q)).collect());
        ma.push(q.iter().map(|&q| -p.muscle(m).moment_arm(q)).collect());
    }
    // peroneus brevis and longus (plantarflexors: negative in CEINMS), soleus, tibialis
    // anterior (dorsiflexor: positive in CEINMS)
    lmt.push(gt.iter().map(|s| 0.18 + 0.002 * s).collect());
    ma.push(vec![-0.007; gt.len()]);
    lmt.push(gt.iter().map(|s| 0.35 + 0.002 * s).collect());
    ma.push(vec![-0.011; gt.len()]);
    lmt.push(q.iter().map(|&q| p.muscle(Muscle::Sol).lmt(q)).collect());
    ma.push(
        q.iter()
            .map(|&q| -p.muscle(Muscle::Sol).moment_arm(q))
            .collect(),
    );
    lmt.push(gt.iter().map(|s| 0.30 + 0.01 * (5.0 * s).sin()).collect());
    ma.push(gt.iter().map(|s| 0.035 + 0.002 * s).collect());
    let names = [
        "gaslat_r",
        "gasmed_r",
        "perbrev_r",
        "perlong_r",
        "sol_r",
        "tibant_r",
    ];
    write(dir, "R_ankle_feMa.txt", &names, &gt, &ma);
    // lmt.txt has more muscles than cross the ankle, in another order
    let mut lmt_names = vec!["vaslat_r"];
    lmt_names.extend(names);
    let mut lmt_cols = vec![vec![0.2; gt.len()]];
    lmt_cols.extend(lmt);
    write(dir, "lmt.txt", &lmt_names, &gt, &lmt_cols);
    let torque: Vec<f64> = resample_linear(&t, &syn.model_torque, &gt)
        .unwrap()
        .iter()
        .map(|x| -x)
        .collect();
    write(dir, "R_ankle_feTorque.txt", &["R_ankle_fe"], &gt, &[torque]);
    Written {
        inputs,
        model_torque: syn.model_torque,
        geometry_times: gt,
    }
}

#[test]
fn the_seed_trial_as_a_ceinms_folder_reads_back() {
    let root = tempfile::tempdir().unwrap();
    let dir = root.path().join("seed_trial");
    std::fs::create_dir(&dir).unwrap();
    let w = write_seed_folder(&dir);
    let tr = read_ceinms_trial(&dir, DEFAULT_JOINT).unwrap();
    assert_eq!(tr.name, "seed_trial");
    assert_eq!(ceinms_trial_dirs(root.path()).unwrap(), vec![dir.clone()]);
    let inp = &tr.inputs;
    assert!((inp.fs() - w.inputs.fs()).abs() < 1e-6 * w.inputs.fs());
    assert_eq!(inp.t0(), w.inputs.t0());
    // the grid ends at the last instant every file covers
    let (g0, g1) = (w.geometry_times[0], *w.geometry_times.last().unwrap());
    let n = inp.len();
    assert!(inp.times()[n - 1] <= g1 + 0.5 / inp.fs() && inp.times()[n - 1] > g1 - 1.0 / inp.fs());
    // envelopes come back as written (on the same grid: no resampling)
    for m in Muscle::ALL {
        assert_eq!(inp.envelope(m), &w.inputs.envelope(m)[..n], "{m}");
    }
    let (ta, pl) = extra_envelopes(&w.inputs);
    assert_eq!(inp.envelope_named("tibant_r").unwrap(), &ta[..n]);
    assert_eq!(inp.envelope_named("perlong_r").unwrap(), &pl[..n]);
    // the peroneus brevis has no channel: it takes the longus's
    assert_eq!(inp.envelope_named("perbrev_r").unwrap(), &pl[..n]);
    assert_eq!(tr.muscles.len(), 6);
    // the angle is unknown
    assert!(inp.angle().iter().all(|&q| q == 0.0));
    // geometry: within linear interpolation's error of the polynomial at the true angle,
    // signs turned to surae's (plantarflexion > 0), held before the 256 Hz files start
    let p = ModelParams::nominal();
    for m in Muscle::ALL {
        let g = inp.geometry(m.name()).unwrap();
        let (mut e_l, mut e_r) = (0.0f64, 0.0f64);
        for (i, &s) in inp.times().iter().enumerate() {
            let q = w.inputs.angle_value_at(s.max(g0));
            e_l = e_l.max((g.lmt_m[i] - p.muscle(m).lmt(q)).abs());
            e_r = e_r.max((g.moment_arm_m[i] - p.muscle(m).moment_arm(q)).abs());
            assert!(
                g.moment_arm_m[i] > 0.03,
                "{m} moment arm {}",
                g.moment_arm_m[i]
            );
        }
        assert!(e_l < 2e-6 && e_r < 2e-6, "{m}: {e_l} m, {e_r} m");
    }
    let ta_g = inp.geometry("tibant_r").unwrap();
    assert!(ta_g.moment_arm_m.iter().all(|&r| r < -0.03));
    assert!(inp.geometry("vaslat_r").is_none());
    // the measured moment: at its own samples exactly the model's (surae's sign), on the grid
    // within the resampling error, weight 0 before the torque file starts
    let want = resample_linear(w.inputs.times(), &w.model_torque, &w.geometry_times).unwrap();
    assert_eq!(tr.torque_times, w.geometry_times);
    for (a, b) in tr.torque_at_samples.iter().zip(&want) {
        assert!((a - b).abs() < 1e-9, "{a} {b}");
    }
    let mut weighted = 0;
    for (i, &s) in inp.times().iter().enumerate() {
        let inside = s >= g0 - 1e-9 && s <= g1 + 1e-9;
        assert_eq!(tr.weights[i], if inside { 1.0 } else { 0.0 }, "t = {s}");
        if inside {
            weighted += 1;
            assert!(
                (tr.torque_nm[i] - w.model_torque[i]).abs() < 0.05,
                "t = {s}"
            );
        }
    }
    assert!(weighted > n / 2);
    // each muscle's drive is envelope × moment arm
    let d = tr.drive("sol_r").unwrap();
    let g = inp.geometry("sol").unwrap();
    assert_eq!(d[10], inp.envelope(Muscle::Sol)[10] * g.moment_arm_m[10]);
    assert!(tr.drive("perter_r").is_err());
}

fn subject_xml(names: &[&str]) -> String {
    let mut s = String::from(
        "<?xml version=\"1.0\"?>\n<subject>\n<mtuDefault><emDelay>0.015</emDelay>\
         <percentageChange>0.15</percentageChange><damping>0.1</damping></mtuDefault>\n<mtuSet>\n",
    );
    for (i, n) in names.iter().enumerate() {
        s += &format!(
            "<mtu><name>{n}</name><c1>-0.5</c1><c2>-0.5</c2><shapeFactor>-1</shapeFactor>\
             <optimalFibreLength>{}</optimalFibreLength><pennationAngle>{}</pennationAngle>\
             <tendonSlackLength>{}</tendonSlackLength><maxIsometricForce>{}</maxIsometricForce>\
             <strengthCoefficient>1.5</strengthCoefficient></mtu>\n",
            0.04 + 0.001 * i as f64,
            5.0 + i as f64,
            0.2 + 0.01 * i as f64,
            1000.0 + 100.0 * i as f64
        );
    }
    s + "</mtuSet>\n</subject>\n"
}

#[test]
fn a_subject_xml_becomes_model_parameters() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("subject.xml");
    let names = [
        "sol_r",
        "gasmed_r",
        "gaslat_r",
        "tibant_r",
        "perlong_r",
        "perbrev_r",
    ];
    std::fs::write(&path, subject_xml(&names)).unwrap();
    let subject = read_subject(&path).unwrap();
    let muscles = [
        "gaslat_r",
        "gasmed_r",
        "perbrev_r",
        "perlong_r",
        "sol_r",
        "tibant_r",
    ];
    let p = ceinms_model_params(&subject, &muscles).unwrap();
    assert_eq!(p.em_delay_s, 0.015);
    let nominal = ModelParams::nominal();
    for (j, m) in Muscle::ALL.iter().enumerate() {
        let mp = p.params.muscle(*m);
        assert_eq!(mp.fom_n, (1000.0 + 100.0 * j as f64) * 1.5);
        assert_eq!(mp.lom_m, 0.04 + 0.001 * j as f64);
        assert_eq!(mp.lst_m, 0.2 + 0.01 * j as f64);
        assert_eq!(mp.alpha_deg, 5.0 + j as f64);
        assert_eq!(mp.lmt_poly_m, nominal.muscle(*m).lmt_poly_m);
    }
    let fixed: Vec<&str> = p.params.fixed.iter().map(|f| f.name).collect();
    assert_eq!(fixed, vec!["perbrev_r", "perlong_r", "tibant_r"]);
    let ta = p.params.fixed.get("tibant_r").unwrap().params;
    assert!(ta.geometry_from_trial());
    assert_eq!(
        (ta.fom_n, ta.alpha_deg, ta.lst_m),
        (1300.0 * 1.5, 8.0, 0.23)
    );
    assert_eq!(p.params.activation, nominal.activation);
    // a muscle of the trial that the subject lacks is named
    let e = ceinms_model_params(&subject, &["perter_r"]).unwrap_err();
    assert_eq!(e.kind(), ErrorKind::MissingColumn);
    assert!(
        e.to_string().contains("subject.xml") && e.to_string().contains("perter_r"),
        "{e}"
    );
    // as is a value the model cannot take
    std::fs::write(
        &path,
        subject_xml(&names).replacen("<tendonSlackLength>0.2<", "<tendonSlackLength>-0.2<", 1),
    )
    .unwrap();
    let e = ceinms_model_params(&read_subject(&path).unwrap(), &muscles).unwrap_err();
    assert_eq!(e.kind(), ErrorKind::OutOfRange);
    assert!(e.to_string().contains("sol"), "{e}");
}

fn small_folder(dir: &Path, emg_names: &[&str], emg_times: &[f64]) {
    let e: Vec<Vec<f64>> = emg_names
        .iter()
        .map(|_| vec![0.1; emg_times.len()])
        .collect();
    write(dir, "emg.txt", emg_names, emg_times, &e);
    let gt = [0.0, 0.004, 0.008, 0.012];
    let names = ["sol_r", "gasmed_r", "gaslat_r", "tibant_r"];
    let l: Vec<Vec<f64>> = names.iter().map(|_| vec![0.3; 4]).collect();
    write(dir, "lmt.txt", &names, &gt, &l);
    let r: Vec<Vec<f64>> = names.iter().map(|_| vec![-0.04; 4]).collect();
    write(dir, "R_ankle_feMa.txt", &names, &gt, &r);
    write(
        dir,
        "R_ankle_feTorque.txt",
        &["R_ankle_fe"],
        &gt,
        &[vec![-5.0; 4]],
    );
}

#[test]
fn bad_folders_are_one_line_errors_naming_file_and_column() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let t2000: Vec<f64> = (0..30).map(|i| -0.002 + i as f64 / 2000.0).collect();
    let read = || ceinms_model_trial(&read_trial_folder(d, DEFAULT_JOINT).unwrap());
    small_folder(d, &["sol_r", "gasmed_r", "gaslat_r", "tibant_r"], &t2000);
    let tr = read().unwrap();
    assert_eq!(tr.inputs.len(), 29);
    // no soleus channel
    small_folder(d, &["gasmed_r", "gaslat_r", "tibant_r"], &t2000);
    let e = read().unwrap_err();
    assert_eq!(e.kind(), ErrorKind::MissingColumn);
    assert!(e.to_string().ends_with("emg.txt: no column `sol_r`"), "{e}");
    // a fixed muscle without a channel
    small_folder(d, &["sol_r", "gasmed_r", "gaslat_r"], &t2000);
    let e = read().unwrap_err();
    assert!(
        e.to_string().ends_with("emg.txt: no column `tibant_r`"),
        "{e}"
    );
    // a clock that is not uniform
    let mut bad = t2000.clone();
    bad[7] += 0.0003;
    small_folder(d, &["sol_r", "gasmed_r", "gaslat_r", "tibant_r"], &bad);
    let e = read().unwrap_err();
    assert_eq!(e.kind(), ErrorKind::NonUniformTime);
    assert!(
        e.to_string().contains("emg.txt: column 1 (time): sample 8"),
        "{e}"
    );
    // EMG that ends before the other files start
    let early: Vec<f64> = (0..30).map(|i| -0.1 + i as f64 / 2000.0).collect();
    small_folder(d, &["sol_r", "gasmed_r", "gaslat_r", "tibant_r"], &early);
    let e = read().unwrap_err();
    assert_eq!(e.kind(), ErrorKind::TooShort);
    assert!(e.to_string().contains("0 EMG samples fall within"), "{e}");
    // a file of the folder that does not parse keeps its line and column
    small_folder(d, &["sol_r", "gasmed_r", "gaslat_r", "tibant_r"], &t2000);
    std::fs::write(
        d.join("lmt.txt"),
        "datacolumns 2\ndatarows 1\ntime\tsol_r\n0\tx\n",
    )
    .unwrap();
    let e = read_ceinms_trial(d, DEFAULT_JOINT).unwrap_err();
    assert_eq!(
        (e.kind(), e.line(), e.column()),
        (ErrorKind::NotANumber, Some(4), Some(2))
    );
    std::fs::remove_file(d.join("lmt.txt")).unwrap();
    let e = read_ceinms_trial(d, DEFAULT_JOINT).unwrap_err();
    assert_eq!(e.kind(), ErrorKind::NotFound);
    assert!(e.to_string().contains("lmt.txt"), "{e}");
    assert_eq!(
        ceinms_trial_dirs(d).unwrap_err().kind(),
        ErrorKind::NotFound
    );
}

#[test]
fn least_squares_and_moment_fit() {
    let x1: Vec<f64> = (0..50).map(|i| (i as f64 * 0.3).sin()).collect();
    let x2: Vec<f64> = (0..50).map(|i| (i as f64 * 0.1).cos()).collect();
    let y: Vec<f64> = x1.iter().zip(&x2).map(|(a, b)| 2.0 * a - 3.0 * b).collect();
    let b = least_squares(&[x1.clone(), x2.clone()], &y).unwrap();
    assert!(
        (b[0] - 2.0).abs() < 1e-10 && (b[1] + 3.0).abs() < 1e-10,
        "{b:?}"
    );
    let e = least_squares(&[x1.clone(), x1.clone()], &y).unwrap_err();
    assert!(e.to_string().contains("linearly dependent"), "{e}");
    assert!(least_squares(&[x1[..3].to_vec()], &y).is_err());
    let (rms, r2) = moment_fit(&[1.0, 2.0, 3.0], &[1.0, 2.0, 4.0]);
    assert!((rms - (1.0f64 / 3.0).sqrt()).abs() < 1e-15 && (r2 - 0.5).abs() < 1e-15);
    assert!(moment_fit(&[1.0], &[]).0.is_nan());
}
