//! The thresholds of every check, with the documented values as `Default` (the parent
//! module's documentation gives the reason for each).

use serde::{Deserialize, Serialize};

/// The thresholds of the checks (module documentation); `Default` holds the documented values.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct CheckSettings {
    /// Smallest plausible angle range of a sweep in degrees (5°).
    pub angle_min_range_deg: f64,
    /// Largest plausible |angle| in degrees from neutral (60°).
    pub angle_max_abs_deg: f64,
    /// Width of the centred least-squares window of the velocity, in seconds (0.05 s).
    pub velocity_window_s: f64,
    /// Speeds at or below this never count as moving, °/s (2 °/s).
    pub min_moving_speed_deg_s: f64,
    /// Moving threshold as a fraction of the 99th percentile of |velocity| (0.2).
    pub moving_fraction_of_peak: f64,
    /// Relative half-width of a plateau around its velocity (0.10 = ±10 %).
    pub plateau_tolerance: f64,
    /// Smallest half-width of a plateau in °/s (1 °/s), for slow tests.
    pub plateau_tolerance_min_deg_s: f64,
    /// Least on-plateau time for a sweep to have a plateau, in seconds (0.05 s).
    pub min_plateau_s: f64,
    /// Least share of the moving time on a plateau for an isokinetic test (0.6).
    pub min_plateau_fraction: f64,
    /// Least length of a run at the extreme value that counts as clipping, in samples (3).
    pub clip_min_run: usize,
    /// Largest share of samples in clipping runs on one side before the warning (0.005).
    pub clip_max_fraction: f64,
    /// Least ratio of samples at the extreme level to those at the next level inward (3).
    pub clip_min_level_ratio: f64,
    /// An EMG channel with fewer distinct finite values than this is flat (8).
    pub flat_min_distinct: usize,
    /// Length of a Welch segment in seconds; rounded up to a power of two of samples (1 s).
    pub welch_segment_s: f64,
    /// Largest usable frequency resolution of the periodogram, Hz (2.5 Hz).
    pub welch_max_resolution_hz: f64,
    /// The EMG (envelope) band, Hz ([10, 350]).
    pub emg_band_hz: [f64; 2],
    /// Half-width of each mains band, Hz (1 Hz; at least one bin).
    pub power_line_half_width_hz: f64,
    /// Harmonics of the mains frequency included (3: 50, 100, 150 Hz and 60, 120, 180 Hz).
    pub power_line_harmonics: usize,
    /// Largest share of the EMG band's power in the mains bands before the warning (0.3).
    pub power_line_max_ratio: f64,
    /// Correlation with the prediction below which the torque looks flipped (−0.3).
    pub flipped_max_correlation: f64,
    /// Fewest sweeps from which the angle can tell a gait trial from a dynamometer's (4).
    pub kind_min_sweeps: usize,
    /// A sweep spans the range when it covers this share of the angle's 1–99 % range (0.7).
    pub kind_sweep_span_fraction: f64,
    /// Below this share of spanning sweeps a trial without a ground force is gait (0.5).
    pub kind_min_spanning_share: f64,
    /// Stance while the vertical ground reaction force exceeds this, N (20 N).
    pub stance_threshold_n: f64,
    /// Fewest strides the per-stride comparison needs (5).
    pub stride_min_count: usize,
    /// Robust score above which a stride's measure is out of line (3.5).
    pub stride_outlier_z: f64,
    /// Least sd of stride and stance durations, as a share of their median (0.03).
    pub stride_time_floor: f64,
    /// Least sd of the peak vertical force, as a share of its median (0.05).
    pub peak_force_floor: f64,
    /// Least sd of the peak moment and of the moment per force, as a share of the median (0.08).
    pub peak_moment_floor: f64,
    /// Least sd of the moment in swing, as a share of the median peak moment (0.05).
    pub swing_moment_floor_of_peak: f64,
    /// Least sd of the largest moment and envelope jumps, as a share of their median (0.10).
    pub moment_jump_floor: f64,
    /// Percentile of the envelope and moment peaks compared across trials (0.95).
    pub envelope_scale_percentile: f64,
    /// Largest factor between trials' envelope per moment before the warning (3).
    pub envelope_scale_max_factor: f64,
}

impl Default for CheckSettings {
    fn default() -> Self {
        Self {
            angle_min_range_deg: 5.0,
            angle_max_abs_deg: 60.0,
            velocity_window_s: 0.05,
            min_moving_speed_deg_s: 2.0,
            moving_fraction_of_peak: 0.2,
            plateau_tolerance: 0.10,
            plateau_tolerance_min_deg_s: 1.0,
            min_plateau_s: 0.05,
            min_plateau_fraction: 0.6,
            clip_min_run: 3,
            clip_max_fraction: 0.005,
            clip_min_level_ratio: 3.0,
            flat_min_distinct: 8,
            welch_segment_s: 1.0,
            welch_max_resolution_hz: 2.5,
            emg_band_hz: [10.0, 350.0],
            power_line_half_width_hz: 1.0,
            power_line_harmonics: 3,
            power_line_max_ratio: 0.3,
            flipped_max_correlation: -0.3,
            kind_min_sweeps: 4,
            kind_sweep_span_fraction: 0.7,
            kind_min_spanning_share: 0.5,
            stance_threshold_n: experiment::STANCE_THRESHOLD_N,
            stride_min_count: 5,
            stride_outlier_z: 3.5,
            stride_time_floor: 0.03,
            peak_force_floor: 0.05,
            peak_moment_floor: 0.08,
            swing_moment_floor_of_peak: 0.05,
            moment_jump_floor: 0.10,
            envelope_scale_percentile: 0.95,
            envelope_scale_max_factor: 3.0,
        }
    }
}
