//! Several trials of one subject identified together: one [`Problem`] per trial, sharing the
//! free parameters and their bounds.
//!
//! With trials `i = 1…T`, the cost is the sum of the trials' costs,
//!
//! ```text
//! SSE(x) = Σ_i Σ_t w_it (τ_it − τ̂_it(x))²,      RMS(x) = sqrt(SSE(x) / Σ_i Σ_t w_it),
//! ```
//!
//! so a trial weighs by its number of (weighted) samples, and the residual vector of a
//! least-squares polish is the trials' residuals one after the other. Each trial keeps its own
//! inputs (knee angle, geometry, envelopes), measured torque, weights and base effects; the
//! muscle parameters are the same for all.

use crate::error::ModelError;
use crate::params::ModelParams;
use crate::problem::{ParamId, Problem, ProblemWorkspace};
use crate::Effects;

/// The trials of one identification (at least one), sharing free parameters and bounds.
#[derive(Clone, Debug)]
pub struct ProblemSet {
    problems: Vec<Problem>,
    samples: usize,
    weight_sum: f64,
}

/// One [`ProblemWorkspace`] per trial of a [`ProblemSet`] (each keeps its trial's cached
/// muscle results, so reusing one across trials would discard them at every switch).
#[derive(Debug, Default)]
pub struct ProblemSetWorkspace {
    per_trial: Vec<ProblemWorkspace>,
}

impl ProblemSetWorkspace {
    /// Workspaces for `set`.
    pub fn new(set: &ProblemSet) -> Self {
        ProblemSetWorkspace {
            per_trial: (0..set.len()).map(|_| ProblemWorkspace::new()).collect(),
        }
    }

    fn fit(&mut self, n: usize) {
        self.per_trial.resize_with(n, ProblemWorkspace::new);
    }
}

impl ProblemSet {
    /// A set of `problems`, which must have the same free parameters (in the same order) and
    /// the same bounds.
    pub fn new(problems: Vec<Problem>) -> Result<Self, ModelError> {
        let Some(first) = problems.first() else {
            return Err(ModelError::input(
                "trials",
                "a set needs at least one trial",
            ));
        };
        for (i, p) in problems.iter().enumerate().skip(1) {
            if p.names() != first.names() {
                return Err(ModelError::invalid(
                    format!("trial {}", i + 1),
                    format!(
                        "frees [{}] where the first trial frees [{}]",
                        p.names().join(", "),
                        first.names().join(", ")
                    ),
                ));
            }
            if p.bounds() != first.bounds() {
                return Err(ModelError::invalid(
                    format!("trial {}", i + 1),
                    "has other bounds than the first trial",
                ));
            }
        }
        let samples = problems.iter().map(|p| p.inputs().len()).sum();
        let weight_sum = problems.iter().map(problem_weight_sum).sum();
        Ok(ProblemSet {
            problems,
            samples,
            weight_sum,
        })
    }

    /// The set of one trial.
    pub fn single(problem: Problem) -> Self {
        let samples = problem.inputs().len();
        let weight_sum = problem_weight_sum(&problem);
        ProblemSet {
            problems: vec![problem],
            samples,
            weight_sum,
        }
    }

    /// Number of trials.
    pub fn len(&self) -> usize {
        self.problems.len()
    }

    /// Always `false` (a set has at least one trial).
    pub fn is_empty(&self) -> bool {
        self.problems.is_empty()
    }

    /// The trials' problems.
    pub fn problems(&self) -> &[Problem] {
        &self.problems
    }

    /// The first trial's problem (which defines names, bounds and base values).
    pub fn first(&self) -> &Problem {
        &self.problems[0]
    }

    /// Number of free parameters.
    pub fn dim(&self) -> usize {
        self.first().dim()
    }

    /// Names of the free parameters.
    pub fn names(&self) -> &[String] {
        self.first().names()
    }

    /// The free parameters.
    pub fn free(&self) -> &[ParamId] {
        self.first().free()
    }

    /// Bounds of the free parameters.
    pub fn bounds(&self) -> &[(f64, f64)] {
        self.first().bounds()
    }

    /// The base values of the free parameters (the first trial's).
    pub fn base_vector(&self) -> Vec<f64> {
        self.first().base_vector()
    }

    /// The muscle parameters and the first trial's effects at `x`.
    pub fn params_from_vector(&self, x: &[f64]) -> Result<(ModelParams, Effects), ModelError> {
        self.first().params_from_vector(x)
    }

    /// Total number of samples (the length of the residual vector).
    pub fn samples(&self) -> usize {
        self.samples
    }

    /// `Σ_i Σ_t w_it` (the number of samples without weights).
    pub fn weight_sum(&self) -> f64 {
        self.weight_sum
    }

    /// The weights of every sample, trial after trial, or `None` when no trial has weights.
    pub fn weights(&self) -> Option<Vec<f64>> {
        if self.problems.iter().all(|p| p.weights().is_none()) {
            return None;
        }
        let mut w = Vec::with_capacity(self.samples);
        for p in &self.problems {
            match p.weights() {
                Some(pw) => w.extend_from_slice(pw),
                None => w.extend(std::iter::repeat_n(1.0, p.inputs().len())),
            }
        }
        Some(w)
    }

    /// `Σ_i SSE_i(x)` (see the module doc).
    pub fn sse_with(&self, x: &[f64], ws: &mut ProblemSetWorkspace) -> Result<f64, ModelError> {
        ws.fit(self.len());
        let mut total = 0.0;
        for (p, w) in self.problems.iter().zip(ws.per_trial.iter_mut()) {
            total += p.sse_with(x, w)?;
        }
        Ok(total)
    }

    /// The residuals `measured − predicted` of every trial, one after the other, into `out`
    /// (length [`ProblemSet::samples`]).
    pub fn residuals_with(
        &self,
        x: &[f64],
        ws: &mut ProblemSetWorkspace,
        out: &mut [f64],
    ) -> Result<(), ModelError> {
        if out.len() != self.samples {
            return Err(ModelError::Length {
                what: "residual vector".into(),
                expected: self.samples,
                got: out.len(),
            });
        }
        ws.fit(self.len());
        let mut start = 0;
        for (p, w) in self.problems.iter().zip(ws.per_trial.iter_mut()) {
            let n = p.inputs().len();
            p.residuals_with(x, w, &mut out[start..start + n])?;
            start += n;
        }
        Ok(())
    }

    /// The exact Jacobian `∂τ̂/∂x` of the predicted torque of every trial, the trials' rows one
    /// after the other (as [`ProblemSet::residuals_with`]), column-major into `jac`
    /// (`jac[k·samples + i]`; resized). See [`Problem::jacobian_with`].
    pub fn jacobian_with(
        &self,
        x: &[f64],
        ws: &mut ProblemSetWorkspace,
        jac: &mut Vec<f64>,
    ) -> Result<(), ModelError> {
        ws.fit(self.len());
        let m = self.samples;
        let k = self.dim();
        jac.clear();
        jac.resize(m * k, 0.0);
        let mut one = Vec::new();
        let mut start = 0;
        for (p, w) in self.problems.iter().zip(ws.per_trial.iter_mut()) {
            let n = p.inputs().len();
            p.jacobian_with(x, w, &mut one)?;
            for j in 0..k {
                jac[j * m + start..j * m + start + n].copy_from_slice(&one[j * n..(j + 1) * n]);
            }
            start += n;
        }
        Ok(())
    }

    /// Weighted RMS torque error over all trials, `sqrt(SSE / Σw)` (N·m).
    pub fn rms_with(&self, x: &[f64], ws: &mut ProblemSetWorkspace) -> Result<f64, ModelError> {
        Ok((self.sse_with(x, ws)? / self.weight_sum).sqrt())
    }

    /// Each trial's weighted RMS torque error at `x` (N·m).
    pub fn rms_per_trial(&self, x: &[f64]) -> Result<Vec<f64>, ModelError> {
        self.problems.iter().map(|p| p.rms(x)).collect()
    }
}

fn problem_weight_sum(p: &Problem) -> f64 {
    p.weights()
        .map_or(p.inputs().len() as f64, |w| w.iter().sum())
}
