//! The sensitivity of the model torque to the identified parameters, by central differences.
//!
//! Column `j` is `∂τ/∂θⱼ ≈ (τ(θ + hⱼeⱼ) − τ(θ − hⱼeⱼ))/(2hⱼ)` with `hⱼ = s·(uⱼ − lⱼ)`, a share
//! `s` of the parameter's bound width (default `s = 4·10⁻³`). The adaptive integrator makes the
//! torque jitter by about its tolerance when a parameter moves by a hair, so the step is not
//! tiny and the simulation is solved tightly ([`SimSettings::tight`], rtol 10⁻¹⁰): the
//! truncation error, `O(h²)`, then dominates and halving `s` changes the columns by well
//! under 1 % (tested).

use muscle_model::{simulate, Effects, ModelParams, ParamId, SimSettings, TrialInputs};
use rayon::prelude::*;

use crate::error::{DesignError, Result};

/// How the Jacobian is differenced.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct JacobianSettings {
    /// Integration settings of every simulation ([`SimSettings::tight`]).
    pub sim: SimSettings,
    /// Difference step as a share of each parameter's bound width, in `(0, 0.25]` (4·10⁻³).
    pub rel_step: f64,
}

impl Default for JacobianSettings {
    fn default() -> Self {
        Self {
            sim: SimSettings::tight(),
            rel_step: 4e-3,
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
/// (bounds: LST ±5 %, F0 and α0 ±20 % around `params`). The `2·9` simulations run in
/// parallel; the result does not depend on the number of threads.
///
/// # Errors
/// [`DesignError::Invalid`] for a step outside `(0, 0.25]`; [`DesignError::Simulation`]
/// naming the parameter when a perturbed simulation fails.
pub fn torque_jacobian(
    trial: &str,
    inputs: &TrialInputs,
    params: &ModelParams,
    settings: &JacobianSettings,
) -> Result<TorqueJacobian> {
    if !(settings.rel_step > 0.0 && settings.rel_step <= 0.25) {
        return Err(DesignError::Invalid {
            what: "rel_step",
            reason: format!("{} is outside (0, 0.25]", settings.rel_step),
        });
    }
    let ids = ParamId::identified().to_vec();
    let none = Effects::none();
    let values: Vec<f64> = ids.iter().map(|id| id.get(params, &none)).collect();
    let bounds: Vec<(f64, f64)> = ids
        .iter()
        .map(|id| id.default_bounds(params, &none))
        .collect();
    let jobs: Vec<(usize, f64)> = (0..ids.len()).flat_map(|j| [(j, 1.0), (j, -1.0)]).collect();
    let torques: Vec<Result<Vec<f64>>> = jobs
        .par_iter()
        .map(|&(j, sign)| {
            let h = settings.rel_step * (bounds[j].1 - bounds[j].0);
            let v = values[j] + sign * h;
            let mut p = *params;
            let mut e = Effects::none();
            ids[j].set(&mut p, &mut e, v);
            simulate(inputs, &p, &e, &settings.sim)
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
    for (lo, hi) in &bounds {
        let plus = it.next().expect("two runs per parameter")?;
        let minus = it.next().expect("two runs per parameter")?;
        let h = settings.rel_step * (hi - lo);
        columns.push(
            plus.iter()
                .zip(&minus)
                .map(|(a, b)| (a - b) / (2.0 * h))
                .collect(),
        );
    }
    let t = inputs.times();
    let dt_s = if t.len() > 1 {
        (t[t.len() - 1] - t[0]) / (t.len() - 1) as f64
    } else {
        0.0
    };
    Ok(TorqueJacobian {
        params: ids,
        values,
        bounds,
        columns,
        dt_s,
    })
}
