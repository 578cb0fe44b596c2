//! A CEINMS trial folder and subject XML as the model's inputs and parameters
//! (`docs/real-data.md`). The files are read by the `ceinms-files` crate; this module decides
//! what they mean for the model.
//!
//! **Grid.** The trial is put on the EMG's own samples (CEINMS writes its envelopes at
//! 2000 Hz). It starts at the first EMG sample and ends at the last sample that every file
//! covers. CEINMS's EMG starts about 0.13 s before its lengths, moment arms and moment; those
//! early samples are kept because they give the activation dynamics a history (CEINMS's own
//! calibration runs its activation from the first EMG sample too), and over them each
//! muscle's length and moment arm are held at their first values. Lengths, moment arms and
//! the moment (250 Hz) are brought to the EMG's grid by linear interpolation
//! ([`numerics::interpolate::resample_linear`]).
//!
//! **Signs.** CEINMS's ankle moment arms and ankle moment are negative towards plantarflexion
//! (`sol_r`'s moment arm is about −0.04 m); surae's are positive. Both are negated here:
//! `r = −r_CEINMS`, `τ = −τ_CEINMS`.
//!
//! **Ankle angle.** CEINMS's files carry no joint angle (the lengths and moment arms already
//! come from the subject's model at each instant), so the angle is zero throughout. Nothing
//! that uses geometry series depends on it; joint-level effects that use the angle
//! (passive moment, gravity, inertia, damping) are meaningless on such a trial.
//!
//! **Muscles and channels.** `sol_r`, `gasmed_r` and `gaslat_r` are the identified `sol`,
//! `gm` and `gl`. Every other muscle with a column in the moment-arm file is a fixed muscle
//! under its CEINMS name, driven by the EMG channel of its own name, or by the peroneus
//! longus's for the peroneus brevis and tertius ([`ceinms_files::emg_channel_for`]). Every
//! muscle of the moment-arm file, the identified ones included, gets its geometry as series.
//!
//! **Measured moment.** On the EMG grid, with weight 1 where the torque file has data and 0
//! elsewhere (where the held values are not measurements); its own 250 Hz samples are kept
//! too, for comparisons at the measured instants.
//!
//! **Parameters.** From a subject XML: F0 = `maxIsometricForce × strengthCoefficient`,
//! LOM = `optimalFibreLength`, LST = `tendonSlackLength`, α0 = `pennationAngle`, vmax =
//! `maxContractionVelocity` when given (else 10 LOM/s). CEINMS's activation (a second-order
//! recursive filter with `c1`, `c2` and an exponential shape factor) is a different model from
//! surae's first-order dynamics with the Manal–Buchanan shape; no choice of surae's τact,
//! τdeact and A reproduces it for every muscle at once (surae's activation is shared by all
//! muscles), so surae's nominal activation is kept and `c1`, `c2`, `shapeFactor` are unused.
//! CEINMS's electromechanical delay is reported ([`CeinmsSubjectParams::em_delay_s`]) and not
//! applied.

use crate::error::{ErrorKind, ExperimentError, Result};
use ceinms_files::{emg_channel_for, CeinmsError, CeinmsSubject, CeinmsTable, CeinmsTrialFolder};
use muscle_model::{GeometrySeries, ModelParams, Muscle, MuscleParams, TrialInputs};
use numerics::interpolate::resample_linear;
use std::path::Path;

/// CEINMS's names of the identified muscles, indexed by [`Muscle::index`].
pub const CEINMS_IDENTIFIED: [&str; 3] = ["sol_r", "gasmed_r", "gaslat_r"];

/// The model's name for CEINMS muscle `name`: `sol`, `gm`, `gl` for the identified ones, the
/// CEINMS name for every other.
pub fn surae_muscle_name(name: &str) -> &str {
    match CEINMS_IDENTIFIED.iter().position(|&c| c == name) {
        Some(j) => Muscle::ALL[j].name(),
        None => name,
    }
}

/// One CEINMS trial as the model sees it.
#[derive(Clone, Debug)]
pub struct CeinmsModelTrial {
    /// The trial's name (its folder's name).
    pub name: String,
    /// Inputs on the EMG's grid: envelopes of sol, gm, gl and of every fixed muscle,
    /// geometry series (surae's sign) of every muscle of the moment-arm file, angle zero.
    pub inputs: TrialInputs,
    /// The CEINMS names of the muscles of the moment-arm file, in file order.
    pub muscles: Vec<String>,
    /// The measured ankle moment on the inputs' grid (N·m, plantarflexion > 0; held at the
    /// ends outside the torque file's span).
    pub torque_nm: Vec<f64>,
    /// 1 where the torque file has data, 0 elsewhere (for `Problem::with_weights`).
    pub weights: Vec<f64>,
    /// The torque file's own times (s).
    pub torque_times: Vec<f64>,
    /// The measured moment at those times (N·m, plantarflexion > 0).
    pub torque_at_samples: Vec<f64>,
}

impl CeinmsModelTrial {
    /// Muscle `name`'s (CEINMS name) envelope × moment arm on the inputs' grid (m; surae's
    /// sign), the quantity a linear moment model weights by a force.
    ///
    /// # Errors
    /// [`ErrorKind::MissingColumn`] when the trial has no envelope or no geometry for it.
    pub fn drive(&self, name: &str) -> Result<Vec<f64>> {
        let m = surae_muscle_name(name);
        let missing = |what: &str| {
            ExperimentError::invalid(
                "CEINMS trial",
                ErrorKind::MissingColumn,
                format!("{}: no {what} for muscle {name}", self.name),
            )
        };
        let env = self
            .inputs
            .envelope_named(m)
            .ok_or_else(|| missing("envelope"))?;
        let g = self.inputs.geometry(m).ok_or_else(|| missing("geometry"))?;
        Ok(env
            .iter()
            .zip(&g.moment_arm_m)
            .map(|(e, r)| e * r)
            .collect())
    }

    /// A series on the inputs' grid sampled at the torque file's own times.
    ///
    /// # Errors
    /// As [`resample_linear`], for a series not as long as the grid.
    pub fn at_torque_samples(&self, series: &[f64]) -> Result<Vec<f64>> {
        resample_linear(self.inputs.times(), series, &self.torque_times)
            .map_err(|e| numerics_error(&self.name, e))
    }
}

/// The ankle moment's RMS error (N·m) and R² (`1 − Σ(y − ŷ)² / Σ(y − ȳ)²`) of `predicted`
/// against `measured`; NaN for empty or unequal inputs.
pub fn moment_fit(measured: &[f64], predicted: &[f64]) -> (f64, f64) {
    if measured.is_empty() || measured.len() != predicted.len() {
        return (f64::NAN, f64::NAN);
    }
    let n = measured.len() as f64;
    let mean = measured.iter().sum::<f64>() / n;
    let ss_res: f64 = measured
        .iter()
        .zip(predicted)
        .map(|(y, p)| (y - p).powi(2))
        .sum();
    let ss_tot: f64 = measured.iter().map(|y| (y - mean).powi(2)).sum();
    ((ss_res / n).sqrt(), 1.0 - ss_res / ss_tot)
}

fn numerics_error(what: &str, e: numerics::NumericsError) -> ExperimentError {
    ExperimentError::invalid(what, ErrorKind::TimeNotIncreasing, e.to_string())
}

impl From<CeinmsError> for ExperimentError {
    fn from(e: CeinmsError) -> Self {
        let path = e.path().display().to_string();
        match e {
            CeinmsError::File { reason, .. } => ExperimentError::File {
                path,
                kind: if reason.starts_with("missing") || reason == "no such file" {
                    ErrorKind::NotFound
                } else {
                    ErrorKind::Io
                },
                reason,
            },
            CeinmsError::Line { line, reason, .. } => ExperimentError::Line {
                path,
                line,
                kind: ErrorKind::FieldCount,
                reason,
            },
            CeinmsError::Cell {
                line,
                column,
                name,
                reason,
                ..
            } => ExperimentError::Cell {
                path,
                line,
                column,
                kind: if name == "time" {
                    ErrorKind::TimeNotIncreasing
                } else if reason.ends_with("not finite") {
                    ErrorKind::NotFinite
                } else {
                    ErrorKind::NotANumber
                },
                name,
                reason,
            },
            CeinmsError::MissingColumn { name, .. } => ExperimentError::File {
                path,
                kind: ErrorKind::MissingColumn,
                reason: format!("no column `{name}`"),
            },
            CeinmsError::Xml {
                line,
                column,
                key,
                reason,
                ..
            } => ExperimentError::Cell {
                path,
                line: line as usize,
                column: column as usize,
                kind: if reason.starts_with("missing") {
                    ErrorKind::MissingColumn
                } else {
                    ErrorKind::NotANumber
                },
                name: key,
                reason,
            },
        }
    }
}

/// Largest departure of a sample time from the uniform clock, as a fraction of the step,
/// that still counts as uniform (CEINMS writes times rounded to the millisecond or finer).
const CLOCK_TOLERANCE: f64 = 0.05;

/// The EMG's rate (Hz) and first time, checked to be a uniform clock.
fn uniform_clock(emg: &CeinmsTable) -> Result<(f64, f64)> {
    let path = emg.path.display().to_string();
    if emg.len() < 2 {
        return Err(ExperimentError::File {
            path,
            kind: ErrorKind::TooShort,
            reason: format!("{} samples: at least 2 are needed", emg.len()),
        });
    }
    let fs = emg.mean_rate_hz();
    let t0 = emg.time[0];
    for (i, t) in emg.time.iter().enumerate() {
        let off = (t - (t0 + i as f64 / fs)) * fs;
        if off.abs() > CLOCK_TOLERANCE {
            return Err(ExperimentError::Column {
                path,
                column: 1,
                name: "time".to_string(),
                kind: ErrorKind::NonUniformTime,
                reason: format!(
                    "sample {} at {t} s is {:.2} steps off a uniform {fs:.3} Hz clock",
                    i + 1,
                    off
                ),
            });
        }
    }
    Ok((fs, t0))
}

fn model_error(name: &str, e: muscle_model::ModelError) -> ExperimentError {
    ExperimentError::invalid(name, ErrorKind::OutOfRange, e.to_string())
}

/// A CEINMS trial folder as the model's inputs (see the module documentation for the grid,
/// the signs and the channels).
///
/// # Errors
/// [`ErrorKind::MissingColumn`] naming the file and column when `emg.txt` lacks `sol_r`,
/// `gasmed_r`, `gaslat_r` or a fixed muscle's channel; [`ErrorKind::NonUniformTime`] for an
/// EMG clock that is not uniform; [`ErrorKind::TooShort`] when fewer than 2 EMG samples fall
/// within the span of the torque file and the geometry; [`ErrorKind::OutOfRange`] for a
/// length that is not positive.
pub fn ceinms_model_trial(folder: &CeinmsTrialFolder) -> Result<CeinmsModelTrial> {
    let name = folder
        .dir
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_else(|| folder.dir.display().to_string());
    let (fs, t0) = uniform_clock(&folder.emg)?;
    let end = [&folder.lmt, &folder.moment_arm, &folder.torque]
        .iter()
        .map(|t| t.time.last().copied().unwrap_or(f64::NEG_INFINITY))
        .fold(f64::INFINITY, f64::min);
    // the EMG samples up to the last instant every file covers (half a step of slack for the
    // rounding of the written times)
    let n = folder
        .emg
        .time
        .iter()
        .take_while(|&&t| t <= end + 0.5 / fs)
        .count();
    if n < 2 {
        return Err(ExperimentError::File {
            path: folder.dir.display().to_string(),
            kind: ErrorKind::TooShort,
            reason: format!("the EMG and the other files share {n} samples: at least 2 are needed"),
        });
    }
    let grid = &folder.emg.time[..n];
    let emg_col =
        |channel: &str| -> Result<Vec<f64>> { Ok(folder.emg.require(channel)?[..n].to_vec()) };
    let env: [Vec<f64>; 3] = [
        emg_col(CEINMS_IDENTIFIED[0])?,
        emg_col(CEINMS_IDENTIFIED[1])?,
        emg_col(CEINMS_IDENTIFIED[2])?,
    ];
    let mut inputs =
        TrialInputs::new(fs, t0, vec![0.0; n], env, None).map_err(|e| model_error(&name, e))?;
    let resample = |table: &CeinmsTable, col: &str, sign: f64| -> Result<Vec<f64>> {
        let v = table.require(col)?;
        let mut r = resample_linear(&table.time, v, grid)
            .map_err(|e| numerics_error(&table.path.display().to_string(), e))?;
        r.iter_mut().for_each(|x| *x *= sign);
        Ok(r)
    };
    let muscles = folder.moment_arm.names.clone();
    for m in &muscles {
        let surae = surae_muscle_name(m);
        if surae == m.as_str() {
            let channel = emg_channel_for(m);
            inputs = inputs
                .with_envelope(m, emg_col(&channel)?)
                .map_err(|e| model_error(&name, e))?;
        }
        let series = GeometrySeries {
            lmt_m: resample(&folder.lmt, m, 1.0)?,
            moment_arm_m: resample(&folder.moment_arm, m, -1.0)?,
        };
        inputs = inputs
            .with_geometry(surae, series)
            .map_err(|e| model_error(&name, e))?;
    }
    let torque_nm = resample(&folder.torque, &folder.joint, -1.0)?;
    let (ta, tb) = (
        folder.torque.time[0] - 0.5 / fs,
        folder.torque.time[folder.torque.len() - 1] + 0.5 / fs,
    );
    let weights: Vec<f64> = grid
        .iter()
        .map(|&t| if t >= ta && t <= tb { 1.0 } else { 0.0 })
        .collect();
    let measured = weights.iter().filter(|&&w| w > 0.0).count();
    if measured < 2 {
        return Err(ExperimentError::File {
            path: folder.dir.display().to_string(),
            kind: ErrorKind::TooShort,
            reason: format!(
                "{measured} EMG samples fall within the torque file's {:.4}–{:.4} s: at least 2 \
                 are needed",
                folder.torque.time[0],
                folder.torque.time[folder.torque.len() - 1]
            ),
        });
    }
    Ok(CeinmsModelTrial {
        name,
        inputs,
        muscles,
        torque_nm,
        weights,
        torque_times: folder.torque.time.clone(),
        torque_at_samples: folder.joint_moment().iter().map(|x| -x).collect(),
    })
}

/// Reads the CEINMS trial folder `dir` for `joint` and makes the model's inputs of it.
///
/// # Errors
/// As [`ceinms_files::read_trial_folder`] and [`ceinms_model_trial`].
pub fn read_ceinms_trial(dir: &Path, joint: &str) -> Result<CeinmsModelTrial> {
    ceinms_model_trial(&ceinms_files::read_trial_folder(dir, joint)?)
}

/// Model parameters from a CEINMS subject, and what of the subject was not carried over.
#[derive(Clone, Debug, PartialEq)]
pub struct CeinmsSubjectParams {
    /// sol, gm, gl from `sol_r`, `gasmed_r`, `gaslat_r`; a fixed muscle (geometry from each
    /// trial) for every other muscle asked for; surae's nominal activation and curves.
    pub params: ModelParams,
    /// CEINMS's global electromechanical delay (s), not applied by the model.
    pub em_delay_s: f64,
    /// The maximum isometric forces of sol, gm and gl before their strength coefficients (N):
    /// the subject's own forces, which a calibration's strength coefficient scales.
    pub unscaled_fom_n: [f64; 3],
}

/// The muscle parameters of `mtu` in surae's terms, keeping `base`'s geometry polynomial and
/// knee moment arm.
fn muscle_params(mtu: &ceinms_files::CeinmsMtu, base: MuscleParams) -> MuscleParams {
    MuscleParams {
        fom_n: mtu.max_force_n(),
        lom_m: mtu.optimal_fibre_length_m,
        lst_m: mtu.tendon_slack_length_m,
        alpha_deg: mtu.pennation_deg,
        vmax_lom_per_s: mtu.max_contraction_velocity.unwrap_or(base.vmax_lom_per_s),
        ..base
    }
}

/// Model parameters from a CEINMS subject for a model of sol, gm, gl and the further muscles
/// `fixed` (CEINMS names, e.g. a trial's [`CeinmsModelTrial::muscles`]; `sol_r`, `gasmed_r`
/// and `gaslat_r` among them are skipped). Fixed muscles have no length polynomial: their
/// geometry comes from each trial.
///
/// # Errors
/// [`ErrorKind::MissingColumn`] naming the subject file and the muscle when it has no `mtu`
/// for one of them; [`ErrorKind::OutOfRange`] naming the muscle and parameter when a value is
/// outside the model's range.
pub fn ceinms_model_params(
    subject: &CeinmsSubject,
    fixed: &[impl AsRef<str>],
) -> Result<CeinmsSubjectParams> {
    let path = subject.path.display().to_string();
    let mtu = |name: &str| {
        subject.mtu(name).ok_or_else(|| ExperimentError::File {
            path: path.clone(),
            kind: ErrorKind::MissingColumn,
            reason: format!("no mtu `{name}`"),
        })
    };
    let mut params = ModelParams::nominal();
    let mut unscaled_fom_n = [0.0; 3];
    for m in Muscle::ALL {
        let unit = mtu(CEINMS_IDENTIFIED[m.index()])?;
        unscaled_fom_n[m.index()] = unit.max_isometric_force_n;
        let p = muscle_params(unit, *params.muscle(m));
        *params.muscle_mut(m) = p;
    }
    for name in fixed {
        let name = name.as_ref();
        if CEINMS_IDENTIFIED.contains(&name) {
            continue;
        }
        let base = MuscleParams {
            lmt_poly_m: [f64::NAN; 4],
            knee_moment_arm_m: 0.0,
            ..MuscleParams::nominal(Muscle::Sol)
        };
        let p = muscle_params(mtu(name)?, base);
        params
            .fixed
            .insert(name, p)
            .map_err(|e| ExperimentError::invalid(&path, ErrorKind::OutOfRange, e.to_string()))?;
    }
    params
        .validate()
        .map_err(|e| ExperimentError::invalid(&path, ErrorKind::OutOfRange, e.to_string()))?;
    Ok(CeinmsSubjectParams {
        params,
        em_delay_s: subject.global_em_delay_s(),
        unscaled_fom_n,
    })
}

/// The CEINMS trial folders in `root`: its subfolders that hold an `emg.txt`, sorted by name.
///
/// # Errors
/// [`ErrorKind::NotFound`] when `root` cannot be listed or holds no trial folder.
pub fn ceinms_trial_dirs(root: &Path) -> Result<Vec<std::path::PathBuf>> {
    let not_found = |reason: String| ExperimentError::File {
        path: root.display().to_string(),
        kind: ErrorKind::NotFound,
        reason,
    };
    let mut dirs: Vec<_> = std::fs::read_dir(root)
        .map_err(|e| not_found(e.to_string()))?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.join("emg.txt").is_file())
        .collect();
    if dirs.is_empty() {
        return Err(not_found(
            "no CEINMS trial folder (a subfolder with emg.txt) in it".to_string(),
        ));
    }
    dirs.sort();
    Ok(dirs)
}

/// Least-squares coefficients `b` of `y ≈ Σ_k b_k x_k` over the rows of the columns `x`
/// (normal equations, solved by Cholesky).
///
/// # Errors
/// [`ErrorKind::InvalidSettings`] when the columns are not as long as `y` or are linearly
/// dependent.
pub fn least_squares(x: &[Vec<f64>], y: &[f64]) -> Result<Vec<f64>> {
    let k = x.len();
    let bad =
        |reason: String| ExperimentError::invalid("regression", ErrorKind::InvalidSettings, reason);
    if k == 0 || x.iter().any(|c| c.len() != y.len()) {
        return Err(bad(format!(
            "{k} regressors for {} observations: every regressor needs one value per observation",
            y.len()
        )));
    }
    let dot = |a: &[f64], b: &[f64]| a.iter().zip(b).map(|(u, v)| u * v).sum::<f64>();
    let mut a = vec![0.0; k * k];
    for i in 0..k {
        for j in 0..=i {
            a[i * k + j] = dot(&x[i], &x[j]);
            a[j * k + i] = a[i * k + j];
        }
    }
    let mut b: Vec<f64> = x.iter().map(|c| dot(c, y)).collect();
    numerics::cholesky::cholesky_solve_in_place(&mut a, &mut b)
        .map_err(|e| bad(format!("the regressors are linearly dependent ({e})")))?;
    Ok(b)
}
