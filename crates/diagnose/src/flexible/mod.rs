//! Flexible terms: what a structure no catalogued effect explains depends on, and a model
//! extended with it (docs/diagnosis-method.md, "Beyond the catalogue").
//!
//! A flexible term in a state variable `v` adds to the model torque
//!
//! ```text
//! τ += Σ_j β_j h_j(v(t))
//! ```
//!
//! with piecewise-linear hat functions `h_j` on knots spread uniformly over the observed range
//! of `v` (five; four for the TA; about every 2 s in time), or, for `direction`, the single
//! column `sign(q̇)` (0 while the joint is still). Time is also tried with a step `1{t ≥ τ}`
//! added at the residual's most likely change point (`with_step`) and with a sinusoid
//! `sin, cos(2πft)` at the residual's strongest frequency (`with_period`), and direction as
//! `tanh(q̇/w)` with the transition width `w` searched on the residual (`with_width`); in the
//! characterisation the angle and the activations are also tried with a step `1{v ≥ c}` at
//! the level the residual asks for (`with_level_step`), and the angle, the acceleration and
//! the activation fitted separately in each direction of motion, `Σ_j (β_j + d γ_j) h_j(v)`
//! with `d = sign(q̇)` (`by_direction`). The
//! best of a variable's forms (held-out gain in the ranking, BIC in the review) stands for
//! the variable, a searched value counting as one parameter in the BIC. Columns are centred on
//! their mean over the trial except in time (a constant is a function of time only). The vocabulary: `angle` (°),
//! `velocity` (°/s), `direction`, `acceleration` (°/s²), `time` (s), `activation` (the mean
//! normalised triceps surae envelope) and `activation_ta` (the normalised tibialis anterior
//! envelope).
//!
//! The stages, a file each: `variable` (the vocabulary), `basis` (a variable's columns),
//! `forms` (the searched forms of time, direction and the hat variables, and the simplest shape in time), `fit`
//! (the fit by variable projection, its cross-validation and the terms' bands), `review` (no
//! false story), `characterise` (the ranking and the extension) and `report` (what the
//! diagnosis reports of them).

mod basis;
mod characterise;
mod fit;
mod forms;
mod report;
mod review;
mod variable;

pub(crate) use basis::{basis, direction_signs, split_by_direction, SPLIT_BY_DIRECTION};
pub(crate) use characterise::{characterise, Characterisation};
pub(crate) use fit::without_effects;
pub(crate) use forms::ramp_column;
pub use report::{
    FlexibleExtension, FlexibleTerm, Replacement, SearchedValue, Unexplained, VariableGain,
};
pub(crate) use review::{heldout_contest, review_causes};
pub use variable::StateVariable;

/// The bundled trial's context (its unloaded run's noise model), for the stages' tests.
#[cfg(test)]
pub(crate) fn seed_context() -> crate::fit::Context {
    let root = concat!(env!("CARGO_MANIFEST_DIR"), "/../../fixtures/seed");
    let trial = experiment::read_trial(format!("{root}/trial.csv")).unwrap();
    let unloaded = experiment::read_unloaded(format!("{root}/unloaded.csv")).unwrap();
    let settings = crate::DiagnoseSettings::default();
    let prepared = settings.prepare(&trial, Some(&unloaded)).unwrap();
    let (nominal, none) = (
        muscle_model::ModelParams::nominal(),
        muscle_model::Effects::none(),
    );
    crate::context::prepared_context(&prepared, nominal, none, &settings)
        .unwrap()
        .0
}
