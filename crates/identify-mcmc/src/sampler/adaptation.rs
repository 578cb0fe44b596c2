//! The adaptive random-walk proposal of one chain: during warm-up a Robbins–Monro update of
//! the log scale `ln λ ← ln λ + n^(−0.6)·(α − α*)` at every step, and the covariance of each
//! window of states (Welford, doubling windows) shrunk towards a small diagonal and refactored
//! at the window's end.

use numerics::cholesky::cholesky_in_place;

/// Proposal state and warm-up accumulators of one chain.
pub(super) struct Adaptation {
    /// Lower Cholesky factor of the proposal covariance, row-major d×d.
    pub(super) chol: Vec<f64>,
    pub(super) log_lambda: f64,
    rm_count: f64,
    window_len: usize,
    window_max: usize,
    win_n: usize,
    win_accepted: usize,
    win_mean: Vec<f64>,
    win_m2: Vec<f64>,
    cov: Vec<f64>,
}

impl Adaptation {
    pub(super) fn new(widths: &[f64]) -> Self {
        let d = widths.len();
        let mut chol = vec![0.0; d * d];
        for (i, w) in widths.iter().enumerate() {
            chol[i * d + i] = 0.1 * w;
        }
        let base = (10 * d).max(100);
        Self {
            chol,
            log_lambda: default_log_lambda(d),
            rm_count: 0.0,
            window_len: base,
            window_max: base << 7,
            win_n: 0,
            win_accepted: 0,
            win_mean: vec![0.0; d],
            win_m2: vec![0.0; d * d],
            cov: vec![0.0; d * d],
        }
    }

    /// One Robbins–Monro scale update and one Welford covariance update.
    pub(super) fn update(
        &mut self,
        x: &[f64],
        alpha: f64,
        accepted: bool,
        target: f64,
        widths: &[f64],
    ) {
        self.rm_count += 1.0;
        let gamma = self.rm_count.powf(-0.6);
        self.log_lambda = (self.log_lambda + gamma * (alpha - target)).clamp(-60.0, 20.0);
        let d = x.len();
        self.win_n += 1;
        if accepted {
            self.win_accepted += 1;
        }
        let n = self.win_n as f64;
        for (i, &xi) in x.iter().enumerate() {
            let delta = xi - self.win_mean[i];
            self.win_mean[i] += delta / n;
            // M2 += δ_old ⊗ (x − mean_new), lower triangle only.
            let row = &mut self.win_m2[i * d..=i * d + i];
            for ((m2, &xj), &mj) in row.iter_mut().zip(x).zip(&self.win_mean) {
                *m2 += delta * (xj - mj);
            }
        }
        if self.win_n >= self.window_len {
            self.end_window(widths);
        }
    }

    /// Close a window: shrink its covariance, refactor, restart the scale.
    fn end_window(&mut self, widths: &[f64]) {
        let d = widths.len();
        let n = self.win_n as f64;
        if self.win_accepted > 2 * d && self.win_n > 1 {
            let shrink = n / (n + 5.0);
            for (i, w) in widths.iter().enumerate() {
                for j in 0..=i {
                    let mut c = shrink * self.win_m2[i * d + j] / (n - 1.0);
                    if i == j {
                        c += ((1.0 - shrink) * 1e-6 + 1e-12) * w * w;
                    }
                    self.cov[i * d + j] = c;
                }
            }
            if cholesky_in_place(&mut self.cov, d).is_ok() {
                self.chol.copy_from_slice(&self.cov);
                self.log_lambda = default_log_lambda(d);
            }
        }
        self.rm_count = 0.0;
        self.win_n = 0;
        self.win_accepted = 0;
        self.win_mean.iter_mut().for_each(|v| *v = 0.0);
        self.win_m2.iter_mut().for_each(|v| *v = 0.0);
        self.window_len = (2 * self.window_len).min(self.window_max);
    }
}

pub(super) fn default_log_lambda(d: usize) -> f64 {
    (2.38f64 * 2.38 / d as f64).ln()
}
