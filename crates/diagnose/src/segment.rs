//! Segmentation of a recording into holds and sweeps, cycles, relaxed/active cycles and motion events.
//!
//! The velocity `v` (central differences of the angle) gives the moving samples
//! (`|v| > 2 %` of the cruise speed, the median `|v|` while moving); runs of equal sign are
//! sweeps (negative = concentric for the plantarflexors, positive = eccentric); stationary runs
//! shorter than 40 ms inside the motion (the reversals) are merged into the sweeps. The low
//! threshold labels every sample that moves at all. The event times (starts, reversals,
//! stops) are `experiment::detect_events`'s, the same the dynamometer correction is placed at
//! (`docs/dynamometer.md`).

use serde::Serialize;

/// What the dynamometer and the subject are doing at a sample.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum PhaseLabel {
    /// Not moving.
    Hold,
    /// A sweep of a relaxed cycle (EMG at rest).
    Relaxed,
    /// A concentric sweep (towards plantarflexion) of an active cycle.
    Concentric,
    /// An eccentric sweep (towards dorsiflexion) of an active cycle.
    Eccentric,
}

impl PhaseLabel {
    /// All labels in display order.
    pub const ALL: [PhaseLabel; 4] = [
        PhaseLabel::Hold,
        PhaseLabel::Relaxed,
        PhaseLabel::Concentric,
        PhaseLabel::Eccentric,
    ];
    /// Short name.
    pub fn name(self) -> &'static str {
        match self {
            PhaseLabel::Hold => "hold",
            PhaseLabel::Relaxed => "relaxed",
            PhaseLabel::Concentric => "concentric",
            PhaseLabel::Eccentric => "eccentric",
        }
    }
}

/// One cycle: a concentric sweep and the eccentric sweep that follows it.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
#[non_exhaustive]
pub struct CycleInfo {
    /// First sample (inclusive).
    pub start: usize,
    /// Last sample (exclusive).
    pub end: usize,
    /// Whether the EMG stays at rest level in this cycle.
    pub relaxed: bool,
    /// Mean normalised plantarflexor envelope over the cycle (0 when unknown).
    pub mean_envelope: f64,
}

/// The segmentation of one recording.
#[derive(Clone, Debug, PartialEq, Serialize)]
#[non_exhaustive]
pub struct Segmentation {
    /// Label per sample.
    pub phase: Vec<PhaseLabel>,
    /// Cycle index per sample (`None` for holds).
    pub cycle: Vec<Option<usize>>,
    /// The cycles in time order.
    pub cycles: Vec<CycleInfo>,
    /// Event times (s, from the first sample's time 0): starts, reversals and stops, sorted.
    pub events: Vec<f64>,
    /// Cruise speed (rad/s).
    pub cruise_speed: f64,
}

impl Segmentation {
    /// Segments a recording from its angle (any unit; only its shape matters) sampled at `fs`,
    /// and optionally the mean plantarflexor envelope per sample (to tell relaxed cycles).
    ///
    /// # Errors
    /// No motion found, or fewer than 16 samples (`reason` says which).
    pub fn new(angle: &[f64], fs: f64, envelope: Option<&[f64]>) -> Result<Self, String> {
        let n = angle.len();
        if n < 8 {
            return Err(format!("{n} samples: too short"));
        }
        let mut v = vec![0.0; n];
        for i in 0..n {
            let (a, b) = (i.saturating_sub(1), (i + 1).min(n - 1));
            v[i] = (angle[b] - angle[a]) * fs / (b - a) as f64;
        }
        let mut speeds: Vec<f64> = v.iter().map(|x| x.abs()).collect();
        speeds.sort_by(f64::total_cmp);
        let vmax = speeds[n - 1];
        if vmax.is_nan() || vmax <= 0.0 {
            return Err("the angle never changes: no sweep".into());
        }
        let moving_speeds: Vec<f64> = speeds.iter().copied().filter(|s| *s > 0.1 * vmax).collect();
        let cruise = moving_speeds[moving_speeds.len() / 2];
        let thr = 0.02 * cruise;
        // sign per sample: -1 concentric, +1 eccentric, 0 hold
        let mut sign: Vec<i8> = v
            .iter()
            .map(|x| {
                if *x > thr {
                    1
                } else if *x < -thr {
                    -1
                } else {
                    0
                }
            })
            .collect();
        // merge short stationary runs between two moving runs (reversals)
        let short = (0.04 * fs).ceil() as usize;
        let mut i = 0;
        while i < n {
            if sign[i] == 0 {
                let s = i;
                while i < n && sign[i] == 0 {
                    i += 1;
                }
                if s > 0 && i < n && i - s <= short {
                    let (l, r) = (sign[s - 1], sign[i]);
                    let mid = (s + i) / 2;
                    for (k, x) in sign.iter_mut().enumerate().take(i).skip(s) {
                        *x = if k < mid { l } else { r };
                    }
                }
            } else {
                i += 1;
            }
        }
        // sweeps -> cycles
        let mut phase = vec![PhaseLabel::Hold; n];
        let mut cycle = vec![None; n];
        let mut cycles: Vec<CycleInfo> = Vec::new();
        let mut i = 0;
        let mut last_sweep = 0i8;
        while i < n {
            let s = sign[i];
            let st = i;
            while i < n && sign[i] == s {
                i += 1;
            }
            if s == 0 {
                continue;
            }
            if s < 0 || last_sweep != -1 || cycles.is_empty() {
                cycles.push(CycleInfo {
                    start: st,
                    end: i,
                    relaxed: false,
                    mean_envelope: 0.0,
                });
            } else if let Some(c) = cycles.last_mut() {
                c.end = i;
            }
            let ci = cycles.len() - 1;
            let label = if s < 0 {
                PhaseLabel::Concentric
            } else {
                PhaseLabel::Eccentric
            };
            for k in st..i {
                phase[k] = label;
                cycle[k] = Some(ci);
            }
            last_sweep = s;
        }
        if cycles.is_empty() {
            return Err("no sweep found".into());
        }
        if let Some(env) = envelope {
            for c in &mut cycles {
                let m = env[c.start..c.end].iter().sum::<f64>() / (c.end - c.start) as f64;
                c.mean_envelope = m;
            }
            let top = cycles.iter().map(|c| c.mean_envelope).fold(0.0, f64::max);
            for c in &mut cycles {
                c.relaxed = c.mean_envelope < 0.3 * top;
            }
            for (k, c) in cycles.iter().enumerate() {
                if c.relaxed {
                    for (p, cy) in phase[c.start..c.end].iter_mut().zip(&cycle[c.start..c.end]) {
                        if *cy == Some(k) {
                            *p = PhaseLabel::Relaxed;
                        }
                    }
                }
            }
        }
        let times: Vec<f64> = (0..n).map(|i| i as f64 / fs).collect();
        let events = experiment::detect_events(&times, angle)
            .map_err(|e| e.to_string())?
            .all();
        Ok(Segmentation {
            phase,
            cycle,
            cycles,
            events,
            cruise_speed: cruise,
        })
    }

    /// The segmentation of `n` samples of a recording without joint motion: one hold, no
    /// cycle, no event.
    pub fn still(n: usize) -> Self {
        Segmentation {
            phase: vec![PhaseLabel::Hold; n],
            cycle: vec![None; n],
            cycles: Vec::new(),
            events: Vec::new(),
            cruise_speed: 0.0,
        }
    }

    /// Indices of the active (not relaxed) cycles.
    pub fn active_cycles(&self) -> Vec<usize> {
        (0..self.cycles.len())
            .filter(|&k| !self.cycles[k].relaxed)
            .collect()
    }
}
