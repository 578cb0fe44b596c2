//! Warm-up adaptation as in Stan: dual averaging of the step size and the windowed estimate of
//! the metric windows (the metric itself is module `metric`).

/// Dual-averaging constants (Hoffman & Gelman 2014, §3.2.1; Stan's defaults).
pub(super) const GAMMA: f64 = 0.05;
/// Iteration offset `t0`.
pub(super) const T0: f64 = 10.0;
/// Decay exponent `κ` of the averaged iterate.
pub(super) const KAPPA: f64 = 0.75;

/// Nesterov's dual averaging of `log ε` toward the mean acceptance statistic `δ`.
#[derive(Clone, Debug)]
pub(super) struct DualAveraging {
    delta: f64,
    mu: f64,
    counter: f64,
    s_bar: f64,
    x_bar: f64,
}

impl DualAveraging {
    pub(super) fn new(delta: f64, step_size: f64) -> Self {
        Self {
            delta,
            mu: (10.0 * step_size).ln(),
            counter: 0.0,
            s_bar: 0.0,
            x_bar: 0.0,
        }
    }

    /// Restarts the averages with `μ = log(10ε)`.
    pub(super) fn restart(&mut self, step_size: f64) {
        self.mu = (10.0 * step_size).ln();
        self.counter = 0.0;
        self.s_bar = 0.0;
        self.x_bar = 0.0;
    }

    /// One update with the transition's acceptance statistic; the next step size `exp(x)`.
    pub(super) fn learn(&mut self, accept_stat: f64) -> f64 {
        self.counter += 1.0;
        let a = if accept_stat.is_nan() {
            0.0
        } else {
            accept_stat.min(1.0)
        };
        let eta = 1.0 / (self.counter + T0);
        self.s_bar = (1.0 - eta) * self.s_bar + eta * (self.delta - a);
        let x = self.mu - self.s_bar * self.counter.sqrt() / GAMMA;
        let w = self.counter.powf(-KAPPA);
        self.x_bar = (1.0 - w) * self.x_bar + w * x;
        x.exp()
    }

    /// The step size after warm-up, `exp(x̄)`.
    pub(super) fn final_step_size(&self) -> f64 {
        self.x_bar.exp()
    }
}

/// Stan's windows for the metric: an initial buffer (step size only), slow windows that double
/// in length, each ending in a metric update, and a terminal buffer (step size only).
#[derive(Clone, Debug)]
pub(super) struct Windows {
    warmup: i64,
    init_buffer: i64,
    term_buffer: i64,
    window_size: i64,
    next_window: i64,
    counter: i64,
}

impl Windows {
    /// Stan's rule: when the three don't fit into `warmup` (≥ 20), the buffers become 15 % and
    /// 10 % of it and one slow window takes the rest; below 20 iterations the metric is not
    /// adapted.
    pub(super) fn new(warmup: usize, init: usize, term: usize, base: usize) -> Self {
        let warmup = warmup as i64;
        let (mut init, mut term, mut base) = (init as i64, term as i64, base as i64);
        if warmup >= 20 && init + term + base > warmup {
            init = (0.15 * warmup as f64) as i64;
            term = (0.1 * warmup as f64) as i64;
            base = warmup - (init + term);
        }
        Self {
            warmup,
            init_buffer: init,
            term_buffer: term,
            window_size: base,
            next_window: init + base - 1,
            counter: 0,
        }
    }

    /// Whether the current iteration's draw goes into the metric estimate.
    pub(super) fn in_window(&self) -> bool {
        self.counter >= self.init_buffer
            && self.counter < self.warmup - self.term_buffer
            && self.counter != self.warmup
    }

    fn end_of_window(&self) -> bool {
        self.counter == self.next_window && self.counter != self.warmup
    }

    fn compute_next_window(&mut self) {
        let last = self.warmup - self.term_buffer - 1;
        if self.next_window == last {
            return;
        }
        self.window_size *= 2;
        self.next_window = self.counter + self.window_size;
        if self.next_window != last {
            let boundary = self.next_window + 2 * self.window_size;
            if boundary >= self.warmup - self.term_buffer {
                self.next_window = last;
            }
        }
    }

    /// Advances by one iteration; true when a slow window ends here (update the metric).
    pub(super) fn advance(&mut self) -> bool {
        let end = self.end_of_window();
        if end {
            self.compute_next_window();
        }
        self.counter += 1;
        end
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn window_ends(warmup: usize) -> Vec<i64> {
        let mut w = Windows::new(warmup, 75, 50, 25);
        (0..warmup as i64).filter(|_| w.advance()).collect()
    }

    #[test]
    fn stan_windows_for_1000() {
        // Stan's schedule for 1000 warm-up iterations: windows of 25, 50, 100, 200 and 500
        // (the last stretched to the terminal buffer), ending at 99, 149, 249, 449, 949.
        assert_eq!(window_ends(1000), vec![99, 149, 249, 449, 949]);
    }

    #[test]
    fn short_warmup_rescales_buffers() {
        // 100 iterations: buffers 15 and 10, one window of 75 ending at 89.
        assert_eq!(window_ends(100), vec![89]);
        assert!(window_ends(10).is_empty());
    }

    #[test]
    fn dual_averaging_moves_toward_target() {
        let mut da = DualAveraging::new(0.8, 1.0);
        // Acceptance always above the target: the step size grows.
        let mut eps = 1.0;
        for _ in 0..50 {
            eps = da.learn(1.0);
        }
        assert!(eps > 1.0 && da.final_step_size() > 1.0);
        da.restart(1.0);
        for _ in 0..50 {
            eps = da.learn(0.1);
        }
        assert!(eps < 1.0 && da.final_step_size() < 1.0);
    }
}
