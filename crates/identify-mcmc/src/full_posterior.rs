//! The posterior of every free parameter in its box, with its exact gradient: the target of
//! the gradient-based sampler on a session's trials.
//!
//! With a uniform prior on the box, trial `t`'s whitened residual `ẽ_t = W_t(y_t − τ̂_t(x))`,
//! `õ_t = W_t·1` and its constant-offset nuisance of prior sd `s_t` integrated out
//! (`κ_t = s_t²/(1 + s_t²|õ_t|²)`),
//!
//! ```text
//! log π(x) = Σ_t [ N_t − ½(ẽ_tᵀẽ_t − κ_t(õ_tᵀẽ_t)²) ]
//! ∇ log π(x) = Σ_t (W_t J_t)ᵀ (ẽ_t − κ_t õ_t (õ_tᵀẽ_t)),    J_t = ∂τ̂_t/∂x
//! ```
//!
//! (`N_t` the normalisation of module `trial_term`). The whitening is linear and its gains do
//! not depend on the data, so a whitened Jacobian column is the whitened column; `J_t` is the
//! model's exact Jacobian ([`muscle_model::Problem::jacobian_with`], forward sensitivities), so
//! the gradient is that of the log density itself, not a difference of two simulations.

use std::cell::RefCell;

use muscle_model::{MuscleField, ParamId, Problem, ProblemWorkspace};

use crate::target::{GradLogDensity, LogDensity};
use crate::trial_term::{TrialModel, TrialTerm};

/// The box the posterior is sampled on: `problem`'s bounds with each F0 capped at the model's
/// limit ([`muscle_model::params::MAX_FOM_N`]). A recording's F0 bounds are multiples of a
/// reference force and can pass it; the model refuses such parameters, and a density of −∞
/// inside the box would end every trajectory that reaches that part of it.
pub(crate) fn sampled_bounds(problem: &Problem) -> Vec<(f64, f64)> {
    problem
        .free()
        .iter()
        .zip(problem.bounds())
        .map(|(id, &(lo, hi))| match id {
            ParamId::Muscle(_, MuscleField::FomN) => {
                let cap = muscle_model::params::MAX_FOM_N;
                (lo.min(cap), hi.min(cap))
            }
            _ => (lo, hi),
        })
        .collect()
}

/// One trial's part of [`FullPosterior`].
struct FullTrial<'a> {
    term: TrialTerm<'a>,
    /// `õ = W·1` over the included samples.
    ones: Vec<f64>,
    /// `κ` (0 without an offset nuisance).
    kappa: f64,
    /// `N_t`, the normalisation with the offset's determinant.
    norm: f64,
}

/// The log posterior density of the module documentation on the first trial's bounds.
pub(crate) struct FullPosterior<'a> {
    trials: Vec<FullTrial<'a>>,
    bounds: Vec<(f64, f64)>,
}

/// Buffers of one evaluation, kept per thread so that a gradient allocates nothing once warm.
#[derive(Default)]
struct Scratch {
    /// One workspace per trial (a workspace keeps its trial's channels).
    workspaces: Vec<ProblemWorkspace>,
    /// The prediction of a value-only evaluation.
    prediction: Vec<f64>,
    /// The residual, then its whitened form `ẽ`, then `v = ẽ − κõ(õᵀẽ)`.
    residual: Vec<f64>,
    whitened: Vec<f64>,
    /// The model's Jacobian, column-major.
    jacobian: Vec<f64>,
    /// One whitened Jacobian column `W J_k` over the included samples.
    column: Vec<f64>,
}

thread_local! {
    static SCRATCH: RefCell<Scratch> = RefCell::new(Scratch::default());
}

impl<'a> FullPosterior<'a> {
    pub(crate) fn new(models: &[TrialModel<'a>]) -> Self {
        let trials = models
            .iter()
            .map(|m| {
                let term = TrialTerm::new(m);
                let n = m.problem.measured().len();
                let mut ones = Vec::new();
                term.whiten_append(&vec![1.0; n], &mut ones);
                let s2 = term.offset_sd() * term.offset_sd();
                let oo: f64 = ones.iter().map(|v| v * v).sum();
                let (kappa, log_offset) = if s2 > 0.0 {
                    (s2 / (1.0 + s2 * oo), -0.5 * (s2 * oo).ln_1p())
                } else {
                    (0.0, 0.0)
                };
                FullTrial {
                    norm: term.log_norm() + log_offset,
                    term,
                    ones,
                    kappa,
                }
            })
            .collect();
        FullPosterior {
            trials,
            bounds: sampled_bounds(models[0].problem),
        }
    }

    /// `log π(x)`, and its gradient into `grad` when given.
    fn evaluate_with(&self, x: &[f64], mut grad: Option<&mut [f64]>) -> Option<f64> {
        SCRATCH.with(|cell| {
            let s = &mut *cell.borrow_mut();
            if s.workspaces.len() < self.trials.len() {
                s.workspaces
                    .resize_with(self.trials.len(), ProblemWorkspace::new);
            }
            if let Some(g) = grad.as_deref_mut() {
                g.fill(0.0);
            }
            let mut total = 0.0;
            for (t, ws) in self.trials.iter().zip(s.workspaces.iter_mut()) {
                let problem = t.term.problem;
                let n = problem.measured().len();
                let pred: &[f64] = if grad.is_some() {
                    problem.jacobian_with(x, ws, &mut s.jacobian).ok()?;
                    ws.prediction()
                } else {
                    s.prediction.resize(n, 0.0);
                    problem.predict_with(x, ws, &mut s.prediction).ok()?;
                    &s.prediction
                };
                s.residual.clear();
                s.residual
                    .extend(problem.measured().iter().zip(pred).map(|(y, p)| y - p));
                s.whitened.clear();
                t.term.whiten_append(&s.residual, &mut s.whitened);
                let we = &mut s.whitened;
                let ee: f64 = we.iter().map(|v| v * v).sum();
                let oe: f64 = we.iter().zip(&t.ones).map(|(a, b)| a * b).sum();
                total += t.norm - 0.5 * (ee - t.kappa * oe * oe);
                let Some(g) = grad.as_deref_mut() else {
                    continue;
                };
                // v = ẽ − κ õ (õᵀẽ); ∂/∂x_k = (W J_k)ᵀ v
                for (v, o) in we.iter_mut().zip(&t.ones) {
                    *v -= t.kappa * o * oe;
                }
                for (k, gk) in g.iter_mut().enumerate() {
                    s.column.clear();
                    t.term
                        .whiten_append(&s.jacobian[k * n..(k + 1) * n], &mut s.column);
                    *gk += s
                        .column
                        .iter()
                        .zip(we.iter())
                        .map(|(a, b)| a * b)
                        .sum::<f64>();
                }
            }
            let finite = total.is_finite()
                && grad
                    .as_deref()
                    .is_none_or(|g| g.iter().all(|v| v.is_finite()));
            finite.then_some(total)
        })
    }
}

impl LogDensity for FullPosterior<'_> {
    fn dim(&self) -> usize {
        self.bounds.len()
    }
    fn bounds(&self) -> &[(f64, f64)] {
        &self.bounds
    }
    fn log_density(&self, x: &[f64]) -> Option<f64> {
        self.evaluate_with(x, None)
    }
}

impl GradLogDensity for FullPosterior<'_> {
    fn log_density_grad(&self, x: &[f64], grad: &mut [f64]) -> Option<f64> {
        self.evaluate_with(x, Some(grad))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::identify::{McmcNoiseSource, NoiseSpec};
    use crate::noise::NoiseKind;
    use experiment::{synthesize, SynthConfig};
    use muscle_model::{Problem, SimSettings};

    #[test]
    fn the_gradient_is_the_derivative_of_the_log_density() {
        // a second of the synthetic seed trial (with a lead-in weighted 0, so two segments are
        // not needed: the weights mask it), an offset nuisance, tight integration so that
        // central differences of the log density are a reference
        let syn = synthesize(&SynthConfig::new("seed".parse().unwrap(), 3)).unwrap();
        let fs = 2048;
        let problem = Problem::standard(syn.inputs.clone(), syn.trial.torque_nm.clone())
            .unwrap()
            .window(2 * fs..3 * fs, fs / 4)
            .unwrap()
            .with_settings(SimSettings {
                rtol: 1e-12,
                atol: 1e-14,
                max_steps: 10_000_000,
                ..SimSettings::default()
            });
        let spec =
            NoiseSpec::from_unloaded(&syn.trial, &syn.unloaded, NoiseKind::Ar1White).unwrap();
        let McmcNoiseSource::Fixed(noise) = spec.source else {
            panic!("an unloaded run gives a fixed noise model")
        };
        let model = TrialModel {
            problem: &problem,
            noise: noise.model().unwrap(),
            offset_sd: 0.5,
        };
        let target = FullPosterior::new(&[model]);
        let bounds = problem.bounds().to_vec();
        for f in [0.3, 0.7] {
            let x: Vec<f64> = bounds.iter().map(|(lo, hi)| lo + f * (hi - lo)).collect();
            let mut g = vec![0.0; x.len()];
            let lp = target.log_density_grad(&x, &mut g).unwrap();
            assert_eq!(Some(lp), target.log_density(&x));
            for k in 0..x.len() {
                let h = 1e-6 * (bounds[k].1 - bounds[k].0);
                let at = |d: f64| {
                    let mut y = x.clone();
                    y[k] += d;
                    target.log_density(&y).unwrap()
                };
                let fd = (at(h) - at(-h)) / (2.0 * h);
                let scale = g[k]
                    .abs()
                    .max(1e-3 * g.iter().fold(0.0f64, |m, v| m.max(v.abs())));
                assert!(
                    (g[k] - fd).abs() < 1e-4 * scale,
                    "{}: exact {} against differences {fd}",
                    problem.names()[k],
                    g[k]
                );
            }
        }
    }
}
