//! Step-size control of the adaptive integrator: the PI controller of Hairer & Wanner.
//!
//! With the scaled error `err` of an attempt of size `h` and `err_prev` of the last accepted
//! step (floored at 1e-4),
//!
//! ```text
//! fac   = clamp(err^α · err_prev^(−β) / safety, 1/10, 1/0.2)     α = 0.2 − 0.75 β
//! h_new = h / fac                                                 β = 0.04, safety = 0.9
//! ```
//!
//! (β is [`crate::AdaptiveSettings::pi_beta`], 0.04 by default; Hairer's `DOPRI5` allows up to
//! 0.1, where larger values damp the oscillation of the step size that sets in near the
//! method's stability limit)
//!
//! accepted when `err ≤ 1` (after a rejection the step may not grow), else retried with
//! `h / min(1/0.2, err^α / safety)`; an attempt whose error cannot be evaluated is retried
//! with `h/4`.

const SAFETY: f64 = 0.9;
const FAC_MIN: f64 = 0.2;
const FAC_MAX: f64 = 10.0;
/// `ln(1e-4)`, the floor of the previous error in the PI controller.
const LN_1E_4: f64 = -9.210_340_371_976_184;

/// What the controller made of an attempt, with the size of the next attempt.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) enum Verdict {
    /// The attempt is accepted; the next step size.
    Accept(f64),
    /// The attempt is rejected; the size of the retry.
    Reject(f64),
    /// The error could not be evaluated (not finite); the size of the retry.
    Unevaluable(f64),
}

/// The PI controller's memory of the previous steps.
#[derive(Clone, Debug)]
pub(crate) struct PiController {
    /// The weight `β` of the previous error.
    beta: f64,
    err_prev: f64,
    /// `err_prev^β`, kept when the controller works with logarithms.
    err_prev_pow: f64,
    /// Powers as `exp(α ln err)` from one logarithm per step instead of two `powf` calls.
    log: bool,
    rejected_last: bool,
}

impl PiController {
    /// A controller with weight `beta` at the start of an integration (`err_prev = 1e-4`), with
    /// powers by `powf`.
    pub(crate) fn new(beta: f64) -> Self {
        PiController {
            beta,
            err_prev: 1e-4,
            err_prev_pow: (beta * LN_1E_4).exp(),
            log: false,
            rejected_last: false,
        }
    }

    /// Evaluates the powers from logarithms from now on.
    pub(crate) fn use_logarithms(&mut self) {
        self.log = true;
    }

    /// Back to the start of an integration (keeping how powers are evaluated).
    pub(crate) fn restart(&mut self) {
        self.err_prev = 1e-4;
        self.err_prev_pow = (self.beta * LN_1E_4).exp();
        self.rejected_last = false;
    }

    /// Judges the attempt of size `h` with scaled error `err` (NaN when it could not be
    /// evaluated) and remembers what the next decision needs.
    #[inline(always)]
    pub(crate) fn judge(&mut self, h: f64, err: f64) -> Verdict {
        let expo1 = 0.2 - self.beta * 0.75;
        if !err.is_finite() {
            // could not evaluate: shrink hard and retry
            self.rejected_last = true;
            return Verdict::Unevaluable(h * 0.25);
        }
        let (fac11, ln_err) = if self.log {
            let ln_err = err.max(1e-300).ln();
            ((expo1 * ln_err).exp(), ln_err)
        } else {
            (err.powf(expo1), 0.0)
        };
        if err <= 1.0 {
            let prev_pow = if self.log {
                self.err_prev_pow
            } else {
                self.err_prev.powf(self.beta)
            };
            let mut fac = fac11 / prev_pow;
            fac = (fac / SAFETY).clamp(1.0 / FAC_MAX, 1.0 / FAC_MIN);
            let mut h_new = h / fac;
            if self.rejected_last {
                h_new = h_new.min(h);
            }
            self.err_prev = err.max(1e-4);
            if self.log {
                self.err_prev_pow = (self.beta * ln_err.max(LN_1E_4)).exp();
            }
            self.rejected_last = false;
            return Verdict::Accept(h_new);
        }
        self.rejected_last = true;
        Verdict::Reject(h / (1.0 / FAC_MIN).min(fac11 / SAFETY))
    }
}
