//! The Dormand–Prince 5(4) stepper ([`DoPri5`]): FSAL, 7 stages, 6 right-hand-side calls per
//! attempt. For `y' = f(t, y)`, an attempt of size `h` from `(t, y)` computes the stages
//! `k_i = f(t + c_i h, y + h Σ_j a_ij k_j)`, the 5th-order solution `y₁ = y + h Σ b_i k_i`
//! (propagated) and the error estimate `e = h Σ (b_i − b̂_i) k_i`, measured in the scaled RMS
//! norm
//!
//! ```text
//! err = sqrt( (1/N) Σ_i ( e_i / (atol + rtol · max(|y_i|, |y₁_i|)) )² )
//! ```
//!
//! which [`crate::controller`] turns into acceptance and the next step size; an accepted step
//! sets the coefficients of its [`crate::dense`] output.

use crate::coefficients::*;
use crate::controller::{PiController, Verdict};
use crate::dense::{DenseCoefficients, DenseStep};
use crate::error::OdeError;
use crate::settings::AdaptiveSettings;
use crate::stats::Stats;
use crate::system::OdeSystem;

/// Dormand–Prince 5(4) stepper with PI step control and dense output.
///
/// Typical use: [`DoPri5::init`], then [`DoPri5::step`] until
/// [`DoPri5::t`] reaches the end time, reading values inside each step with
/// [`DoPri5::interpolate`]. [`crate::dopri5_dense`] does exactly that for a grid.
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
    /// Dense output coefficients of the last accepted step.
    dense: DenseCoefficients<N>,
    control: PiController,
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
            dense: DenseCoefficients::constant([0.0; N]),
            control: PiController::new(settings.pi_beta),
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
        self.control.use_logarithms();
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
        self.control.restart();
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
        self.dense = DenseCoefficients::constant(self.y);
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
    /// Sets component `i` of the current state to `value` between two steps; the last step's
    /// dense output and the stored derivative at the current point (first-same-as-last) are
    /// kept. Meant for a jump that an event gives a component whose derivative does not depend
    /// on it there: a forward sensitivity at the time a switching right-hand side switches.
    ///
    /// # Panics
    /// When `i ≥ N`.
    pub fn set_component(&mut self, i: usize, value: f64) {
        self.y[i] = value;
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

    pub(crate) fn check_can_step(&self) -> Result<(), OdeError> {
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
    pub(crate) fn prepare(&self) -> Result<(f64, f64), OdeError> {
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
    pub(crate) fn conclude(&mut self, h: f64, remaining: f64) -> Result<bool, OdeError> {
        let err = self.error_norm(h);
        let t_new = self.t + h;
        let h_new = match self.control.judge(h, err) {
            Verdict::Accept(h_new) => h_new,
            Verdict::Reject(h_retry) => {
                self.stats.rejected += 1;
                self.h = h_retry;
                return Ok(false);
            }
            Verdict::Unevaluable(h_retry) => {
                self.stats.rejected += 1;
                self.h = h_retry;
                if self.h < self.settings.h_min {
                    return Err(OdeError::NonFinite { t: self.t });
                }
                return Ok(false);
            }
        };
        // dense output coefficients
        let d = &mut self.dense;
        for i in 0..N {
            let ydiff = self.ynew[i] - self.y[i];
            let bspl = h * self.k1[i] - ydiff;
            d.r1[i] = self.y[i];
            d.r2[i] = ydiff;
            d.r3[i] = bspl;
            d.r4[i] = ydiff - h * self.k7[i] - bspl;
            d.r5[i] = h
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
        Ok(true)
    }

    #[inline(always)]
    pub(crate) fn stage2<S: OdeSystem<N>>(&mut self, sys: &mut S, h: f64) {
        let y = &self.y;
        for i in 0..N {
            self.ytmp[i] = y[i] + h * A21 * self.k1[i];
        }
        sys.rhs(self.t + C2 * h, &self.ytmp, &mut self.k2);
    }

    #[inline(always)]
    pub(crate) fn stage3<S: OdeSystem<N>>(&mut self, sys: &mut S, h: f64) {
        let y = &self.y;
        for i in 0..N {
            self.ytmp[i] = y[i] + h * (A31 * self.k1[i] + A32 * self.k2[i]);
        }
        sys.rhs(self.t + C3 * h, &self.ytmp, &mut self.k3);
    }

    #[inline(always)]
    pub(crate) fn stage4<S: OdeSystem<N>>(&mut self, sys: &mut S, h: f64) {
        let y = &self.y;
        for i in 0..N {
            self.ytmp[i] = y[i] + h * (A41 * self.k1[i] + A42 * self.k2[i] + A43 * self.k3[i]);
        }
        sys.rhs(self.t + C4 * h, &self.ytmp, &mut self.k4);
    }

    #[inline(always)]
    pub(crate) fn stage5<S: OdeSystem<N>>(&mut self, sys: &mut S, h: f64) {
        let y = &self.y;
        for i in 0..N {
            self.ytmp[i] = y[i]
                + h * (A51 * self.k1[i] + A52 * self.k2[i] + A53 * self.k3[i] + A54 * self.k4[i]);
        }
        sys.rhs(self.t + C5 * h, &self.ytmp, &mut self.k5);
    }

    #[inline(always)]
    pub(crate) fn stage6<S: OdeSystem<N>>(&mut self, sys: &mut S, h: f64) {
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
    pub(crate) fn stage7<S: OdeSystem<N>>(&mut self, sys: &mut S, h: f64) {
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
            out[i] = self.dense.value(i, theta, theta1);
        }
    }

    /// The dense output of the last accepted step `[t_prev, t]` as a value that reads many
    /// times inside the step cheaply (the step's `1/h` computed once), component by
    /// component if only some are wanted.
    pub fn dense(&self) -> DenseStep<'_, N> {
        DenseStep::new(&self.dense, &self.y, self.t_prev, self.t)
    }
}

fn all_finite<const N: usize>(v: &[f64; N]) -> bool {
    v.iter().all(|x| x.is_finite())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_systems::{oscillator, Forced};

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
