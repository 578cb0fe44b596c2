//! The simulation of [`crate::Formulation::Fast`]: activation and musculotendon length
//! precomputed once per trial, then each fibre length integrated alone ([`ode::DoPri5`] with
//! dense output at the samples; the activation's error estimate joins the step-size control).
//!
//! Activation `a(t)`, `â = f_A(a)`, the fatigue factor `exp(−k∫â)` and `LMT(q(t))` do not
//! depend on the identified parameters (LST, F0, α0), so a [`Channel`] holds them at every
//! point of the trial's table grid (value and time derivative) and the integrator reads them
//! by cubic Hermite interpolation. The grid is the samples, or in a low-rate trial
//! ([`crate::TrialInputs::is_low_rate`]) several points per sample interval, at least 400 per
//! second ([`grid`]). The activation is integrated once with classical RK4, four substeps per
//! grid interval (the envelope is a polynomial inside one: linear, or a low-rate trial's
//! monotone cubic). The only state left per muscle is the fibre length `LM`;
//! `F̃T = fT(ε(LMT, LM))` at the samples.
//!
//! A delay `d` only shifts the activation in time: the input `u(t) = env(t − d)` is held at
//! `env(t₀)` before `t₀ + d`, where the activation rests at equilibrium, so
//! `a_d(t) = a₀(t − d)` (and `a₀(t₀)` before `t₀ + d`) and
//! `∫₀ᵗ â_d = â(a₀(t₀))·d + ∫₀^{t−d} â₀` after it. A delayed table is therefore the undelayed
//! one read at `tᵢ − d` by cubic Hermite interpolation from its values and rates at the
//! samples (the envelope's kinks at the samples make the error O(Δt²): 1.2·10⁻⁸ of the
//! activation against an RK4 of the delayed input at 2048 Hz), with `ȧ` from the
//! activation equation at the delayed input: a delay fit costs one read per sample instead of
//! an RK4 integration of the three muscles.
//!
//! Two levels are kept per trial: an [`activation_table::ActTable`] (`a`, `ȧ` and, when asked for, `∫â`)
//! depends on the activation parameters and the delay only, so fits that move the fatigue
//! rate reuse it and only rebuild the per-sample drive; the three muscles' tables are
//! integrated together (a new delay needs all three). When several muscles need integrating
//! (a delay, fatigue or activation change, or a move of every muscle's parameters),
//! [`run_lanes`] advances their fibre integrations together with [`ode::attempt_lanes`].
//! Both interleave independent recurrences for the processor's sake only: every muscle's
//! numbers are the same bits as when it is computed alone.
//!
//! Submodules: the grid the tables are computed on ([`grid`]), the activation tables
//! ([`activation_table`]), the per-muscle drive built from them ([`channel`]), where both are kept per trial ([`cache`]), the fibre right-hand side
//! and the torque read from `LM` ([`fibre`]), and the integration of one or several muscles
//! ([`integrate`]).

mod activation_table;
mod cache;
mod channel;
mod fibre;
mod grid;
mod integrate;
mod kept;
mod sensitivity;
#[cfg(test)]
mod test_support;

pub(crate) use cache::channel_for;
pub(crate) use channel::Channel;
pub(crate) use fibre::FibreValues;
pub(crate) use fibre::{state, unit_torque, Fibre};
pub(crate) use integrate::{run, run_lanes};
pub(crate) use sensitivity::{
    drive_derivative, dual, eps_of, initial_length, run_sensitivities, DriveSeat, SensitivityTrace,
};
