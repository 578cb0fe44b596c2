//! What the files hold: a [`Trial`], an [`Unloaded`] run, their column names and the reader's
//! [`ReadOptions`].

use serde::{Deserialize, Serialize};

/// Required columns of a trial file, in the order they are written.
pub const TRIAL_REQUIRED: [&str; 6] = [
    "time_s",
    "ankle_angle_deg",
    "torque_nm",
    "emg_sol",
    "emg_gm",
    "emg_gl",
];
/// Optional columns of a trial file, in the order they are written (after the required ones).
pub const TRIAL_OPTIONAL: [&str; 2] = ["emg_ta", "knee_angle_deg"];
/// Prefix of the EMG columns; `emg_<name>` for a muscle other than sol, gm, gl and ta is read
/// into [`Trial::emg_other`].
pub const EMG_PREFIX: &str = "emg_";
/// Required columns of an unloaded-run file (it has no optional ones).
pub const UNLOADED_REQUIRED: [&str; 3] = ["time_s", "ankle_angle_deg", "torque_nm"];

/// Default tolerance on sampling uniformity: every time step must lie within this
/// relative distance of the median step.
pub const DEFAULT_TIME_TOLERANCE: f64 = 1e-6;
/// Default minimum duration `t_last − t_first` in seconds.
pub const DEFAULT_MIN_DURATION_S: f64 = 1.0;

/// Options of the reader. `Default` is what [`super::parse_trial`] and [`super::read_trial`] use.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct ReadOptions {
    /// Relative tolerance of every time step against the median step (default 1e-6).
    pub time_tolerance: f64,
    /// Minimum `t_last − t_first` in seconds (default 1 s).
    pub min_duration_s: f64,
}

impl Default for ReadOptions {
    fn default() -> Self {
        Self {
            time_tolerance: DEFAULT_TIME_TOLERANCE,
            min_duration_s: DEFAULT_MIN_DURATION_S,
        }
    }
}

/// One isokinetic trial: uniformly sampled columns of equal length (SI-ish file units:
/// seconds, degrees with dorsiflexion > 0, N·m with plantarflexion > 0, raw EMG in any unit).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Trial {
    /// Time in seconds, strictly increasing and uniform.
    pub time_s: Vec<f64>,
    /// Ankle angle in degrees, dorsiflexion positive.
    pub ankle_angle_deg: Vec<f64>,
    /// Measured joint torque in N·m, plantarflexion positive.
    pub torque_nm: Vec<f64>,
    /// Raw EMG of soleus.
    pub emg_sol: Vec<f64>,
    /// Raw EMG of gastrocnemius medialis.
    pub emg_gm: Vec<f64>,
    /// Raw EMG of gastrocnemius lateralis.
    pub emg_gl: Vec<f64>,
    /// Raw EMG of tibialis anterior, if recorded.
    pub emg_ta: Option<Vec<f64>>,
    /// Raw EMG of further muscles (`emg_<name>` columns other than sol, gm, gl and ta), as
    /// `(name, samples)` with the name after `emg_` (e.g. `perlong`), in file order. A fixed
    /// muscle of the model with that name is driven by its envelope.
    #[serde(default)]
    pub emg_other: Vec<(String, Vec<f64>)>,
    /// Knee angle in degrees (0 = extended), if recorded.
    pub knee_angle_deg: Option<Vec<f64>>,
    /// Vertical ground reaction force under the tested leg's foot in N, if recorded (a gait
    /// trial read through a recording map's `grf_vertical_n`); it marks the stances (force
    /// above a threshold). The trial CSV does not carry it.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub grf_vertical_n: Option<Vec<f64>>,
    /// Text of the `#` comment lines (after the `#`), in file order; written at the top.
    pub comments: Vec<String>,
    /// Names of unknown columns that the reader ignored (a warning list; never written).
    pub ignored_columns: Vec<String>,
}

/// An unloaded run: the dynamometer moving with nothing attached (`docs/formats.md`).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Unloaded {
    /// Time in seconds, strictly increasing and uniform.
    pub time_s: Vec<f64>,
    /// Ankle (dynamometer arm) angle in degrees, dorsiflexion positive.
    pub ankle_angle_deg: Vec<f64>,
    /// Recorded torque in N·m (the dynamometer's own error).
    pub torque_nm: Vec<f64>,
    /// Text of the `#` comment lines (after the `#`), in file order; written at the top.
    pub comments: Vec<String>,
    /// Names of unknown columns that the reader ignored (never written).
    pub ignored_columns: Vec<String>,
}

fn sample_interval(t: &[f64]) -> f64 {
    if t.len() < 2 {
        return f64::NAN;
    }
    (t[t.len() - 1] - t[0]) / (t.len() - 1) as f64
}

impl Trial {
    /// Number of samples.
    #[must_use]
    pub fn len(&self) -> usize {
        self.time_s.len()
    }
    /// True when there are no samples.
    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.time_s.is_empty()
    }
    /// Sampling interval `(t_last − t_first)/(n − 1)` in seconds (NaN with < 2 samples).
    #[must_use]
    pub fn dt(&self) -> f64 {
        sample_interval(&self.time_s)
    }
    /// Sampling rate `1/dt` in Hz.
    #[must_use]
    pub fn sample_rate_hz(&self) -> f64 {
        1.0 / self.dt()
    }
    /// The EMG columns present, as `(column name, samples)`: sol, gm, gl, then ta if present,
    /// then the further channels ([`Trial::emg_other`]) in their order.
    #[must_use]
    pub fn emg_channels(&self) -> Vec<(String, &[f64])> {
        let mut v: Vec<(String, &[f64])> = vec![
            ("emg_sol".into(), &self.emg_sol),
            ("emg_gm".into(), &self.emg_gm),
            ("emg_gl".into(), &self.emg_gl),
        ];
        if let Some(ta) = &self.emg_ta {
            v.push(("emg_ta".into(), ta));
        }
        for (name, raw) in &self.emg_other {
            v.push((format!("{EMG_PREFIX}{name}"), raw));
        }
        v
    }

    /// Raw EMG of the further muscle `name` (the name after `emg_`), if recorded.
    #[must_use]
    pub fn emg_named(&self, name: &str) -> Option<&[f64]> {
        self.emg_other
            .iter()
            .find(|(n, _)| n == name)
            .map(|(_, v)| v.as_slice())
    }
}

impl Unloaded {
    /// Number of samples.
    #[must_use]
    pub fn len(&self) -> usize {
        self.time_s.len()
    }
    /// True when there are no samples.
    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.time_s.is_empty()
    }
    /// Sampling interval `(t_last − t_first)/(n − 1)` in seconds (NaN with < 2 samples).
    #[must_use]
    pub fn dt(&self) -> f64 {
        sample_interval(&self.time_s)
    }
    /// Sampling rate `1/dt` in Hz.
    #[must_use]
    pub fn sample_rate_hz(&self) -> f64 {
        1.0 / self.dt()
    }
}
