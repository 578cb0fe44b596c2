//! Numerical building blocks shared by the surae crates, each written once:
//!
//! * [`lm`]: a bounded Levenberg–Marquardt for nonlinear least squares with a parallel
//!   finite-difference Jacobian (the polish of the annealing fits, the diagnosis's fits);
//! * [`mod@nelder_mead`]: a bounded Nelder–Mead with restarts, on any [`Objective`];
//! * [`cycle_shape`]: whether a residual keeps a shape locked to the motion's cycle, tested
//!   against the cycle-to-cycle scatter (sign flips) or a template shape (Student's t);
//! * [`cholesky`]: the dense Cholesky factorisation and its triangular solves;
//! * [`interpolate`]: linear resampling of a time series onto other times;
//! * [`latin_hypercube`]: Latin-hypercube designs from a caller's random stream;
//! * [`special`]: the normal distribution, the gamma function and the χ², F and incomplete
//!   gamma / beta functions built on it;
//! * [`rms()`] and [`rms_diff`]: the root mean square of a slice and of a difference;
//! * [`text`]: numbers written for a reader, with the typographic minus.
//!
//! Bad input gives a [`NumericsError`] (or NaN from a special function), never a panic —
//! except [`rms_diff`] of slices of different lengths, a caller's bug.
//!
//! ```
//! use numerics::{nelder_mead, FnObjective, NelderMeadSettings};
//! use numerics::cholesky::spd_inverse;
//! // the minimum of (x − 1)² + 2(y + 0.5)² in the box [−5, 5]²
//! let mut q = FnObjective::new(vec![(-5.0, 5.0); 2], |x: &[f64]| {
//!     Some((x[0] - 1.0).powi(2) + 2.0 * (x[1] + 0.5).powi(2))
//! });
//! let out = nelder_mead(&mut q, &[3.0, 3.0], &NelderMeadSettings::default()).unwrap();
//! assert!((out.x[0] - 1.0).abs() < 1e-5 && (out.x[1] + 0.5).abs() < 1e-5);
//! // the covariance (½ Hessian)⁻¹ of the same quadratic
//! let cov = spd_inverse(&[1.0, 0.0, 0.0, 2.0], 2).unwrap();
//! assert!((cov[0] - 1.0).abs() < 1e-15 && (cov[3] - 0.5).abs() < 1e-15 && cov[1] == 0.0);
//! ```

pub mod cholesky;
pub mod cycle_shape;
mod error;
pub mod fft;
pub mod interpolate;
pub mod latin_hypercube;
pub mod lm;
pub mod nelder_mead;
mod objective;
mod rms;
pub mod special;
pub mod text;

pub use error::NumericsError;
pub use lm::{
    levenberg_marquardt, FiniteDifferences, LevenbergMarquardtOutcome, LevenbergMarquardtSettings,
    LevenbergMarquardtStop, Residuals,
};
pub use nelder_mead::{
    nelder_mead, nelder_mead_unit, NelderMeadOutcome, NelderMeadSettings, NelderMeadUnitOutcome,
};
pub use objective::{map_coordinate, FnObjective, Objective, UnitBox};
pub use rms::{rms, rms_diff};
