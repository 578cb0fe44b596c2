//! Crosstalk of one EMG channel into another, measured on their raw signals.
//!
//! A surface electrode over muscle A picks up its own motor units' action potentials, `s_A`,
//! and, when it sits near muscle B, a share `f` of B's signal:
//!
//! ```text
//! x_A(t) = s_A(t) + f·x_B(t)
//! ```
//!
//! The carriers of two muscles are independent, so without crosstalk the band-passed raw
//! signals are uncorrelated at zero lag even when both muscles contract together (their
//! envelopes may rise and fall together; their carriers do not). Crosstalk correlates them,
//! and the share can be estimated by least squares. The precision comes from the blocks where
//! A's own signal is weak against B's (A at rest, B active), so the estimate is weighted: over
//! `J` consecutive blocks of `L` samples (`L` long against the carriers' correlation time of a
//! few milliseconds), with `S_j = Σ_{t∈j} x_A x_B`, `Q_j = Σ_{t∈j} x_B²` and the block's own
//! power `v_j = Σ_{t∈j} (x_A − f x_B)² / L`,
//!
//! ```text
//! f̂ = Σ_j S_j/v_j / Σ_j Q_j/v_j
//! ```
//!
//! starting from the unweighted share and updating `v_j` twice. Its standard error comes from
//! the block sums themselves, which stays valid whatever the envelopes do (amplitude
//! modulation, co-contraction, coloured carriers): with `B_j = (S_j − f̂ Q_j)/v_j`,
//!
//! ```text
//! se(f̂) = √(J/(J−1) · Σ_j B_j²) / Σ_j Q_j/v_j,     z = f̂ / se(f̂)
//! ```
//!
//! and `z` is standard normal under no crosstalk when there are many blocks. Subtracting
//! `f̂·x_B` from `x_A` (on the raw signal: the band-pass is linear) removes the share.
//!
//! Common-mode interference (mains hum, a shared reference's artefacts) also correlates two
//! channels; this statistic cannot tell it from crosstalk, so the signals should be
//! band-passed (and notch-filtered when the hum is strong) before it is computed.

use crate::SignalError;

/// The share of one channel's signal found in another ([`crosstalk`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CrosstalkEstimate {
    /// `f̂`: the weighted least-squares share of the source's signal in the target's.
    pub fraction: f64,
    /// Its standard error (block sums).
    pub fraction_se: f64,
    /// `f̂ / se`: standard normal under no crosstalk.
    pub z: f64,
    /// Number of blocks the standard error was estimated from.
    pub blocks: usize,
}

/// The share of `source` in `target` (both band-passed raw EMG on one grid) and its
/// standard error from blocks of `block_len` samples (module docs); a last partial block is
/// left out.
///
/// # Errors
/// Lengths that differ, a block length of 0, fewer than 10 blocks, a non-finite sample, or a
/// source that is zero over the blocks.
pub fn crosstalk(
    target: &[f64],
    source: &[f64],
    block_len: usize,
) -> Result<CrosstalkEstimate, SignalError> {
    if target.len() != source.len() {
        return Err(SignalError::LengthMismatch {
            what: "crosstalk source",
            expected: target.len(),
            got: source.len(),
        });
    }
    crate::error::check_finite(target)?;
    crate::error::check_finite(source)?;
    let blocks = target.len().checked_div(block_len).unwrap_or(0);
    if blocks < 10 {
        return Err(SignalError::TooFewBlocks {
            len: target.len(),
            block_len,
            min_blocks: 10,
        });
    }
    let n = blocks * block_len;
    // per block: Σ x_A x_B, Σ x_B², Σ x_A²
    let sums: Vec<[f64; 3]> = target[..n]
        .chunks_exact(block_len)
        .zip(source[..n].chunks_exact(block_len))
        .map(|(xa, xb)| {
            xa.iter().zip(xb).fold([0.0; 3], |[ab, bb, aa], (a, b)| {
                [ab + a * b, bb + b * b, aa + a * a]
            })
        })
        .collect();
    if sums.iter().all(|s| s[1] <= 0.0) {
        return Err(SignalError::ZeroSignal {
            what: "crosstalk source",
        });
    }
    // own-signal power of each block at share f: Σ(x_A − f x_B)² / L, floored at 10⁻⁶ of
    // the median so that a silent block cannot take all the weight
    let own = |f: f64| -> Vec<f64> {
        let mut v: Vec<f64> = sums
            .iter()
            .map(|[ab, bb, aa]| ((aa - 2.0 * f * ab + f * f * bb) / block_len as f64).max(0.0))
            .collect();
        // the power is smooth in time: averaging each block with its neighbours keeps the
        // weights from following the block's own noise
        let k = v.len();
        v = (0..k)
            .map(|j| {
                let (lo, hi) = (j.saturating_sub(1), (j + 1).min(k - 1));
                v[lo..=hi].iter().sum::<f64>() / (hi - lo + 1) as f64
            })
            .collect();
        let mut sorted = v.clone();
        sorted.sort_by(f64::total_cmp);
        let floor = 1e-6 * sorted[sorted.len() / 2];
        v.iter_mut()
            .for_each(|x| *x = x.max(floor).max(f64::MIN_POSITIVE));
        v
    };
    let weighted = |w: &[f64]| -> f64 {
        let (num, den) = sums
            .iter()
            .zip(w)
            .fold((0.0, 0.0), |(n, d), ([ab, bb, _], v)| {
                (n + ab / v, d + bb / v)
            });
        num / den
    };
    let mut fraction = weighted(&vec![1.0; blocks]);
    let mut w = own(fraction);
    for _ in 0..2 {
        fraction = weighted(&w);
        w = own(fraction);
    }
    let den: f64 = sums.iter().zip(&w).map(|([_, bb, _], v)| bb / v).sum();
    let ss: f64 = sums
        .iter()
        .zip(&w)
        .map(|([ab, bb, _], v)| {
            let b = (ab - fraction * bb) / v;
            b * b
        })
        .sum();
    let j = blocks as f64;
    let fraction_se = (j / (j - 1.0) * ss).sqrt() / den;
    Ok(CrosstalkEstimate {
        fraction,
        fraction_se,
        z: fraction / fraction_se,
        blocks,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A deterministic white-ish sequence (xorshift) in [-1, 1).
    fn noise(n: usize, mut state: u64) -> Vec<f64> {
        (0..n)
            .map(|_| {
                state ^= state << 13;
                state ^= state >> 7;
                state ^= state << 17;
                (state >> 11) as f64 / (1u64 << 52) as f64 - 1.0
            })
            .collect()
    }

    #[test]
    fn recovers_the_share_and_is_null_without_it() {
        let n = 40_000;
        let b = noise(n, 0x9e37_79b9_7f4a_7c15);
        // an amplitude-modulated own signal: co-varying envelopes must not look like crosstalk
        let own: Vec<f64> = noise(n, 0x1234_5678_9abc_def1)
            .iter()
            .enumerate()
            .map(|(i, v)| v * (1.0 + (i as f64 / 2000.0).sin().abs()))
            .collect();
        let mixed: Vec<f64> = own.iter().zip(&b).map(|(a, b)| a + 0.4 * b).collect();
        let e = crosstalk(&mixed, &b, 200).unwrap();
        assert!((e.fraction - 0.4).abs() < 4.0 * e.fraction_se, "{e:?}");
        assert!(e.z > 20.0, "{e:?}");
        assert_eq!(e.blocks, 200);
        let null = crosstalk(&own, &b, 200).unwrap();
        assert!(null.z.abs() < 4.0, "{null:?}");
        assert!(null.fraction.abs() < 0.05, "{null:?}");
    }

    #[test]
    fn refuses_what_it_cannot_estimate() {
        let b = noise(1000, 7);
        assert!(matches!(
            crosstalk(&b, &b[..999], 10),
            Err(SignalError::LengthMismatch { .. })
        ));
        assert!(matches!(
            crosstalk(&b, &b, 200),
            Err(SignalError::TooFewBlocks { .. })
        ));
        assert!(crosstalk(&b, &b, 0).is_err());
        assert!(matches!(
            crosstalk(&b, &vec![0.0; 1000], 10),
            Err(SignalError::ZeroSignal { .. })
        ));
    }
}
