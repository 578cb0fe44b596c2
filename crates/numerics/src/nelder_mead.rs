//! Bounded Nelder–Mead with dimension-adaptive coefficients and restarts.
//!
//! The simplex of `n + 1` vertices lives in unit-box coordinates. With the vertices sorted by
//! cost, `c` the centroid of all but the worst `w`, a step tries the reflection
//! `r = c + α(c − w)`, then the expansion `e = c + γ(r − c)` or a contraction
//! `c + ρ(t − c)` (`t = r` outside, `t = w` inside), and else shrinks every vertex towards the
//! best `b` as `b + σ(v − b)`; every trial point is clamped onto the box. The coefficients
//! are those of Gao & Han (2012), `α = 1`, `γ = 1 + 2/n`, `ρ = 0.75 − 1/(2n)`, `σ = 1 − 1/n`
//! (the classical 1, 2, ½, ½ for `n ≤ 2`).

use crate::objective::UnitBox;
use crate::{NumericsError, Objective};

/// Settings of [`nelder_mead`] (also the final polish of the annealer in `identify-sa`). All lengths are in unit-box coordinates
/// (every parameter rescaled to `[0, 1]`).
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[cfg_attr(feature = "serde", serde(default))]
pub struct NelderMeadSettings {
    /// Maximum objective evaluations. Default 20 000.
    pub max_evaluations: u64,
    /// Edge of the initial simplex, unit coordinates. Default 0.05.
    pub initial_step: f64,
    /// Absolute tolerance on the spread of costs over the simplex. Default 1e-12.
    pub ftol_abs: f64,
    /// Relative tolerance on the spread of costs over the simplex. Default 1e-10.
    pub ftol_rel: f64,
    /// Tolerance on the simplex size (max-norm, unit coordinates). Default 1e-9.
    pub xtol: f64,
    /// Restarts of a fresh simplex at the best point after convergence; stops
    /// early when a restart gains less than the cost tolerance. Default 6.
    pub max_restarts: u32,
}

impl Default for NelderMeadSettings {
    fn default() -> Self {
        Self {
            max_evaluations: 20_000,
            initial_step: 0.05,
            ftol_abs: 1e-12,
            ftol_rel: 1e-10,
            xtol: 1e-9,
            max_restarts: 6,
        }
    }
}

impl NelderMeadSettings {
    /// Validated settings with the given budget, other fields at their defaults.
    ///
    /// # Errors
    /// [`NumericsError::InvalidSetting`] when `max_evaluations` is 0.
    pub fn new(max_evaluations: u64) -> Result<Self, NumericsError> {
        Self {
            max_evaluations,
            ..Self::default()
        }
        .validate()
    }

    /// Set the evaluation budget.
    #[must_use]
    pub fn with_max_evaluations(mut self, v: u64) -> Self {
        self.max_evaluations = v;
        self
    }
    /// Set the initial simplex edge (unit coordinates).
    #[must_use]
    pub fn with_initial_step(mut self, v: f64) -> Self {
        self.initial_step = v;
        self
    }
    /// Set the cost tolerances (absolute, relative).
    #[must_use]
    pub fn with_ftol(mut self, abs: f64, rel: f64) -> Self {
        self.ftol_abs = abs;
        self.ftol_rel = rel;
        self
    }
    /// Set the simplex-size tolerance (unit coordinates).
    #[must_use]
    pub fn with_xtol(mut self, v: f64) -> Self {
        self.xtol = v;
        self
    }
    /// Set the number of restarts.
    #[must_use]
    pub fn with_max_restarts(mut self, v: u32) -> Self {
        self.max_restarts = v;
        self
    }

    /// Check every field; returns the settings unchanged when valid.
    ///
    /// # Errors
    /// [`NumericsError::InvalidSetting`] naming the first invalid field.
    pub fn validate(self) -> Result<Self, NumericsError> {
        let bad = NumericsError::setting;
        if self.max_evaluations == 0 {
            return bad("max_evaluations", 0.0, "must be at least 1");
        }
        if !(self.initial_step > 0.0 && self.initial_step <= 1.0) {
            return bad("initial_step", self.initial_step, "must be in (0, 1]");
        }
        for (name, v) in [
            ("ftol_abs", self.ftol_abs),
            ("ftol_rel", self.ftol_rel),
            ("xtol", self.xtol),
        ] {
            if !(v >= 0.0 && v.is_finite()) {
                return bad(name, v, "must be finite and non-negative");
            }
        }
        Ok(self)
    }
}

/// What [`nelder_mead`] found.
#[derive(Debug, Clone, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct NelderMeadOutcome {
    /// Best point, in the objective's coordinates.
    pub x: Vec<f64>,
    /// Cost at `x`.
    pub cost: f64,
    /// Objective evaluations used (the start point included).
    pub evaluations: u64,
    /// Evaluations that failed (`None` or non-finite).
    pub failed_evaluations: u64,
    /// Restarts performed after the first convergence.
    pub restarts: u32,
    /// Whether the last simplex met the tolerances (false: budget ran out).
    pub converged: bool,
}

/// Minimise `objective` from `x0` (inside the bounds) by Nelder–Mead.
///
/// The simplex lives in unit-box coordinates; every trial vertex is projected
/// (clamped) onto the box, so the objective is never called outside its
/// bounds. Coefficients are the dimension-adaptive ones of Gao & Han (2012):
/// reflection 1, expansion `1 + 2/n`, contraction `0.75 − 1/(2n)`, shrink
/// `1 − 1/n` (the classical 1, 2, ½, ½ for `n ≤ 2`). A simplex has converged when the costs
/// of its vertices differ from the best by at most `ftol_abs + ftol_rel·|f_best|`
/// and every vertex lies within `xtol` (max-norm) of the best; it is then
/// restarted at the best point with the initial edge, up to `max_restarts`
/// times, stopping as soon as a restart gains no more than the cost tolerance.
/// Failed evaluations count as `+∞`.
///
/// ```
/// use numerics::{nelder_mead, FnObjective, NelderMeadSettings};
/// let mut q = FnObjective::new(vec![(-5.0, 5.0); 3], |x: &[f64]| {
///     Some((x[0] - 1.0).powi(2) + 2.0 * (x[1] + 0.5).powi(2) + 3.0 * x[2] * x[2])
/// });
/// let out = nelder_mead(&mut q, &[3.0, 3.0, 3.0], &NelderMeadSettings::default()).unwrap();
/// assert!(out.cost < 1e-10);
/// assert!((out.x[0] - 1.0).abs() < 1e-5);
/// ```
///
/// # Errors
/// Invalid bounds or settings, a start point of the wrong length or outside
/// the bounds, or a start point where the objective fails.
pub fn nelder_mead<O: Objective + ?Sized>(
    objective: &mut O,
    x0: &[f64],
    settings: &NelderMeadSettings,
) -> Result<NelderMeadOutcome, NumericsError> {
    let settings = settings.validate()?;
    let mut ubox = UnitBox::new(objective)?;
    let n = ubox.dim();
    let mut u0 = vec![0.0; n];
    ubox.to_unit(x0, &mut u0)?;
    let f0 = ubox
        .eval(objective, &u0)
        .ok_or(NumericsError::StartEvaluationFailed)?;
    let steps = vec![settings.initial_step; n];
    let r = nelder_mead_unit(
        objective,
        &mut ubox,
        &u0,
        f0,
        &steps,
        &settings,
        settings.max_evaluations.saturating_sub(1),
    );
    Ok(NelderMeadOutcome {
        x: ubox.to_box(&r.u),
        cost: r.f,
        evaluations: r.evaluations + 1,
        failed_evaluations: r.failed,
        restarts: r.restarts,
        converged: r.converged,
    })
}

/// Result of [`nelder_mead_unit`], in unit coordinates.
#[derive(Debug, Clone, PartialEq)]
pub struct NelderMeadUnitOutcome {
    /// Best point (unit coordinates).
    pub u: Vec<f64>,
    /// Cost at `u`.
    pub f: f64,
    /// New evaluations used (the start point's not included).
    pub evaluations: u64,
    /// Evaluations that failed.
    pub failed: u64,
    /// Restarts performed after the first convergence.
    pub restarts: u32,
    /// Whether the last simplex met the tolerances.
    pub converged: bool,
}

/// Counts evaluations against a budget; failures become `+∞`.
struct Counter<'a, O: ?Sized> {
    objective: &'a mut O,
    ubox: &'a mut UnitBox,
    evaluations: u64,
    failed: u64,
    budget: u64,
}

impl<O: Objective + ?Sized> Counter<'_, O> {
    fn exhausted(&self) -> bool {
        self.evaluations >= self.budget
    }
    fn eval(&mut self, u: &[f64]) -> f64 {
        self.evaluations += 1;
        match self.ubox.eval(self.objective, u) {
            Some(v) => v,
            None => {
                self.failed += 1;
                f64::INFINITY
            }
        }
    }
}

/// The step coefficients of Gao & Han (2012): reflection, expansion, contraction, shrink.
#[derive(Clone, Copy)]
struct Coefficients {
    alpha: f64,
    gamma: f64,
    rho: f64,
    sigma: f64,
}

impl Coefficients {
    /// The coefficients for `n` dimensions: the classical 1, 2, ½, ½ up to `n = 2` (at `n = 2`
    /// they are the adaptive ones; at `n = 1` the adaptive shrink σ = 0 would collapse the
    /// simplex onto its best vertex).
    fn for_dimension(n: usize) -> Self {
        let nf = n as f64;
        if n <= 2 {
            Self {
                alpha: 1.0,
                gamma: 2.0,
                rho: 0.5,
                sigma: 0.5,
            }
        } else {
            Self {
                alpha: 1.0,
                gamma: 1.0 + 2.0 / nf,
                rho: 0.75 - 0.5 / nf,
                sigma: 1.0 - 1.0 / nf,
            }
        }
    }
}

/// The best point met so far and its cost.
struct Best {
    u: Vec<f64>,
    f: f64,
}

impl Best {
    /// Takes `(v, f)` when it is strictly better (a tie keeps the point already held).
    fn take_if_better(&mut self, v: &[f64], f: f64) {
        if f < self.f {
            self.f = f;
            self.u.copy_from_slice(v);
        }
    }
}

/// The `n + 1` vertices (flat, `n` unit coordinates each), their costs, and their order by
/// cost after [`Simplex::rank`].
struct Simplex {
    n: usize,
    vertices: Vec<f64>,
    costs: Vec<f64>,
    order: Vec<usize>,
}

/// Where the vertices stand after ranking: best, second worst and worst.
#[derive(Clone, Copy)]
struct Ranks {
    best: usize,
    second_worst: usize,
    worst: usize,
}

impl Simplex {
    fn new(n: usize) -> Self {
        Self {
            n,
            vertices: vec![0.0; (n + 1) * n],
            costs: vec![0.0; n + 1],
            order: (0..=n).collect(),
        }
    }

    fn vertex(&self, j: usize) -> &[f64] {
        &self.vertices[j * self.n..(j + 1) * self.n]
    }

    /// Puts `v` with cost `f` in place of vertex `j`.
    fn replace(&mut self, j: usize, v: &[f64], f: f64) {
        let n = self.n;
        self.vertices[j * n..(j + 1) * n].copy_from_slice(v);
        self.costs[j] = f;
    }

    /// Sorts the vertices by cost (the sort is stable: the previous order breaks ties).
    fn rank(&mut self) -> Ranks {
        let costs = &self.costs;
        self.order.sort_by(|&a, &b| costs[a].total_cmp(&costs[b]));
        let n = self.n;
        Ranks {
            best: self.order[0],
            second_worst: self.order[n - 1],
            worst: self.order[n],
        }
    }

    /// Whether the costs spread by at most the cost tolerance about the best and every vertex
    /// lies within `xtol` (max-norm) of the best.
    fn converged(&self, ranks: Ranks, settings: &NelderMeadSettings) -> bool {
        let n = self.n;
        let fb = self.costs[ranks.best];
        let ftol = settings.ftol_abs + settings.ftol_rel * fb.abs();
        let fspread = self.costs[ranks.worst] - fb;
        let vb = self.vertex(ranks.best);
        let xspread = (0..=n)
            .flat_map(|j| (0..n).map(move |k| (j, k)))
            .map(|(j, k)| (self.vertices[j * n + k] - vb[k]).abs())
            .fold(0.0f64, f64::max);
        fspread <= ftol && xspread <= settings.xtol
    }
}

/// The centroid and the trial points of one step, kept between steps to avoid allocations.
struct TrialPoints {
    centroid: Vec<f64>,
    reflected: Vec<f64>,
    expanded: Vec<f64>,
    contracted: Vec<f64>,
}

impl TrialPoints {
    fn new(n: usize) -> Self {
        Self {
            centroid: vec![0.0; n],
            reflected: vec![0.0; n],
            expanded: vec![0.0; n],
            contracted: vec![0.0; n],
        }
    }

    /// The centroid of every vertex but the worst (summed in cost order, then divided).
    fn centre(&mut self, simplex: &Simplex) {
        let n = simplex.n;
        self.centroid.fill(0.0);
        for &j in &simplex.order[..n] {
            for k in 0..n {
                self.centroid[k] += simplex.vertices[j * n + k];
            }
        }
        for c in self.centroid.iter_mut() {
            *c /= n as f64;
        }
    }

    /// `r = c + α(c − w)`, clamped onto the box.
    fn reflect(&mut self, worst: &[f64], alpha: f64) {
        for ((r, &c), &w) in self.reflected.iter_mut().zip(&self.centroid).zip(worst) {
            *r = (c + alpha * (c - w)).clamp(0.0, 1.0);
        }
    }

    /// `e = c + γ(r − c)`, clamped onto the box.
    fn expand(&mut self, gamma: f64) {
        for ((e, &c), &r) in self
            .expanded
            .iter_mut()
            .zip(&self.centroid)
            .zip(&self.reflected)
        {
            *e = (c + gamma * (r - c)).clamp(0.0, 1.0);
        }
    }

    /// `c + ρ(t − c)`, clamped onto the box, with `t` the reflected point (`outside`) or the
    /// worst vertex.
    fn contract(&mut self, worst: &[f64], rho: f64, outside: bool) {
        let targets: &[f64] = if outside { &self.reflected } else { worst };
        for ((x, &c), &t) in self.contracted.iter_mut().zip(&self.centroid).zip(targets) {
            *x = (c + rho * (t - c)).clamp(0.0, 1.0);
        }
    }
}

/// How a run of the simplex ended.
enum RunEnd {
    /// The simplex met the tolerances.
    Converged,
    /// The budget ran out first.
    OutOfBudget,
}

/// Nelder–Mead from `u0` (cost `f0` already known) with per-coordinate
/// initial edges `steps`, using at most `budget` new evaluations, on an already validated
/// unit box (the annealer's polish; [`nelder_mead`] is the checked entry point).
pub fn nelder_mead_unit<O: Objective + ?Sized>(
    objective: &mut O,
    ubox: &mut UnitBox,
    u0: &[f64],
    f0: f64,
    steps: &[f64],
    settings: &NelderMeadSettings,
    budget: u64,
) -> NelderMeadUnitOutcome {
    let n = u0.len();
    let mut counter = Counter {
        objective,
        ubox,
        evaluations: 0,
        failed: 0,
        budget,
    };
    let coefficients = Coefficients::for_dimension(n);
    let mut best = Best {
        u: u0.to_vec(),
        f: f0,
    };
    let mut simplex = Simplex::new(n);
    let mut points = TrialPoints::new(n);
    let mut restarts = 0u32;
    // Stays as the last finished run left it when a fresh simplex runs out of budget.
    let mut converged = false;
    let mut run_start_f = f0;
    loop {
        if !lay_simplex(&mut counter, &mut simplex, &best, steps) {
            break;
        }
        let end = descend(
            &mut counter,
            &mut simplex,
            &mut points,
            coefficients,
            settings,
            &mut best,
        );
        converged = matches!(end, RunEnd::Converged);
        if !converged || !worth_restarting(settings, restarts, run_start_f, best.f) {
            break;
        }
        restarts += 1;
        run_start_f = best.f;
    }
    // Pick up a better vertex found in a run cut short by the budget.
    for j in 0..=n {
        best.take_if_better(simplex.vertex(j), simplex.costs[j]);
    }
    NelderMeadUnitOutcome {
        u: best.u,
        f: best.f,
        evaluations: counter.evaluations,
        failed: counter.failed,
        restarts,
        converged,
    }
}

/// Lays a fresh simplex around the best point: vertex 0 at it, vertex `i + 1` moved along
/// coordinate `i` (see [`edge_vertex`]). Returns `false` when the budget runs out on the way;
/// the vertices not reached then keep an infinite cost.
fn lay_simplex<O: Objective + ?Sized>(
    counter: &mut Counter<'_, O>,
    simplex: &mut Simplex,
    best: &Best,
    steps: &[f64],
) -> bool {
    let n = simplex.n;
    simplex.vertices[..n].copy_from_slice(&best.u);
    simplex.costs.fill(f64::INFINITY);
    simplex.costs[0] = best.f;
    for (i, &s) in steps[..n].iter().enumerate() {
        let (head, tail) = simplex.vertices.split_at_mut((i + 1) * n);
        let v = &mut tail[..n];
        v.copy_from_slice(&head[..n]);
        match edge_vertex(counter, v, &best.u, i, s) {
            Some(f) => simplex.costs[i + 1] = f,
            None => return false,
        }
    }
    true
}

/// Moves `v` (a copy of `base`) along coordinate `i` and returns its cost, `None` when the
/// budget runs out first. Up to six tries, so that the simplex starts with finite costs where
/// the objective allows: `+s` (or `−s` when `+s` leaves the box), then the other sign, then
/// both again at `s/2` and at `s/4`; the first finite cost is kept, else the last one met. A try
/// that the box clamps back onto `base` is skipped without an evaluation.
fn edge_vertex<O: Objective + ?Sized>(
    counter: &mut Counter<'_, O>,
    v: &mut [f64],
    base: &[f64],
    i: usize,
    s: f64,
) -> Option<f64> {
    let mut f = f64::INFINITY;
    for attempt in 0..6 {
        if counter.exhausted() {
            return None;
        }
        let h = s * 0.5f64.powi(attempt / 2);
        let dir = if (base[i] + h <= 1.0) == (attempt % 2 == 0) {
            h
        } else {
            -h
        };
        v[i] = (base[i] + dir).clamp(0.0, 1.0);
        if v[i] == base[i] {
            continue;
        }
        f = counter.eval(v);
        if f.is_finite() {
            break;
        }
    }
    Some(f)
}

/// Steps the simplex until it converges or the budget runs out, keeping `best` up to date with
/// its best vertex.
fn descend<O: Objective + ?Sized>(
    counter: &mut Counter<'_, O>,
    simplex: &mut Simplex,
    points: &mut TrialPoints,
    coefficients: Coefficients,
    settings: &NelderMeadSettings,
    best: &mut Best,
) -> RunEnd {
    loop {
        let ranks = simplex.rank();
        best.take_if_better(simplex.vertex(ranks.best), simplex.costs[ranks.best]);
        if simplex.converged(ranks, settings) {
            return RunEnd::Converged;
        }
        if counter.exhausted() {
            return RunEnd::OutOfBudget;
        }
        step(counter, simplex, points, coefficients, ranks);
    }
}

/// One Nelder–Mead step on a ranked simplex: reflect the worst vertex through the centroid of
/// the others, then expand, accept, contract or shrink. A step cut short by the budget keeps
/// the reflected point when it beats the worst vertex.
fn step<O: Objective + ?Sized>(
    counter: &mut Counter<'_, O>,
    simplex: &mut Simplex,
    points: &mut TrialPoints,
    coefficients: Coefficients,
    ranks: Ranks,
) {
    let Ranks {
        best: b,
        second_worst: sw,
        worst: w,
    } = ranks;
    points.centre(simplex);
    points.reflect(simplex.vertex(w), coefficients.alpha);
    let fr = counter.eval(&points.reflected);
    if fr < simplex.costs[b] {
        expand_or_reflect(counter, simplex, points, coefficients.gamma, w, fr);
        return;
    }
    if fr < simplex.costs[sw] {
        simplex.replace(w, &points.reflected, fr);
        return;
    }
    if counter.exhausted() {
        if fr < simplex.costs[w] {
            simplex.replace(w, &points.reflected, fr);
        }
        return;
    }
    if !contract(counter, simplex, points, coefficients.rho, w, fr) {
        shrink(counter, simplex, coefficients.sigma, b);
    }
}

/// The reflected point (cost `fr`) beat the best vertex: try going further along the same
/// direction and put the better of the two in place of the worst vertex `w`.
fn expand_or_reflect<O: Objective + ?Sized>(
    counter: &mut Counter<'_, O>,
    simplex: &mut Simplex,
    points: &mut TrialPoints,
    gamma: f64,
    w: usize,
    fr: f64,
) {
    if counter.exhausted() {
        simplex.replace(w, &points.reflected, fr);
        return;
    }
    points.expand(gamma);
    let fe = counter.eval(&points.expanded);
    if fe < fr {
        simplex.replace(w, &points.expanded, fe);
    } else {
        simplex.replace(w, &points.reflected, fr);
    }
}

/// The reflected point (cost `fr`) is no better than the second worst vertex: contract towards
/// it when it beats the worst vertex `w` (outside), towards `w` otherwise (inside). Returns
/// whether the contracted point was accepted in place of `w`.
fn contract<O: Objective + ?Sized>(
    counter: &mut Counter<'_, O>,
    simplex: &mut Simplex,
    points: &mut TrialPoints,
    rho: f64,
    w: usize,
    fr: f64,
) -> bool {
    let outside = fr < simplex.costs[w];
    points.contract(simplex.vertex(w), rho, outside);
    let fc = counter.eval(&points.contracted);
    let ok = if outside {
        fc <= fr
    } else {
        fc < simplex.costs[w]
    };
    if ok {
        simplex.replace(w, &points.contracted, fc);
    }
    ok
}

/// Shrinks every vertex towards the best one `b` as `b + σ(v − b)`, evaluating each, while the
/// budget lasts.
fn shrink<O: Objective + ?Sized>(
    counter: &mut Counter<'_, O>,
    simplex: &mut Simplex,
    sigma: f64,
    b: usize,
) {
    let n = simplex.n;
    for j in 0..=n {
        if j == b {
            continue;
        }
        if counter.exhausted() {
            break;
        }
        for k in 0..n {
            let vbk = simplex.vertices[b * n + k];
            simplex.vertices[j * n + k] = vbk + sigma * (simplex.vertices[j * n + k] - vbk);
        }
        simplex.costs[j] = counter.eval(simplex.vertex(j));
    }
}

/// Whether a converged run earns a restart: restarts remain and the last run (after the first)
/// gained more than the cost tolerance from its start `run_start_f` down to `best_f`.
fn worth_restarting(
    settings: &NelderMeadSettings,
    restarts: u32,
    run_start_f: f64,
    best_f: f64,
) -> bool {
    let tol = settings.ftol_abs + settings.ftol_rel * best_f.abs();
    let gained = run_start_f - best_f;
    !(restarts >= settings.max_restarts || (restarts > 0 && gained <= tol))
}
