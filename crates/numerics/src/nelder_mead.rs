//! Bounded Nelder–Mead with dimension-adaptive coefficients and restarts.
//!
//! The simplex of `n + 1` vertices lives in unit-box coordinates. With the vertices sorted by
//! cost, `c` the centroid of all but the worst `w`, a step tries the reflection
//! `r = c + α(c − w)`, then the expansion `e = c + γ(r − c)` or a contraction
//! `c + ρ(t − c)` (`t = r` outside, `t = w` inside), and else shrinks every vertex towards the
//! best `b` as `b + σ(v − b)`; every trial point is clamped onto the box. The coefficients
//! are those of Gao & Han (2012), `α = 1`, `γ = 1 + 2/n`, `ρ = 0.75 − 1/(2n)`, `σ = 1 − 1/n`
//! (the classical 1, 2, ½, ½ for `n ≤ 2`).

use crate::objective::UnitBox;
use crate::{NumericsError, Objective};

/// Settings of [`nelder_mead`] (also the final polish of the annealer in `identify-sa`). All lengths are in unit-box coordinates
/// (every parameter rescaled to `[0, 1]`).
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[cfg_attr(feature = "serde", serde(default))]
pub struct NelderMeadSettings {
    /// Maximum objective evaluations. Default 20 000.
    pub max_evaluations: u64,
    /// Edge of the initial simplex, unit coordinates. Default 0.05.
    pub initial_step: f64,
    /// Absolute tolerance on the spread of costs over the simplex. Default 1e-12.
    pub ftol_abs: f64,
    /// Relative tolerance on the spread of costs over the simplex. Default 1e-10.
    pub ftol_rel: f64,
    /// Tolerance on the simplex size (max-norm, unit coordinates). Default 1e-9.
    pub xtol: f64,
    /// Restarts of a fresh simplex at the best point after convergence; stops
    /// early when a restart gains less than the cost tolerance. Default 6.
    pub max_restarts: u32,
}

impl Default for NelderMeadSettings {
    fn default() -> Self {
        Self {
            max_evaluations: 20_000,
            initial_step: 0.05,
            ftol_abs: 1e-12,
            ftol_rel: 1e-10,
            xtol: 1e-9,
            max_restarts: 6,
        }
    }
}

impl NelderMeadSettings {
    /// Validated settings with the given budget, other fields at their defaults.
    ///
    /// # Errors
    /// [`NumericsError::InvalidSetting`] when `max_evaluations` is 0.
    pub fn new(max_evaluations: u64) -> Result<Self, NumericsError> {
        Self {
            max_evaluations,
            ..Self::default()
        }
        .validate()
    }

    /// Set the evaluation budget.
    #[must_use]
    pub fn with_max_evaluations(mut self, v: u64) -> Self {
        self.max_evaluations = v;
        self
    }
    /// Set the initial simplex edge (unit coordinates).
    #[must_use]
    pub fn with_initial_step(mut self, v: f64) -> Self {
        self.initial_step = v;
        self
    }
    /// Set the cost tolerances (absolute, relative).
    #[must_use]
    pub fn with_ftol(mut self, abs: f64, rel: f64) -> Self {
        self.ftol_abs = abs;
        self.ftol_rel = rel;
        self
    }
    /// Set the simplex-size tolerance (unit coordinates).
    #[must_use]
    pub fn with_xtol(mut self, v: f64) -> Self {
        self.xtol = v;
        self
    }
    /// Set the number of restarts.
    #[must_use]
    pub fn with_max_restarts(mut self, v: u32) -> Self {
        self.max_restarts = v;
        self
    }

    /// Check every field; returns the settings unchanged when valid.
    ///
    /// # Errors
    /// [`NumericsError::InvalidSetting`] naming the first invalid field.
    pub fn validate(self) -> Result<Self, NumericsError> {
        let bad = NumericsError::setting;
        if self.max_evaluations == 0 {
            return bad("max_evaluations", 0.0, "must be at least 1");
        }
        if !(self.initial_step > 0.0 && self.initial_step <= 1.0) {
            return bad("initial_step", self.initial_step, "must be in (0, 1]");
        }
        for (name, v) in [
            ("ftol_abs", self.ftol_abs),
            ("ftol_rel", self.ftol_rel),
            ("xtol", self.xtol),
        ] {
            if !(v >= 0.0 && v.is_finite()) {
                return bad(name, v, "must be finite and non-negative");
            }
        }
        Ok(self)
    }
}

/// What [`nelder_mead`] found.
#[derive(Debug, Clone, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct NelderMeadOutcome {
    /// Best point, in the objective's coordinates.
    pub x: Vec<f64>,
    /// Cost at `x`.
    pub cost: f64,
    /// Objective evaluations used (the start point included).
    pub evaluations: u64,
    /// Evaluations that failed (`None` or non-finite).
    pub failed_evaluations: u64,
    /// Restarts performed after the first convergence.
    pub restarts: u32,
    /// Whether the last simplex met the tolerances (false: budget ran out).
    pub converged: bool,
}

/// Minimise `objective` from `x0` (inside the bounds) by Nelder–Mead.
///
/// The simplex lives in unit-box coordinates; every trial vertex is projected
/// (clamped) onto the box, so the objective is never called outside its
/// bounds. Coefficients are the dimension-adaptive ones of Gao & Han (2012):
/// reflection 1, expansion `1 + 2/n`, contraction `0.75 − 1/(2n)`, shrink
/// `1 − 1/n` (the classical 1, 2, ½, ½ for `n ≤ 2`). A simplex has converged when the costs
/// of its vertices differ from the best by at most `ftol_abs + ftol_rel·|f_best|`
/// and every vertex lies within `xtol` (max-norm) of the best; it is then
/// restarted at the best point with the initial edge, up to `max_restarts`
/// times, stopping as soon as a restart gains no more than the cost tolerance.
/// Failed evaluations count as `+∞`.
///
/// ```
/// use numerics::{nelder_mead, FnObjective, NelderMeadSettings};
/// let mut q = FnObjective::new(vec![(-5.0, 5.0); 3], |x: &[f64]| {
///     Some((x[0] - 1.0).powi(2) + 2.0 * (x[1] + 0.5).powi(2) + 3.0 * x[2] * x[2])
/// });
/// let out = nelder_mead(&mut q, &[3.0, 3.0, 3.0], &NelderMeadSettings::default()).unwrap();
/// assert!(out.cost < 1e-10);
/// assert!((out.x[0] - 1.0).abs() < 1e-5);
/// ```
///
/// # Errors
/// Invalid bounds or settings, a start point of the wrong length or outside
/// the bounds, or a start point where the objective fails.
pub fn nelder_mead<O: Objective + ?Sized>(
    objective: &mut O,
    x0: &[f64],
    settings: &NelderMeadSettings,
) -> Result<NelderMeadOutcome, NumericsError> {
    let settings = settings.validate()?;
    let mut ubox = UnitBox::new(objective)?;
    let n = ubox.dim();
    let mut u0 = vec![0.0; n];
    ubox.to_unit(x0, &mut u0)?;
    let f0 = ubox
        .eval(objective, &u0)
        .ok_or(NumericsError::StartEvaluationFailed)?;
    let steps = vec![settings.initial_step; n];
    let r = nelder_mead_unit(
        objective,
        &mut ubox,
        &u0,
        f0,
        &steps,
        &settings,
        settings.max_evaluations.saturating_sub(1),
    );
    Ok(NelderMeadOutcome {
        x: ubox.to_box(&r.u),
        cost: r.f,
        evaluations: r.evaluations + 1,
        failed_evaluations: r.failed,
        restarts: r.restarts,
        converged: r.converged,
    })
}

/// Result of [`nelder_mead_unit`], in unit coordinates.
#[derive(Debug, Clone, PartialEq)]
pub struct NelderMeadUnitOutcome {
    /// Best point (unit coordinates).
    pub u: Vec<f64>,
    /// Cost at `u`.
    pub f: f64,
    /// New evaluations used (the start point's not included).
    pub evaluations: u64,
    /// Evaluations that failed.
    pub failed: u64,
    /// Restarts performed after the first convergence.
    pub restarts: u32,
    /// Whether the last simplex met the tolerances.
    pub converged: bool,
}

/// Counts evaluations against a budget; failures become `+∞`.
struct Counter<'a, O: ?Sized> {
    objective: &'a mut O,
    ubox: &'a mut UnitBox,
    evaluations: u64,
    failed: u64,
    budget: u64,
}

impl<O: Objective + ?Sized> Counter<'_, O> {
    fn exhausted(&self) -> bool {
        self.evaluations >= self.budget
    }
    fn eval(&mut self, u: &[f64]) -> f64 {
        self.evaluations += 1;
        match self.ubox.eval(self.objective, u) {
            Some(v) => v,
            None => {
                self.failed += 1;
                f64::INFINITY
            }
        }
    }
}

/// Nelder–Mead from `u0` (cost `f0` already known) with per-coordinate
/// initial edges `steps`, using at most `budget` new evaluations, on an already validated
/// unit box (the annealer's polish; [`nelder_mead`] is the checked entry point).
pub fn nelder_mead_unit<O: Objective + ?Sized>(
    objective: &mut O,
    ubox: &mut UnitBox,
    u0: &[f64],
    f0: f64,
    steps: &[f64],
    settings: &NelderMeadSettings,
    budget: u64,
) -> NelderMeadUnitOutcome {
    let n = u0.len();
    let mut counter = Counter {
        objective,
        ubox,
        evaluations: 0,
        failed: 0,
        budget,
    };
    let nf = n as f64;
    let (alpha, gamma, rho, sigma) = if n <= 2 {
        (1.0, 2.0, 0.5, 0.5)
    } else {
        (1.0, 1.0 + 2.0 / nf, 0.75 - 0.5 / nf, 1.0 - 1.0 / nf)
    };

    let mut best_u = u0.to_vec();
    let mut best_f = f0;
    let mut simplex = vec![0.0; (n + 1) * n];
    let mut fs = vec![0.0; n + 1];
    let mut order: Vec<usize> = (0..=n).collect();
    let mut centroid = vec![0.0; n];
    let mut xr = vec![0.0; n];
    let mut xe = vec![0.0; n];
    let mut xc = vec![0.0; n];
    let mut restarts = 0u32;
    let mut converged = false;
    let mut run_start_f = f0;

    'runs: loop {
        // Build the simplex around the best point.
        simplex[..n].copy_from_slice(&best_u);
        fs.fill(f64::INFINITY);
        fs[0] = best_f;
        for i in 0..n {
            let (head, tail) = simplex.split_at_mut((i + 1) * n);
            let v = &mut tail[..n];
            v.copy_from_slice(&head[..n]);
            let s = steps[i];
            let mut f = f64::INFINITY;
            for attempt in 0..6 {
                if counter.exhausted() {
                    break 'runs;
                }
                let h = s * 0.5f64.powi(attempt / 2);
                let dir = if (best_u[i] + h <= 1.0) == (attempt % 2 == 0) {
                    h
                } else {
                    -h
                };
                v[i] = (best_u[i] + dir).clamp(0.0, 1.0);
                if v[i] == best_u[i] {
                    continue;
                }
                f = counter.eval(v);
                if f.is_finite() {
                    break;
                }
            }
            fs[i + 1] = f;
        }
        converged = false;
        loop {
            order.sort_by(|&a, &b| fs[a].total_cmp(&fs[b]));
            let b = order[0];
            let w = order[n];
            let sw = order[n - 1];
            if fs[b] < best_f {
                best_f = fs[b];
                best_u.copy_from_slice(&simplex[b * n..(b + 1) * n]);
            }
            // Convergence.
            let ftol = settings.ftol_abs + settings.ftol_rel * fs[b].abs();
            let fspread = fs[w] - fs[b];
            let vb = &simplex[b * n..(b + 1) * n];
            let xspread = (0..=n)
                .flat_map(|j| (0..n).map(move |k| (j, k)))
                .map(|(j, k)| (simplex[j * n + k] - vb[k]).abs())
                .fold(0.0f64, f64::max);
            if fspread <= ftol && xspread <= settings.xtol {
                converged = true;
                break;
            }
            if counter.exhausted() {
                break 'runs;
            }
            // Centroid of all but the worst.
            centroid.fill(0.0);
            for &j in &order[..n] {
                for k in 0..n {
                    centroid[k] += simplex[j * n + k];
                }
            }
            for c in centroid.iter_mut() {
                *c /= nf;
            }
            for k in 0..n {
                xr[k] = (centroid[k] + alpha * (centroid[k] - simplex[w * n + k])).clamp(0.0, 1.0);
            }
            let fr = counter.eval(&xr);
            if fr < fs[b] {
                if counter.exhausted() {
                    replace(&mut simplex, &mut fs, w, &xr, fr, n);
                    continue;
                }
                for k in 0..n {
                    xe[k] = (centroid[k] + gamma * (xr[k] - centroid[k])).clamp(0.0, 1.0);
                }
                let fe = counter.eval(&xe);
                if fe < fr {
                    replace(&mut simplex, &mut fs, w, &xe, fe, n);
                } else {
                    replace(&mut simplex, &mut fs, w, &xr, fr, n);
                }
                continue;
            }
            if fr < fs[sw] {
                replace(&mut simplex, &mut fs, w, &xr, fr, n);
                continue;
            }
            if counter.exhausted() {
                if fr < fs[w] {
                    replace(&mut simplex, &mut fs, w, &xr, fr, n);
                }
                continue;
            }
            let outside = fr < fs[w];
            for k in 0..n {
                let target = if outside { xr[k] } else { simplex[w * n + k] };
                xc[k] = (centroid[k] + rho * (target - centroid[k])).clamp(0.0, 1.0);
            }
            let fc = counter.eval(&xc);
            let ok = if outside { fc <= fr } else { fc < fs[w] };
            if ok {
                replace(&mut simplex, &mut fs, w, &xc, fc, n);
                continue;
            }
            // Shrink towards the best vertex.
            for j in 0..=n {
                if j == b {
                    continue;
                }
                if counter.exhausted() {
                    break;
                }
                for k in 0..n {
                    let vbk = simplex[b * n + k];
                    simplex[j * n + k] = vbk + sigma * (simplex[j * n + k] - vbk);
                }
                fs[j] = counter.eval(&simplex[j * n..(j + 1) * n]);
            }
        }
        // Converged: restart unless the last run gained nothing.
        let tol = settings.ftol_abs + settings.ftol_rel * best_f.abs();
        let gained = run_start_f - best_f;
        if restarts >= settings.max_restarts || (restarts > 0 && gained <= tol) {
            break;
        }
        restarts += 1;
        run_start_f = best_f;
    }
    // Pick up a better vertex found in a run cut short by the budget.
    for j in 0..=n {
        if fs[j] < best_f {
            best_f = fs[j];
            best_u.copy_from_slice(&simplex[j * n..(j + 1) * n]);
        }
    }
    NelderMeadUnitOutcome {
        u: best_u,
        f: best_f,
        evaluations: counter.evaluations,
        failed: counter.failed,
        restarts,
        converged,
    }
}

fn replace(simplex: &mut [f64], fs: &mut [f64], j: usize, v: &[f64], f: f64, n: usize) {
    simplex[j * n..(j + 1) * n].copy_from_slice(v);
    fs[j] = f;
}
