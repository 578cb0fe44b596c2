//! Dense output of the Dormand–Prince 5(4) pair: the continuous extension of Dormand & Prince
//! (as in Hairer's `DOPRI5`). With `θ = (t − t_n)/h` inside the step `[t_n, t_n + h]`,
//!
//! ```text
//! y(t_n + θh) = r1 + θ (r2 + (1−θ)(r3 + θ (r4 + (1−θ) r5)))
//! r1 = y_n,  r2 = Δ,  r3 = B,  r4 = Δ − h k₇ − B,  r5 = D
//! ```
//!
//! where `Δ = y_{n+1} − y_n`, `B = h k₁ − Δ` and `D = h Σ d_i k_i`: 4th order, exact at both
//! ends of the step.

/// The coefficients `r1 … r5` of the continuous extension of one step.
#[derive(Clone, Debug)]
pub(crate) struct DenseCoefficients<const N: usize> {
    pub(crate) r1: [f64; N],
    pub(crate) r2: [f64; N],
    pub(crate) r3: [f64; N],
    pub(crate) r4: [f64; N],
    pub(crate) r5: [f64; N],
}

impl<const N: usize> DenseCoefficients<N> {
    /// The constant `y` (the extension of a step of length zero).
    pub(crate) fn constant(y: [f64; N]) -> Self {
        DenseCoefficients {
            r1: y,
            r2: [0.0; N],
            r3: [0.0; N],
            r4: [0.0; N],
            r5: [0.0; N],
        }
    }

    /// Component `i` at `θ` (`theta1 = 1 − θ`).
    #[inline(always)]
    pub(crate) fn value(&self, i: usize, theta: f64, theta1: f64) -> f64 {
        self.r1[i]
            + theta
                * (self.r2[i] + theta1 * (self.r3[i] + theta * (self.r4[i] + theta1 * self.r5[i])))
    }
}

/// Dense output of the last accepted step of a [`crate::DoPri5`] (see
/// [`crate::DoPri5::dense`]).
///
/// Same continuous extension as [`crate::DoPri5::interpolate`], with `θ = (t − t_prev)·(1/h)`;
/// exact at the end of the step (returns the stepper's state there).
#[derive(Clone, Copy, Debug)]
pub struct DenseStep<'a, const N: usize> {
    coef: &'a DenseCoefficients<N>,
    /// The state at the end of the step.
    y: &'a [f64; N],
    t_prev: f64,
    t: f64,
    inv_h: f64,
}

impl<'a, const N: usize> DenseStep<'a, N> {
    /// The step `[t_prev, t]` with its coefficients and its end state `y`.
    pub(crate) fn new(
        coef: &'a DenseCoefficients<N>,
        y: &'a [f64; N],
        t_prev: f64,
        t: f64,
    ) -> Self {
        let h = t - t_prev;
        DenseStep {
            coef,
            y,
            t_prev,
            t,
            inv_h: if h > 0.0 { 1.0 / h } else { 0.0 },
        }
    }

    /// Start of the step.
    pub fn t_prev(&self) -> f64 {
        self.t_prev
    }
    /// End of the step.
    pub fn t(&self) -> f64 {
        self.t
    }
    /// Component `i` of the solution at `t` in `[t_prev, t]`.
    ///
    /// # Panics
    ///
    /// If `i >= N` (a programming error, like an out-of-range index).
    #[inline]
    pub fn component(&self, t: f64, i: usize) -> f64 {
        if t == self.t {
            return self.y[i];
        }
        let theta = (t - self.t_prev) * self.inv_h;
        let theta1 = 1.0 - theta;
        self.coef.value(i, theta, theta1)
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
        let c = self.coef;
        let (r1, r2, r3, r4, r5) = (c.r1[i], c.r2[i], c.r3[i], c.r4[i], c.r5[i]);
        let (t_end, t_prev, inv_h, y) = (self.t, self.t_prev, self.inv_h, self.y[i]);
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
