//! The sensitivity of the model torque to the identified parameters.
//!
//! By default ([`JacobianMethod::Exact`]) column `j`, `∂τ/∂θⱼ`, is the model's exact
//! derivative: forward sensitivities integrated with the fibre states under one step control
//! ([`muscle_model::Problem::jacobian_with`]), at tight tolerances (rtol 10⁻¹⁰). It has no
//! difference step and no integration jitter.
//!
//! [`JacobianMethod::Central`] differences instead: `(τ(θ + hⱼeⱼ) − τ(θ − hⱼeⱼ))/(2hⱼ)` with
//! `hⱼ = s·(uⱼ − lⱼ)`, a share `s` of the parameter's bound width (`s = 4·10⁻³`). The adaptive
//! integrator makes the torque jitter when a parameter moves by a hair, so that step is not
//! tiny; its truncation error, `O(h²)`, is what separates it from the exact columns (tested).

use muscle_model::{
    simulate, Effects, Formulation, ModelParams, ParamId, Problem, ProblemWorkspace, SimSettings,
    TrialInputs,
};
use rayon::prelude::*;

use crate::error::{DesignError, Result};

/// How the Jacobian's columns are taken.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum JacobianMethod {
    /// The model's exact derivative by forward sensitivities (default).
    Exact,
    /// Central differences with a step of this share of each parameter's bound width, in
    /// `(0, 0.25]`.
    Central {
        /// The step's share of the bound width (4·10⁻³ in the documentation's comparisons).
        rel_step: f64,
    },
}

impl JacobianMethod {
    /// `"exact"` or `"central"`, as `design.json` names it.
    pub fn name(&self) -> &'static str {
        match self {
            JacobianMethod::Exact => "exact",
            JacobianMethod::Central { .. } => "central",
        }
    }

    /// The difference step, `None` for the exact Jacobian.
    pub fn rel_step(&self) -> Option<f64> {
        match *self {
            JacobianMethod::Exact => None,
            JacobianMethod::Central { rel_step } => Some(rel_step),
        }
    }
}

/// How the Jacobian is taken.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct JacobianSettings {
    /// Integration settings of every simulation: the tight tolerances of
    /// [`SimSettings::tight`] (rtol 10⁻¹⁰) with the fast formulation, the one the sensitivities
    /// are integrated with.
    pub sim: SimSettings,
    /// Exact, or differenced.
    pub method: JacobianMethod,
}

impl Default for JacobianSettings {
    fn default() -> Self {
        Self {
            sim: SimSettings {
                formulation: Formulation::Fast,
                ..SimSettings::tight()
            },
            method: JacobianMethod::Exact,
        }
    }
}

/// `∂τ/∂θ` of one trial at one parameter point.
#[derive(Clone, Debug, PartialEq)]
pub struct TorqueJacobian {
    /// The parameters, in column order.
    pub params: Vec<ParamId>,
    /// Their values at the point.
    pub values: Vec<f64>,
    /// Their bounds (the width sets the step and the prior).
    pub bounds: Vec<(f64, f64)>,
    /// Column `j`: `∂τ(t)/∂θⱼ` at every sample (N·m per parameter unit).
    pub columns: Vec<Vec<f64>>,
    /// Sampling interval of the trial (s).
    pub dt_s: f64,
}

/// The torque Jacobian of `inputs` with respect to the 9 identified parameters at `params`
/// (bounds: LST ±5 %, F0 and α0 ±20 % around `params`). Differenced, the `2·9` simulations
/// run in parallel; the result does not depend on the number of threads.
///
/// # Errors
/// [`DesignError::Invalid`] for a step outside `(0, 0.25]`; [`DesignError::Simulation`]
/// naming the parameter when a perturbed simulation fails (`all` when the exact Jacobian's
/// integration fails).
pub fn torque_jacobian(
    trial: &str,
    inputs: &TrialInputs,
    params: &ModelParams,
    settings: &JacobianSettings,
) -> Result<TorqueJacobian> {
    let ids = ParamId::identified().to_vec();
    let none = Effects::none();
    let values: Vec<f64> = ids.iter().map(|id| id.get(params, &none)).collect();
    let bounds: Vec<(f64, f64)> = ids
        .iter()
        .map(|id| id.default_bounds(params, &none))
        .collect();
    let t = inputs.times();
    let dt_s = if t.len() > 1 {
        (t[t.len() - 1] - t[0]) / (t.len() - 1) as f64
    } else {
        0.0
    };
    let columns = match settings.method {
        JacobianMethod::Exact => exact_columns(trial, inputs, params, &ids, &settings.sim)?,
        JacobianMethod::Central { rel_step } => central_columns(
            trial,
            inputs,
            params,
            &ids,
            &bounds,
            rel_step,
            &settings.sim,
        )?,
    };
    Ok(TorqueJacobian {
        params: ids,
        values,
        bounds,
        columns,
        dt_s,
    })
}

/// The exact columns ([`muscle_model::Problem::jacobian_with`]).
fn exact_columns(
    trial: &str,
    inputs: &TrialInputs,
    params: &ModelParams,
    ids: &[ParamId],
    sim: &SimSettings,
) -> Result<Vec<Vec<f64>>> {
    let n = inputs.len();
    let failed = |reason: String| DesignError::Simulation {
        trial: trial.to_string(),
        param: "all".into(),
        value: f64::NAN,
        reason,
    };
    let problem = Problem::new(
        inputs.clone(),
        vec![0.0; n],
        *params,
        Effects::none(),
        ids.to_vec(),
    )
    .map_err(|e| failed(e.to_string()))?
    .with_settings(*sim);
    let mut jac = Vec::new();
    problem
        .jacobian_with(
            &problem.base_vector(),
            &mut ProblemWorkspace::new(),
            &mut jac,
        )
        .map_err(|e| failed(e.to_string()))?;
    Ok(jac.chunks(n).map(<[f64]>::to_vec).collect())
}

/// Central differences of step `rel_step` of each bound width.
fn central_columns(
    trial: &str,
    inputs: &TrialInputs,
    params: &ModelParams,
    ids: &[ParamId],
    bounds: &[(f64, f64)],
    rel_step: f64,
    sim: &SimSettings,
) -> Result<Vec<Vec<f64>>> {
    if !(rel_step > 0.0 && rel_step <= 0.25) {
        return Err(DesignError::Invalid {
            what: "rel_step",
            reason: format!("{rel_step} is outside (0, 0.25]"),
        });
    }
    let values: Vec<f64> = ids
        .iter()
        .map(|id| id.get(params, &Effects::none()))
        .collect();
    let jobs: Vec<(usize, f64)> = (0..ids.len()).flat_map(|j| [(j, 1.0), (j, -1.0)]).collect();
    let torques: Vec<Result<Vec<f64>>> = jobs
        .par_iter()
        .map(|&(j, sign)| {
            let h = rel_step * (bounds[j].1 - bounds[j].0);
            let v = values[j] + sign * h;
            let mut p = *params;
            let mut e = Effects::none();
            ids[j].set(&mut p, &mut e, v);
            simulate(inputs, &p, &e, sim)
                .map(|o| o.torque)
                .map_err(|err| DesignError::Simulation {
                    trial: trial.to_string(),
                    param: ids[j].name(),
                    value: v,
                    reason: err.to_string(),
                })
        })
        .collect();
    let mut columns = Vec::with_capacity(ids.len());
    let mut it = torques.into_iter();
    for (lo, hi) in bounds {
        let plus = it.next().expect("two runs per parameter")?;
        let minus = it.next().expect("two runs per parameter")?;
        let h = rel_step * (hi - lo);
        columns.push(
            plus.iter()
                .zip(&minus)
                .map(|(a, b)| (a - b) / (2.0 * h))
                .collect(),
        );
    }
    Ok(columns)
}
