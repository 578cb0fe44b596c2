//! One trial's share of the likelihood in the sampling coordinates.
//!
//! The trials of a session share the muscle parameters but not their noise: each has its own
//! dynamometer correction (already in its measured torque), its own whitening filter `W_t`, its
//! own masked segments and its own constant-offset nuisance of prior sd `s_t`. Their noises are
//! independent, so the log-likelihood is a sum over trials, and so is every quadratic form the
//! conditional of module `sampling_coordinates` needs. For trial `t`, with `ỹ_t = W_t(y_t − c_t)`,
//! `G̃_t = W_t[g_j]`, `õ_t = W_t·1` and `κ_t = s_t²/(1 + s_t²|õ_t|²)`:
//!
//! * `A_t = G̃_tᵀG̃_t − κ_t·G̃_tᵀõ_t·õ_tᵀG̃_t`,
//! * `b_t = G̃_tᵀỹ_t − κ_t·G̃_tᵀõ_t·õ_tᵀỹ_t`,
//! * `(yᵀy)_t = ỹ_tᵀỹ_t − κ_t·(õ_tᵀỹ_t)²`,
//! * `N_t = Σ_segments ln-normalisation of W_t − ½ ln(1 + s_t²|õ_t|²)`,
//!
//! and the conditional uses `A = Σ A_t`, `b = Σ b_t`, `yᵀy = Σ (yᵀy)_t`, `N = Σ N_t`.

use muscle_model::{simulate_into, Problem, Workspace};

use crate::noise::{Noise, Whitener};

/// A trial as the sampling coordinates see it: its problem (measured torque already corrected
/// by its systematic dynamometer error), its noise model and the prior sd of its residual
/// constant offset (0: none).
#[derive(Clone, Copy)]
pub(crate) struct TrialModel<'a> {
    /// The trial's problem (shared free parameters and bounds).
    pub problem: &'a Problem,
    /// Its random noise model.
    pub noise: Noise,
    /// Prior sd of the constant offset integrated out (N·m).
    pub offset_sd: f64,
}

/// A trial's Gram quantities at one parameter vector (module documentation), for up to three
/// F0 columns.
pub(crate) struct TrialGram {
    /// `A_t`, row-major `p×p`.
    pub a: [f64; 9],
    /// `b_t`.
    pub b: [f64; 3],
    /// `(yᵀy)_t`.
    pub yy: f64,
    /// `N_t`.
    pub norm: f64,
}

/// A trial's whitening and masking, ready to evaluate its Gram quantities.
pub(crate) struct TrialTerm<'a> {
    pub problem: &'a Problem,
    whitener: Whitener,
    offset_sd: f64,
    /// Runs `[start, end)` of included samples (the whole trial without weights).
    segments: Vec<(usize, usize)>,
}

impl<'a> TrialTerm<'a> {
    pub fn new(model: &TrialModel<'a>) -> Self {
        let problem = model.problem;
        let n = problem.measured().len();
        let segments = match problem.weights() {
            None => vec![(0, n)],
            Some(w) => {
                let mut segs = Vec::new();
                let mut i = 0;
                while i < n {
                    if w[i] > 0.0 {
                        let s = i;
                        while i < n && w[i] > 0.0 {
                            i += 1;
                        }
                        segs.push((s, i));
                    } else {
                        i += 1;
                    }
                }
                segs
            }
        };
        let longest = segments.iter().map(|(a, b)| b - a).max().unwrap_or(0);
        let offset_sd = if model.offset_sd.is_finite() && model.offset_sd > 0.0 {
            model.offset_sd
        } else {
            0.0
        };
        Self {
            problem,
            whitener: model.noise.whitener(longest),
            offset_sd,
            segments,
        }
    }

    /// Prior sd of the constant offset integrated out (N·m; 0: none).
    pub fn offset_sd(&self) -> f64 {
        self.offset_sd
    }

    /// `Σ_segments` ln-normalisation of the whitening filter (module documentation).
    pub fn log_norm(&self) -> f64 {
        self.segments
            .iter()
            .map(|(a, b)| self.whitener.log_norm(b - a))
            .sum()
    }

    /// Append the whitened `e` (segment by segment, masked samples dropped) to `out`.
    pub fn whiten_append(&self, e: &[f64], out: &mut Vec<f64>) {
        for &(a, b) in &self.segments {
            let start = out.len();
            out.resize(start + (b - a), 0.0);
            self.whitener.whiten(&e[a..b], &mut out[start..]);
        }
    }

    /// The trial's Gram quantities at the model vector `x`, `lin` the `(free index, muscle
    /// index)` of the F0 parameters; `ws`/`total` are scratch. `None`: the simulation failed.
    pub fn gram(
        &self,
        x: &[f64],
        lin: &[(usize, usize)],
        ws: &mut Workspace,
        total: &mut Vec<f64>,
    ) -> Option<TrialGram> {
        let problem = self.problem;
        let (params, effects) = problem.params_from_vector(x).ok()?;
        let p = lin.len();
        let n = problem.measured().len();
        total.resize(n, 0.0);
        simulate_into(
            ws,
            problem.inputs(),
            &params,
            &effects,
            problem.settings(),
            total,
        )
        .ok()?;
        // y − c, with c the torque that does not scale with a free F0.
        // One fused pass: y − c, the unit-F0 columns g_k and the vector of ones, whitened
        // side by side, with all their inner products (module documentation).
        let measured = problem.measured();
        let tms = ws.torque_muscle();
        let mut cols: [&[f64]; 3] = [&[]; 3];
        let mut inv_f0 = [0.0; 3];
        for (k, &(i, muscle)) in lin.iter().enumerate() {
            cols[k] = &tms[muscle].torque;
            inv_f0[k] = 1.0 / x[i];
        }
        let total = &*total;
        let mut gram = [[0.0; 5]; 5];
        for &(a0, b0) in &self.segments {
            let part = self.whitener.whitened_gram::<5, _>(b0 - a0, |t| {
                let i = a0 + t;
                let mut r = [0.0; 5];
                let mut y = measured[i] - total[i];
                for k in 0..p {
                    let v = cols[k][i];
                    y += v;
                    r[k + 1] = v * inv_f0[k];
                }
                r[0] = y;
                r[4] = 1.0;
                r
            });
            for (gi, pi) in gram.iter_mut().zip(&part) {
                for (g, q) in gi.iter_mut().zip(pi) {
                    *g += q;
                }
            }
        }
        let mut a = [0.0; 9];
        let mut b = [0.0; 3];
        for k in 0..p {
            for l in 0..=k {
                a[k * p + l] = gram[l + 1][k + 1];
                a[l * p + k] = gram[l + 1][k + 1];
            }
            b[k] = gram[0][k + 1];
        }
        let mut yy = gram[0][0];
        let mut log_offset = 0.0;
        if self.offset_sd > 0.0 {
            let s2 = self.offset_sd * self.offset_sd;
            let oo = gram[4][4];
            let kappa = s2 / (1.0 + s2 * oo);
            let oy = gram[0][4];
            for k in 0..p {
                for l in 0..p {
                    a[k * p + l] -= kappa * gram[k + 1][4] * gram[l + 1][4];
                }
                b[k] -= kappa * gram[k + 1][4] * oy;
            }
            yy -= kappa * oy * oy;
            log_offset = -0.5 * (s2 * oo).ln_1p();
        }
        let n_used: usize = self.segments.iter().map(|(a, b)| b - a).sum();
        let norm: f64 = if self.segments.len() == 1 {
            self.whitener.log_norm(n_used)
        } else {
            self.segments
                .iter()
                .map(|(a, b)| self.whitener.log_norm(b - a))
                .sum()
        } + log_offset;
        Some(TrialGram { a, b, yy, norm })
    }
}
