//! Isokinetic protocols (docs/formats.md, "Synthetic trials"): trapezoidal-velocity sweeps sampled at 2048 Hz, phases and events.

use std::fmt;
use std::str::FromStr;

use serde::{Deserialize, Serialize};

use crate::error::{ErrorKind, ExperimentError, Result};

/// Largest number of cycles a protocol string may ask for.
pub const MAX_CYCLES: usize = 100;

/// A protocol: which cycles the dynamometer performs and when the subject pushes.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum Protocol {
    /// `seed`: 0.5 s hold (drive ramps up), one maximal concentric + eccentric cycle,
    /// 0.4 s hold (drive relaxes).
    Seed,
    /// `relaxed+N`: 0.5 s hold at rest, one relaxed cycle, 0.5 s hold (drive ramps up),
    /// `cycles` maximal cycles back to back, 0.4 s hold.
    Relaxed {
        /// Number of maximal cycles after the relaxed one (1..=100).
        cycles: usize,
    },
    /// `cycles+N`: like `seed` with `cycles` maximal cycles back to back. The unloaded run
    /// is `cycles+3` ([`Protocol::unloaded`]); its "subject" flags are irrelevant there.
    Cycles {
        /// Number of cycles (1..=100).
        cycles: usize,
    },
}

impl Protocol {
    /// The motion of the unloaded run: the seed motion with 3 cycles back to back.
    #[must_use]
    pub const fn unloaded() -> Self {
        Self::Cycles { cycles: 3 }
    }

    /// Samples the protocol with the nominal [`MotionSettings`] at 2048 Hz.
    ///
    /// # Errors
    /// A cycle count outside `1..=MAX_CYCLES`.
    pub fn trace(&self) -> Result<ProtocolTrace> {
        self.trace_with(&MotionSettings::default())
    }

    /// Samples the protocol with explicit motion settings.
    ///
    /// # Errors
    /// Invalid settings or a cycle count outside `1..=MAX_CYCLES`.
    pub fn trace_with(&self, m: &MotionSettings) -> Result<ProtocolTrace> {
        m.validate()?;
        let segments = self.segments(m)?;
        let total = segments.last().map_or(0.0, |s| s.end_s);
        let fs = m.sample_rate_hz;
        let n = (total * fs + 1e-9).floor() as usize + 1;
        let mut tr = ProtocolTrace {
            protocol: *self,
            sample_rate_hz: fs,
            time_s: Vec::with_capacity(n),
            angle_deg: Vec::with_capacity(n),
            velocity_deg_s: Vec::with_capacity(n),
            acceleration_deg_s2: Vec::with_capacity(n),
            phase: Vec::with_capacity(n),
            active: Vec::with_capacity(n),
            segments: Vec::new(),
            events: Events::default(),
        };
        let mut seg = 0usize;
        for i in 0..n {
            let t = i as f64 / fs;
            while seg + 1 < segments.len() && t >= segments[seg].end_s {
                seg += 1;
            }
            let s = &segments[seg];
            let (x, v, a) = s.kinematics(t, m);
            tr.time_s.push(t);
            tr.angle_deg.push(x);
            tr.velocity_deg_s.push(v);
            tr.acceleration_deg_s2.push(a);
            tr.phase.push(s.phase);
            tr.active.push(s.active);
        }
        // Events: a sweep after a hold is a start, a sweep after a sweep a reversal,
        // a hold after a sweep a stop.
        for w in segments.windows(2) {
            let (a, b) = (w[0].phase, w[1].phase);
            let t = w[1].start_s;
            match (a == MotionPhase::Hold, b == MotionPhase::Hold) {
                (true, false) => tr.events.starts.push(t),
                (false, false) => tr.events.reversals.push(t),
                (false, true) => tr.events.stops.push(t),
                (true, true) => {}
            }
        }
        tr.segments = segments;
        Ok(tr)
    }

    fn segments(&self, m: &MotionSettings) -> Result<Vec<Segment>> {
        let check = |n: usize| {
            if (1..=MAX_CYCLES).contains(&n) {
                Ok(n)
            } else {
                Err(ExperimentError::invalid(
                    "protocol",
                    ErrorKind::InvalidProtocol,
                    format!("the number of cycles must be 1..={MAX_CYCLES}, got {n}"),
                ))
            }
        };
        let ts = m.sweep_duration_s();
        let mut segs = Vec::new();
        let mut t = 0.0;
        let mut push = |phase: MotionPhase, dur: f64, active: bool, cycle: Option<usize>| {
            segs.push(Segment {
                phase,
                start_s: t,
                end_s: t + dur,
                active,
                cycle,
            });
            t += dur;
        };
        let (relaxed_first, maximal) = match *self {
            Self::Seed => (false, 1),
            Self::Relaxed { cycles } => (true, check(cycles)?),
            Self::Cycles { cycles } => (false, check(cycles)?),
        };
        let mut cycle = 0;
        if relaxed_first {
            push(MotionPhase::Hold, m.hold_start_s, false, None);
            push(MotionPhase::Concentric, ts, false, Some(cycle));
            push(MotionPhase::Eccentric, ts, false, Some(cycle));
            cycle += 1;
        }
        push(MotionPhase::Hold, m.hold_start_s, true, None);
        for _ in 0..maximal {
            push(MotionPhase::Concentric, ts, true, Some(cycle));
            push(MotionPhase::Eccentric, ts, true, Some(cycle));
            cycle += 1;
        }
        push(MotionPhase::Hold, m.hold_end_s, false, None);
        Ok(segs)
    }
}

impl fmt::Display for Protocol {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Seed => write!(f, "seed"),
            Self::Relaxed { cycles } => write!(f, "relaxed+{cycles}"),
            Self::Cycles { cycles } => write!(f, "cycles+{cycles}"),
        }
    }
}

impl FromStr for Protocol {
    type Err = ExperimentError;
    fn from_str(s: &str) -> Result<Self> {
        let bad = |reason: String| {
            ExperimentError::invalid("protocol", ErrorKind::InvalidProtocol, reason)
        };
        let s = s.trim();
        if s == "seed" {
            return Ok(Self::Seed);
        }
        let (kind, n) = s.split_once('+').ok_or_else(|| {
            bad(format!(
                "'{s}' is not a protocol; expected 'seed', 'relaxed+N' or 'cycles+N'"
            ))
        })?;
        let n: usize = n.trim().parse().map_err(|_| {
            bad(format!(
                "'{s}': the number of cycles after '+' must be a whole number"
            ))
        })?;
        if !(1..=MAX_CYCLES).contains(&n) {
            return Err(bad(format!(
                "'{s}': the number of cycles must be 1..={MAX_CYCLES}"
            )));
        }
        match kind.trim() {
            "relaxed" => Ok(Self::Relaxed { cycles: n }),
            "cycles" => Ok(Self::Cycles { cycles: n }),
            _ => Err(bad(format!(
                "'{s}' is not a protocol; expected 'seed', 'relaxed+N' or 'cycles+N'"
            ))),
        }
    }
}

/// Geometry and timing of the motion. `Default` is the motion of docs/formats.md, "Synthetic trials".
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct MotionSettings {
    /// Sampling rate (2048 Hz).
    pub sample_rate_hz: f64,
    /// Start/end angle, dorsiflexed (+15°).
    pub dorsi_angle_deg: f64,
    /// Turning angle, plantarflexed (−20°).
    pub plantar_angle_deg: f64,
    /// Cruise speed (30 °/s).
    pub speed_deg_s: f64,
    /// Duration of each constant-acceleration ramp (0.05 s).
    pub ramp_s: f64,
    /// Hold before the motion (0.5 s); also the hold between the relaxed cycle and the maximal ones.
    pub hold_start_s: f64,
    /// Hold after the motion (0.4 s).
    pub hold_end_s: f64,
}

impl Default for MotionSettings {
    fn default() -> Self {
        Self {
            sample_rate_hz: 2048.0,
            dorsi_angle_deg: 15.0,
            plantar_angle_deg: -20.0,
            speed_deg_s: 30.0,
            ramp_s: 0.05,
            hold_start_s: 0.5,
            hold_end_s: 0.4,
        }
    }
}

impl MotionSettings {
    /// Range of motion `dorsi − plantar` in degrees.
    #[must_use]
    pub fn range_deg(&self) -> f64 {
        self.dorsi_angle_deg - self.plantar_angle_deg
    }
    /// Ramp acceleration `speed/ramp` in °/s².
    #[must_use]
    pub fn acceleration_deg_s2(&self) -> f64 {
        self.speed_deg_s / self.ramp_s
    }
    /// Duration of one sweep, `range/speed + ramp` (1.21667 s nominal).
    #[must_use]
    pub fn sweep_duration_s(&self) -> f64 {
        self.range_deg() / self.speed_deg_s + self.ramp_s
    }

    fn validate(&self) -> Result<()> {
        let ok = |x: f64| x.is_finite() && x > 0.0;
        let bad = |r: &str| {
            Err(ExperimentError::invalid(
                "motion settings",
                ErrorKind::InvalidSettings,
                r.to_string(),
            ))
        };
        if !(ok(self.sample_rate_hz)
            && ok(self.speed_deg_s)
            && ok(self.ramp_s)
            && ok(self.hold_start_s)
            && ok(self.hold_end_s)
            && self.dorsi_angle_deg.is_finite()
            && self.plantar_angle_deg.is_finite())
        {
            return bad("all durations, rates and the speed must be finite and > 0");
        }
        if self.range_deg() < self.speed_deg_s * self.ramp_s {
            return bad("the range of motion must exceed speed·ramp (trapezoidal profile)");
        }
        Ok(())
    }
}

/// What the dynamometer is doing.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum MotionPhase {
    /// Not moving (at +15°).
    Hold,
    /// Moving towards plantarflexion (+15° → −20°): plantarflexors shorten.
    Concentric,
    /// Moving towards dorsiflexion (−20° → +15°): plantarflexors lengthen.
    Eccentric,
}

/// One piece of the protocol.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Segment {
    /// Hold or sweep direction.
    pub phase: MotionPhase,
    /// Start time (s).
    pub start_s: f64,
    /// End time (s).
    pub end_s: f64,
    /// Whether the subject is (getting) active: true for the hold in which the drive ramps
    /// up and for maximal sweeps; false for rest holds, relaxed sweeps and the final hold.
    pub active: bool,
    /// Cycle index (0-based, the relaxed cycle counts) for sweeps; `None` for holds.
    pub cycle: Option<usize>,
}

impl Segment {
    /// Analytic angle (°), velocity (°/s) and acceleration (°/s²) at time `t` in this segment.
    #[must_use]
    pub fn kinematics(&self, t: f64, m: &MotionSettings) -> (f64, f64, f64) {
        let (x0, dir) = match self.phase {
            MotionPhase::Hold => return (m.dorsi_angle_deg, 0.0, 0.0),
            MotionPhase::Concentric => (m.dorsi_angle_deg, -1.0),
            MotionPhase::Eccentric => (m.plantar_angle_deg, 1.0),
        };
        let ts = m.sweep_duration_s();
        let acc = m.acceleration_deg_s2();
        let (v, tr, d) = (m.speed_deg_s, m.ramp_s, m.range_deg());
        let tau = (t - self.start_s).clamp(0.0, ts);
        let (x, vel, a) = if tau < tr {
            (0.5 * acc * tau * tau, acc * tau, acc)
        } else if tau <= ts - tr {
            (0.5 * acc * tr * tr + v * (tau - tr), v, 0.0)
        } else {
            let r = ts - tau;
            (d - 0.5 * acc * r * r, acc * r, -acc)
        };
        (x0 + dir * x, dir * vel, dir * a)
    }
}

/// Times (s) at which the motion starts, reverses and stops.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Events {
    /// Motion starts (a sweep after a hold).
    pub starts: Vec<f64>,
    /// Reversals (a sweep directly after a sweep: at −20°, and at +15° between back-to-back cycles).
    pub reversals: Vec<f64>,
    /// Motion stops (a hold after a sweep).
    pub stops: Vec<f64>,
}

impl Events {
    /// All event times, sorted.
    #[must_use]
    pub fn all(&self) -> Vec<f64> {
        let mut v: Vec<f64> = self
            .starts
            .iter()
            .chain(&self.reversals)
            .chain(&self.stops)
            .copied()
            .collect();
        v.sort_by(f64::total_cmp);
        v
    }
}

/// A sampled protocol: uniform time, analytic kinematics, phase and activity per sample.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ProtocolTrace {
    /// The protocol sampled.
    pub protocol: Protocol,
    /// Sampling rate (Hz).
    pub sample_rate_hz: f64,
    /// `t_i = i / fs`, from 0 to the end of the final hold.
    pub time_s: Vec<f64>,
    /// Ankle angle (°), dorsiflexion positive.
    pub angle_deg: Vec<f64>,
    /// Angular velocity (°/s).
    pub velocity_deg_s: Vec<f64>,
    /// Angular acceleration (°/s²), piecewise constant (±speed/ramp in the ramps).
    pub acceleration_deg_s2: Vec<f64>,
    /// Phase of each sample (a sample at a boundary belongs to the later segment).
    pub phase: Vec<MotionPhase>,
    /// Whether the subject is active at each sample (see [`Segment::active`]).
    pub active: Vec<bool>,
    /// The segments, in time order, contiguous.
    pub segments: Vec<Segment>,
    /// Motion starts, reversals and stops.
    pub events: Events,
}

impl ProtocolTrace {
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
    /// Sampling interval `1/fs` (s).
    #[must_use]
    pub fn dt(&self) -> f64 {
        1.0 / self.sample_rate_hz
    }
    /// Duration: end of the last segment (s).
    #[must_use]
    pub fn duration_s(&self) -> f64 {
        self.segments.last().map_or(0.0, |s| s.end_s)
    }
}

/// Slowest and fastest cruise speed a protocol may ask for (°/s): isokinetic dynamometers
/// run from a few degrees per second up to several hundred.
pub const SPEED_RANGE_DEG_S: (f64, f64) = (5.0, 300.0);

/// The nominal cruise speed (°/s) of [`MotionSettings::default`].
pub const NOMINAL_SPEED_DEG_S: f64 = 30.0;

/// The knee angles accepted (degrees), the same range the trial reader accepts in the column.
pub const KNEE_RANGE_DEG: (f64, f64) = (-30.0, 180.0);

/// The protocol of a synthetic trial: a motion ([`Protocol`]) at a cruise speed with the knee
/// held at a constant flexion (degrees; 0 extended).
///
/// Two spellings are read:
/// - `<motion>[@knee<DEG>][@<SPEED>]`, e.g. `seed`, `relaxed+2@knee90`, `seed@knee0@60`;
/// - the protocol-design shorthand `knee<DEG>[@<SPEED>][x<N>]`: the seed motion (`N` = 1) or
///   `N` maximal cycles back to back (`cycles+N`), e.g. `knee90`, `knee0@60`, `knee0@30x3`.
///
/// `SPEED` is the cruise speed in °/s (default 30). A protocol is written back in the shortest
/// form that reads as itself (`knee90`, `knee0@60`, `relaxed+2@knee90`, `seed`).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct SynthProtocol {
    /// The motion and when the subject pushes.
    pub protocol: Protocol,
    /// Knee flexion throughout the trial (degrees; 0 extended, > 0 flexed).
    pub knee_angle_deg: f64,
    /// Cruise speed of the sweeps (°/s; [`NOMINAL_SPEED_DEG_S`] unless said).
    #[serde(default = "nominal_speed")]
    pub speed_deg_s: f64,
}

fn nominal_speed() -> f64 {
    NOMINAL_SPEED_DEG_S
}

impl SynthProtocol {
    /// The motion settings of this protocol: [`MotionSettings::default`] at its speed.
    #[must_use]
    pub fn motion(&self) -> MotionSettings {
        MotionSettings {
            speed_deg_s: self.speed_deg_s,
            ..MotionSettings::default()
        }
    }

    /// The trial's motion sampled at 2048 Hz ([`Protocol::trace_with`] at this speed).
    ///
    /// # Errors
    /// An invalid speed or cycle count.
    pub fn trace(&self) -> Result<ProtocolTrace> {
        self.protocol.trace_with(&self.motion())
    }
}

impl From<Protocol> for SynthProtocol {
    fn from(protocol: Protocol) -> Self {
        Self {
            protocol,
            knee_angle_deg: 0.0,
            speed_deg_s: NOMINAL_SPEED_DEG_S,
        }
    }
}

impl fmt::Display for SynthProtocol {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let k = self.knee_angle_deg;
        let v = self.speed_deg_s;
        if v == NOMINAL_SPEED_DEG_S {
            return match self.protocol {
                _ if k == 0.0 => write!(f, "{}", self.protocol),
                Protocol::Seed => write!(f, "knee{k}"),
                p => write!(f, "{p}@knee{k}"),
            };
        }
        match self.protocol {
            Protocol::Seed => write!(f, "knee{k}@{v}"),
            Protocol::Cycles { cycles } => write!(f, "knee{k}@{v}x{cycles}"),
            p => write!(f, "{p}@knee{k}@{v}"),
        }
    }
}

impl FromStr for SynthProtocol {
    type Err = ExperimentError;
    fn from_str(s: &str) -> Result<Self> {
        let s = s.trim();
        let bad = |reason: String| {
            ExperimentError::invalid("protocol", ErrorKind::InvalidProtocol, reason)
        };
        let mut parts = s.split('@').map(str::trim);
        let first = parts.next().unwrap_or("");
        let rest: Vec<&str> = parts.collect();
        let mut knee = None;
        let mut speed = None;
        let protocol = if first.starts_with("knee") {
            // Shorthand: knee<DEG>[@<SPEED>][x<N>], the x<N> on the last part.
            if rest.len() > 1 {
                return Err(bad(format!(
                    "'{s}': the shorthand is 'knee<degrees>[@<speed>][x<cycles>]', e.g. 'knee0@30x3'"
                )));
            }
            let last = rest.first().copied().unwrap_or(first);
            let (body, cycles) = match last.split_once('x') {
                Some((b, n)) => {
                    let n: usize = n.trim().parse().map_err(|_| {
                        bad(format!(
                            "'{s}': the number of cycles after 'x' must be a whole number"
                        ))
                    })?;
                    if !(1..=MAX_CYCLES).contains(&n) {
                        return Err(bad(format!(
                            "'{s}': the number of cycles must be 1..={MAX_CYCLES}"
                        )));
                    }
                    (b.trim(), n)
                }
                None => (last, 1),
            };
            if rest.is_empty() {
                knee = Some(parse_knee(body, s)?);
            } else {
                knee = Some(parse_knee(first, s)?);
                speed = Some(parse_speed(body, s)?);
            }
            if cycles == 1 {
                Protocol::Seed
            } else {
                Protocol::Cycles { cycles }
            }
        } else {
            let protocol: Protocol = first.parse()?;
            for part in rest {
                if part.starts_with("knee") && knee.is_none() {
                    knee = Some(parse_knee(part, s)?);
                } else if !part.starts_with("knee") && speed.is_none() {
                    speed = Some(parse_speed(part, s)?);
                } else {
                    return Err(bad(format!(
                        "'{s}': expected '<motion>[@knee<degrees>][@<speed>]', e.g. 'seed@knee90@60'"
                    )));
                }
            }
            protocol
        };
        Ok(Self {
            protocol,
            knee_angle_deg: knee.unwrap_or(0.0),
            speed_deg_s: speed.unwrap_or(NOMINAL_SPEED_DEG_S),
        })
    }
}

/// `<SPEED>` → a cruise speed in °/s within [`SPEED_RANGE_DEG_S`].
fn parse_speed(v: &str, whole: &str) -> Result<f64> {
    let bad =
        |reason: String| ExperimentError::invalid("protocol", ErrorKind::InvalidProtocol, reason);
    let speed: f64 = v.trim().parse().map_err(|_| {
        bad(format!(
            "'{whole}': '{v}' is not a speed; the speed is written in degrees per second after '@', e.g. 'knee0@60'"
        ))
    })?;
    let (lo, hi) = SPEED_RANGE_DEG_S;
    if !(speed.is_finite() && (lo..=hi).contains(&speed)) {
        return Err(bad(format!(
            "'{whole}': the speed must be within [{lo}, {hi}] °/s"
        )));
    }
    Ok(speed)
}

/// `knee<DEG>` → DEG, a finite angle inside the knee's range.
fn parse_knee(k: &str, whole: &str) -> Result<f64> {
    let bad =
        |reason: String| ExperimentError::invalid("protocol", ErrorKind::InvalidProtocol, reason);
    let deg: f64 = k
        .strip_prefix("knee")
        .and_then(|d| d.trim().parse().ok())
        .ok_or_else(|| {
            bad(format!(
                "'{whole}': the knee angle is written 'knee<degrees>', e.g. 'knee90' or 'seed@knee90'"
            ))
        })?;
    let (lo, hi) = KNEE_RANGE_DEG;
    if !(deg.is_finite() && (lo..=hi).contains(&deg)) {
        return Err(bad(format!(
            "'{whole}': the knee angle must be within [{lo}, {hi}] degrees"
        )));
    }
    Ok(deg)
}
