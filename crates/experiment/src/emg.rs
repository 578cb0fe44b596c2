//! Synthetic raw EMG (docs/formats.md, "Synthetic trials"): band-limited Gaussian carrier × drive `d(t)` per channel.
//!
//! **Knee flexion.** In a trial with the knee flexed by `k`, the gastrocnemii's active drive
//! (their concentric and eccentric levels, not the rest level) is multiplied by
//! `f(k) = 1 − (1 − f90)·(1 − cos k)`, `k` clamped to `[0°, 90°]`, `f90` =
//! [`GASTROCNEMIUS_DRIVE_AT_90_DEG`] = 0.7: `f` = 1 at 0°, 0.96 at 30°, 0.85 at 60°, 0.7 at 90°;
//! the soleus's drive is unchanged. Why: the gastrocnemii cross the knee, and with the knee
//! flexed they are shortened and at a mechanical disadvantage; in maximal plantarflexion their
//! surface EMG falls with knee flexion while the soleus's stays the same (Cresswell et al. 1995;
//! Miaki et al. 1999; Arampatzis et al. 2006), by roughly 20–50 % at 90°. 0.7 is inside that
//! range. Those studies measured only a few knee angles; the cosine between them is a choice
//! that keeps the drive nearly unchanged over the first 30° and puts most of the loss between
//! 45° and 90°. The factor changes only the
//! EMG the synthetic subject produces: the model reads its envelope like any other, so with
//! each channel normalised by its own trial maximum the model's input is unchanged, and the
//! lower drive shows where envelopes are normalised by an MVC or across several trials.

use rand::Rng;
use rand_distr::{Distribution, StandardNormal};
use serde::{Deserialize, Serialize};

use crate::error::{ErrorKind, ExperimentError, Result};
use crate::files::Trial;
use crate::protocol::{MotionPhase, ProtocolTrace, Segment, KNEE_RANGE_DEG};
use crate::seeds::{rng, Stream};

/// An EMG channel of the trial file.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum EmgMuscle {
    /// Soleus.
    Sol,
    /// Gastrocnemius medialis.
    Gm,
    /// Gastrocnemius lateralis.
    Gl,
    /// Tibialis anterior (antagonist).
    Ta,
}

impl EmgMuscle {
    /// All four, in file order.
    pub const ALL: [Self; 4] = [Self::Sol, Self::Gm, Self::Gl, Self::Ta];

    /// Short name (`sol`, `gm`, `gl`, `ta`).
    #[must_use]
    pub fn name(self) -> &'static str {
        match self {
            Self::Sol => "sol",
            Self::Gm => "gm",
            Self::Gl => "gl",
            Self::Ta => "ta",
        }
    }
    /// CSV column name (`emg_sol`, …).
    #[must_use]
    pub fn column(self) -> &'static str {
        match self {
            Self::Sol => "emg_sol",
            Self::Gm => "emg_gm",
            Self::Gl => "emg_gl",
            Self::Ta => "emg_ta",
        }
    }
    fn index(self) -> u8 {
        self as u8
    }
}

/// The gastrocnemii's drive at 90° of knee flexion, as a fraction of the extended knee's (see
/// the module documentation).
pub const GASTROCNEMIUS_DRIVE_AT_90_DEG: f64 = 0.7;

/// The factor on the gastrocnemii's active drive at knee flexion `knee_angle_deg` (degrees):
/// `1 − (1 − 0.7)·(1 − cos k)` with `k` clamped to `[0°, 90°]`; exactly 1 for an extended (or
/// hyperextended) knee.
#[must_use]
pub fn gastrocnemius_drive_factor(knee_angle_deg: f64) -> f64 {
    if knee_angle_deg >= 90.0 {
        // exactly f90 (cos of the rounded π/2 is 6e-17, not 0)
        return GASTROCNEMIUS_DRIVE_AT_90_DEG;
    }
    let k = knee_angle_deg.clamp(0.0, 90.0).to_radians();
    1.0 - (1.0 - GASTROCNEMIUS_DRIVE_AT_90_DEG) * (1.0 - k.cos())
}

/// Parameters of the synthetic EMG. `Default` is the fixtures' choice.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct EmgSettings {
    /// Drive at rest, the floor of `d(t)` (0.03).
    pub rest_level: f64,
    /// Triceps drive in maximal concentric sweeps (0.92).
    pub concentric_level: f64,
    /// Eccentric drive as a fraction of the concentric one (0.85).
    pub eccentric_ratio: f64,
    /// The ramp-up fills the pre-motion hold minus this margin at each end (0.05 s).
    pub ramp_margin_s: f64,
    /// Half-width of the level change around a reversal between maximal sweeps (0.1 s).
    pub reversal_blend_s: f64,
    /// Time to relax to rest after the motion stops (0.2 s).
    pub relax_s: f64,
    /// RMS of the slow relative wobble of the active drive (0.03 = 3 %).
    pub wobble_rms: f64,
    /// Frequencies of the three wobble sines (0.31, 0.53, 0.87 Hz); phases are random.
    pub wobble_freqs_hz: [f64; 3],
    /// Carrier pass band (20, 450 Hz): 4th-order Butterworth high-pass, then low-pass.
    pub band_hz: [f64; 2],
    /// Per-channel gain, sol, gm, gl, ta (0.35, 0.5, 0.2, 0.15; arbitrary units ~ mV).
    pub gains: [f64; 4],
    /// Whether to synthesise `emg_ta` (false).
    pub include_ta: bool,
    /// TA drive at rest (0.02).
    pub ta_rest_level: f64,
    /// TA drive in maximal concentric sweeps (0.04).
    pub ta_concentric_level: f64,
    /// TA drive in maximal eccentric (dorsiflexion) sweeps (0.10).
    pub ta_eccentric_level: f64,
}

impl Default for EmgSettings {
    fn default() -> Self {
        Self {
            rest_level: 0.03,
            concentric_level: 0.92,
            eccentric_ratio: 0.85,
            ramp_margin_s: 0.05,
            reversal_blend_s: 0.1,
            relax_s: 0.2,
            wobble_rms: 0.03,
            wobble_freqs_hz: [0.31, 0.53, 0.87],
            band_hz: [20.0, 450.0],
            gains: [0.35, 0.5, 0.2, 0.15],
            include_ta: false,
            ta_rest_level: 0.02,
            ta_concentric_level: 0.04,
            ta_eccentric_level: 0.10,
        }
    }
}

impl EmgSettings {
    /// Checks ranges: `0 < rest ≤ levels ≤ 1`, ratio in (0, 1], durations ≥ 0,
    /// `0 < f_lo < f_hi < fs/2`, gains finite and > 0.
    ///
    /// # Errors
    /// [`ErrorKind::InvalidSettings`].
    pub fn validate(&self, sample_rate_hz: f64) -> Result<()> {
        let bad = |r: &str| {
            Err(ExperimentError::invalid(
                "EMG settings",
                ErrorKind::InvalidSettings,
                r.to_string(),
            ))
        };
        let unit = |x: f64| x.is_finite() && x > 0.0 && x <= 1.0;
        let ecc = self.concentric_level * self.eccentric_ratio;
        if !(unit(self.rest_level)
            && unit(self.concentric_level)
            && unit(self.eccentric_ratio)
            && self.rest_level <= ecc)
        {
            return bad("need 0 < rest_level ≤ eccentric level ≤ concentric_level ≤ 1");
        }
        if !(unit(self.ta_rest_level)
            && unit(self.ta_concentric_level)
            && unit(self.ta_eccentric_level)
            && self.ta_rest_level <= self.ta_concentric_level.min(self.ta_eccentric_level))
        {
            return bad("need 0 < ta_rest_level ≤ TA sweep levels ≤ 1");
        }
        let dur = |x: f64| x.is_finite() && x >= 0.0;
        if !(dur(self.ramp_margin_s)
            && dur(self.reversal_blend_s)
            && dur(self.relax_s)
            && dur(self.wobble_rms)
            && self.wobble_rms < 0.3
            && self.wobble_freqs_hz.iter().all(|&f| dur(f)))
        {
            return bad(
                "durations, wobble_rms (< 0.3) and wobble frequencies must be finite and ≥ 0",
            );
        }
        let [lo, hi] = self.band_hz;
        if !(lo.is_finite() && hi.is_finite() && lo > 0.0 && lo < hi && hi < 0.5 * sample_rate_hz) {
            return bad("band_hz must satisfy 0 < low < high < fs/2");
        }
        if !self.gains.iter().all(|&g| g.is_finite() && g > 0.0) {
            return bad("gains must be finite and > 0");
        }
        Ok(())
    }
}

/// One synthesised channel.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct EmgChannel {
    /// Which muscle.
    pub muscle: EmgMuscle,
    /// Raw EMG `gain·d(t)·c(t)`, `c` the unit-RMS band-limited carrier.
    pub raw: Vec<f64>,
    /// The drive `d(t)` ∈ [rest, 1].
    pub drive: Vec<f64>,
    /// The channel gain.
    pub gain: f64,
}

/// Synthetic EMG for a protocol: sol, gm, gl and optionally ta.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SyntheticEmg {
    /// Channels in file order (sol, gm, gl[, ta]).
    pub channels: Vec<EmgChannel>,
}

impl SyntheticEmg {
    /// The channel of one muscle, if synthesised.
    #[must_use]
    pub fn channel(&self, m: EmgMuscle) -> Option<&EmgChannel> {
        self.channels.iter().find(|c| c.muscle == m)
    }

    /// Assembles a [`Trial`] from the protocol's time and angle, a torque and this EMG
    /// (the `gen-fixtures` step). The knee angle column is omitted.
    ///
    /// # Errors
    /// Lengths that differ, or anything the reader would reject.
    pub fn to_trial(&self, trace: &ProtocolTrace, torque_nm: Vec<f64>) -> Result<Trial> {
        let get = |m| {
            self.channel(m).map(|c| c.raw.clone()).ok_or_else(|| {
                ExperimentError::invalid(
                    "synthetic EMG",
                    ErrorKind::LengthMismatch,
                    format!("channel {} missing", m.name()),
                )
            })
        };
        let trial = Trial {
            time_s: trace.time_s.clone(),
            ankle_angle_deg: trace.angle_deg.clone(),
            torque_nm,
            emg_sol: get(EmgMuscle::Sol)?,
            emg_gm: get(EmgMuscle::Gm)?,
            emg_gl: get(EmgMuscle::Gl)?,
            emg_ta: self.channel(EmgMuscle::Ta).map(|c| c.raw.clone()),
            emg_other: Vec::new(),
            knee_angle_deg: None,
            grf_vertical_n: None,
            comments: Vec::new(),
            ignored_columns: Vec::new(),
        };
        trial.validate("<synthetic trial>")?;
        Ok(trial)
    }
}

/// Levels of one drive profile.
#[derive(Clone, Copy)]
struct Levels {
    rest: f64,
    concentric: f64,
    eccentric: f64,
}

fn is_active_sweep(s: Option<&Segment>) -> bool {
    s.is_some_and(|s| s.active && s.phase != MotionPhase::Hold)
}

/// Breakpoints `(t, level)` of the base drive; smoothstep between consecutive ones.
fn breakpoints(segs: &[Segment], lv: Levels, st: &EmgSettings) -> Vec<(f64, f64)> {
    let level = |p: MotionPhase| match p {
        MotionPhase::Concentric => lv.concentric,
        MotionPhase::Eccentric => lv.eccentric,
        MotionPhase::Hold => lv.rest,
    };
    let mut bp = vec![(0.0, lv.rest)];
    for (i, s) in segs.iter().enumerate() {
        let dur = s.end_s - s.start_s;
        let prev = if i > 0 { segs.get(i - 1) } else { None };
        let next = segs.get(i + 1);
        match (s.phase, s.active) {
            (MotionPhase::Hold, true) => {
                let m = st.ramp_margin_s.min(dur / 4.0);
                let target = next
                    .filter(|n| is_active_sweep(Some(n)))
                    .map_or(lv.concentric, |n| level(n.phase));
                bp.push((s.start_s + m, lv.rest));
                bp.push((s.end_s - m, target));
            }
            (MotionPhase::Hold, false) => {
                if is_active_sweep(prev) {
                    bp.push((s.start_s + st.relax_s.min(dur), lv.rest));
                }
                bp.push((s.end_s, lv.rest));
            }
            (p, true) => {
                let w = st.reversal_blend_s.min(dur / 4.0);
                let w_in = if is_active_sweep(prev) { w } else { 0.0 };
                let w_out = if is_active_sweep(next) { w } else { 0.0 };
                bp.push((s.start_s + w_in, level(p)));
                bp.push((s.end_s - w_out, level(p)));
            }
            (_, false) => {
                bp.push((s.start_s, lv.rest));
                bp.push((s.end_s, lv.rest));
            }
        }
    }
    bp
}

/// Base drive at the sample times (no wobble), by smoothstep interpolation of `bp`.
fn base_drive(time_s: &[f64], bp: &[(f64, f64)]) -> Vec<f64> {
    let mut k = 0usize;
    time_s
        .iter()
        .map(|&t| {
            while k + 1 < bp.len() && t >= bp[k + 1].0 {
                k += 1;
            }
            if k + 1 >= bp.len() {
                return bp[bp.len() - 1].1;
            }
            let (t0, y0) = bp[k];
            let (t1, y1) = bp[k + 1];
            if t1 <= t0 {
                return y1;
            }
            let u = ((t - t0) / (t1 - t0)).clamp(0.0, 1.0);
            y0 + (y1 - y0) * u * u * (3.0 - 2.0 * u)
        })
        .collect()
}

/// The drive of one channel: `d = rest + (base − rest)·(1 + w(t))`, clamped to [rest, 1],
/// with `w(t) = wobble_rms·Σ_k sin(2π f_k t + φ_k)/sqrt(3/2)` and random phases `φ_k`.
fn drive<R: Rng>(
    trace: &ProtocolTrace,
    lv: Levels,
    st: &EmgSettings,
    wobble_rng: &mut R,
) -> Vec<f64> {
    let bp = breakpoints(&trace.segments, lv, st);
    let base = base_drive(&trace.time_s, &bp);
    let two_pi = 2.0 * std::f64::consts::PI;
    let phases: [f64; 3] = std::array::from_fn(|_| two_pi * wobble_rng.random::<f64>());
    let norm = st.wobble_rms / 1.5f64.sqrt();
    base.iter()
        .zip(&trace.time_s)
        .map(|(&b, &t)| {
            let w: f64 = st
                .wobble_freqs_hz
                .iter()
                .zip(&phases)
                .map(|(&f, &p)| (two_pi * f * t + p).sin())
                .sum::<f64>()
                * norm;
            (lv.rest + (b - lv.rest) * (1.0 + w)).clamp(lv.rest, 1.0)
        })
        .collect()
}

/// One digital biquad (transposed direct form II), coefficients normalised by `a0`.
#[derive(Clone, Copy)]
struct Biquad {
    b: [f64; 3],
    a: [f64; 2],
    z: [f64; 2],
}

impl Biquad {
    /// Bilinear-transform (pre-warped) 2nd-order low- or high-pass with quality factor `q`.
    fn new(fc: f64, fs: f64, q: f64, high: bool) -> Self {
        let w0 = 2.0 * std::f64::consts::PI * fc / fs;
        let (sn, cs) = w0.sin_cos();
        let alpha = sn / (2.0 * q);
        let a0 = 1.0 + alpha;
        let b = if high {
            [(1.0 + cs) / 2.0, -(1.0 + cs), (1.0 + cs) / 2.0]
        } else {
            [(1.0 - cs) / 2.0, 1.0 - cs, (1.0 - cs) / 2.0]
        };
        Self {
            b: [b[0] / a0, b[1] / a0, b[2] / a0],
            a: [-2.0 * cs / a0, (1.0 - alpha) / a0],
            z: [0.0; 2],
        }
    }
    fn step(&mut self, x: f64) -> f64 {
        let y = self.b[0] * x + self.z[0];
        self.z[0] = self.b[1] * x - self.a[0] * y + self.z[1];
        self.z[1] = self.b[2] * x - self.a[1] * y;
        y
    }
}

/// Unit-RMS Gaussian noise band-limited by 4th-order Butterworth high-pass at `lo` and
/// low-pass at `hi` (two biquads each, Q = 0.5412 and 1.3066), after a 1 s burn-in.
fn carrier<R: Rng>(n: usize, fs: f64, band: [f64; 2], r: &mut R) -> Vec<f64> {
    let qs = [
        1.0 / (2.0 * (std::f64::consts::PI / 8.0).cos()),
        1.0 / (2.0 * (3.0 * std::f64::consts::PI / 8.0).cos()),
    ];
    let mut f = [
        Biquad::new(band[0], fs, qs[0], true),
        Biquad::new(band[0], fs, qs[1], true),
        Biquad::new(band[1], fs, qs[0], false),
        Biquad::new(band[1], fs, qs[1], false),
    ];
    let burn = fs.ceil() as usize;
    let mut out = Vec::with_capacity(n);
    for i in 0..burn + n {
        let mut x: f64 = StandardNormal.sample(r);
        for b in &mut f {
            x = b.step(x);
        }
        if i >= burn {
            out.push(x);
        }
    }
    let rms = numerics::rms(&out);
    if rms > 0.0 {
        for x in &mut out {
            *x /= rms;
        }
    }
    out
}

/// Synthesises raw EMG for `trace` (sol, gm, gl, and ta when `settings.include_ta`).
///
/// The triceps drive is at `rest_level` until the hold before the first maximal sweep,
/// ramps (smoothstep) to `concentric_level` during that hold, changes to
/// `eccentric_ratio·concentric_level` around each concentric→eccentric reversal (and back),
/// and relaxes to rest within `relax_s` after the motion stops; relaxed cycles stay at rest.
/// Each channel has its own wobble phases and carrier (own RNG streams of `seed`). The knee is
/// extended ([`synthetic_emg_at_knee`] for a flexed one).
///
/// # Errors
/// Invalid settings or an empty trace.
pub fn synthetic_emg(
    trace: &ProtocolTrace,
    settings: &EmgSettings,
    seed: u64,
) -> Result<SyntheticEmg> {
    synthetic_emg_at_knee(trace, settings, seed, 0.0)
}

/// [`synthetic_emg`] with the knee flexed by `knee_angle_deg` (degrees) throughout: the
/// gastrocnemii's active levels are multiplied by [`gastrocnemius_drive_factor`]. At 0° the
/// result is [`synthetic_emg`]'s, bit for bit.
///
/// # Errors
/// As [`synthetic_emg`], and a knee angle outside [`KNEE_RANGE_DEG`].
pub fn synthetic_emg_at_knee(
    trace: &ProtocolTrace,
    settings: &EmgSettings,
    seed: u64,
    knee_angle_deg: f64,
) -> Result<SyntheticEmg> {
    settings.validate(trace.sample_rate_hz)?;
    let (lo, hi) = KNEE_RANGE_DEG;
    if !(knee_angle_deg.is_finite() && (lo..=hi).contains(&knee_angle_deg)) {
        return Err(ExperimentError::invalid(
            "knee angle",
            ErrorKind::InvalidSettings,
            format!("{knee_angle_deg}° is outside the knee's range [{lo}, {hi}] degrees"),
        ));
    }
    if trace.is_empty() {
        return Err(ExperimentError::invalid(
            "protocol trace",
            ErrorKind::TooShort,
            "no samples",
        ));
    }
    let triceps = Levels {
        rest: settings.rest_level,
        concentric: settings.concentric_level,
        eccentric: settings.concentric_level * settings.eccentric_ratio,
    };
    let f = gastrocnemius_drive_factor(knee_angle_deg);
    // never below rest: the drive stays in [rest, 1]
    let gastrocnemii = Levels {
        rest: settings.rest_level,
        concentric: (settings.concentric_level * f).max(settings.rest_level),
        eccentric: (settings.concentric_level * f * settings.eccentric_ratio)
            .max(settings.rest_level),
    };
    let ta = Levels {
        rest: settings.ta_rest_level,
        concentric: settings.ta_concentric_level,
        eccentric: settings.ta_eccentric_level,
    };
    let muscles: &[EmgMuscle] = if settings.include_ta {
        &EmgMuscle::ALL
    } else {
        &EmgMuscle::ALL[..3]
    };
    let channels = muscles
        .iter()
        .map(|&m| {
            let lv = match m {
                EmgMuscle::Ta => ta,
                EmgMuscle::Gm | EmgMuscle::Gl => gastrocnemii,
                EmgMuscle::Sol => triceps,
            };
            let d = drive(
                trace,
                lv,
                settings,
                &mut rng(seed, Stream::EmgWobble(m.index())),
            );
            let c = carrier(
                trace.len(),
                trace.sample_rate_hz,
                settings.band_hz,
                &mut rng(seed, Stream::EmgCarrier(m.index())),
            );
            let gain = settings.gains[m.index() as usize];
            let raw = d.iter().zip(&c).map(|(d, c)| gain * d * c).collect();
            EmgChannel {
                muscle: m,
                raw,
                drive: d,
                gain,
            }
        })
        .collect();
    Ok(SyntheticEmg { channels })
}
