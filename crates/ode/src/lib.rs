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
//! `α = 0.2 − 0.75 β`, `β = 0.04`, `safety = 0.9`, limited to a factor in
//! `[0.2, 10]`; after a rejection the step may not grow.
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

mod tableau;

pub use tableau::{rk4_fixed, rk4_step, rk_fixed, rk_step, Tableau, DP5, RK4};

/// Right-hand side of `y' = f(t, y)` with a fixed-size state.
///
/// Closures `FnMut(f64, &[f64; N], &mut [f64; N])` implement it.
pub trait OdeSystem<const N: usize> {
    /// Writes `f(t, y)` into `dydt`. Writing a non-finite value signals that
    /// the system cannot be evaluated there; the integrator then fails with
    /// [`OdeError::NonFinite`] (or rejects and shrinks the step first).
    fn rhs(&mut self, t: f64, y: &[f64; N], dydt: &mut [f64; N]);
}

impl<F, const N: usize> OdeSystem<N> for F
where
    F: FnMut(f64, &[f64; N], &mut [f64; N]),
{
    #[inline]
    fn rhs(&mut self, t: f64, y: &[f64; N], dydt: &mut [f64; N]) {
        self(t, y, dydt)
    }
}

/// Errors of the integrators.
#[derive(thiserror::Error, Debug, Clone, PartialEq)]
pub enum OdeError {
    /// The controller asked for a step smaller than the minimum.
    #[error("step size underflow at t = {t}: h = {h:e} is below the minimum")]
    StepSizeUnderflow {
        /// Time at which the step was attempted.
        t: f64,
        /// The step size that was too small.
        h: f64,
    },
    /// The state or its derivative became NaN or infinite.
    #[error("non-finite state or derivative at t = {t}")]
    NonFinite {
        /// Time at which it happened.
        t: f64,
    },
    /// The step budget ran out before the end time.
    #[error("maximum number of steps ({steps}) reached at t = {t}")]
    MaxSteps {
        /// Time reached.
        t: f64,
        /// The budget.
        steps: usize,
    },
    /// Settings or arguments that make no sense.
    #[error("invalid input: {what}")]
    InvalidInput {
        /// What is wrong.
        what: &'static str,
    },
}

/// Work counters of an integration.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Stats {
    /// Accepted steps.
    pub accepted: usize,
    /// Rejected steps.
    pub rejected: usize,
    /// Right-hand-side evaluations.
    pub rhs_calls: usize,
}

/// Tolerances and limits of the adaptive integrator.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AdaptiveSettings {
    /// Relative tolerance (default 1e-6).
    pub rtol: f64,
    /// Absolute tolerance (default 1e-9).
    pub atol: f64,
    /// First step size; `None` picks one from the problem (Hairer's `hinit`).
    pub h_init: Option<f64>,
    /// Largest step size (default unlimited).
    pub h_max: f64,
    /// Smallest step size before [`OdeError::StepSizeUnderflow`] (default 1e-14).
    pub h_min: f64,
    /// Largest number of attempted steps (default 1 000 000).
    pub max_steps: usize,
}

impl Default for AdaptiveSettings {
    fn default() -> Self {
        Self {
            rtol: 1e-6,
            atol: 1e-9,
            h_init: None,
            h_max: f64::INFINITY,
            h_min: 1e-14,
            max_steps: 1_000_000,
        }
    }
}

impl AdaptiveSettings {
    /// Sets the relative tolerance.
    #[must_use]
    pub fn with_rtol(mut self, rtol: f64) -> Self {
        self.rtol = rtol;
        self
    }
    /// Sets the absolute tolerance.
    #[must_use]
    pub fn with_atol(mut self, atol: f64) -> Self {
        self.atol = atol;
        self
    }
    /// Sets the first step size.
    #[must_use]
    pub fn with_h_init(mut self, h: f64) -> Self {
        self.h_init = Some(h);
        self
    }
    /// Sets the largest step size.
    #[must_use]
    pub fn with_h_max(mut self, h: f64) -> Self {
        self.h_max = h;
        self
    }
    /// Sets the step budget.
    #[must_use]
    pub fn with_max_steps(mut self, n: usize) -> Self {
        self.max_steps = n;
        self
    }

    fn validate(&self) -> Result<(), OdeError> {
        let ok_tol = |v: f64| v.is_finite() && v >= 0.0;
        if !ok_tol(self.rtol) || !ok_tol(self.atol) || (self.rtol == 0.0 && self.atol == 0.0) {
            return Err(OdeError::InvalidInput {
                what: "tolerances must be finite, non-negative and not both zero",
            });
        }
        if let Some(h) = self.h_init {
            if !(h.is_finite() && h > 0.0) {
                return Err(OdeError::InvalidInput {
                    what: "h_init must be positive and finite",
                });
            }
        }
        if self.h_max.is_nan()
            || self.h_max <= 0.0
            || self.h_min.is_nan()
            || self.h_min < 0.0
            || self.h_min > self.h_max
        {
            return Err(OdeError::InvalidInput {
                what: "need 0 <= h_min <= h_max and h_max > 0",
            });
        }
        if self.max_steps == 0 {
            return Err(OdeError::InvalidInput {
                what: "max_steps must be positive",
            });
        }
        Ok(())
    }
}

// Dormand–Prince 5(4) coefficients.
const C2: f64 = 1.0 / 5.0;
const C3: f64 = 3.0 / 10.0;
const C4: f64 = 4.0 / 5.0;
const C5: f64 = 8.0 / 9.0;
const A21: f64 = 1.0 / 5.0;
const A31: f64 = 3.0 / 40.0;
const A32: f64 = 9.0 / 40.0;
const A41: f64 = 44.0 / 45.0;
const A42: f64 = -56.0 / 15.0;
const A43: f64 = 32.0 / 9.0;
const A51: f64 = 19372.0 / 6561.0;
const A52: f64 = -25360.0 / 2187.0;
const A53: f64 = 64448.0 / 6561.0;
const A54: f64 = -212.0 / 729.0;
const A61: f64 = 9017.0 / 3168.0;
const A62: f64 = -355.0 / 33.0;
const A63: f64 = 46732.0 / 5247.0;
const A64: f64 = 49.0 / 176.0;
const A65: f64 = -5103.0 / 18656.0;
const A71: f64 = 35.0 / 384.0;
const A73: f64 = 500.0 / 1113.0;
const A74: f64 = 125.0 / 192.0;
const A75: f64 = -2187.0 / 6784.0;
const A76: f64 = 11.0 / 84.0;
const E1: f64 = 71.0 / 57600.0;
const E3: f64 = -71.0 / 16695.0;
const E4: f64 = 71.0 / 1920.0;
const E5: f64 = -17253.0 / 339200.0;
const E6: f64 = 22.0 / 525.0;
const E7: f64 = -1.0 / 40.0;
const D1: f64 = -12715105075.0 / 11282082432.0;
const D3: f64 = 87487479700.0 / 32700410799.0;
const D4: f64 = -10690763975.0 / 1880347072.0;
const D5: f64 = 701980252875.0 / 199316789632.0;
const D6: f64 = -1453857185.0 / 822651844.0;
const D7: f64 = 69997945.0 / 29380423.0;

const SAFETY: f64 = 0.9;
const BETA: f64 = 0.04;
const FAC_MIN: f64 = 0.2;
const FAC_MAX: f64 = 10.0;
/// `ln(1e-4)`, the floor of the previous error in the PI controller.
const LN_1E_4: f64 = -9.210_340_371_976_184;

/// Dormand–Prince 5(4) stepper with PI step control and dense output.
///
/// Typical use: [`DoPri5::init`], then [`DoPri5::step`] until
/// [`DoPri5::t`] reaches the end time, reading values inside each step with
/// [`DoPri5::interpolate`]. [`dopri5_dense`] does exactly that for a grid.
#[derive(Clone, Debug)]
pub struct DoPri5<const N: usize> {
    settings: AdaptiveSettings,
    t: f64,
    t_prev: f64,
    t_end: f64,
    h: f64,
    y: [f64; N],
    k1: [f64; N],
    k2: [f64; N],
    k3: [f64; N],
    k4: [f64; N],
    k5: [f64; N],
    k6: [f64; N],
    k7: [f64; N],
    ytmp: [f64; N],
    ynew: [f64; N],
    // dense output coefficients of the last accepted step
    r1: [f64; N],
    r2: [f64; N],
    r3: [f64; N],
    r4: [f64; N],
    r5: [f64; N],
    err_prev: f64,
    /// `err_prev^β`, kept when the controller works with logarithms.
    err_prev_pow: f64,
    log_controller: bool,
    rejected_last: bool,
    stats: Stats,
    initialised: bool,
}

impl<const N: usize> DoPri5<N> {
    /// A stepper with the given settings (validated).
    pub fn new(settings: AdaptiveSettings) -> Result<Self, OdeError> {
        settings.validate()?;
        Ok(Self {
            settings,
            t: 0.0,
            t_prev: 0.0,
            t_end: 0.0,
            h: 0.0,
            y: [0.0; N],
            k1: [0.0; N],
            k2: [0.0; N],
            k3: [0.0; N],
            k4: [0.0; N],
            k5: [0.0; N],
            k6: [0.0; N],
            k7: [0.0; N],
            ytmp: [0.0; N],
            ynew: [0.0; N],
            r1: [0.0; N],
            r2: [0.0; N],
            r3: [0.0; N],
            r4: [0.0; N],
            r5: [0.0; N],
            err_prev: 1e-4,
            err_prev_pow: (BETA * LN_1E_4).exp(),
            log_controller: false,
            rejected_last: false,
            stats: Stats::default(),
            initialised: false,
        })
    }

    /// The same stepper with the powers of the PI controller, `err^α` and `err_prev^β`,
    /// evaluated as `exp(α ln err)` from one logarithm per step (and `err_prev^β` kept from
    /// the previous step) instead of two `powf` calls. The controller is mathematically the
    /// same; step sizes differ only by rounding. Meant for cheap right-hand sides, where the
    /// controller is a visible part of a step's cost.
    #[must_use]
    pub fn with_log_controller(mut self) -> Self {
        self.log_controller = true;
        self
    }

    /// Starts an integration from `(t0, y0)` towards `t_end > t0`.
    pub fn init<S: OdeSystem<N>>(
        &mut self,
        sys: &mut S,
        t0: f64,
        y0: [f64; N],
        t_end: f64,
    ) -> Result<(), OdeError> {
        if !(t0.is_finite() && t_end.is_finite()) || t_end <= t0 {
            return Err(OdeError::InvalidInput {
                what: "need finite t0 < t_end",
            });
        }
        if !all_finite(&y0) {
            return Err(OdeError::NonFinite { t: t0 });
        }
        self.t = t0;
        self.t_prev = t0;
        self.t_end = t_end;
        self.y = y0;
        self.stats = Stats::default();
        self.err_prev = 1e-4;
        self.err_prev_pow = (BETA * LN_1E_4).exp();
        self.rejected_last = false;
        sys.rhs(t0, &self.y, &mut self.k1);
        self.stats.rhs_calls += 1;
        if !all_finite(&self.k1) {
            return Err(OdeError::NonFinite { t: t0 });
        }
        self.h = match self.settings.h_init {
            Some(h) => h,
            None => self.initial_step(sys)?,
        }
        .min(self.settings.h_max)
        .min(t_end - t0);
        // dense output of the degenerate step [t0, t0]: constant
        self.r1 = self.y;
        self.r2 = [0.0; N];
        self.r3 = [0.0; N];
        self.r4 = [0.0; N];
        self.r5 = [0.0; N];
        self.initialised = true;
        Ok(())
    }

    /// Hairer & Wanner's starting step size heuristic.
    fn initial_step<S: OdeSystem<N>>(&mut self, sys: &mut S) -> Result<f64, OdeError> {
        let s = &self.settings;
        let mut d0 = 0.0;
        let mut d1 = 0.0;
        for i in 0..N {
            let sc = s.atol + s.rtol * self.y[i].abs();
            d0 += (self.y[i] / sc).powi(2);
            d1 += (self.k1[i] / sc).powi(2);
        }
        let n = N.max(1) as f64;
        d0 = (d0 / n).sqrt();
        d1 = (d1 / n).sqrt();
        let mut h0 = if d0 < 1e-5 || d1 < 1e-5 {
            1e-6
        } else {
            0.01 * d0 / d1
        };
        h0 = h0.min(s.h_max).min(self.t_end - self.t);
        for i in 0..N {
            self.ytmp[i] = self.y[i] + h0 * self.k1[i];
        }
        sys.rhs(self.t + h0, &self.ytmp, &mut self.k2);
        self.stats.rhs_calls += 1;
        if !all_finite(&self.k2) {
            return Ok(h0 * 1e-3);
        }
        let mut d2 = 0.0;
        for i in 0..N {
            let sc = s.atol + s.rtol * self.y[i].abs();
            d2 += ((self.k2[i] - self.k1[i]) / sc).powi(2);
        }
        d2 = (d2 / n).sqrt() / h0;
        let dmax = d1.max(d2);
        let h1 = if dmax <= 1e-15 {
            (h0 * 1e-3).max(1e-6)
        } else {
            (0.01 / dmax).powf(0.2)
        };
        Ok((100.0 * h0).min(h1))
    }

    /// Current time (end of the last accepted step).
    pub fn t(&self) -> f64 {
        self.t
    }
    /// Start of the last accepted step.
    pub fn t_prev(&self) -> f64 {
        self.t_prev
    }
    /// Current state.
    pub fn y(&self) -> &[f64; N] {
        &self.y
    }
    /// Step size proposed for the next step.
    pub fn h(&self) -> f64 {
        self.h
    }
    /// Work counters so far.
    pub fn stats(&self) -> Stats {
        self.stats
    }

    /// Takes one accepted step (never past `t_end`). Rejected attempts are
    /// retried with a smaller step inside this call.
    pub fn step<S: OdeSystem<N>>(&mut self, sys: &mut S) -> Result<(), OdeError> {
        self.check_can_step()?;
        loop {
            let (h, remaining) = self.prepare()?;
            self.stage2(sys, h);
            self.stage3(sys, h);
            self.stage4(sys, h);
            self.stage5(sys, h);
            self.stage6(sys, h);
            self.stage7(sys, h);
            if self.conclude(h, remaining)? {
                return Ok(());
            }
        }
    }

    fn check_can_step(&self) -> Result<(), OdeError> {
        if !self.initialised {
            return Err(OdeError::InvalidInput {
                what: "step() called before init()",
            });
        }
        if self.t >= self.t_end {
            return Err(OdeError::InvalidInput {
                what: "step() called after reaching t_end",
            });
        }
        Ok(())
    }

    /// Whether the integration has reached `t_end`.
    pub fn finished(&self) -> bool {
        self.initialised && self.t >= self.t_end
    }

    /// The size `h` of the next attempt and the time remaining to `t_end`.
    #[inline(always)]
    fn prepare(&self) -> Result<(f64, f64), OdeError> {
        if self.stats.accepted + self.stats.rejected >= self.settings.max_steps {
            return Err(OdeError::MaxSteps {
                t: self.t,
                steps: self.settings.max_steps,
            });
        }
        let remaining = self.t_end - self.t;
        let mut h = self.h.min(self.settings.h_max);
        // land exactly on t_end, avoiding a sliver of a last step
        if h >= remaining || remaining - h < 1e-12 * remaining.abs().max(1.0) {
            h = remaining;
        }
        if h < self.settings.h_min || self.t + h == self.t {
            return Err(OdeError::StepSizeUnderflow { t: self.t, h });
        }
        Ok((h, remaining))
    }

    /// Accepts or rejects the attempt of size `h` whose stages are computed: returns whether
    /// it was accepted, and sets the next step size either way.
    #[inline(always)]
    fn conclude(&mut self, h: f64, remaining: f64) -> Result<bool, OdeError> {
        let expo1 = 0.2 - BETA * 0.75;
        let err = self.error_norm(h);
        let t_new = self.t + h;
        if !err.is_finite() {
            // could not evaluate: shrink hard and retry
            self.stats.rejected += 1;
            self.rejected_last = true;
            self.h = h * 0.25;
            if self.h < self.settings.h_min {
                return Err(OdeError::NonFinite { t: self.t });
            }
            return Ok(false);
        }
        let (fac11, ln_err) = if self.log_controller {
            let ln_err = err.max(1e-300).ln();
            ((expo1 * ln_err).exp(), ln_err)
        } else {
            (err.powf(expo1), 0.0)
        };
        if err <= 1.0 {
            let prev_pow = if self.log_controller {
                self.err_prev_pow
            } else {
                self.err_prev.powf(BETA)
            };
            let mut fac = fac11 / prev_pow;
            fac = (fac / SAFETY).clamp(1.0 / FAC_MAX, 1.0 / FAC_MIN);
            let mut h_new = h / fac;
            if self.rejected_last {
                h_new = h_new.min(h);
            }
            self.err_prev = err.max(1e-4);
            if self.log_controller {
                self.err_prev_pow = (BETA * ln_err.max(LN_1E_4)).exp();
            }
            self.rejected_last = false;
            // dense output coefficients
            for i in 0..N {
                let ydiff = self.ynew[i] - self.y[i];
                let bspl = h * self.k1[i] - ydiff;
                self.r1[i] = self.y[i];
                self.r2[i] = ydiff;
                self.r3[i] = bspl;
                self.r4[i] = ydiff - h * self.k7[i] - bspl;
                self.r5[i] = h
                    * (D1 * self.k1[i]
                        + D3 * self.k3[i]
                        + D4 * self.k4[i]
                        + D5 * self.k5[i]
                        + D6 * self.k6[i]
                        + D7 * self.k7[i]);
            }
            self.t_prev = self.t;
            self.t = if h == remaining { self.t_end } else { t_new };
            self.y = self.ynew;
            self.k1 = self.k7; // FSAL
            self.h = h_new;
            self.stats.accepted += 1;
            return Ok(true);
        }
        self.stats.rejected += 1;
        self.rejected_last = true;
        self.h = h / (1.0 / FAC_MIN).min(fac11 / SAFETY);
        Ok(false)
    }

    #[inline(always)]
    fn stage2<S: OdeSystem<N>>(&mut self, sys: &mut S, h: f64) {
        let y = &self.y;
        for i in 0..N {
            self.ytmp[i] = y[i] + h * A21 * self.k1[i];
        }
        sys.rhs(self.t + C2 * h, &self.ytmp, &mut self.k2);
    }

    #[inline(always)]
    fn stage3<S: OdeSystem<N>>(&mut self, sys: &mut S, h: f64) {
        let y = &self.y;
        for i in 0..N {
            self.ytmp[i] = y[i] + h * (A31 * self.k1[i] + A32 * self.k2[i]);
        }
        sys.rhs(self.t + C3 * h, &self.ytmp, &mut self.k3);
    }

    #[inline(always)]
    fn stage4<S: OdeSystem<N>>(&mut self, sys: &mut S, h: f64) {
        let y = &self.y;
        for i in 0..N {
            self.ytmp[i] = y[i] + h * (A41 * self.k1[i] + A42 * self.k2[i] + A43 * self.k3[i]);
        }
        sys.rhs(self.t + C4 * h, &self.ytmp, &mut self.k4);
    }

    #[inline(always)]
    fn stage5<S: OdeSystem<N>>(&mut self, sys: &mut S, h: f64) {
        let y = &self.y;
        for i in 0..N {
            self.ytmp[i] = y[i]
                + h * (A51 * self.k1[i] + A52 * self.k2[i] + A53 * self.k3[i] + A54 * self.k4[i]);
        }
        sys.rhs(self.t + C5 * h, &self.ytmp, &mut self.k5);
    }

    #[inline(always)]
    fn stage6<S: OdeSystem<N>>(&mut self, sys: &mut S, h: f64) {
        let y = &self.y;
        for i in 0..N {
            self.ytmp[i] = y[i]
                + h * (A61 * self.k1[i]
                    + A62 * self.k2[i]
                    + A63 * self.k3[i]
                    + A64 * self.k4[i]
                    + A65 * self.k5[i]);
        }
        sys.rhs(self.t + h, &self.ytmp, &mut self.k6);
    }

    #[inline(always)]
    fn stage7<S: OdeSystem<N>>(&mut self, sys: &mut S, h: f64) {
        let y = &self.y;
        for i in 0..N {
            self.ynew[i] = y[i]
                + h * (A71 * self.k1[i]
                    + A73 * self.k3[i]
                    + A74 * self.k4[i]
                    + A75 * self.k5[i]
                    + A76 * self.k6[i]);
        }
        sys.rhs(self.t + h, &self.ynew, &mut self.k7);
        self.stats.rhs_calls += 6;
    }

    /// The scaled error norm of the attempt of size `h` whose stages are computed (NaN when
    /// something was not finite).
    #[inline(always)]
    fn error_norm(&self, h: f64) -> f64 {
        let s = &self.settings;
        let y = &self.y;
        let mut acc = 0.0;
        for i in 0..N {
            let e = h
                * (E1 * self.k1[i]
                    + E3 * self.k3[i]
                    + E4 * self.k4[i]
                    + E5 * self.k5[i]
                    + E6 * self.k6[i]
                    + E7 * self.k7[i]);
            let sc = s.atol + s.rtol * y[i].abs().max(self.ynew[i].abs());
            acc += (e / sc) * (e / sc);
        }
        let err = (acc / N.max(1) as f64).sqrt();
        if err.is_finite() && all_finite(&self.ynew) && all_finite(&self.k7) {
            err
        } else {
            f64::NAN
        }
    }

    /// The solution at `t` inside the last accepted step `[t_prev, t]`
    /// (4th-order continuous extension; exact at both ends).
    pub fn interpolate(&self, t: f64, out: &mut [f64; N]) {
        let h = self.t - self.t_prev;
        if h <= 0.0 {
            *out = self.y;
            return;
        }
        let theta = (t - self.t_prev) / h;
        let theta1 = 1.0 - theta;
        for i in 0..N {
            out[i] = self.r1[i]
                + theta
                    * (self.r2[i]
                        + theta1 * (self.r3[i] + theta * (self.r4[i] + theta1 * self.r5[i])));
        }
    }

    /// The dense output of the last accepted step `[t_prev, t]` as a value that reads many
    /// times inside the step cheaply (the step's `1/h` computed once), component by
    /// component if only some are wanted.
    pub fn dense(&self) -> DenseStep<'_, N> {
        let h = self.t - self.t_prev;
        DenseStep {
            s: self,
            inv_h: if h > 0.0 { 1.0 / h } else { 0.0 },
        }
    }
}

/// Dense output of the last accepted step of a [`DoPri5`] (see [`DoPri5::dense`]).
///
/// Same continuous extension as [`DoPri5::interpolate`], with `θ = (t − t_prev)·(1/h)`;
/// exact at the end of the step (returns the stepper's state there).
#[derive(Clone, Copy, Debug)]
pub struct DenseStep<'a, const N: usize> {
    s: &'a DoPri5<N>,
    inv_h: f64,
}

impl<const N: usize> DenseStep<'_, N> {
    /// Start of the step.
    pub fn t_prev(&self) -> f64 {
        self.s.t_prev
    }
    /// End of the step.
    pub fn t(&self) -> f64 {
        self.s.t
    }
    /// Component `i` of the solution at `t` in `[t_prev, t]`.
    ///
    /// # Panics
    ///
    /// If `i >= N` (a programming error, like an out-of-range index).
    #[inline]
    pub fn component(&self, t: f64, i: usize) -> f64 {
        let s = self.s;
        if t == s.t {
            return s.y[i];
        }
        let theta = (t - s.t_prev) * self.inv_h;
        let theta1 = 1.0 - theta;
        s.r1[i] + theta * (s.r2[i] + theta1 * (s.r3[i] + theta * (s.r4[i] + theta1 * s.r5[i])))
    }
    /// Component `i` at every time of `ts` (each in `[t_prev, t]`) into `out`: the same
    /// numbers as [`DenseStep::component`], in a loop without branches that the compiler can
    /// vectorise.
    ///
    /// # Panics
    ///
    /// If `i >= N` (a programming error, like an out-of-range index).
    #[inline]
    pub fn component_into(&self, ts: &[f64], i: usize, out: &mut [f64]) {
        let s = self.s;
        let (r1, r2, r3, r4, r5) = (s.r1[i], s.r2[i], s.r3[i], s.r4[i], s.r5[i]);
        let (t_end, t_prev, inv_h, y) = (s.t, s.t_prev, self.inv_h, s.y[i]);
        for (o, &t) in out.iter_mut().zip(ts) {
            let theta = (t - t_prev) * inv_h;
            let theta1 = 1.0 - theta;
            let v = r1 + theta * (r2 + theta1 * (r3 + theta * (r4 + theta1 * r5)));
            *o = if t == t_end { y } else { v };
        }
    }
    /// The whole solution at `t` in `[t_prev, t]`.
    #[inline]
    pub fn at(&self, t: f64, out: &mut [f64; N]) {
        for i in 0..N {
            out[i] = self.component(t, i);
        }
    }
}

/// One attempt of every active lane: `L` independent integrations advanced together, stage by
/// stage, so that a processor can overlap their right-hand sides (each alone is one long
/// chain of dependent operations). Every lane computes exactly what [`DoPri5::step`] computes,
/// attempt for attempt, so its results are the same bits as when it is integrated alone.
///
/// `active[l]` selects the lanes (a lane must be initialised and not
/// [`finished`](DoPri5::finished)); returns which lanes' attempts were accepted (their
/// [`DoPri5::dense`] then covers the new step), or the first failing lane and its error.
pub fn attempt_lanes<S: OdeSystem<N>, const N: usize, const L: usize>(
    steppers: &mut [DoPri5<N>; L],
    systems: &mut [S; L],
    active: [bool; L],
) -> Result<[bool; L], (usize, OdeError)> {
    let mut h = [0.0; L];
    let mut remaining = [0.0; L];
    for l in 0..L {
        if active[l] {
            steppers[l].check_can_step().map_err(|e| (l, e))?;
            (h[l], remaining[l]) = steppers[l].prepare().map_err(|e| (l, e))?;
        }
    }
    macro_rules! stage {
        ($f:ident) => {
            for l in 0..L {
                if active[l] {
                    steppers[l].$f(&mut systems[l], h[l]);
                }
            }
        };
    }
    stage!(stage2);
    stage!(stage3);
    stage!(stage4);
    stage!(stage5);
    stage!(stage6);
    stage!(stage7);
    let mut accepted = [false; L];
    for l in 0..L {
        if active[l] {
            accepted[l] = steppers[l]
                .conclude(h[l], remaining[l])
                .map_err(|e| (l, e))?;
        }
    }
    Ok(accepted)
}

fn all_finite<const N: usize>(v: &[f64; N]) -> bool {
    v.iter().all(|x| x.is_finite())
}

/// Integrates from `t_out[0]` to the last output time and calls
/// `out(i, &y(t_out[i]))` for every output time, in order, using dense output
/// (so the step size is not tied to the grid). `out(0, &y0)` comes first.
///
/// `t_out` must be strictly increasing and finite.
pub fn dopri5_dense<S: OdeSystem<N>, const N: usize>(
    sys: &mut S,
    y0: [f64; N],
    t_out: &[f64],
    settings: &AdaptiveSettings,
    mut out: impl FnMut(usize, &[f64; N]),
) -> Result<Stats, OdeError> {
    let mut stepper = DoPri5::<N>::new(*settings)?;
    let Some(&t0) = t_out.first() else {
        return Err(OdeError::InvalidInput {
            what: "no output times",
        });
    };
    if t_out
        .windows(2)
        .any(|w| w[1].partial_cmp(&w[0]) != Some(std::cmp::Ordering::Greater))
        || !t_out.iter().all(|t| t.is_finite())
    {
        return Err(OdeError::InvalidInput {
            what: "output times must be finite and strictly increasing",
        });
    }
    out(0, &y0);
    if t_out.len() == 1 {
        return Ok(Stats::default());
    }
    let t_end = t_out[t_out.len() - 1];
    stepper.init(sys, t0, y0, t_end)?;
    let mut next = 1;
    let mut buf = [0.0; N];
    while next < t_out.len() {
        stepper.step(sys)?;
        while next < t_out.len() && t_out[next] <= stepper.t() {
            if t_out[next] == stepper.t() {
                out(next, stepper.y());
            } else {
                stepper.interpolate(t_out[next], &mut buf);
                out(next, &buf);
            }
            next += 1;
        }
    }
    Ok(stepper.stats())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A stiff-ish forced oscillator whose rate differs per lane (so lanes take different
    /// steps, with rejections).
    struct Forced {
        k: f64,
    }

    impl OdeSystem<2> for Forced {
        fn rhs(&mut self, t: f64, y: &[f64; 2], dy: &mut [f64; 2]) {
            dy[0] = y[1];
            dy[1] = -self.k * y[0] - 0.5 * y[1] + (7.0 * t).sin() * (1.0 + (3.0 * t).cos().abs());
        }
    }

    #[test]
    fn dense_output_over_a_slice_equals_point_by_point() {
        let mut st = DoPri5::<2>::new(AdaptiveSettings::default()).unwrap();
        let mut sys = Forced { k: 40.0 };
        st.init(&mut sys, 0.0, [1.0, 0.0], 2.0).unwrap();
        let mut checked = 0;
        while !st.finished() {
            st.step(&mut sys).unwrap();
            let d = st.dense();
            // grid points inside the step, and its exact end
            let mut ts: Vec<f64> = (0..=2000)
                .map(|j| j as f64 * 1e-3)
                .filter(|&t| t >= d.t_prev() && t <= d.t())
                .collect();
            ts.push(d.t());
            let mut out = vec![0.0; ts.len()];
            for i in 0..2 {
                d.component_into(&ts, i, &mut out);
                for (t, o) in ts.iter().zip(&out) {
                    assert_eq!(o.to_bits(), d.component(*t, i).to_bits(), "t {t}");
                }
            }
            assert_eq!(*out.last().unwrap(), st.y()[1]);
            checked += ts.len();
        }
        assert!(checked > 2000);
    }

    #[test]
    fn lanes_equal_each_integration_alone_bit_for_bit() {
        let ks = [1.0, 40.0, 400.0];
        let set = AdaptiveSettings::default().with_rtol(1e-7).with_atol(1e-9);
        // alone: the sequence of accepted steps and states
        let alone: Vec<Vec<(f64, [f64; 2])>> = ks
            .iter()
            .map(|&k| {
                let mut st = DoPri5::<2>::new(set).unwrap();
                let mut sys = Forced { k };
                st.init(&mut sys, 0.0, [1.0, 0.0], 3.0).unwrap();
                let mut v = Vec::new();
                while !st.finished() {
                    st.step(&mut sys).unwrap();
                    v.push((st.t(), *st.y()));
                }
                assert!(st.stats().rejected > 0 || k < 100.0);
                v
            })
            .collect();
        let mut steppers: [DoPri5<2>; 3] = std::array::from_fn(|_| DoPri5::new(set).unwrap());
        let mut systems = ks.map(|k| Forced { k });
        for l in 0..3 {
            steppers[l]
                .init(&mut systems[l], 0.0, [1.0, 0.0], 3.0)
                .unwrap();
        }
        let mut together: Vec<Vec<(f64, [f64; 2])>> = vec![Vec::new(); 3];
        // lane 1 starts late: lanes need not be in step
        let mut round = 0;
        loop {
            let active = std::array::from_fn(|l| !steppers[l].finished() && (l != 1 || round > 5));
            if !active.iter().any(|a| *a) {
                break;
            }
            let acc = attempt_lanes(&mut steppers, &mut systems, active).unwrap();
            for l in 0..3 {
                if acc[l] {
                    together[l].push((steppers[l].t(), *steppers[l].y()));
                }
            }
            round += 1;
        }
        for l in 0..3 {
            assert_eq!(together[l], alone[l], "lane {l}");
            assert!(alone[l].len() > 10);
        }
    }

    #[test]
    fn error_weights_sum_to_zero() {
        // b − b̂ must sum to zero for consistency of both formulas.
        let s = E1 + E3 + E4 + E5 + E6 + E7;
        assert!(s.abs() < 1e-15, "{s}");
        let b = A71 + A73 + A74 + A75 + A76;
        assert!((b - 1.0).abs() < 1e-15);
    }

    #[test]
    fn rejects_bad_settings() {
        assert!(DoPri5::<1>::new(AdaptiveSettings::default().with_rtol(-1.0)).is_err());
        assert!(DoPri5::<1>::new(AdaptiveSettings::default().with_max_steps(0)).is_err());
        let mut sys = |_t: f64, _y: &[f64; 1], d: &mut [f64; 1]| d[0] = 0.0;
        let r = dopri5_dense(
            &mut sys,
            [0.0],
            &[0.0, 1.0, 0.5],
            &AdaptiveSettings::default(),
            |_, _| {},
        );
        assert!(matches!(r, Err(OdeError::InvalidInput { .. })));
    }

    /// Harmonic oscillator `y'' = −y` as `[y, y']`, exact solution `[cos t, −sin t]`.
    fn oscillator(_t: f64, y: &[f64; 2], d: &mut [f64; 2]) {
        d[0] = y[1];
        d[1] = -y[0];
    }

    #[test]
    fn log_controller_is_the_same_controller() {
        let set = AdaptiveSettings::default().with_rtol(1e-8).with_atol(1e-10);
        let t_end = 10.0;
        let run = |log: bool| {
            let mut s = DoPri5::<2>::new(set).unwrap();
            if log {
                s = s.with_log_controller();
            }
            let mut sys = oscillator;
            s.init(&mut sys, 0.0, [1.0, 0.0], t_end).unwrap();
            let mut hs = Vec::new();
            while s.t() < t_end {
                s.step(&mut sys).unwrap();
                hs.push(s.t() - s.t_prev());
            }
            (*s.y(), s.stats(), hs)
        };
        let (y_pow, st_pow, h_pow) = run(false);
        let (y_log, st_log, h_log) = run(true);
        assert!((y_log[0] - t_end.cos()).abs() < 1e-6, "{y_log:?}");
        assert!((y_log[1] + t_end.sin()).abs() < 1e-6, "{y_log:?}");
        // same controller: same number of steps, step sizes equal up to rounding (which the
        // feedback of the controller amplifies a little along the run)
        assert_eq!(st_pow, st_log);
        for (a, b) in h_pow.iter().zip(&h_log) {
            assert!((a - b).abs() <= 1e-6 * a, "{a} vs {b}");
        }
        assert!((y_pow[0] - y_log[0]).abs() < 1e-9);
        assert!((y_pow[1] - y_log[1]).abs() < 1e-9);
    }

    #[test]
    fn dense_step_agrees_with_interpolate() {
        let set = AdaptiveSettings::default().with_rtol(1e-9).with_atol(1e-12);
        let mut s = DoPri5::<2>::new(set).unwrap();
        let mut sys = oscillator;
        s.init(&mut sys, 0.0, [1.0, 0.0], 6.0).unwrap();
        let mut buf = [0.0; 2];
        let mut at = [0.0; 2];
        let mut checked = 0;
        while s.t() < 6.0 {
            s.step(&mut sys).unwrap();
            let d = s.dense();
            assert_eq!(d.t_prev(), s.t_prev());
            assert_eq!(d.t(), s.t());
            // exact at the end of the step
            assert_eq!(d.component(s.t(), 0), s.y()[0]);
            assert_eq!(d.component(s.t(), 1), s.y()[1]);
            for f in [0.0, 0.25, 0.5, 0.9] {
                let t = s.t_prev() + f * (s.t() - s.t_prev());
                s.interpolate(t, &mut buf);
                d.at(t, &mut at);
                for i in 0..2 {
                    assert!((at[i] - buf[i]).abs() < 1e-14, "t = {t}");
                    assert_eq!(at[i], d.component(t, i));
                }
                assert!((at[0] - t.cos()).abs() < 1e-7, "t = {t}");
                assert!((at[1] + t.sin()).abs() < 1e-7, "t = {t}");
                checked += 1;
            }
        }
        assert!(checked >= 8);
    }

    #[test]
    fn step_before_init_is_an_error() {
        let mut s = DoPri5::<1>::new(AdaptiveSettings::default()).unwrap();
        let mut sys = |_t: f64, _y: &[f64; 1], d: &mut [f64; 1]| d[0] = 0.0;
        assert!(s.step(&mut sys).is_err());
    }
}
