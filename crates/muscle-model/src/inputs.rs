//! Trial inputs (ankle angle and normalised EMG envelopes on a uniform grid) and their
//! interpolation between samples.
//!
//! Between samples the angle is a cubic Hermite interpolant whose node slopes are central
//! differences (one-sided at the ends), so `q(t)` is C¹ and `q̇(t)` is its exact derivative.
//! Envelopes, the knee angle and geometry series are interpolated linearly, except in a
//! trial sampled below [`LOW_RATE_BELOW_HZ`]: there the envelopes are monotone cubics and the
//! knee angle and series central-difference cubics (module `interp`), so that no input has
//! a kink at the samples. Times outside the trial are clamped to its ends.

use crate::error::ModelError;
use crate::params::Muscle;
use std::any::Any;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, OnceLock};

/// Results derived from one trial's inputs and kept with them, shared by their clones and by
/// every thread (the fast simulation keeps its activation tables and channels here). The
/// inputs hold the value without knowing its type, so its owner defines it.
#[derive(Default)]
pub(crate) struct TrialMemo(OnceLock<Box<dyn Any + Send + Sync>>);

impl TrialMemo {
    /// The kept value of type `T`, made with `T::default()` on first use; `None` when a value
    /// of another type was made first.
    pub(crate) fn get_or_default<T: Any + Send + Sync + Default>(&self) -> Option<&T> {
        self.0.get_or_init(|| Box::new(T::default())).downcast_ref()
    }
}

impl std::fmt::Debug for TrialMemo {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("TrialMemo")
    }
}

/// Source of [`TrialInputs`] identities (caches key on them; clones share the identity, which
/// is sound because inputs are immutable after construction).
static NEXT_UID: AtomicU64 = AtomicU64::new(1);

/// Half-width of the central second difference used for `q̈` (inertia effect), in seconds.
pub const ACCEL_HALF_WINDOW_S: f64 = 0.005;

/// A trial sampled below this rate (Hz) is a *low-rate* trial: its envelopes, knee angle and
/// geometry series are read between samples by C¹ cubics instead of straight lines.
///
/// Why: a linear interpolant has a kink at every sample. Where the samples are closer than the
/// integrator's steps (2048 Hz: 0.5 ms against steps of 4–30 ms) a step spans many small kinks
/// and sees their smooth mean; where they are as far apart as the steps (envelopes exported at
/// 100–250 Hz by a motion-capture system), every kink of the envelope is a kink of the
/// activation's rate that the step control has to find, and a signal that was low-passed at a
/// few hertz is better represented by a smooth curve through its samples anyway. Raw EMG needs
/// at least 700 Hz (its 10–350 Hz band), so a trial below 500 Hz carries envelopes.
pub const LOW_RATE_BELOW_HZ: f64 = 500.0;

/// Validated inputs of one trial, with derived velocity and acceleration at the samples.
#[derive(Clone, Debug)]
pub struct TrialInputs {
    uid: u64,
    fs: f64,
    /// `fs < LOW_RATE_BELOW_HZ`.
    low_rate: bool,
    t0: f64,
    times: Vec<f64>,
    angle: Vec<f64>,
    velocity: Vec<f64>,
    acceleration: Vec<f64>,
    env: [Vec<f64>; 3],
    env_ta: Option<Vec<f64>>,
    knee: Option<Vec<f64>>,
    channels: Vec<(String, Vec<f64>)>,
    geometry: Vec<(String, GeometrySeries)>,
    memo: Arc<TrialMemo>,
}

/// A muscle's musculotendon length and signed ankle moment arm at the trial's samples, from
/// the user's own musculoskeletal model (OpenSim's MuscleAnalysis, CEINMS's `lmt.txt` and
/// `<joint>Ma.txt`), used instead of the length polynomial. Between samples the length is
/// interpolated linearly in time (in a low-rate trial by the central-difference cubic); the
/// moment arm is used at the samples.
#[derive(Clone, Debug, PartialEq)]
pub struct GeometrySeries {
    /// Musculotendon length (m).
    pub lmt_m: Vec<f64>,
    /// Ankle moment arm (m; > 0 plantarflexion).
    pub moment_arm_m: Vec<f64>,
}

impl TrialInputs {
    /// Builds validated inputs.
    ///
    /// * `fs`: sampling rate (Hz), positive;
    /// * `t0`: time of the first sample (s);
    /// * `angle_rad`: ankle angle (rad, dorsiflexion > 0), at least 2 finite samples;
    /// * `env`: normalised envelopes of `sol`, `gm`, `gl` (same length; clamped to `[0, 1]`);
    /// * `env_ta`: optional normalised tibialis-anterior envelope (for
    ///   `antagonist_coactivation`).
    pub fn new(
        fs: f64,
        t0: f64,
        angle_rad: Vec<f64>,
        env: [Vec<f64>; 3],
        env_ta: Option<Vec<f64>>,
    ) -> Result<Self, ModelError> {
        if !(fs.is_finite() && fs > 0.0) {
            return Err(ModelError::input("fs", format!("{fs} must be positive")));
        }
        if !t0.is_finite() {
            return Err(ModelError::input("t0", "must be finite"));
        }
        let n = angle_rad.len();
        if n < 2 {
            return Err(ModelError::input("angle_rad", "needs at least 2 samples"));
        }
        if let Some(i) = angle_rad.iter().position(|x| !x.is_finite()) {
            return Err(ModelError::input(
                "angle_rad",
                format!("non-finite value at sample {i}"),
            ));
        }
        let mut env = env;
        for m in Muscle::ALL {
            check_env(&mut env[m.index()], n, &format!("env[{}]", m.name()))?;
        }
        let mut env_ta = env_ta;
        if let Some(e) = env_ta.as_mut() {
            check_env(e, n, "env_ta")?;
        }
        let times = (0..n).map(|i| t0 + i as f64 / fs).collect();
        let mut velocity = vec![0.0; n];
        for i in 0..n {
            velocity[i] = if i == 0 {
                (angle_rad[1] - angle_rad[0]) * fs
            } else if i == n - 1 {
                (angle_rad[n - 1] - angle_rad[n - 2]) * fs
            } else {
                0.5 * (angle_rad[i + 1] - angle_rad[i - 1]) * fs
            };
        }
        let kmax = ((ACCEL_HALF_WINDOW_S * fs).round() as usize).max(1);
        let mut acceleration = vec![0.0; n];
        for i in 0..n {
            let k = kmax.min(i).min(n - 1 - i);
            if k > 0 {
                let h = k as f64 / fs;
                acceleration[i] =
                    (angle_rad[i + k] - 2.0 * angle_rad[i] + angle_rad[i - k]) / (h * h);
            }
        }
        // ends: copy the nearest interior value
        if n > 2 {
            acceleration[0] = acceleration[1];
            acceleration[n - 1] = acceleration[n - 2];
        }
        Ok(TrialInputs {
            uid: NEXT_UID.fetch_add(1, Ordering::Relaxed),
            fs,
            low_rate: fs < LOW_RATE_BELOW_HZ,
            t0,
            times,
            angle: angle_rad,
            velocity,
            acceleration,
            env,
            env_ta,
            knee: None,
            channels: Vec::new(),
            geometry: Vec::new(),
            memo: Arc::default(),
        })
    }

    /// The same inputs with a knee flexion angle at every sample (rad; 0 extended, > 0
    /// flexed). Without it the knee is extended.
    pub fn with_knee_angle(mut self, knee_rad: Vec<f64>) -> Result<Self, ModelError> {
        check_finite(&knee_rad, self.len(), "knee angle")?;
        self.knee = Some(knee_rad);
        Ok(self.renewed())
    }

    /// The same inputs with the normalised envelope of a further muscle `name` (a fixed muscle
    /// of the model; `ta` is also the antagonist effect's channel; `sol`, `gm` or `gl`
    /// replaces that muscle's envelope). Values are clamped to `[0, 1]`; a second envelope of
    /// the same name replaces the first.
    pub fn with_envelope(mut self, name: &str, mut env: Vec<f64>) -> Result<Self, ModelError> {
        check_env(&mut env, self.len(), &format!("envelope {name}"))?;
        if let Some(m) = Muscle::from_name(name) {
            self.env[m.index()] = env;
        } else if name == "ta" {
            self.env_ta = Some(env);
        } else if let Some(slot) = self.channels.iter_mut().find(|(n, _)| n == name) {
            slot.1 = env;
        } else {
            self.channels.push((name.to_string(), env));
        }
        Ok(self.renewed())
    }

    /// The same inputs with muscle `name`'s geometry given as series at the samples (for any
    /// muscle, identified or fixed; its length polynomial and knee term are then unused).
    pub fn with_geometry(mut self, name: &str, series: GeometrySeries) -> Result<Self, ModelError> {
        let n = self.len();
        check_finite(&series.lmt_m, n, &format!("musculotendon length of {name}"))?;
        check_finite(&series.moment_arm_m, n, &format!("moment arm of {name}"))?;
        if let Some(i) = series.lmt_m.iter().position(|&l| l <= 0.0) {
            return Err(ModelError::input(
                format!("musculotendon length of {name}"),
                format!("{} m at sample {i} is not positive", series.lmt_m[i]),
            ));
        }
        if let Some(slot) = self.geometry.iter_mut().find(|(m, _)| m == name) {
            slot.1 = series;
        } else {
            self.geometry.push((name.to_string(), series));
        }
        Ok(self.renewed())
    }

    /// The inputs of the samples `range` alone, as a trial of their own starting at
    /// `times()[range.start]`: every series cut to the range, velocity and acceleration
    /// differenced again inside it (one-sided at its ends). A calibration searches on windows of
    /// a long recording because the simulation's cost grows with the length it integrates.
    ///
    /// # Errors
    /// [`ModelError::InvalidInput`] for a range of fewer than 2 samples or beyond the trial.
    pub fn window(&self, range: std::ops::Range<usize>) -> Result<Self, ModelError> {
        if range.end > self.len() || range.end < range.start + 2 {
            return Err(ModelError::input(
                "window",
                format!(
                    "samples {}..{} are not a range of at least 2 of the trial's {}",
                    range.start,
                    range.end,
                    self.len()
                ),
            ));
        }
        let cut = |v: &[f64]| v[range.clone()].to_vec();
        let mut w = TrialInputs::new(
            self.fs,
            self.times[range.start],
            cut(&self.angle),
            std::array::from_fn(|j| cut(&self.env[j])),
            self.env_ta.as_deref().map(cut),
        )?;
        if let Some(k) = &self.knee {
            w = w.with_knee_angle(cut(k))?;
        }
        for (name, env) in &self.channels {
            w = w.with_envelope(name, cut(env))?;
        }
        for (name, g) in &self.geometry {
            let series = GeometrySeries {
                lmt_m: cut(&g.lmt_m),
                moment_arm_m: cut(&g.moment_arm_m),
            };
            w = w.with_geometry(name, series)?;
        }
        Ok(w)
    }

    /// A new cache identity: what was derived from the earlier inputs no longer holds.
    fn renewed(mut self) -> Self {
        self.uid = NEXT_UID.fetch_add(1, Ordering::Relaxed);
        self.memo = Arc::default();
        self
    }

    /// The same inputs with every envelope (sol, gm, gl, ta and the fixed muscles') divided by
    /// its own peak over the trial, so that each reaches 1: EMG normalised per trial rather
    /// than by one reference for a session. An envelope that is zero throughout stays zero.
    /// Returns the peaks divided by, by envelope name.
    pub fn scaled_to_own_peaks(mut self) -> (Self, Vec<(String, f64)>) {
        fn scale(e: &mut [f64]) -> f64 {
            let peak = e.iter().copied().fold(0.0_f64, f64::max);
            if peak > 0.0 {
                // clamped: x / peak can round to a hair above 1
                e.iter_mut().for_each(|x| *x = (*x / peak).min(1.0));
            }
            peak
        }
        let mut peaks = Vec::with_capacity(4 + self.channels.len());
        for m in Muscle::ALL {
            peaks.push((m.name().to_string(), scale(&mut self.env[m.index()])));
        }
        if let Some(e) = self.env_ta.as_mut() {
            peaks.push(("ta".to_string(), scale(e)));
        }
        for (name, e) in &mut self.channels {
            peaks.push((name.clone(), scale(e)));
        }
        (self.renewed(), peaks)
    }

    /// Knee flexion at the samples (rad), if given.
    pub fn knee_angle(&self) -> Option<&[f64]> {
        self.knee.as_deref()
    }

    /// Normalised envelope of the muscle called `name` (`sol`, `gm`, `gl`, `ta` or a fixed
    /// muscle), if the trial has it.
    pub fn envelope_named(&self, name: &str) -> Option<&[f64]> {
        match Muscle::from_name(name) {
            Some(m) => Some(&self.env[m.index()]),
            None if name == "ta" => self.env_ta.as_deref(),
            None => self
                .channels
                .iter()
                .find(|(n, _)| n == name)
                .map(|(_, e)| e.as_slice()),
        }
    }

    /// Muscle `name`'s geometry series, if the trial gives one.
    pub fn geometry(&self, name: &str) -> Option<&GeometrySeries> {
        self.geometry
            .iter()
            .find(|(m, _)| m == name)
            .map(|(_, g)| g)
    }

    /// Identity of these inputs for caches (equal for clones, distinct for separately built
    /// inputs).
    #[inline]
    pub(crate) fn uid(&self) -> u64 {
        self.uid
    }

    /// What is kept with these inputs (shared by their clones).
    #[inline]
    pub(crate) fn memo(&self) -> &TrialMemo {
        &self.memo
    }

    /// Number of samples.
    pub fn len(&self) -> usize {
        self.angle.len()
    }

    /// Always `false` (at least 2 samples are required).
    pub fn is_empty(&self) -> bool {
        self.angle.is_empty()
    }

    /// Sampling rate (Hz).
    pub fn fs(&self) -> f64 {
        self.fs
    }

    /// Whether the trial is sampled below [`LOW_RATE_BELOW_HZ`] (its envelopes, knee angle and
    /// geometry series are then read between samples by cubics).
    pub fn is_low_rate(&self) -> bool {
        self.low_rate
    }

    /// Time of the first sample (s).
    pub fn t0(&self) -> f64 {
        self.t0
    }

    /// Sample times `t0 + i/fs` (s).
    pub fn times(&self) -> &[f64] {
        &self.times
    }

    /// Ankle angle at the samples (rad).
    pub fn angle(&self) -> &[f64] {
        &self.angle
    }

    /// Angular velocity at the samples (rad/s; central differences).
    pub fn velocity(&self) -> &[f64] {
        &self.velocity
    }

    /// Angular acceleration at the samples (rad/s², central second difference over
    /// ±[`ACCEL_HALF_WINDOW_S`]).
    pub fn acceleration(&self) -> &[f64] {
        &self.acceleration
    }

    /// Normalised envelope of muscle `m` at the samples.
    pub fn envelope(&self, m: Muscle) -> &[f64] {
        &self.env[m.index()]
    }

    /// Normalised tibialis-anterior envelope, if given.
    pub fn envelope_ta(&self) -> Option<&[f64]> {
        self.env_ta.as_deref()
    }

    #[inline]
    fn locate(&self, t: f64) -> (usize, f64) {
        let n = self.angle.len();
        let x = ((t - self.t0) * self.fs).clamp(0.0, (n - 1) as f64);
        // `x ≥ 0` (or NaN, which casts to 0 like its floor), so truncation is the floor (and
        // avoids a libm call on targets without a rounding instruction)
        let i = (x as usize).min(n - 2);
        (i, x - i as f64)
    }

    /// Angle and angular velocity at time `t` (cubic Hermite interpolation).
    #[inline]
    pub fn angle_at(&self, t: f64) -> (f64, f64) {
        let (i, s) = self.locate(t);
        let dt = 1.0 / self.fs;
        let (q0, q1) = (self.angle[i], self.angle[i + 1]);
        let (m0, m1) = (self.velocity[i], self.velocity[i + 1]);
        let s2 = s * s;
        let s3 = s2 * s;
        let q = (2.0 * s3 - 3.0 * s2 + 1.0) * q0
            + (s3 - 2.0 * s2 + s) * dt * m0
            + (-2.0 * s3 + 3.0 * s2) * q1
            + (s3 - s2) * dt * m1;
        let qd = (6.0 * s2 - 6.0 * s) * (q0 - q1) * self.fs
            + (3.0 * s2 - 4.0 * s + 1.0) * m0
            + (3.0 * s2 - 2.0 * s) * m1;
        (q, qd)
    }

    /// Angle at time `t` (cubic Hermite interpolation; cheaper than [`TrialInputs::angle_at`]).
    #[inline]
    pub fn angle_value_at(&self, t: f64) -> f64 {
        self.hermite_at(&self.angle, &self.velocity, t)
    }

    /// A quantity known at the samples as values `v` and time derivatives `dv`, at time `t`
    /// (cubic Hermite interpolation; the first or last value outside the trial).
    #[inline]
    pub(crate) fn hermite_at(&self, v: &[f64], dv: &[f64], t: f64) -> f64 {
        let (i, s) = self.locate(t);
        crate::interp::hermite_dt(v[i], dv[i], v[i + 1], dv[i + 1], s, 1.0 / self.fs)
    }

    /// Envelope of muscle index `j` (0..3) at time `t` (linear interpolation; a monotone cubic
    /// in a low-rate trial).
    #[inline]
    pub fn envelope_at(&self, j: usize, t: f64) -> f64 {
        self.envelope_value_at(&self.env[j], t)
    }

    /// An envelope `v` known at the samples, at time `t`: linear interpolation, or in a
    /// low-rate trial the monotone cubic, which stays between neighbouring samples (so in
    /// `[0, 1]`); the first or last value outside the trial.
    #[inline]
    pub(crate) fn envelope_value_at(&self, v: &[f64], t: f64) -> f64 {
        let (i, s) = self.locate(t);
        if self.low_rate {
            crate::interp::pchip(v, i, s).0
        } else {
            lerp(v, (i, s))
        }
    }

    /// The time derivative of [`TrialInputs::envelope_value_at`] (per second): the slope of
    /// the linear interpolant on the interval holding `t`, or the monotone cubic's; 0 outside
    /// the trial, where the value is held.
    #[inline]
    pub(crate) fn envelope_rate_at(&self, v: &[f64], t: f64) -> f64 {
        let times = self.times();
        if !(t > times[0] && t < times[times.len() - 1]) {
            return 0.0;
        }
        let (i, s) = self.locate(t);
        if self.low_rate {
            crate::interp::pchip(v, i, s).1 * self.fs
        } else {
            (v[i + 1] - v[i]) * self.fs
        }
    }

    /// A series `v` known at the samples (knee angle, musculotendon length), at time `t`:
    /// linear interpolation, or in a low-rate trial the central-difference cubic; the first or
    /// last value outside the trial.
    #[inline]
    pub(crate) fn series_at(&self, v: &[f64], t: f64) -> f64 {
        let (i, s) = self.locate(t);
        if self.low_rate {
            crate::interp::central(v, i, s).0
        } else {
            lerp(v, (i, s))
        }
    }

    /// The time derivative of [`TrialInputs::series_at`] (per second): the slope of the
    /// linear interpolant on the sample interval holding `t`, or the cubic's derivative (the
    /// first or last interval's outside the trial).
    #[inline]
    pub(crate) fn series_rate_at(&self, v: &[f64], t: f64) -> f64 {
        let (i, s) = self.locate(t);
        if self.low_rate {
            crate::interp::central(v, i, s).1 * self.fs
        } else {
            (v[i + 1] - v[i]) * self.fs
        }
    }

    /// TA envelope at time `t`, if given (as [`TrialInputs::envelope_at`]).
    #[inline]
    pub fn envelope_ta_at(&self, t: f64) -> Option<f64> {
        self.env_ta.as_ref().map(|e| self.envelope_value_at(e, t))
    }
}

impl PartialEq for TrialInputs {
    /// Equal data (the cache identity is ignored).
    fn eq(&self, o: &Self) -> bool {
        self.fs == o.fs
            && self.low_rate == o.low_rate
            && self.t0 == o.t0
            && self.times == o.times
            && self.angle == o.angle
            && self.velocity == o.velocity
            && self.acceleration == o.acceleration
            && self.env == o.env
            && self.env_ta == o.env_ta
            && self.knee == o.knee
            && self.channels == o.channels
            && self.geometry == o.geometry
    }
}

#[inline]
fn lerp(v: &[f64], (i, s): (usize, f64)) -> f64 {
    v[i] + s * (v[i + 1] - v[i])
}

fn check_finite(v: &[f64], n: usize, what: &str) -> Result<(), ModelError> {
    if v.len() != n {
        return Err(ModelError::Length {
            what: what.to_string(),
            expected: n,
            got: v.len(),
        });
    }
    match v.iter().position(|x| !x.is_finite()) {
        Some(i) => Err(ModelError::input(
            what,
            format!("non-finite value at sample {i}"),
        )),
        None => Ok(()),
    }
}

fn check_env(e: &mut [f64], n: usize, what: &str) -> Result<(), ModelError> {
    if e.len() != n {
        return Err(ModelError::Length {
            what: what.to_string(),
            expected: n,
            got: e.len(),
        });
    }
    for (i, x) in e.iter_mut().enumerate() {
        if !x.is_finite() {
            return Err(ModelError::input(
                what,
                format!("non-finite value at sample {i}"),
            ));
        }
        *x = x.clamp(0.0, 1.0);
    }
    Ok(())
}
