//! The grid the fast formulation tabulates a trial's activation and musculotendon length on
//! ([`TableGrid`]): the samples, or in a low-rate trial `m` points per sample interval.
//!
//! The integrator reads the tables between their points by cubic Hermite interpolation from
//! values and rates. On a 2048 Hz trial the samples are close enough for that (the points are
//! 0.5 ms apart, the curves change over tens of milliseconds). At 100 Hz the cubic between two
//! samples 10 ms apart would stand in for an activation that rises with a 15 ms time constant,
//! so a low-rate trial's tables are computed at `m = ⌈TABLE_RATE_HZ / fs⌉` points per sample
//! interval (at `tⱼ = t₀ + j/(m·fs)`), from the trial's smooth interpolants of its inputs.

use crate::inputs::TrialInputs;

/// The lowest rate (Hz) of a low-rate trial's tables.
pub(crate) const TABLE_RATE_HZ: f64 = 400.0;

/// Points `tⱼ = t₀ + j/rate`, `j = 0 … len − 1`, every `per_sample`-th a sample.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct TableGrid {
    pub(crate) t0: f64,
    /// Points per second.
    pub(crate) rate: f64,
    pub(crate) len: usize,
    /// Points per sample interval (1: the samples themselves).
    pub(crate) per_sample: usize,
}

impl TableGrid {
    /// The grid of `inputs`: its samples, or `m` points per sample interval in a low-rate
    /// trial. With `m = 1` every point and rate is computed exactly as the trial's own
    /// (`t₀ + i/fs`), so a trial's tables on its samples are the same bits either way.
    pub(crate) fn of(inputs: &TrialInputs) -> Self {
        let n = inputs.len();
        let m = if inputs.is_low_rate() {
            points_per_sample(inputs.fs())
        } else {
            1
        };
        TableGrid {
            t0: inputs.t0(),
            rate: if m == 1 {
                inputs.fs()
            } else {
                inputs.fs() * m as f64
            },
            len: (n - 1) * m + 1,
            per_sample: m,
        }
    }

    /// `tⱼ`.
    #[inline]
    pub(crate) fn time(&self, j: usize) -> f64 {
        self.t0 + j as f64 / self.rate
    }

    /// A quantity tabulated on the grid as values `v` and time derivatives `dv`, at time `t`
    /// (cubic Hermite; the first or last value outside the grid). On the samples' grid this is
    /// [`TrialInputs::hermite_at`] operation for operation.
    #[inline]
    pub(crate) fn hermite_at(&self, v: &[f64], dv: &[f64], t: f64) -> f64 {
        let n = self.len;
        let x = ((t - self.t0) * self.rate).clamp(0.0, (n - 1) as f64);
        let i = (x as usize).min(n - 2);
        let s = x - i as f64;
        crate::interp::hermite_dt(v[i], dv[i], v[i + 1], dv[i + 1], s, 1.0 / self.rate)
    }
}

/// `⌈TABLE_RATE_HZ / fs⌉`.
fn points_per_sample(fs: f64) -> usize {
    ((TABLE_RATE_HZ / fs).ceil() as usize).max(1)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::synthetic::{gait_like_trial, seed_like_trial};

    #[test]
    fn a_high_rate_trials_grid_is_its_samples_to_the_bit() {
        let tr = seed_like_trial(2048.0).unwrap();
        let g = TableGrid::of(&tr);
        assert_eq!((g.per_sample, g.len, g.rate), (1, tr.len(), tr.fs()));
        for (j, &t) in tr.times().iter().enumerate() {
            assert_eq!(g.time(j).to_bits(), t.to_bits());
        }
        // the grid's Hermite reading is the trial's, operation for operation
        let (v, dv) = (tr.angle(), tr.velocity());
        for k in 0..997 {
            let t = -0.01 + k as f64 * 3.4e-3;
            assert_eq!(
                g.hermite_at(v, dv, t).to_bits(),
                tr.hermite_at(v, dv, t).to_bits()
            );
        }
    }

    #[test]
    fn a_low_rate_trials_grid_has_at_least_400_points_per_second() {
        for (fs, m) in [(100.0, 4), (120.0, 4), (250.0, 2), (499.0, 1)] {
            let tr = gait_like_trial(fs, 2.0).unwrap();
            let g = TableGrid::of(&tr);
            assert_eq!(g.per_sample, m, "fs {fs}");
            assert_eq!(g.len, (tr.len() - 1) * m + 1);
            // every m-th point is a sample (to rounding) and the last one the last sample
            for (i, &t) in tr.times().iter().enumerate() {
                assert!((g.time(i * m) - t).abs() < 1e-12, "fs {fs} sample {i}");
            }
        }
    }
}
