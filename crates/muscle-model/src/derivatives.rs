//! The exact Jacobian of the predicted torque with respect to free parameters
//! ([`exact_torque_jacobian`]), by forward sensitivities.
//!
//! The torque is `τ = τ_effects + Σ_j F0_j·fT(ε_j)·r_j`, `ε_j = (LMT_j − LM_j·cos α_j − LST_j)/LST_j`.
//! Its derivative with respect to a parameter `θ` of muscle `j`'s fibre (`LOM`, `LST`, `α0`,
//! `vmax`, a curve constant, `Flen`) is
//!
//! ```text
//! ∂τ/∂θ = Σ_j F0_j·r_j·fT′(ε_j)·(∂ε_j/∂θ + ∂ε_j/∂LM·s_j),    s_j = ∂LM_j/∂θ
//! ```
//!
//! with `s_j` integrated beside `LM_j` under the simulation's own step control (see the
//! variational equation in the crate's fast simulation). `∂τ/∂F0_j = fT(ε_j)·r_j`, and the
//! joint-level terms (offset, passive moment, gravity, damping, inertia, antagonist gain) are
//! explicit functions of their parameters. Every partial derivative of the right-hand side is
//! computed in dual numbers through the same code the simulation runs, so none is a
//! difference quotient, and a column does not jitter as the parameter moves: a difference of
//! two adaptive integrations moves by up to 10⁻² N·m for a change of 10⁻¹² in a parameter
//! (`docs/model.md`, "Integration jitter"); this derivative moves smoothly.
//!
//! The activation's shape `A` and the electromechanical delay move every muscle's drive (the
//! tabulated activation); their derivatives enter the same variational equation through
//! `∂vM/∂act` (the crate's fast simulation, module `sensitivity`).
//!
//! What it covers: the [`Formulation::Fast`] simulation (the default) and the parameters
//! above. The activation time constants and fatigue change the activation by an integration
//! of their own (and with fatigue on, neither shape nor delay is covered); their columns are
//! not exact here and the call fails with [`ModelError::NoExactDerivative`] naming the
//! parameter, so that a caller can difference them instead ([`exact_derivative_available`]
//! says beforehand).

use crate::effects::{EffectKind, Effects};
use crate::error::ModelError;
use crate::fast_simulation::{
    drive_derivative, dual, eps_of, initial_length, run_sensitivities, DriveSeat, Fibre,
    FibreValues, SensitivityTrace,
};
use crate::inputs::TrialInputs;
use crate::joint_effects::{delay_s, joint_effect_derivative, run_ta};
use crate::muscle_torque::{envelope_of, fast_prepare, integration_error};
use crate::musculotendon::MuscleUnit;
use crate::params::{ModelParams, Muscle};
use crate::problem::{MuscleField, ParamId};
use crate::settings::{Formulation, SimSettings};
use crate::stats::SimStats;
use num_dual::{Dual64, DualSVec64};

/// The value of a muscle's fibre a parameter moves.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Seat {
    Lom,
    Lst,
    Alpha,
    Vmax,
    /// Curve constant `af, flen, gamma, kpe, e0m, e0t, damping` by index.
    Curve(usize),
    /// Not a fibre value: what moves the activation the fibre is driven by.
    Drive(DriveSeat),
}

/// How one free parameter enters the torque.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Route {
    /// `F0` of a triceps muscle: the muscle's unit torque.
    Scale(Muscle),
    /// A value of one muscle's fibre (`None`: of every muscle, the fixed ones included).
    Fibre(Option<Muscle>, Seat),
    /// A joint-level effect's parameter.
    Joint(EffectKind, usize),
    /// A parameter without influence here (`curves.flen` under `eccentric_enhancement`).
    Zero,
}

fn route(p: ParamId, effects: &Effects) -> Result<Route, ModelError> {
    let refuse = |reason| ModelError::NoExactDerivative {
        param: p.name(),
        reason,
    };
    Ok(match p {
        ParamId::Muscle(m, MuscleField::FomN) => Route::Scale(m),
        ParamId::Muscle(m, MuscleField::LomM) => Route::Fibre(Some(m), Seat::Lom),
        ParamId::Muscle(m, MuscleField::LstM) => Route::Fibre(Some(m), Seat::Lst),
        ParamId::Muscle(m, MuscleField::AlphaDeg) => Route::Fibre(Some(m), Seat::Alpha),
        ParamId::Muscle(m, MuscleField::VmaxLomPerS) => Route::Fibre(Some(m), Seat::Vmax),
        ParamId::Curve(1) if effects.eccentric_enhancement.is_some() => Route::Zero,
        ParamId::Curve(i) => Route::Fibre(None, Seat::Curve(i)),
        ParamId::Effect(EffectKind::EccentricEnhancement, _) => Route::Fibre(None, Seat::Curve(1)),
        ParamId::Activation(_) | ParamId::Effect(EffectKind::ElectromechanicalDelay, _)
            if effects.fatigue.is_some() =>
        {
            return Err(refuse(
                "with fatigue on, the activation's parameters change the fatigue factor too",
            ))
        }
        ParamId::Activation(2) => Route::Fibre(None, Seat::Drive(DriveSeat::Shape)),
        ParamId::Activation(_) => {
            return Err(refuse(
                "the activation time constants change the activation's own integration",
            ))
        }
        ParamId::Effect(EffectKind::ElectromechanicalDelay, _)
            if effects.antagonist_coactivation.is_some() =>
        {
            return Err(refuse(
                "the delay moves the antagonist's integrated activation too",
            ))
        }
        ParamId::Effect(EffectKind::ElectromechanicalDelay, _) => {
            Route::Fibre(None, Seat::Drive(DriveSeat::Delay))
        }
        ParamId::Effect(EffectKind::Fatigue, _) => {
            return Err(refuse("fatigue changes the activation table"))
        }
        ParamId::Effect(k, i) => Route::Joint(k, i),
    })
}

/// `Ok` when [`exact_torque_jacobian`] can take every column of `free` under `effects` and
/// `settings`; otherwise the error it would return.
pub fn exact_derivative_available(
    free: &[ParamId],
    effects: &Effects,
    settings: &SimSettings,
) -> Result<(), ModelError> {
    if settings.formulation != Formulation::Fast {
        return Err(ModelError::NoExactDerivative {
            param: "formulation".into(),
            reason: "forward sensitivities are integrated with the fast formulation only",
        });
    }
    for &p in free {
        route(p, effects)?;
    }
    Ok(())
}

/// The Jacobian `∂τ̂ᵢ/∂θ_k` of the predicted torque at every sample `i` with respect to the
/// free parameters `free`, at `params` and `effects` (which already hold the parameters'
/// values), column-major into `jac` (`jac[k·n + i]`, `n` samples; resized).
///
/// # Errors
/// [`ModelError::NoExactDerivative`] for a parameter or formulation it does not cover (see the
/// module documentation), the simulation's errors otherwise.
pub fn exact_torque_jacobian(
    inputs: &TrialInputs,
    params: &ModelParams,
    effects: &Effects,
    settings: &SimSettings,
    free: &[ParamId],
    jac: &mut Vec<f64>,
) -> Result<SimStats, ModelError> {
    exact_derivative_available(free, effects, settings)?;
    params.validate()?;
    effects.validate()?;
    let n = inputs.len();
    jac.clear();
    jac.resize(n * free.len(), 0.0);
    let routes: Vec<Route> = free
        .iter()
        .map(|&p| route(p, effects))
        .collect::<Result<_, _>>()?;
    let delay = delay_s(effects);
    let flen = effects
        .eccentric_enhancement
        .map_or(params.curves.flen, |e| e.flen);
    let mut stats = SimStats::default();
    let triceps = Muscle::ALL.map(|m| (Some(m), m.name(), params.muscle(m)));
    let fixed = params.fixed.iter().map(|f| (None, f.name, &f.params));
    for (muscle, name, mp) in triceps.into_iter().chain(fixed) {
        // the columns this muscle's fibre values move, one dual direction per value
        let mut seats: Vec<(Seat, Vec<usize>)> = Vec::new();
        let mut scale = None;
        for (k, r) in routes.iter().enumerate() {
            match *r {
                Route::Fibre(owner, seat) if owner.is_none() || owner == muscle => {
                    match seats.iter_mut().find(|(s, _)| *s == seat) {
                        Some((_, cols)) => cols.push(k),
                        None => seats.push((seat, vec![k])),
                    }
                }
                Route::Scale(m) if Some(m) == muscle => scale = Some(k),
                _ => {}
            }
        }
        if seats.is_empty() && scale.is_none() {
            continue;
        }
        let unit = MuscleUnit::of(name, mp, params, effects);
        let values = FibreValues::of(mp, &params.curves, flen);
        let job = UnitJob {
            inputs,
            unit: &unit,
            values: &values,
            seats: &seats,
            scale,
            delay,
            drive_values: [params.activation.shape_a, delay * 1e3],
            settings,
        };
        let s = match seats.len() {
            0 | 1 => job.run::<3, 1>(jac),
            2 => job.run::<4, 2>(jac),
            3 | 4 => job.run::<6, 4>(jac),
            5..=8 => job.run::<10, 8>(jac),
            _ => job.run::<13, 11>(jac),
        }?;
        stats.add(s);
    }
    let ta = if routes
        .iter()
        .any(|r| matches!(r, Route::Joint(EffectKind::AntagonistCoactivation, _)))
    {
        let mut ta = vec![0.0; n];
        run_ta(inputs, params, effects, settings, &mut ta)?;
        ta
    } else {
        Vec::new()
    };
    for (k, r) in routes.iter().enumerate() {
        if let Route::Joint(kind, i) = *r {
            let col = &mut jac[k * n..(k + 1) * n];
            if !joint_effect_derivative(inputs, effects, kind, i, &ta, col) {
                return Err(ModelError::NoExactDerivative {
                    param: free[k].name(),
                    reason: "not a joint-level term",
                });
            }
        }
    }
    Ok(stats)
}

/// One muscle's part of the Jacobian.
struct UnitJob<'a> {
    inputs: &'a TrialInputs,
    unit: &'a MuscleUnit,
    values: &'a FibreValues<f64>,
    seats: &'a [(Seat, Vec<usize>)],
    scale: Option<usize>,
    delay: f64,
    /// The values of the shape `A` and of the delay in ms (the parameters' own unit).
    drive_values: [f64; 2],
    settings: &'a SimSettings,
}

impl UnitJob<'_> {
    /// Integrates the fibre with `K ≥ seats` sensitivities (`N = K + 2`; directions past the
    /// seats are zero) and adds the muscle's columns into `jac`.
    fn run<const N: usize, const K: usize>(&self, jac: &mut [f64]) -> Result<SimStats, ModelError> {
        let inputs = self.inputs;
        let n = inputs.len();
        let v = self.values;
        // Direction k is seeded with the value's own size, `∂/∂ln θ`, so that every
        // sensitivity is a length of the order of the fibre's and the error norm weighs them
        // alike (a derivative per degree of α0 is a ten-thousandth of one per metre of LST and
        // would otherwise hide under the absolute tolerance); the columns are divided back.
        let size = |re: f64| if re != 0.0 { re.abs() } else { 1.0 };
        let mut per_unit = [1.0; K];
        let seeded = |seat: Seat, re: f64, per_unit: &mut [f64; K]| {
            let mut eps = [0.0; K];
            if let Some(k) = self.seats.iter().position(|(s, _)| *s == seat) {
                eps[k] = size(re);
                per_unit[k] = 1.0 / size(re);
            }
            dual::<K>(re, eps)
        };
        let values = FibreValues {
            lom: seeded(Seat::Lom, v.lom, &mut per_unit),
            lst: seeded(Seat::Lst, v.lst, &mut per_unit),
            alpha_deg: seeded(Seat::Alpha, v.alpha_deg, &mut per_unit),
            vmax_lom_per_s: seeded(Seat::Vmax, v.vmax_lom_per_s, &mut per_unit),
            curves: std::array::from_fn(|i| seeded(Seat::Curve(i), v.curves[i], &mut per_unit)),
        };
        let fib = Fibre::<DualSVec64<K>>::of_values(&values);
        let real = Fibre::<Dual64>::of_values(&FibreValues {
            lom: v.lom.into(),
            lst: v.lst.into(),
            alpha_deg: v.alpha_deg.into(),
            vmax_lom_per_s: v.vmax_lom_per_s.into(),
            curves: v.curves.map(Dual64::from),
        });
        let (ch, _, lm0) = fast_prepare(None, inputs, self.unit, self.delay)?;
        let mut moved = Vec::new();
        for (k, (seat, _)) in self.seats.iter().enumerate() {
            if let Seat::Drive(d) = *seat {
                let (value, per_second) = match d {
                    DriveSeat::Shape => (self.drive_values[0], 1.0),
                    // the delay's parameter is in ms
                    DriveSeat::Delay => (self.drive_values[1], 1e-3),
                };
                per_unit[k] = 1.0 / size(value);
                let env = envelope_of(inputs, self.unit)?;
                moved.push(drive_derivative(
                    &ch,
                    inputs,
                    env,
                    d,
                    per_second * size(value),
                    k,
                ));
            }
        }
        let lm0 = initial_length(&ch, &fib, &real, &moved, lm0);
        let mut trace = SensitivityTrace::default();
        let stats =
            run_sensitivities::<N, K>(&ch, inputs, &fib, &moved, lm0, self.settings, &mut trace)
                .map_err(integration_error(self.unit.name))?;
        let f0 = self.unit.f0;
        for i in 0..n {
            let lmi = dual::<K>(trace.lm[i], std::array::from_fn(|k| trace.sens[k][i]));
            let ft = fib.tendon_force(ch.lmt[i], lmi);
            let r = ch.r[i];
            let e = eps_of(&ft);
            for (k, (_, cols)) in self.seats.iter().enumerate() {
                let d = f0 * r * e[k] * per_unit[k];
                for &c in cols {
                    jac[c * n + i] += d;
                }
            }
            if let Some(c) = self.scale {
                jac[c * n + i] = ft.re * r;
            }
        }
        Ok(stats)
    }
}
