//! Explicit Runge–Kutta integrators with fixed-size state.
//!
//! The state is a plain array `[f64; N]`, so a step never allocates. Two
//! families are provided:
//!
//! * [`DoPri5`]: the Dormand–Prince 5(4) pair (FSAL, 7 stages, 6 right-hand-side
//!   calls per accepted step) with the PI step-size controller of Hairer &
//!   Wanner and the 4th-order continuous extension ("dense output"), so that
//!   the solution at any time inside the last step costs no extra call.
//!   [`dopri5_dense`] drives it over a grid of output times (a sampling grid).
//! * Fixed-step methods given as data ([`Tableau`]): the classic RK4
//!   ([`RK4`]) and the 5th-order Dormand–Prince weights ([`DP5`]), driven by
//!   [`rk_fixed`] / [`rk4_fixed`].
//!
//! # The adaptive method
//!
//! For `y' = f(t, y)`, a step of size `h` from `(t, y)` computes the stages
//! `k_i = f(t + c_i h, y + h Σ_j a_ij k_j)`, the 5th-order solution
//! `y₁ = y + h Σ b_i k_i` (propagated) and the error estimate
//! `e = h Σ (b_i − b̂_i) k_i`. The error is measured in the scaled RMS norm
//!
//! ```text
//! err = sqrt( (1/N) Σ_i ( e_i / (atol + rtol · max(|y_i|, |y₁_i|)) )² )
//! ```
//!
//! and the step is accepted when `err ≤ 1`. The next step size follows the PI
//! controller `h_new = h · safety · err^(−α) · err_prev^(β)` with
//! `α = 0.2 − 0.75 β`, `β = 0.04` ([`AdaptiveSettings::pi_beta`]), `safety = 0.9`, limited to
//! a factor in `[0.2, 10]`; after a rejection the step may not grow.
//!
//! Dense output uses the continuous extension of Dormand & Prince (as in
//! Hairer's `DOPRI5`): with `θ = (t − t_n)/h`,
//!
//! ```text
//! y(t_n + θh) = y_n + θ (Δ + (1−θ)(B + θ (Δ − h k₇ − B + (1−θ) D)))
//! ```
//!
//! where `Δ = y_{n+1} − y_n`, `B = h k₁ − Δ` and `D = h Σ d_i k_i`.
//!
//! # Example
//!
//! Exponential decay `y' = −2y`, sampled on a grid:
//!
//! ```
//! use ode::{dopri5_dense, AdaptiveSettings};
//!
//! let times: Vec<f64> = (0..=10).map(|i| i as f64 * 0.1).collect();
//! let mut sys = |_t: f64, y: &[f64; 1], dy: &mut [f64; 1]| dy[0] = -2.0 * y[0];
//! let mut out = vec![0.0; times.len()];
//! let stats = dopri5_dense(&mut sys, [1.0], &times, &AdaptiveSettings::default(), |i, y| {
//!     out[i] = y[0];
//! })
//! .unwrap();
//! assert!((out[10] - (-2.0f64).exp()).abs() < 1e-6);
//! assert!(stats.accepted < 40);
//! ```
//!
//! # Errors
//!
//! Failures are values ([`OdeError`]): a step size that underflows the
//! minimum, a non-finite state or derivative (a right-hand side may write
//! `NaN` to say it cannot be evaluated), too many steps, or invalid settings.

// Index loops over several same-length state arrays read better than zipped iterators here.
#![allow(clippy::needless_range_loop)]

mod coefficients;
mod controller;
mod dense;
mod dopri5;
mod driver;
mod error;
mod lanes;
mod settings;
mod stats;
mod system;
mod tableau;
#[cfg(test)]
mod test_systems;

pub use dense::DenseStep;
pub use dopri5::DoPri5;
pub use driver::dopri5_dense;
pub use error::OdeError;
pub use lanes::attempt_lanes;
pub use settings::{AdaptiveSettings, DEFAULT_PI_BETA, STABILISED_PI_BETA};
pub use stats::Stats;
pub use system::OdeSystem;
pub use tableau::{rk4_fixed, rk4_step, rk_fixed, rk_step, Tableau, DP5, RK4};
