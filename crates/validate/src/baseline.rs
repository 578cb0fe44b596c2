//! The linear EMG baseline every muscle model has to beat held out: the moment regressed on
//! each muscle's envelope times its moment arm,
//!
//! ```text
//! τ̂(t) = Σ_m F_m · e_m(t − d) · r_m(t)
//! ```
//!
//! one force `F_m` per muscle (the triceps and every fixed muscle with an envelope), `r_m` the
//! trial's own moment-arm series when it gives one, else the model's `dLMT/dq` at the measured
//! angle, and one delay `d` shared by the muscles. `F` is fitted by weighted least squares on
//! the calibration samples only (the normal equations with a ridge of 10⁻¹⁰ of their mean
//! diagonal, which keeps muscles that share an EMG channel solvable), and `d` is the value on
//! a grid of `0, step, …, max` ms whose fit has the least calibration error: the baseline is
//! calibrated exactly as the Hill model is, then predicts the same held-out samples.

use muscle_model::{Muscle, Problem};
use serde::Serialize;

use crate::folds::TrialPart;
use crate::ValidateError;

/// A fitted linear baseline.
#[derive(Clone, Debug, PartialEq, Serialize)]
#[non_exhaustive]
pub struct LinearBaseline {
    /// The muscles, in the order of `forces_n`.
    pub muscles: Vec<String>,
    /// The force of each (N; the sign follows the moment arm's convention).
    pub forces_n: Vec<f64>,
    /// The shared EMG delay (ms).
    pub delay_ms: f64,
}

/// The muscles the baseline regresses on: the triceps, then the problem's fixed muscles whose
/// envelope the trial carries.
fn muscles_of(problem: &Problem) -> Vec<String> {
    let inputs = problem.inputs();
    Muscle::ALL
        .iter()
        .map(|m| m.name().to_string())
        .chain(
            problem
                .base_params()
                .fixed
                .iter()
                .filter(|f| inputs.envelope_named(f.name).is_some())
                .map(|f| f.name.to_string()),
        )
        .collect()
}

/// The regressor `e_m(t − d)·r_m(t)` of muscle `name` on `problem`'s trial (zeros when the
/// trial has no envelope for it), with the delay `lag` in samples.
fn regressor(problem: &Problem, name: &str, lag: usize) -> Vec<f64> {
    let inputs = problem.inputs();
    let n = inputs.len();
    let Some(env) = inputs.envelope_named(name) else {
        return vec![0.0; n];
    };
    let params = problem.base_params();
    let arm_at = |i: usize| -> f64 {
        if let Some(g) = inputs.geometry(name) {
            return g.moment_arm_m[i];
        }
        let q = inputs.angle()[i];
        match Muscle::from_name(name) {
            Some(m) => params.muscle(m).moment_arm(q),
            None => params
                .fixed
                .get(name)
                .map_or(0.0, |f| f.params.moment_arm(q)),
        }
    };
    (0..n)
        .map(|i| env[i.saturating_sub(lag)] * arm_at(i))
        .collect()
}

impl LinearBaseline {
    /// Fits the baseline to the samples `parts` of `problems` (each weighted by its problem's
    /// weights), the delay chosen on the grid `0, step_ms, …, max_delay_ms`.
    ///
    /// # Errors
    /// No calibration sample, a grid that is not finite and ≥ 0, or normal equations that
    /// cannot be solved.
    pub fn fit(
        problems: &[&Problem],
        parts: &[TrialPart],
        max_delay_ms: f64,
        step_ms: f64,
    ) -> Result<Self, ValidateError> {
        if !(max_delay_ms.is_finite()
            && max_delay_ms >= 0.0
            && step_ms.is_finite()
            && step_ms > 0.0)
        {
            return Err(ValidateError::invalid(
                "linear baseline",
                format!("delay grid 0..{max_delay_ms} ms by {step_ms} ms"),
            ));
        }
        let first = parts
            .first()
            .ok_or_else(|| ValidateError::invalid("linear baseline", "no calibration sample"))?;
        let muscles = muscles_of(problems[first.trial]);
        let mut best: Option<(f64, Self)> = None;
        let steps = (max_delay_ms / step_ms).floor() as usize;
        for k in 0..=steps {
            let delay_ms = k as f64 * step_ms;
            let (forces_n, sse) = Self::solve(problems, parts, &muscles, delay_ms)?;
            if best.as_ref().is_none_or(|(b, _)| sse < *b) {
                best = Some((
                    sse,
                    Self {
                        muscles: muscles.clone(),
                        forces_n,
                        delay_ms,
                    },
                ));
            }
        }
        best.map(|(_, b)| b)
            .ok_or_else(|| ValidateError::invalid("linear baseline", "no delay on the grid"))
    }

    /// The forces at one delay and their weighted calibration SSE.
    fn solve(
        problems: &[&Problem],
        parts: &[TrialPart],
        muscles: &[String],
        delay_ms: f64,
    ) -> Result<(Vec<f64>, f64), ValidateError> {
        let k = muscles.len();
        let mut ata = vec![0.0; k * k];
        let mut aty = vec![0.0; k];
        let mut rows: Vec<(Vec<Vec<f64>>, &TrialPart)> = Vec::with_capacity(parts.len());
        for part in parts {
            let p = problems[part.trial];
            let lag = (delay_ms * 1e-3 * p.inputs().fs()).round() as usize;
            let cols: Vec<Vec<f64>> = muscles.iter().map(|m| regressor(p, m, lag)).collect();
            let y = p.measured();
            for i in part.samples.clone() {
                let w = p.weights().map_or(1.0, |w| w[i]);
                if w <= 0.0 {
                    continue;
                }
                for a in 0..k {
                    aty[a] += w * cols[a][i] * y[i];
                    for b in 0..k {
                        ata[a * k + b] += w * cols[a][i] * cols[b][i];
                    }
                }
            }
            rows.push((cols, part));
        }
        let ridge = 1e-10 * (0..k).map(|a| ata[a * k + a]).sum::<f64>() / k.max(1) as f64;
        if ridge.is_nan() || ridge <= 0.0 {
            return Err(ValidateError::invalid(
                "linear baseline",
                "no calibration sample has an envelope",
            ));
        }
        for a in 0..k {
            ata[a * k + a] += ridge;
        }
        let mut forces = aty;
        numerics::cholesky::cholesky_solve_in_place(&mut ata, &mut forces)
            .map_err(|e| ValidateError::invalid("linear baseline", e.to_string()))?;
        let mut sse = 0.0;
        for (cols, part) in &rows {
            let p = problems[part.trial];
            let y = p.measured();
            for i in part.samples.clone() {
                let w = p.weights().map_or(1.0, |w| w[i]);
                let pred: f64 = (0..k).map(|a| forces[a] * cols[a][i]).sum();
                sse += w * (y[i] - pred) * (y[i] - pred);
            }
        }
        Ok((forces, sse))
    }

    /// The baseline's moment on `problem`'s trial (N·m).
    #[must_use]
    pub fn predict(&self, problem: &Problem) -> Vec<f64> {
        let n = problem.inputs().len();
        let lag = (self.delay_ms * 1e-3 * problem.inputs().fs()).round() as usize;
        let mut out = vec![0.0; n];
        for (m, f) in self.muscles.iter().zip(&self.forces_n) {
            for (o, x) in out.iter_mut().zip(regressor(problem, m, lag)) {
                *o += f * x;
            }
        }
        out
    }
}
