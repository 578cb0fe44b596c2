//! Fitting a model (the 9 muscle parameters plus the parameters of a set of effects) by whitened least squares, and its cycle-wise cross-validation.

use muscle_model::{EffectKind, Effects, ModelParams, ParamId, Problem, TrialInputs};
use nalgebra::DMatrix;
use rayon::prelude::*;

use crate::lm::{minimise, LmSettings};
use crate::noise::{NoiseModel, WhitenPlan};
use crate::segment::Segmentation;
use crate::DiagnoseError;

/// Everything a fit needs that does not change between models.
pub(crate) struct Context {
    pub inputs: TrialInputs,
    /// Measured torque minus the dynamometer's systematic part.
    pub y: Vec<f64>,
    pub noise: NoiseModel,
    pub seg: Segmentation,
    pub plan: WhitenPlan,
    /// Per fold: held-out mask (true = held out) and the plan of the training samples.
    pub folds: Vec<(Vec<bool>, WhitenPlan)>,
    pub lm: LmSettings,
    pub cv_lm: LmSettings,
}

/// A fitted model.
#[derive(Clone, Debug)]
pub(crate) struct Fit {
    pub kinds: Vec<EffectKind>,
    pub free: Vec<ParamId>,
    pub x: Vec<f64>,
    pub pred: Vec<f64>,
    /// Whitened residual.
    pub white: Vec<f64>,
    pub white_ss: f64,
    pub loglik: f64,
    pub rms: f64,
    /// Whitened Jacobian (x units).
    pub jac: DMatrix<f64>,
    pub heldout_rms: f64,
    pub evaluations: usize,
}

impl Fit {
    pub fn k(&self) -> usize {
        self.x.len()
    }
    pub fn bic(&self, n: usize) -> f64 {
        -2.0 * self.loglik + self.k() as f64 * (n as f64).ln()
    }
}

/// Effects at their null values for each kind.
pub(crate) fn base_effects(kinds: &[EffectKind]) -> Effects {
    let mut e = Effects::none();
    for k in kinds {
        e = e.with_null(*k);
    }
    e
}

pub(crate) fn free_params(kinds: &[EffectKind]) -> Vec<ParamId> {
    let mut free = ParamId::identified().to_vec();
    for k in kinds {
        free.extend(ParamId::of_effect(*k));
    }
    free
}

pub(crate) fn model_name(kinds: &[EffectKind]) -> String {
    let mut s = String::from("baseline");
    for k in kinds {
        s.push('+');
        s.push_str(k.name());
    }
    s
}

impl Context {
    pub fn problem(&self, kinds: &[EffectKind]) -> Result<Problem, DiagnoseError> {
        Ok(Problem::new(
            self.inputs.clone(),
            self.y.clone(),
            ModelParams::nominal(),
            base_effects(kinds),
            free_params(kinds),
        )?)
    }

    fn residual_fn<'a>(
        &'a self,
        problem: &'a Problem,
        plan: &'a WhitenPlan,
    ) -> impl Fn(&[f64]) -> Option<Vec<f64>> + Sync + 'a {
        move |x: &[f64]| {
            let pred = problem.predict(x).ok()?;
            let e: Vec<f64> = self.y.iter().zip(&pred).map(|(a, b)| a - b).collect();
            let mut w = vec![0.0; e.len()];
            plan.whiten(&e, &mut w);
            if w.iter().all(|v| v.is_finite()) {
                Some(w)
            } else {
                None
            }
        }
    }

    /// Fits `kinds` from `x0` (full vector: 9 muscle params then effect params).
    pub fn fit(&self, kinds: &[EffectKind], x0: &[f64], cv: bool) -> Result<Fit, DiagnoseError> {
        let name = model_name(kinds);
        let problem = self.problem(kinds)?;
        let bounds = problem.bounds().to_vec();
        let f = self.residual_fn(&problem, &self.plan);
        let mut out = minimise(&f, x0, &bounds, &self.lm).ok_or_else(|| DiagnoseError::Fit {
            model: name.clone(),
            reason: "the model cannot be simulated at the start point".into(),
        })?;
        // An extended model starts from the current fit, whose muscle parameters may sit at
        // their bounds because they were standing in for the missing effect (e.g. sol α0 and
        // F0 at their upper bounds mimicking an antagonist torque); from there the bounded LM
        // can stop in that corner. A second start with the muscle parameters at their base
        // (nominal) values and the same effect start; the lower cost wins.
        if !kinds.is_empty() {
            let base = problem.base_vector();
            let mut x1 = x0.to_vec();
            for (i, id) in problem.free().iter().enumerate() {
                if id.muscle().is_some() {
                    x1[i] = base[i].clamp(bounds[i].0, bounds[i].1);
                }
            }
            if x1 != x0 {
                if let Some(alt) = minimise(&f, &x1, &bounds, &self.lm) {
                    let evaluations = out.evaluations + alt.evaluations;
                    if alt.cost < out.cost {
                        out = alt;
                    }
                    out.evaluations = evaluations;
                }
            }
        }
        let pred = problem.predict(&out.x)?;
        let n = pred.len();
        let rms = (self
            .y
            .iter()
            .zip(&pred)
            .map(|(a, b)| (a - b) * (a - b))
            .sum::<f64>()
            / n as f64)
            .sqrt();
        let mut fit = Fit {
            kinds: kinds.to_vec(),
            free: problem.free().to_vec(),
            x: out.x.clone(),
            pred,
            white_ss: out.cost,
            loglik: self.plan.log_likelihood(out.cost),
            white: out.residual,
            rms,
            jac: out.jacobian,
            heldout_rms: f64::NAN,
            evaluations: out.evaluations,
        };
        if cv {
            let (h, ev) = self.cross_validate(&problem, &out.x);
            fit.heldout_rms = h;
            fit.evaluations += ev;
        }
        Ok(fit)
    }

    /// Cycle-wise cross-validation: refit without each cycle, predict it; pooled held-out RMS.
    fn cross_validate(&self, problem: &Problem, x: &[f64]) -> (f64, usize) {
        let bounds = problem.bounds();
        let res: Vec<(f64, usize, usize)> = self
            .folds
            .par_iter()
            .map(|(held, plan)| {
                let f = self.residual_fn(problem, plan);
                let (xf, ev) = match minimise(&f, x, bounds, &self.cv_lm) {
                    Some(o) => (o.x, o.evaluations),
                    None => (x.to_vec(), 0),
                };
                let pred = problem
                    .predict(&xf)
                    .unwrap_or_else(|_| vec![0.0; self.y.len()]);
                let mut ss = 0.0;
                let mut cnt = 0;
                for i in 0..pred.len() {
                    if held[i] {
                        ss += (self.y[i] - pred[i]).powi(2);
                        cnt += 1;
                    }
                }
                (ss, cnt, ev)
            })
            .collect();
        let ss: f64 = res.iter().map(|r| r.0).sum();
        let cnt: usize = res.iter().map(|r| r.1).sum();
        let ev: usize = res.iter().map(|r| r.2).sum();
        ((ss / cnt.max(1) as f64).sqrt(), ev)
    }
}
