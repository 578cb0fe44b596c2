//! The EMG checks: flat channels and power-line interference.
//!
//! **Flat**: fewer than **8** distinct finite values (constant, or toggling over a few ADC
//! codes: an electrode or amplifier that records nothing).
//!
//! **Power-line interference** from a Welch periodogram: segments of `L` samples, `L` the
//! power of two reaching `fs·1 s` (bins `Δf = fs/L ≤ 1 Hz`; a shorter trial uses the largest
//! power of two that fits, and no ratio is computed with `Δf > 2.5 Hz`), 50 % overlap,
//! periodic Hann window, mean removed per segment; segments holding a non-finite sample are
//! skipped. With `P_k` the averaged `|X_k|²` and `f_k = k·Δf`, the EMG (envelope) band is
//! `B = {k : 10 ≤ f_k ≤ 350 Hz}` (the upper edge capped at `fs/2`), and for mains frequency
//! `f₀ ∈ {50, 60}` the line bands are `{k ∈ B : |f_k − h·f₀| ≤ max(1 Hz, Δf), h = 1, 2, 3}`.
//! The ratio
//!
//! `ρ(f₀) = Σ_{line bands of f₀} P_k / Σ_{B} P_k`
//!
//! is the share of the envelope band's power in the mains bands; the check reports the larger
//! of `ρ(50)`, `ρ(60)` and its `f₀`. Broadband EMG puts about 9 of 341 one-hertz bins, i.e.
//! **≈ 3 %**, of its power there; the warning is above **0.3** (30 %), where the mains
//! amplitude is comparable to the EMG's and biases the envelope, most visibly at rest.
//! (A Hann-windowed tone spreads over its bin and the two neighbours, all within ±1 Hz of a
//! bin-centred tone, so a pure tone scores ≈ 100 %.) The transform is a small radix-2 FFT of
//! this module. A sampling rate below `2·350 Hz` is a warning (the band is cut at `fs/2`).

use serde::Serialize;

use super::settings::CheckSettings;

#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct EmgCheck {
    /// Column name (`emg_sol`, …).
    pub channel: String,
    /// Number of samples.
    pub samples: usize,
    /// Number of non-finite samples.
    pub non_finite: usize,
    /// Standard deviation of the finite samples.
    pub sd: Option<f64>,
    /// Number of distinct finite values.
    pub distinct_values: usize,
    /// Fewer than `flat_min_distinct` distinct values.
    pub flat: bool,
    /// Share of the EMG band's power in the mains bands of `power_line_hz` (`null` when flat,
    /// too short or without a sampling rate).
    pub power_line_ratio: Option<f64>,
    /// The mains frequency (50 or 60 Hz) with the larger share.
    pub power_line_hz: Option<f64>,
    /// `power_line_ratio` above the threshold.
    pub power_line: bool,
}

pub(super) fn emg_check(
    name: &str,
    x: &[f64],
    welch: Option<&Welch>,
    s: &CheckSettings,
) -> EmgCheck {
    let finite: Vec<f64> = x.iter().copied().filter(|v| v.is_finite()).collect();
    let non_finite = x.len() - finite.len();
    let sd = (!finite.is_empty()).then(|| {
        let m = finite.iter().sum::<f64>() / finite.len() as f64;
        (finite.iter().map(|v| (v - m).powi(2)).sum::<f64>() / finite.len() as f64).sqrt()
    });
    let mut sorted = finite;
    sorted.sort_by(f64::total_cmp);
    sorted.dedup();
    let distinct = sorted.len();
    let flat = distinct < s.flat_min_distinct.max(1) || sd.is_some_and(|v| v == 0.0);
    let mut out = EmgCheck {
        channel: name.to_string(),
        samples: x.len(),
        non_finite,
        sd,
        distinct_values: distinct,
        flat,
        power_line_ratio: None,
        power_line_hz: None,
        power_line: false,
    };
    if flat {
        return out;
    }
    if let Some((ratio, hz)) = welch.and_then(|w| w.power_line(x, s)) {
        out.power_line_ratio = Some(ratio);
        out.power_line_hz = Some(hz);
        out.power_line = ratio > s.power_line_max_ratio;
    }
    out
}

/// A Welch periodogram of one segment length, with its window and FFT twiddles.
pub(super) struct Welch {
    fs: f64,
    len: usize,
    window: Vec<f64>,
}

impl Welch {
    /// The segment length for `n` samples at `fs` (module documentation), or `None` when the
    /// resolution would exceed the limit.
    pub(super) fn new(fs: f64, n: usize, s: &CheckSettings) -> Option<Self> {
        let want = (fs * s.welch_segment_s).ceil();
        if !(want.is_finite() && want >= 2.0) || n < 2 {
            return None;
        }
        let want = (want as usize).min(1 << 20).next_power_of_two();
        let fit = if n >= want {
            want
        } else {
            // The largest power of two not above n.
            1usize << (usize::BITS - 1 - n.leading_zeros())
        };
        if fit < 4 || fs / fit as f64 > s.welch_max_resolution_hz {
            return None;
        }
        let tau = 2.0 * std::f64::consts::PI;
        let window = (0..fit)
            .map(|j| 0.5 - 0.5 * (tau * j as f64 / fit as f64).cos())
            .collect();
        Some(Self {
            fs,
            len: fit,
            window,
        })
    }

    /// Averaged `|X_k|²`, `k = 0..=len/2`, over the finite 50 %-overlapping segments.
    fn psd(&self, x: &[f64]) -> Option<Vec<f64>> {
        let l = self.len;
        let mut acc = vec![0.0; l / 2 + 1];
        let mut segments = 0usize;
        let (mut re, mut im) = (vec![0.0; l], vec![0.0; l]);
        let hop = (l / 2).max(1);
        let mut start = 0;
        while start + l <= x.len() {
            let seg = &x[start..start + l];
            start += hop;
            if seg.iter().any(|v| !v.is_finite()) {
                continue;
            }
            let mean = seg.iter().sum::<f64>() / l as f64;
            for j in 0..l {
                re[j] = (seg[j] - mean) * self.window[j];
                im[j] = 0.0;
            }
            numerics::fft::fft_in_place(&mut re, &mut im, false);
            for (k, a) in acc.iter_mut().enumerate() {
                *a += re[k] * re[k] + im[k] * im[k];
            }
            segments += 1;
        }
        (segments > 0).then_some(acc)
    }

    /// `(ρ, f₀)`: the larger share of the EMG band's power in the mains bands, and its `f₀`.
    fn power_line(&self, x: &[f64], s: &CheckSettings) -> Option<(f64, f64)> {
        let p = self.psd(x)?;
        let df = self.fs / self.len as f64;
        let lo = s.emg_band_hz[0];
        let hi = s.emg_band_hz[1].min(0.5 * self.fs);
        let half = s.power_line_half_width_hz.max(df);
        let mut band = 0.0;
        let mut line = [0.0f64; 2];
        let mains = [50.0, 60.0];
        for (k, pk) in p.iter().enumerate() {
            let f = k as f64 * df;
            if f < lo || f > hi {
                continue;
            }
            band += pk;
            for (m, f0) in mains.iter().enumerate() {
                if (1..=s.power_line_harmonics).any(|h| (f - h as f64 * f0).abs() <= half) {
                    line[m] += pk;
                }
            }
        }
        if !(band > 0.0 && band.is_finite()) {
            return None;
        }
        let (m, &best) = line.iter().enumerate().max_by(|a, b| a.1.total_cmp(b.1))?;
        Some((best / band, mains[m]))
    }
}
