//! EMG signal chain (EMG to envelope, `docs/model.md` section 1): Butterworth filters as second-order sections, causal and
//! zero-phase filtering, rectification and normalised envelopes — all reproducing
//! `scipy.signal` (1.17) to rounding error.
//!
//! # Filter design ([`butter`])
//!
//! Exactly scipy's `butter(N, Wn, btype, fs=fs, output='sos')` chain:
//!
//! 1. **Analog prototype** (`buttap`): no zeros, gain 1, poles on the unit circle
//!    `p_m = −exp(iπm / (2N))`, `m = −N+1, −N+3, …, N−1`.
//! 2. **Prewarp**: with the normalised edge `W = f / (fs/2)` and scipy's internal
//!    sampling rate 2, the analog edge is `ω = 2·2·tan(π W / 2)`, so that the digital
//!    filter's −3 dB point lands exactly on `f`.
//! 3. **Frequency transform** of zeros/poles/gain: low-pass `s → s/ω`
//!    (`p ← ω p`, `k ← k ω^N`); high-pass `s → ω/s` (`p ← ω/p`, zeros at 0);
//!    band-pass `s → (s² + ω₀²)/(s·B)` with `ω₀ = √(ω₁ω₂)`, `B = ω₂ − ω₁`, each pole
//!    giving `pB/2 ± √((pB/2)² − ω₀²)` (so the order doubles), `N` zeros at 0, `k ← k Bᴺ`;
//!    band-stop analogously with `s → s·B/(s² + ω₀²)`.
//! 4. **Bilinear transform** `s = 2f_s (z − 1)/(z + 1)`, i.e. `z = (2f_s + s)/(2f_s − s)`
//!    with `f_s = 2`: every root maps by that formula, zeros at infinity go to `z = −1`,
//!    `k ← k · Re(∏(2f_s − z_i) / ∏(2f_s − p_i))`.
//! 5. **Second-order sections** (`zpk2sos`, pairing `'nearest'`): pad with roots at 0 to an
//!    even count; repeatedly take the remaining pole closest to the unit circle (with its
//!    conjugate, or the next-worst real pole), pair it with the nearest zero(s), and fill
//!    sections from the last one backwards; the overall gain multiplies the first row.
//!
//! A section is `H_s(z) = (b0 + b1 z⁻¹ + b2 z⁻²)/(1 + a1 z⁻¹ + a2 z⁻²)`, stored as the row
//! `[b0, b1, b2, a0 = 1, a1, a2]` of [`Sos`]; the filter is `H(z) = ∏_s H_s(z)`.
//!
//! # Filtering
//!
//! [`sosfilt`] runs each section in transposed direct form II,
//! `y = b0 x + z0`, `z0 ← b1 x − a1 y + z1`, `z1 ← b2 x − a2 y`, feeding each section's
//! output into the next. [`sosfilt_zi`] gives the state of the unit-step steady state
//! (`(I − Aᵀ) zi = b[1:] − a[1:] b0` per section, scaled by the DC gain `H_{<s}(1)` of
//! the preceding sections).
//!
//! [`sosfiltfilt`] is zero-phase (magnitude `|H|²`, no delay), as scipy's default:
//! with `n_s` sections the pad length is
//! `padlen = 3·(2 n_s + 1 − min(#{b2 = 0}, #{a2 = 0}))` and the input must have
//! `len(x) > padlen`. The signal is extended at both ends by **odd reflection**,
//! `x[−i] = 2x[0] − x[i]` and `x[n−1+i] = 2x[n−1] − x[n−1−i]` for `i = 1..=padlen`;
//! the extension is filtered forward from state `zi · ext[0]`, then backward from
//! `zi · y[last]`, and the padding is cut off.
//!
//! # EMG envelope ([`envelope()`], [`normalise`])
//!
//! Raw EMG → band-pass `butter(2, [10, 350])` zero-phase → full-wave rectification `|x|`
//! → low-pass `butter(4, 2 Hz)` zero-phase → divide by the trial maximum (or a user MVC
//! value) → clamp to `[0, 1]`. [`EnvelopeSettings::default`] holds these settings.
//!
//! # Fidelity to scipy
//!
//! Every step uses numpy's operation order, including its vectorised complex `abs`
//! (`l·√(fma(s/l, s/l, 1))`) and complex multiply (fused multiply-add), glibc's `csqrt`
//! and numpy's Smith division, because `zpk2sos` breaks ties between poles of equal
//! magnitude on the last bit. Over 3000 random designs (orders 1–16, all four band types,
//! 30 % of them band edges symmetric about `fs/4`, where such ties occur) the sections
//! equal scipy 1.17.1's to ≤ 1e-15 relative, except 3 symmetric band designs in which
//! numpy's own `tan` (not the correctly rounded libm one; numpy's result depends on the
//! CPU's SIMD level) moved a pole by one ulp and flipped a tie: those come out as the
//! same sections in a different order, i.e. the same filter.
//!
//! # Example
//!
//! ```
//! use signal::{butter, envelope, normalise, sosfiltfilt, Band, EnvelopeSettings, Normalisation};
//!
//! let fs = 2048.0;
//! // A 4th-order 2 Hz low-pass has unit gain at DC: a constant passes unchanged.
//! let lp = butter(4, Band::Lowpass(2.0), fs)?;
//! assert_eq!(lp.len(), 2);
//! let y = sosfiltfilt(&lp, &vec![3.0; 500])?;
//! assert!(y.iter().all(|v| (v - 3.0).abs() < 1e-9));
//!
//! // Envelope of a 100 Hz burst whose amplitude grows linearly over 2 s.
//! let raw: Vec<f64> = (0..4096)
//!     .map(|i| {
//!         let t = i as f64 / fs;
//!         (0.1 + t) * (2.0 * std::f64::consts::PI * 100.0 * t).sin()
//!     })
//!     .collect();
//! let mut env = envelope(&raw, fs, &EnvelopeSettings::default())?;
//! normalise(&mut env, Normalisation::TrialMax)?;
//! assert!(env.iter().all(|v| (0.0..=1.0).contains(v)));
//! assert!(env[3000] > env[1000]);
//! # Ok::<(), signal::SignalError>(())
//! ```

mod complex;
pub mod crosstalk;
pub mod design;
pub mod envelope;
pub mod error;
pub mod filter;

pub use crosstalk::{crosstalk, CrosstalkEstimate};
pub use design::{butter, Band, Sos};
pub use envelope::{
    envelope, normalise, normalised_envelope, rectify, EnvelopeFilter, EnvelopeSettings,
    Normalisation,
};
pub use error::SignalError;
pub use filter::{
    sosfilt, sosfilt_inplace, sosfilt_into, sosfilt_zi, sosfiltfilt, sosfiltfilt_inplace,
    sosfiltfilt_into, sosfiltfilt_padlen,
};
