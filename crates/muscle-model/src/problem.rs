//! The identification problem: parameter vector ↔ model, bounds, the weighted sum-of-squares
//! cost (dissertation eq. 12)
//!
//! ```text
//! SSE(x) = Σᵢ wᵢ (τᵢ − τ̂ᵢ(x))²
//! ```
//!
//! and the log-likelihood of the residual under a [`NoiseLikelihood`] of [`crate::likelihood`].

use crate::effects::{EffectKind, Effects};
use crate::error::ModelError;
use crate::inputs::TrialInputs;
use crate::likelihood::{masked_log_likelihood, NoiseLikelihood};
use crate::params::{ModelParams, Muscle};
use crate::settings::SimSettings;
use crate::simulate::{predict_into, Target};
use crate::workspace::Workspace;
use serde::{Deserialize, Serialize};
use std::cell::RefCell;

/// Scalar muscle parameters addressable by name (`<muscle>.<field>`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum MuscleField {
    /// `fom_n` (F0).
    FomN,
    /// `lom_m` (LOM).
    LomM,
    /// `lst_m` (LST).
    LstM,
    /// `alpha_deg` (α0).
    AlphaDeg,
    /// `vmax_lom_per_s`.
    VmaxLomPerS,
}

impl MuscleField {
    /// All fields.
    pub const ALL: [MuscleField; 5] = [
        MuscleField::FomN,
        MuscleField::LomM,
        MuscleField::LstM,
        MuscleField::AlphaDeg,
        MuscleField::VmaxLomPerS,
    ];
    /// JSON key.
    pub fn name(self) -> &'static str {
        match self {
            MuscleField::FomN => "fom_n",
            MuscleField::LomM => "lom_m",
            MuscleField::LstM => "lst_m",
            MuscleField::AlphaDeg => "alpha_deg",
            MuscleField::VmaxLomPerS => "vmax_lom_per_s",
        }
    }
}

const ACTIVATION_FIELDS: [&str; 3] = ["tau_act_s", "tau_deact_s", "shape_a"];
const CURVE_FIELDS: [&str; 7] = ["af", "flen", "gamma", "kpe", "e0m", "e0t", "damping"];

/// Smallest half-width of α0's default interval (degrees): ±20 % of the value from 5° up.
const ALPHA_MIN_HALF_WIDTH_DEG: f64 = 1.0;

/// A named scalar parameter of the model or of an effect.
///
/// Names: `sol.lst_m`, `gm.fom_n`, … (muscle fields), `activation.<field>`, `curves.<field>`,
/// `<effect>.<param>` (e.g. `electromechanical_delay.delay_ms`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum ParamId {
    /// A muscle parameter.
    Muscle(Muscle, MuscleField),
    /// An activation parameter (index into `tau_act_s, tau_deact_s, shape_a`).
    Activation(usize),
    /// A curve parameter (index into `af, flen, gamma, kpe, e0m, e0t, damping`).
    Curve(usize),
    /// Parameter `index` of an effect (see [`EffectKind::params`]).
    Effect(EffectKind, usize),
}

impl ParamId {
    /// The 9 identified parameters (LST, F0 and α0 of each muscle), in the order `sol.lst_m, sol.fom_n,
    /// sol.alpha_deg, gm.lst_m, …, gl.alpha_deg`.
    pub fn identified() -> [ParamId; 9] {
        let mut out = [ParamId::Muscle(Muscle::Sol, MuscleField::LstM); 9];
        for (k, m) in Muscle::ALL.into_iter().enumerate() {
            out[3 * k] = ParamId::Muscle(m, MuscleField::LstM);
            out[3 * k + 1] = ParamId::Muscle(m, MuscleField::FomN);
            out[3 * k + 2] = ParamId::Muscle(m, MuscleField::AlphaDeg);
        }
        out
    }

    /// All 15 scalar muscle parameters (F0, LOM, LST, α0, vmax of each muscle).
    pub fn all_muscle() -> Vec<ParamId> {
        Muscle::ALL
            .into_iter()
            .flat_map(|m| MuscleField::ALL.map(|f| ParamId::Muscle(m, f)))
            .collect()
    }

    /// All parameters of an effect.
    pub fn of_effect(kind: EffectKind) -> Vec<ParamId> {
        (0..kind.params().len())
            .map(|i| ParamId::Effect(kind, i))
            .collect()
    }

    /// Parses a name such as `sol.lst_m` or `gravity.phase_deg`.
    pub fn parse(name: &str) -> Result<ParamId, ModelError> {
        let err = || ModelError::UnknownParam {
            name: name.to_string(),
        };
        let (head, tail) = name.split_once('.').ok_or_else(err)?;
        if let Some(m) = Muscle::from_name(head) {
            let f = MuscleField::ALL
                .into_iter()
                .find(|f| f.name() == tail)
                .ok_or_else(err)?;
            return Ok(ParamId::Muscle(m, f));
        }
        if head == "activation" {
            let i = ACTIVATION_FIELDS
                .iter()
                .position(|f| *f == tail)
                .ok_or_else(err)?;
            return Ok(ParamId::Activation(i));
        }
        if head == "curves" {
            let i = CURVE_FIELDS
                .iter()
                .position(|f| *f == tail)
                .ok_or_else(err)?;
            return Ok(ParamId::Curve(i));
        }
        let kind = EffectKind::from_name(head).ok_or_else(err)?;
        let i = kind.param_index(tail).ok_or_else(err)?;
        Ok(ParamId::Effect(kind, i))
    }

    /// The parameter's name (inverse of [`ParamId::parse`]).
    pub fn name(&self) -> String {
        match *self {
            ParamId::Muscle(m, f) => format!("{}.{}", m.name(), f.name()),
            ParamId::Activation(i) => format!("activation.{}", ACTIVATION_FIELDS[i]),
            ParamId::Curve(i) => format!("curves.{}", CURVE_FIELDS[i]),
            ParamId::Effect(k, i) => format!("{}.{}", k.name(), k.params()[i].name),
        }
    }

    /// The muscle this parameter belongs to, if any.
    pub fn muscle(&self) -> Option<Muscle> {
        match *self {
            ParamId::Muscle(m, _) => Some(m),
            _ => None,
        }
    }

    /// Current value in `params` / `effects` (an absent effect gives its null value; an absent
    /// `eccentric_enhancement.flen` gives `params.curves.flen`).
    pub fn get(&self, params: &ModelParams, effects: &Effects) -> f64 {
        match *self {
            ParamId::Muscle(m, f) => {
                let p = params.muscle(m);
                match f {
                    MuscleField::FomN => p.fom_n,
                    MuscleField::LomM => p.lom_m,
                    MuscleField::LstM => p.lst_m,
                    MuscleField::AlphaDeg => p.alpha_deg,
                    MuscleField::VmaxLomPerS => p.vmax_lom_per_s,
                }
            }
            ParamId::Activation(i) => {
                let a = &params.activation;
                [a.tau_act_s, a.tau_deact_s, a.shape_a][i]
            }
            ParamId::Curve(i) => {
                let c = &params.curves;
                [c.af, c.flen, c.gamma, c.kpe, c.e0m, c.e0t, c.damping][i]
            }
            ParamId::Effect(k, i) => effects.effective_value(k, i, params),
        }
    }

    /// Sets the value (enabling an absent effect at its null values first). No validation: the
    /// simulation validates.
    pub fn set(&self, params: &mut ModelParams, effects: &mut Effects, v: f64) {
        match *self {
            ParamId::Muscle(m, f) => {
                let p = params.muscle_mut(m);
                match f {
                    MuscleField::FomN => p.fom_n = v,
                    MuscleField::LomM => p.lom_m = v,
                    MuscleField::LstM => p.lst_m = v,
                    MuscleField::AlphaDeg => p.alpha_deg = v,
                    MuscleField::VmaxLomPerS => p.vmax_lom_per_s = v,
                }
            }
            ParamId::Activation(i) => {
                let a = &mut params.activation;
                *[&mut a.tau_act_s, &mut a.tau_deact_s, &mut a.shape_a][i] = v;
            }
            ParamId::Curve(i) => {
                let c = &mut params.curves;
                *[
                    &mut c.af,
                    &mut c.flen,
                    &mut c.gamma,
                    &mut c.kpe,
                    &mut c.e0m,
                    &mut c.e0t,
                    &mut c.damping,
                ][i] = v;
            }
            ParamId::Effect(k, i) => {
                let mut vals = effects.values(k).unwrap_or_else(|| {
                    let mut n = k.null_values();
                    if k == EffectKind::EccentricEnhancement {
                        n[0] = params.curves.flen;
                    }
                    n
                });
                vals[i] = v;
                effects.set_values(k, vals);
            }
        }
    }

    /// Default search bounds around the values in `base` (`docs/model.md` section 5): LST
    /// ±5 %, F0 ±20 %, α0 ±20 % but at least ±1° (never below 0°); other model parameters
    /// ±20 %, `shape_a` by at least ±20 % of its nominal value (0.016) inside [0, 0.12], and
    /// `flen` ≥ 1; effect parameters: their documented bounds.
    pub fn default_bounds(&self, base: &ModelParams, base_effects: &Effects) -> (f64, f64) {
        let v = self.get(base, base_effects);
        let rel = |f: f64| (v * (1.0 - f), v * (1.0 + f));
        match *self {
            ParamId::Muscle(_, MuscleField::LstM) => rel(0.05),
            // a muscle without pennation (α0 = 0, as some musculoskeletal models give it) would
            // get an empty interval from ±20 % of itself: at least ±1°, never below 0 (from 5°
            // up the relative interval, computed as it always was)
            ParamId::Muscle(_, MuscleField::AlphaDeg) if 0.2 * v < ALPHA_MIN_HALF_WIDTH_DEG => {
                let h = ALPHA_MIN_HALF_WIDTH_DEG;
                ((v - h).max(0.0), v + h)
            }
            ParamId::Muscle(_, _) => rel(0.20),
            // A = 0 (a linear activation, where CEINMS's calibrations often leave it) would get
            // an empty interval from ±20 % of itself: below the nominal shape the span is ±20 %
            // of the nominal one; from it up, ±20 % of the value as it always was
            ParamId::Activation(2) if v < ModelParams::nominal().activation.shape_a => {
                let h = 0.2 * ModelParams::nominal().activation.shape_a;
                ((v - h).max(0.0), (v + h).min(0.12))
            }
            ParamId::Activation(2) => (v * 0.8, (v * 1.2).min(0.12)),
            ParamId::Activation(_) => rel(0.20),
            ParamId::Curve(1) => ((v * 0.8).max(1.0), v * 1.2),
            ParamId::Curve(_) => rel(0.20),
            ParamId::Effect(k, i) => {
                let p = &k.params()[i];
                (p.lower, p.upper)
            }
        }
    }
}

impl std::fmt::Display for ParamId {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.name())
    }
}

impl Serialize for ParamId {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_str(&self.name())
    }
}

impl<'de> Deserialize<'de> for ParamId {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        let s = String::deserialize(d)?;
        ParamId::parse(&s).map_err(serde::de::Error::custom)
    }
}

/// Scratch memory for evaluating a [`Problem`] (one per thread).
#[derive(Clone, Debug, Default)]
pub struct ProblemWorkspace {
    sim: Workspace,
    pred: Vec<f64>,
}

impl ProblemWorkspace {
    /// An empty workspace.
    pub fn new() -> Self {
        ProblemWorkspace::default()
    }

    /// The prediction of the last evaluation.
    pub fn prediction(&self) -> &[f64] {
        &self.pred
    }
}

thread_local! {
    static SCRATCH: RefCell<ProblemWorkspace> = RefCell::new(ProblemWorkspace::new());
}

/// An identification problem: a trial, its measured torque, base parameters and effects, the
/// free parameters and their bounds.
///
/// `Problem` is `Sync`: evaluate it from several threads with one [`ProblemWorkspace`] each (the
/// methods without `_with` use a thread-local workspace).
#[derive(Clone, Debug)]
pub struct Problem {
    inputs: TrialInputs,
    measured: Vec<f64>,
    weights: Option<Vec<f64>>,
    weight_sum: f64,
    base_params: ModelParams,
    base_effects: Effects,
    free: Vec<ParamId>,
    names: Vec<String>,
    bounds: Vec<(f64, f64)>,
    settings: SimSettings,
}

impl Problem {
    /// A problem with free parameters `free` and their default bounds around the base values
    /// (see [`ParamId::default_bounds`]).
    pub fn new(
        inputs: TrialInputs,
        measured: Vec<f64>,
        base_params: ModelParams,
        base_effects: Effects,
        free: Vec<ParamId>,
    ) -> Result<Self, ModelError> {
        if measured.len() != inputs.len() {
            return Err(ModelError::Length {
                what: "measured torque".into(),
                expected: inputs.len(),
                got: measured.len(),
            });
        }
        if let Some(i) = measured.iter().position(|x| !x.is_finite()) {
            return Err(ModelError::input(
                "measured torque",
                format!("non-finite value at sample {i}"),
            ));
        }
        base_params.validate()?;
        base_effects.validate()?;
        // every evaluation would fail: say so once, here, rather than at each start
        let antagonist = base_effects.antagonist_coactivation.is_some()
            || free
                .iter()
                .any(|p| matches!(p, ParamId::Effect(EffectKind::AntagonistCoactivation, _)));
        if antagonist && inputs.envelope_ta().is_none() {
            return Err(ModelError::input(
                "env_ta",
                "the antagonist_coactivation effect needs the tibialis anterior's envelope \
                 (an emg_ta channel), which this trial does not have",
            ));
        }
        for (i, p) in free.iter().enumerate() {
            if free[..i].contains(p) {
                return Err(ModelError::invalid(
                    p.name(),
                    "listed twice among the free parameters",
                ));
            }
        }
        let bounds = free
            .iter()
            .map(|p| p.default_bounds(&base_params, &base_effects))
            .collect();
        let names = free.iter().map(|p| p.name()).collect();
        let n = inputs.len() as f64;
        Ok(Problem {
            inputs,
            measured,
            weights: None,
            weight_sum: n,
            base_params,
            base_effects,
            free,
            names,
            bounds,
            settings: SimSettings::default(),
        })
    }

    /// The standard problem: nominal parameters, no effects, the 9 identified parameters.
    pub fn standard(inputs: TrialInputs, measured: Vec<f64>) -> Result<Self, ModelError> {
        Problem::new(
            inputs,
            measured,
            ModelParams::nominal(),
            Effects::none(),
            ParamId::identified().to_vec(),
        )
    }

    /// Replaces the bounds (one `(lower, upper)` per free parameter, `lower < upper`).
    pub fn with_bounds(mut self, bounds: Vec<(f64, f64)>) -> Result<Self, ModelError> {
        if bounds.len() != self.free.len() {
            return Err(ModelError::Length {
                what: "bounds".into(),
                expected: self.free.len(),
                got: bounds.len(),
            });
        }
        for (k, &(lo, hi)) in bounds.iter().enumerate() {
            if !(lo.is_finite() && hi.is_finite() && lo < hi) {
                return Err(ModelError::invalid(
                    &self.names[k],
                    format!("bounds [{lo}, {hi}] are not an interval"),
                ));
            }
        }
        self.bounds = bounds;
        Ok(self)
    }

    /// Per-sample weights of the cost (`≥ 0`, not all zero); e.g. 0/1 to hold out cycles.
    pub fn with_weights(mut self, weights: Vec<f64>) -> Result<Self, ModelError> {
        if weights.len() != self.inputs.len() {
            return Err(ModelError::Length {
                what: "weights".into(),
                expected: self.inputs.len(),
                got: weights.len(),
            });
        }
        if weights.iter().any(|w| !(w.is_finite() && *w >= 0.0)) {
            return Err(ModelError::input(
                "weights",
                "must be finite and non-negative",
            ));
        }
        let s: f64 = weights.iter().sum();
        if s <= 0.0 {
            return Err(ModelError::input("weights", "all weights are zero"));
        }
        self.weight_sum = s;
        self.weights = Some(weights);
        Ok(self)
    }

    /// The problem on the samples `range` alone, with up to `lead_in` samples before it
    /// integrated but weighted 0: the simulation starts a window at equilibrium, and the lead-in
    /// lets activation and fibres settle before the window is judged. Free parameters, bounds,
    /// base values and settings are kept; weights inside the range are kept.
    ///
    /// # Errors
    /// As [`TrialInputs::window`]; [`ModelError::InvalidInput`] when every weight of `range` is 0.
    pub fn window(
        &self,
        range: std::ops::Range<usize>,
        lead_in: usize,
    ) -> Result<Problem, ModelError> {
        let start = range.start.saturating_sub(lead_in);
        let inputs = self.inputs.window(start..range.end)?;
        let weights = (start..range.end)
            .map(|i| {
                if i < range.start {
                    0.0
                } else {
                    self.weights.as_ref().map_or(1.0, |w| w[i])
                }
            })
            .collect();
        let mut p = Problem {
            inputs,
            measured: self.measured[start..range.end].to_vec(),
            weights: None,
            weight_sum: 0.0,
            base_params: self.base_params,
            base_effects: self.base_effects,
            free: self.free.clone(),
            names: self.names.clone(),
            bounds: self.bounds.clone(),
            settings: self.settings,
        };
        p = p.with_weights(weights)?;
        Ok(p)
    }

    /// Replaces the simulation settings.
    #[must_use]
    pub fn with_settings(mut self, settings: SimSettings) -> Self {
        self.settings = settings;
        self
    }

    /// Number of free parameters.
    pub fn dim(&self) -> usize {
        self.free.len()
    }

    /// Names of the free parameters (`sol.lst_m`, …).
    pub fn names(&self) -> &[String] {
        &self.names
    }

    /// The free parameters.
    pub fn free(&self) -> &[ParamId] {
        &self.free
    }

    /// Bounds of the free parameters.
    pub fn bounds(&self) -> &[(f64, f64)] {
        &self.bounds
    }

    /// The trial inputs.
    pub fn inputs(&self) -> &TrialInputs {
        &self.inputs
    }

    /// The measured torque.
    pub fn measured(&self) -> &[f64] {
        &self.measured
    }

    /// The sample weights, if any.
    pub fn weights(&self) -> Option<&[f64]> {
        self.weights.as_deref()
    }

    /// Base parameters (values of the parameters that are not free).
    pub fn base_params(&self) -> &ModelParams {
        &self.base_params
    }

    /// Base effects.
    pub fn base_effects(&self) -> &Effects {
        &self.base_effects
    }

    /// Simulation settings.
    pub fn settings(&self) -> &SimSettings {
        &self.settings
    }

    /// The base values of the free parameters as a vector.
    pub fn base_vector(&self) -> Vec<f64> {
        self.vector_from(&self.base_params, &self.base_effects)
    }

    /// The free parameters' values in `params` / `effects`.
    pub fn vector_from(&self, params: &ModelParams, effects: &Effects) -> Vec<f64> {
        self.free.iter().map(|p| p.get(params, effects)).collect()
    }

    /// Whether `x` lies inside the bounds.
    pub fn in_bounds(&self, x: &[f64]) -> bool {
        x.len() == self.dim()
            && x.iter()
                .zip(&self.bounds)
                .all(|(v, (lo, hi))| *v >= *lo && *v <= *hi)
    }

    /// The model at `x` (base values for everything not free).
    pub fn params_from_vector(&self, x: &[f64]) -> Result<(ModelParams, Effects), ModelError> {
        if x.len() != self.dim() {
            return Err(ModelError::Length {
                what: "parameter vector".into(),
                expected: self.dim(),
                got: x.len(),
            });
        }
        let mut p = self.base_params;
        let mut e = self.base_effects;
        for (id, &v) in self.free.iter().zip(x) {
            id.set(&mut p, &mut e, v);
        }
        Ok((p, e))
    }

    /// Predicted torque at `x` into `out` (length = samples).
    pub fn predict_with(
        &self,
        x: &[f64],
        ws: &mut ProblemWorkspace,
        out: &mut [f64],
    ) -> Result<(), ModelError> {
        let (p, e) = self.params_from_vector(x)?;
        predict_into(&mut ws.sim, &self.inputs, &p, &e, &self.settings, out, None)?;
        Ok(())
    }

    /// Whether [`Problem::jacobian_with`] covers every free parameter under this problem's
    /// effects and settings (`Err` says which one it does not).
    pub fn exact_jacobian_available(&self) -> Result<(), ModelError> {
        crate::derivatives::exact_derivative_available(
            &self.free,
            &self.base_effects_with_free(),
            &self.settings,
        )
    }

    /// The exact Jacobian `∂τ̂/∂x` of the predicted torque at `x` by forward sensitivities
    /// ([`crate::derivatives`]), column-major into `jac` (`jac[k·n + i]` for sample `i` and
    /// free parameter `k`; resized), and the prediction itself into the workspace
    /// ([`ProblemWorkspace::prediction`]).
    ///
    /// # Errors
    /// [`ModelError::NoExactDerivative`] for a free parameter or formulation it does not cover,
    /// the simulation's errors otherwise.
    pub fn jacobian_with(
        &self,
        x: &[f64],
        ws: &mut ProblemWorkspace,
        jac: &mut Vec<f64>,
    ) -> Result<(), ModelError> {
        let (p, e) = self.params_from_vector(x)?;
        crate::derivatives::exact_torque_jacobian(
            &self.inputs,
            &p,
            &e,
            &self.settings,
            &self.free,
            jac,
        )?;
        self.eval_pred(x, ws)
    }

    /// The base effects with every free effect parameter's effect enabled (as
    /// [`Problem::params_from_vector`] leaves them).
    fn base_effects_with_free(&self) -> Effects {
        let mut p = self.base_params;
        let mut e = self.base_effects;
        for id in &self.free {
            id.set(
                &mut p,
                &mut e,
                id.get(&self.base_params, &self.base_effects),
            );
        }
        e
    }

    /// Predicted torque at `x` (allocates the output).
    pub fn predict(&self, x: &[f64]) -> Result<Vec<f64>, ModelError> {
        let mut out = vec![0.0; self.inputs.len()];
        SCRATCH.with(|s| self.predict_with(x, &mut s.borrow_mut(), &mut out))?;
        Ok(out)
    }

    fn eval_pred(&self, x: &[f64], ws: &mut ProblemWorkspace) -> Result<(), ModelError> {
        let mut pred = std::mem::take(&mut ws.pred);
        pred.resize(self.inputs.len(), 0.0);
        let r = self.predict_with(x, ws, &mut pred);
        ws.pred = pred;
        r
    }

    /// Residual `measured − predicted` at `x` into `out`.
    pub fn residuals_with(
        &self,
        x: &[f64],
        ws: &mut ProblemWorkspace,
        out: &mut [f64],
    ) -> Result<(), ModelError> {
        self.predict_with(x, ws, out)?;
        for (o, m) in out.iter_mut().zip(&self.measured) {
            *o = m - *o;
        }
        Ok(())
    }

    /// Weighted sum of squared torque errors (dissertation eq. 12), `Σ wᵢ (τᵢ − τ̂ᵢ)²`.
    pub fn sse_with(&self, x: &[f64], ws: &mut ProblemWorkspace) -> Result<f64, ModelError> {
        let (p, e) = self.params_from_vector(x)?;
        let mut pred = std::mem::take(&mut ws.pred);
        pred.resize(self.inputs.len(), 0.0);
        let target = Target {
            measured: &self.measured,
            weights: self.weights.as_deref(),
        };
        let r = predict_into(
            &mut ws.sim,
            &self.inputs,
            &p,
            &e,
            &self.settings,
            &mut pred,
            Some(target),
        );
        ws.pred = pred;
        r
    }

    /// [`Problem::sse_with`] using a thread-local workspace.
    pub fn sse(&self, x: &[f64]) -> Result<f64, ModelError> {
        SCRATCH.with(|s| self.sse_with(x, &mut s.borrow_mut()))
    }

    /// Weighted RMS torque error `sqrt(SSE / Σ w)` (N·m).
    pub fn rms_with(&self, x: &[f64], ws: &mut ProblemWorkspace) -> Result<f64, ModelError> {
        Ok((self.sse_with(x, ws)? / self.weight_sum).sqrt())
    }

    /// [`Problem::rms_with`] using a thread-local workspace.
    pub fn rms(&self, x: &[f64]) -> Result<f64, ModelError> {
        SCRATCH.with(|s| self.rms_with(x, &mut s.borrow_mut()))
    }

    /// Log-likelihood of the measured torque at `x` under `noise`.
    ///
    /// Without weights the whole residual is one run. With weights, samples of zero weight are
    /// excluded and every maximal run of included samples is treated as an independent segment
    /// (weights act as a mask here, not as precisions).
    pub fn log_likelihood_with<N: NoiseLikelihood + ?Sized>(
        &self,
        x: &[f64],
        noise: &N,
        ws: &mut ProblemWorkspace,
    ) -> Result<f64, ModelError> {
        self.eval_pred(x, ws)?;
        for (p, m) in ws.pred.iter_mut().zip(&self.measured) {
            *p = m - *p;
        }
        let ll = masked_log_likelihood(noise, &ws.pred, self.weights.as_deref());
        if ll.is_finite() {
            Ok(ll)
        } else {
            Err(ModelError::NonFinite {
                what: "log-likelihood",
                index: 0,
            })
        }
    }

    /// [`Problem::log_likelihood_with`] using a thread-local workspace.
    pub fn log_likelihood<N: NoiseLikelihood + ?Sized>(
        &self,
        x: &[f64],
        noise: &N,
    ) -> Result<f64, ModelError> {
        SCRATCH.with(|s| self.log_likelihood_with(x, noise, &mut s.borrow_mut()))
    }
}
