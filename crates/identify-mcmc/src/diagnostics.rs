//! Convergence diagnostics: rank-normalised split R̂, bulk/tail ESS and friends.
//!
//! Every function takes one slice per chain (`&[&[f64]]`, all chains of the
//! same length) and reproduces R's `posterior` package (Vehtari et al. 2021)
//! to rounding error. The shared conventions:
//!
//! * **split**: each chain of length `n` becomes two chains of length
//!   `⌊n/2⌋`, the middle draw dropped when `n` is odd;
//! * **rank normalisation** (`z_scale`): pooled ranks `r` over all draws
//!   (average rank for ties), `z = Φ⁻¹((r − 3/8)/(S + 1/4))`, `S` the number of
//!   draws (Blom's fractional offset);
//! * **folding**: `|x − median(x)|` with the median over all draws;
//! * **quantiles**: R's default `quantile(type = 7)`.
//!
//! What is returned for degenerate input (documented deviations from R noted):
//! * any non-finite draw (NaN or ±∞) → NaN (posterior returns `NA` for NaN and
//!   ranks ±∞; here ±∞ gives NaN too, since a sampler never stores them);
//! * all draws equal (max − min < machine ε) → NaN (posterior: `NA`);
//! * chains of unequal length, no chains, or empty chains → NaN;
//! * ESS with fewer than 3 draws per (split) chain → NaN.

use numerics::special::normal_quantile;

/// `chains` as owned columns if they form a valid m × n matrix.
fn matrix(chains: &[&[f64]]) -> Option<Vec<Vec<f64>>> {
    let n = chains.first()?.len();
    if n == 0 || chains.iter().any(|c| c.len() != n) {
        return None;
    }
    Some(chains.iter().map(|c| c.to_vec()).collect())
}

/// Split every chain into its first and second halves (R's `.split_chains`).
fn split(m: &[Vec<f64>]) -> Vec<Vec<f64>> {
    let n = m[0].len();
    if n == 1 {
        return m.to_vec();
    }
    let half = n / 2;
    let mut out = Vec::with_capacity(2 * m.len());
    for c in m {
        out.push(c[..half].to_vec());
    }
    for c in m {
        out.push(c[n - half..].to_vec());
    }
    out
}

/// True when posterior would return `NA`: a non-finite value or a constant matrix.
fn degenerate(m: &[Vec<f64>]) -> bool {
    let mut lo = f64::INFINITY;
    let mut hi = f64::NEG_INFINITY;
    for &v in m.iter().flatten() {
        if !v.is_finite() {
            return true;
        }
        lo = lo.min(v);
        hi = hi.max(v);
    }
    (hi - lo).abs() < f64::EPSILON
}

fn mean(x: &[f64]) -> f64 {
    x.iter().sum::<f64>() / x.len() as f64
}

/// Sample variance with denominator `n − 1` (NaN for `n < 2`).
fn var(x: &[f64]) -> f64 {
    if x.len() < 2 {
        return f64::NAN;
    }
    let m = mean(x);
    x.iter().map(|v| (v - m) * (v - m)).sum::<f64>() / (x.len() - 1) as f64
}

/// Ranks of `x` (1-based), ties given their average rank (R's `rank(ties = "average")`).
///
/// `x` must be free of NaN.
pub fn ranks(x: &[f64]) -> Vec<f64> {
    let mut idx: Vec<usize> = (0..x.len()).collect();
    idx.sort_by(|&a, &b| x[a].total_cmp(&x[b]));
    let mut r = vec![0.0; x.len()];
    let mut i = 0;
    while i < idx.len() {
        let mut j = i;
        while j + 1 < idx.len() && x[idx[j + 1]] == x[idx[i]] {
            j += 1;
        }
        let avg = (i + j) as f64 / 2.0 + 1.0;
        for &k in &idx[i..=j] {
            r[k] = avg;
        }
        i = j + 1;
    }
    r
}

/// Rank-normalise pooled draws: `Φ⁻¹((r − 3/8)/(S + 1/4))`, shape kept.
fn z_scale(m: &[Vec<f64>]) -> Vec<Vec<f64>> {
    let flat: Vec<f64> = m.iter().flatten().copied().collect();
    let s = flat.len() as f64;
    let r = ranks(&flat);
    let n = m[0].len();
    r.chunks(n)
        .map(|c| {
            c.iter()
                .map(|&ri| normal_quantile((ri - 0.375) / (s + 0.25)))
                .collect()
        })
        .collect()
}

/// Quantile of `x` by R's default definition (`type = 7`):
/// `h = 1 + (n − 1)p`, linear interpolation between the order statistics
/// `x₍⌊h⌋₎` and `x₍⌈h⌉₎`. NaN for empty input, `p` outside `[0, 1]` or NaN in `x`.
///
/// ```
/// use identify_mcmc::diagnostics::quantile7;
/// assert_eq!(quantile7(&[4.0, 1.0, 3.0, 2.0], 0.5), 2.5);
/// assert!((quantile7(&[1.0, 2.0, 3.0, 4.0, 5.0], 0.05) - 1.2).abs() < 1e-15);
/// ```
pub fn quantile7(x: &[f64], p: f64) -> f64 {
    if x.is_empty() || !(0.0..=1.0).contains(&p) || x.iter().any(|v| v.is_nan()) {
        return f64::NAN;
    }
    let mut s = x.to_vec();
    s.sort_by(f64::total_cmp);
    quantile7_sorted(&s, p)
}

fn quantile7_sorted(s: &[f64], p: f64) -> f64 {
    let index = 1.0 + (s.len() - 1) as f64 * p;
    let lo = index.floor();
    let hi = index.ceil();
    let qlo = s[lo as usize - 1];
    let qhi = s[hi as usize - 1];
    let h = index - lo;
    if index > lo && qhi != qlo {
        (1.0 - h) * qlo + h * qhi
    } else {
        qlo
    }
}

/// Median (average of the two middle order statistics for even length).
fn median(x: &[f64]) -> f64 {
    let mut s = x.to_vec();
    s.sort_by(f64::total_cmp);
    let n = s.len();
    if n % 2 == 1 {
        s[n / 2]
    } else {
        (s[n / 2 - 1] + s[n / 2]) / 2.0
    }
}

/// Classic Gelman–Rubin R̂ of the columns of `m` (R's `.rhat`).
fn rhat_core(m: &[Vec<f64>]) -> f64 {
    if degenerate(m) {
        return f64::NAN;
    }
    let n = m[0].len() as f64;
    let means: Vec<f64> = m.iter().map(|c| mean(c)).collect();
    let vars: Vec<f64> = m.iter().map(|c| var(c)).collect();
    let var_between = n * var(&means);
    let var_within = mean(&vars);
    ((var_between / var_within + n - 1.0) / n).sqrt()
}

/// Biased autocovariance of `x` at every lag `t = 0 … n−1`:
/// `γ̂_t = (1/n) Σ_{i<n−t} (x_i − x̄)(x_{i+t} − x̄)` (Geyer 1992), the estimator
/// of posterior's `autocovariance()`. Computed by a zero-padded FFT
/// (O(n log n)); agrees with the direct sum to rounding error.
///
/// ```
/// use identify_mcmc::diagnostics::autocovariance;
/// let g = autocovariance(&[1.0, 2.0, 3.0, 4.0]);
/// // x − x̄ = (−1.5, −0.5, 0.5, 1.5): γ̂₀ = 5/4, γ̂₃ = −2.25/4.
/// assert!((g[0] - 1.25).abs() < 1e-14 && (g[3] + 0.5625).abs() < 1e-14);
/// ```
pub fn autocovariance(x: &[f64]) -> Vec<f64> {
    let n = x.len();
    if n == 0 {
        return Vec::new();
    }
    let m = mean(x);
    let size = (2 * n).next_power_of_two();
    let mut re = vec![0.0; size];
    let mut im = vec![0.0; size];
    for (r, v) in re.iter_mut().zip(x) {
        *r = v - m;
    }
    numerics::fft::fft_in_place(&mut re, &mut im, false);
    for (r, i) in re.iter_mut().zip(im.iter_mut()) {
        *r = *r * *r + *i * *i;
        *i = 0.0;
    }
    numerics::fft::fft_in_place(&mut re, &mut im, true);
    let scale = 1.0 / (size as f64 * n as f64);
    re.truncate(n);
    for r in &mut re {
        *r *= scale;
    }
    re
}

/// Effective sample size of the columns of `m` (R's `.ess`): Geyer's initial
/// positive then monotone sequence on the multi-chain autocorrelation, the
/// "improved" antithetic-safe truncation, and `τ̂ ≥ 1/log₁₀(mn)`.
fn ess_core(m: &[Vec<f64>]) -> f64 {
    let chains = m.len();
    let n = m[0].len();
    if n < 3 || degenerate(m) {
        return f64::NAN;
    }
    let acov: Vec<Vec<f64>> = m.iter().map(|c| autocovariance(c)).collect();
    let acov_mean = |t: usize| acov.iter().map(|a| a[t]).sum::<f64>() / chains as f64;
    let nf = n as f64;
    let mean_var = acov_mean(0) * nf / (nf - 1.0);
    let mut var_plus = mean_var * (nf - 1.0) / nf;
    if chains > 1 {
        let means: Vec<f64> = m.iter().map(|c| mean(c)).collect();
        var_plus += var(&means);
    }
    let rho = |t: usize| 1.0 - (mean_var - acov_mean(t)) / var_plus;

    // Geyer's initial positive sequence.
    let mut rho_hat = vec![0.0; n];
    let mut t = 0usize;
    let mut rho_even = 1.0;
    rho_hat[0] = rho_even;
    let mut rho_odd = rho(1);
    rho_hat[1] = rho_odd;
    while (t as isize) < n as isize - 5
        && !(rho_even + rho_odd).is_nan()
        && rho_even + rho_odd > 0.0
    {
        t += 2;
        rho_even = rho(t);
        rho_odd = rho(t + 1);
        if rho_even + rho_odd >= 0.0 {
            rho_hat[t] = rho_even;
            rho_hat[t + 1] = rho_odd;
        }
    }
    let max_t = t;
    if rho_even > 0.0 {
        rho_hat[max_t] = rho_even;
    }
    // Geyer's initial monotone sequence.
    let mut t = 0usize;
    while (t as isize) <= max_t as isize - 4 {
        t += 2;
        if rho_hat[t] + rho_hat[t + 1] > rho_hat[t - 2] + rho_hat[t - 1] {
            rho_hat[t] = (rho_hat[t - 2] + rho_hat[t - 1]) / 2.0;
            rho_hat[t + 1] = rho_hat[t];
        }
    }
    let total = (chains * n) as f64;
    // R sums rho_hat[1:max_t]; for max_t = 0 that is rho_hat[c(1, 0)] = rho_hat[1].
    let head: f64 = if max_t == 0 {
        rho_hat[0]
    } else {
        rho_hat[..max_t].iter().sum()
    };
    let mut tau = -1.0 + 2.0 * head + rho_hat[max_t];
    let bound = 1.0 / total.log10();
    if tau < bound {
        tau = bound;
    }
    total / tau
}

/// R̂ of Vehtari et al. (2021): the larger of the rank-normalised split-R̂ and
/// the rank-normalised split-R̂ of the draws folded about their median
/// (`posterior::rhat`).
///
/// ```
/// use identify_mcmc::diagnostics::rhat;
/// let a: Vec<f64> = (0..200).map(|i| ((i * 37) % 101) as f64).collect();
/// let b: Vec<f64> = (0..200).map(|i| ((i * 53) % 103) as f64).collect();
/// let r = rhat(&[&a, &b]);
/// assert!(r > 0.99 && r < 1.05);
/// ```
pub fn rhat(chains: &[&[f64]]) -> f64 {
    let Some(m) = matrix(chains) else {
        return f64::NAN;
    };
    if degenerate(&m) {
        return f64::NAN;
    }
    let bulk = rhat_core(&z_scale(&split(&m)));
    let med = median(&m.iter().flatten().copied().collect::<Vec<_>>());
    let folded: Vec<Vec<f64>> = m
        .iter()
        .map(|c| c.iter().map(|v| (v - med).abs()).collect())
        .collect();
    let tail = rhat_core(&z_scale(&split(&folded)));
    if bulk.is_nan() || tail.is_nan() {
        f64::NAN
    } else {
        bulk.max(tail)
    }
}

/// Split-R̂ of the raw draws, no rank normalisation (`posterior::rhat_basic(x)`):
/// with `n` draws per split chain, chain means `x̄_j`, variances `s_j²`,
/// `B = n·var(x̄_j)`, `W = mean(s_j²)`, `R̂ = √((B/W + n − 1)/n)`.
pub fn rhat_basic(chains: &[&[f64]]) -> f64 {
    match matrix(chains) {
        Some(m) => rhat_core(&split(&m)),
        None => f64::NAN,
    }
}

/// Classic Gelman–Rubin R̂ on the unsplit raw chains
/// (`posterior::rhat_basic(x, split = FALSE)`); NaN for a single chain.
pub fn rhat_classic(chains: &[&[f64]]) -> f64 {
    match matrix(chains) {
        Some(m) => rhat_core(&m),
        None => f64::NAN,
    }
}

/// Bulk ESS: the ESS of the rank-normalised split chains (`posterior::ess_bulk`).
pub fn ess_bulk(chains: &[&[f64]]) -> f64 {
    match matrix(chains) {
        Some(m) if !degenerate(&m) => ess_core(&z_scale(&split(&m))),
        _ => f64::NAN,
    }
}

/// Tail ESS: the smaller of the ESS of the 5 % and 95 % quantile indicators
/// `I(x ≤ q₀.₀₅)`, `I(x ≤ q₀.₉₅)` on split chains (`posterior::ess_tail`).
pub fn ess_tail(chains: &[&[f64]]) -> f64 {
    let lo = ess_quantile(chains, 0.05);
    let hi = ess_quantile(chains, 0.95);
    if lo.is_nan() || hi.is_nan() {
        f64::NAN
    } else {
        lo.min(hi)
    }
}

/// ESS of the `prob` quantile: ESS of the split indicator `I(x ≤ q_prob)`,
/// with `q_prob` the type-7 quantile of all draws (`posterior::ess_quantile`;
/// `prob = 1` uses `(S − 1/2)/S` as posterior does). NaN for `prob ∉ [0, 1]`.
pub fn ess_quantile(chains: &[&[f64]], prob: f64) -> f64 {
    let Some(m) = matrix(chains) else {
        return f64::NAN;
    };
    if degenerate(&m) || !(0.0..=1.0).contains(&prob) {
        return f64::NAN;
    }
    let flat: Vec<f64> = m.iter().flatten().copied().collect();
    let prob = if prob == 1.0 {
        let s = flat.len() as f64;
        (s - 0.5) / s
    } else {
        prob
    };
    let q = quantile7(&flat, prob);
    let ind: Vec<Vec<f64>> = m
        .iter()
        .map(|c| c.iter().map(|&v| if v <= q { 1.0 } else { 0.0 }).collect())
        .collect();
    ess_core(&split(&ind))
}

/// ESS of the median (`posterior::ess_median`).
pub fn ess_median(chains: &[&[f64]]) -> f64 {
    ess_quantile(chains, 0.5)
}

/// ESS for the mean: ESS of the raw split chains (`posterior::ess_mean`,
/// `ess_basic(x)`). The Monte Carlo standard error of the mean is
/// `sd/√ess_mean`.
pub fn ess_mean(chains: &[&[f64]]) -> f64 {
    match matrix(chains) {
        Some(m) => ess_core(&split(&m)),
        None => f64::NAN,
    }
}

/// ESS of the raw unsplit chains (`posterior::ess_basic(x, split = FALSE)`).
pub fn ess_unsplit(chains: &[&[f64]]) -> f64 {
    match matrix(chains) {
        Some(m) => ess_core(&m),
        None => f64::NAN,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn direct_autocov(x: &[f64]) -> Vec<f64> {
        let n = x.len();
        let m = mean(x);
        (0..n)
            .map(|t| (0..n - t).map(|i| (x[i] - m) * (x[i + t] - m)).sum::<f64>() / n as f64)
            .collect()
    }

    #[test]
    fn fft_autocovariance_matches_direct_sum() {
        for n in [1usize, 2, 3, 7, 64, 100, 333, 1000] {
            let x: Vec<f64> = (0..n)
                .map(|i| ((i as f64) * 0.7).sin() + ((i * i) % 17) as f64 * 0.1)
                .collect();
            let a = autocovariance(&x);
            let b = direct_autocov(&x);
            assert_eq!(a.len(), n);
            for t in 0..n {
                assert!(
                    (a[t] - b[t]).abs() <= 1e-13 * b[0].abs().max(1e-300),
                    "n = {n}, lag {t}: {} vs {}",
                    a[t],
                    b[t]
                );
            }
        }
    }

    #[test]
    fn split_drops_the_middle_draw() {
        let m = vec![
            vec![1.0, 2.0, 3.0, 4.0, 5.0],
            vec![6.0, 7.0, 8.0, 9.0, 10.0],
        ];
        let s = split(&m);
        assert_eq!(
            s,
            vec![
                vec![1.0, 2.0],
                vec![6.0, 7.0],
                vec![4.0, 5.0],
                vec![9.0, 10.0]
            ]
        );
        let even = split(&[vec![1.0, 2.0, 3.0, 4.0]]);
        assert_eq!(even, vec![vec![1.0, 2.0], vec![3.0, 4.0]]);
    }

    #[test]
    fn ranks_average_ties() {
        assert_eq!(
            ranks(&[3.0, 1.0, 3.0, 2.0, 3.0]),
            vec![4.0, 1.0, 4.0, 2.0, 4.0]
        );
    }

    #[test]
    fn quantile7_matches_r() {
        // R: quantile(c(10, 1, 7, 3), c(0, 0.05, 0.5, 0.95, 1)) = 1, 1.3, 5, 9.55, 10
        let x = [10.0, 1.0, 7.0, 3.0];
        let want = [
            (0.0, 1.0),
            (0.05, 1.3),
            (0.5, 5.0),
            (0.95, 9.55),
            (1.0, 10.0),
        ];
        for (p, q) in want {
            assert!((quantile7(&x, p) - q).abs() < 1e-12, "p = {p}");
        }
        assert!(quantile7(&[], 0.5).is_nan());
        assert!(quantile7(&x, 1.5).is_nan());
    }

    #[test]
    fn degenerate_inputs_give_nan() {
        let c = [2.0; 50];
        let chains: [&[f64]; 2] = [&c, &c];
        for f in [rhat, rhat_basic, rhat_classic, ess_bulk, ess_tail, ess_mean] {
            assert!(f(&chains).is_nan());
        }
        let mut with_nan: Vec<f64> = (0..50).map(|i| i as f64).collect();
        with_nan[7] = f64::NAN;
        let good: Vec<f64> = (0..50).map(|i| (i * 7 % 50) as f64).collect();
        let chains: [&[f64]; 2] = [&with_nan, &good];
        for f in [rhat, rhat_basic, rhat_classic, ess_bulk, ess_tail, ess_mean] {
            assert!(f(&chains).is_nan());
        }
        let short = [1.0, 2.0];
        let chains: [&[f64]; 2] = [&good, &short];
        assert!(rhat(&chains).is_nan());
        assert!(ess_bulk(&[]).is_nan());
        // Too few draws for ESS after splitting (2 per split chain).
        let four = [1.0, 3.0, 2.0, 4.0];
        assert!(ess_bulk(&[&four]).is_nan());
    }

    #[test]
    fn iid_draws_have_ess_near_draw_count_and_rhat_near_one() {
        use rand::{Rng, SeedableRng};
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(7);
        let chains: Vec<Vec<f64>> = (0..4)
            .map(|_| (0..1000).map(|_| rng.random::<f64>()).collect())
            .collect();
        let refs: Vec<&[f64]> = chains.iter().map(|c| c.as_slice()).collect();
        let r = rhat(&refs);
        assert!((r - 1.0).abs() < 0.01, "rhat = {r}");
        let e = ess_bulk(&refs);
        assert!(e > 3200.0 && e < 4800.0, "ess_bulk = {e}");
        let t = ess_tail(&refs);
        assert!(t > 2800.0 && t < 5200.0, "ess_tail = {t}");
    }

    #[test]
    fn shifted_chain_is_flagged() {
        let a: Vec<f64> = (0..500).map(|i| ((i * 37) % 101) as f64).collect();
        let b: Vec<f64> = a.iter().map(|v| v + 60.0).collect();
        assert!(rhat(&[&a, &b]) > 1.3);
        assert!(rhat_classic(&[&a, &b]) > 1.3);
    }
}
