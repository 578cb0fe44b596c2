//! One NUTS transition: the Hamiltonian on the unconstrained coordinates, the leapfrog, the
//! recursive doubling with multinomial sampling and the generalised U-turn criterion (Stan's
//! `base_nuts`; Betancourt 2017, appendix A).

use rand::Rng;
use rand_chacha::ChaCha8Rng;

use super::metric::Metric;
use crate::{GradLogDensity, LogisticBox, NutsSettings};

/// A point of phase space: position `q` (unconstrained), momentum `p`, `log p(q)` (Jacobian
/// included; `−∞` when the evaluation failed) and its gradient.
#[derive(Clone, Debug, Default)]
pub(super) struct Point {
    pub(super) q: Vec<f64>,
    pub(super) p: Vec<f64>,
    pub(super) grad: Vec<f64>,
    pub(super) logp: f64,
}

/// The target seen on the unconstrained coordinates, with the evaluation counters.
pub(super) struct Model<'a, T: ?Sized> {
    target: &'a T,
    transform: &'a LogisticBox,
    x: Vec<f64>,
    /// Calls of `log_density_grad`.
    pub(super) evaluations: u64,
    /// Calls that failed (`None`, a non-finite value or gradient).
    pub(super) failed: u64,
}

impl<'a, T: GradLogDensity + ?Sized> Model<'a, T> {
    pub(super) fn new(target: &'a T, transform: &'a LogisticBox) -> Self {
        Self {
            target,
            transform,
            x: vec![0.0; transform.dim()],
            evaluations: 0,
            failed: 0,
        }
    }

    /// `log π(x(u)) + log J(u)` and its gradient in `grad`; `−∞` on failure.
    pub(super) fn eval(&mut self, u: &[f64], grad: &mut [f64]) -> f64 {
        self.evaluations += 1;
        let value = if u.iter().all(|v| v.is_finite()) {
            self.transform.to_box(u, &mut self.x);
            self.target.log_density_grad(&self.x, grad)
        } else {
            None
        };
        match value {
            Some(v) if v.is_finite() && grad.iter().all(|g| g.is_finite()) => {
                self.transform.chain_rule(u, grad);
                v + self.transform.log_jacobian(u)
            }
            _ => {
                self.failed += 1;
                f64::NEG_INFINITY
            }
        }
    }

    /// The box coordinates of `u`.
    pub(super) fn to_box(&self, u: &[f64], x: &mut [f64]) {
        self.transform.to_box(u, x);
    }
}

/// `log(eᵃ + eᵇ)`, exact when either is `−∞`.
pub(super) fn log_add_exp(a: f64, b: f64) -> f64 {
    let m = a.max(b);
    if m == f64::NEG_INFINITY {
        m
    } else {
        m + ((a - m).exp() + (b - m).exp()).ln()
    }
}

/// `H = −log p(q) + ½ pᵀ M⁻¹ p`; NaN becomes `+∞`.
pub(super) fn hamiltonian(z: &Point, metric: &Metric) -> f64 {
    let h = -z.logp + 0.5 * metric.quadratic(&z.p);
    if h.is_nan() {
        f64::INFINITY
    } else {
        h
    }
}

/// Draws `p ~ N(0, M)`.
pub(super) fn sample_momentum(z: &mut Point, metric: &Metric, rng: &mut ChaCha8Rng) {
    metric.sample(&mut z.p, rng);
}

/// One leapfrog step of size `eps` (negative: backward in time).
pub(super) fn leapfrog<T: GradLogDensity + ?Sized>(
    z: &mut Point,
    eps: f64,
    metric: &Metric,
    model: &mut Model<'_, T>,
) {
    for (p, g) in z.p.iter_mut().zip(&z.grad) {
        *p += 0.5 * eps * g;
    }
    metric.step_position(&mut z.q, &z.p, eps);
    z.logp = model.eval(&z.q, &mut z.grad);
    if z.logp.is_finite() {
        for (p, g) in z.p.iter_mut().zip(&z.grad) {
            *p += 0.5 * eps * g;
        }
    }
}

/// `p♯ = M⁻¹p`.
fn sharp(p: &[f64], metric: &Metric, out: &mut [f64]) {
    metric.sharp(p, out);
}

/// The generalised no-U-turn criterion: the trajectory keeps going while both ends' sharp
/// momenta point along the summed momentum `ρ`.
fn no_u_turn(p_sharp_minus: &[f64], p_sharp_plus: &[f64], rho: &[f64]) -> bool {
    let dot = |a: &[f64]| a.iter().zip(rho).map(|(a, r)| a * r).sum::<f64>();
    dot(p_sharp_plus) > 0.0 && dot(p_sharp_minus) > 0.0
}

fn add(a: &[f64], b: &[f64], out: &mut [f64]) {
    for ((o, a), b) in out.iter_mut().zip(a).zip(b) {
        *o = a + b;
    }
}

/// What one transition reports.
#[derive(Clone, Copy, Debug)]
pub(super) struct Transition {
    pub(super) accept_stat: f64,
    pub(super) tree_depth: u32,
    pub(super) n_leapfrog: u32,
    pub(super) divergent: bool,
    pub(super) energy: f64,
}

/// Working vectors of one level of the recursion: the two halves' summed momenta, the momenta
/// where they meet, the second half's sample.
#[derive(Clone, Debug, Default)]
struct Level {
    rho_init: Vec<f64>,
    p_init_end: Vec<f64>,
    p_sharp_init_end: Vec<f64>,
    rho_final: Vec<f64>,
    p_final_beg: Vec<f64>,
    p_sharp_final_beg: Vec<f64>,
    rho_subtree: Vec<f64>,
    rho_ext: Vec<f64>,
    z_final: Point,
}

/// The recursion's working memory, sized once per chain (one [`Level`] per tree depth) so that
/// building a trajectory allocates nothing.
#[derive(Clone, Debug)]
pub(super) struct Scratch {
    levels: Vec<Level>,
}

impl Scratch {
    pub(super) fn new(d: usize, max_depth: u32) -> Self {
        let v = vec![0.0; d];
        let level = Level {
            rho_init: v.clone(),
            p_init_end: v.clone(),
            p_sharp_init_end: v.clone(),
            rho_final: v.clone(),
            p_final_beg: v.clone(),
            p_sharp_final_beg: v.clone(),
            rho_subtree: v.clone(),
            rho_ext: v.clone(),
            z_final: Point {
                q: v.clone(),
                p: v.clone(),
                grad: v,
                logp: f64::NEG_INFINITY,
            },
        };
        Self {
            levels: vec![level; max_depth as usize + 1],
        }
    }
}

/// The state of the trajectory being built.
struct Tree<'b, 'a, T: ?Sized> {
    scratch: &'b mut Scratch,
    model: &'b mut Model<'a, T>,
    rng: &'b mut ChaCha8Rng,
    inv_metric: &'b Metric,
    h0: f64,
    max_energy_error: f64,
    n_leapfrog: u32,
    sum_metro_prob: f64,
    divergent: bool,
    /// The end of the trajectory being extended.
    z: Point,
}

impl<T: GradLogDensity + ?Sized> Tree<'_, '_, T> {
    /// Extends the trajectory from `self.z` by `2^depth` leapfrog steps of size `eps`. On
    /// return `z_propose` is the subtree's multinomial sample, `log_sum_weight` has the
    /// subtree's weights added, `rho` its summed momenta, and `p_beg`/`p_end` (and their sharp
    /// versions) the momenta at the subtree's first and last points. False when the subtree
    /// diverged or made a U-turn (it is then discarded).
    #[allow(clippy::too_many_arguments)]
    fn build(
        &mut self,
        depth: u32,
        eps: f64,
        z_propose: &mut Point,
        p_sharp_beg: &mut [f64],
        p_sharp_end: &mut [f64],
        rho: &mut [f64],
        p_beg: &mut [f64],
        p_end: &mut [f64],
        log_sum_weight: &mut f64,
    ) -> bool {
        if depth == 0 {
            leapfrog(&mut self.z, eps, self.inv_metric, self.model);
            self.n_leapfrog += 1;
            let h = hamiltonian(&self.z, self.inv_metric);
            if h - self.h0 > self.max_energy_error {
                self.divergent = true;
            }
            let w = self.h0 - h;
            *log_sum_weight = log_add_exp(*log_sum_weight, w);
            self.sum_metro_prob += if w > 0.0 { 1.0 } else { w.exp() };
            z_propose.clone_from(&self.z);
            sharp(&self.z.p, self.inv_metric, p_sharp_beg);
            p_sharp_end.copy_from_slice(p_sharp_beg);
            for (r, p) in rho.iter_mut().zip(&self.z.p) {
                *r += p;
            }
            p_beg.copy_from_slice(&self.z.p);
            p_end.copy_from_slice(&self.z.p);
            return !self.divergent;
        }
        // This level's vectors, moved out while the halves use the levels below.
        let mut lv = std::mem::take(&mut self.scratch.levels[depth as usize]);
        let persist = self.merge_halves(
            depth,
            eps,
            &mut lv,
            z_propose,
            p_sharp_beg,
            p_sharp_end,
            rho,
            p_beg,
            p_end,
            log_sum_weight,
        );
        self.scratch.levels[depth as usize] = lv;
        persist
    }

    /// [`Tree::build`] for `depth ≥ 1`: two subtrees of `depth − 1`, a multinomial choice
    /// between their samples and the U-turn checks of the merged subtree.
    #[allow(clippy::too_many_arguments)]
    fn merge_halves(
        &mut self,
        depth: u32,
        eps: f64,
        lv: &mut Level,
        z_propose: &mut Point,
        p_sharp_beg: &mut [f64],
        p_sharp_end: &mut [f64],
        rho: &mut [f64],
        p_beg: &mut [f64],
        p_end: &mut [f64],
        log_sum_weight: &mut f64,
    ) -> bool {
        // The first half.
        lv.rho_init.fill(0.0);
        let mut lsw_init = f64::NEG_INFINITY;
        if !self.build(
            depth - 1,
            eps,
            z_propose,
            p_sharp_beg,
            &mut lv.p_sharp_init_end,
            &mut lv.rho_init,
            p_beg,
            &mut lv.p_init_end,
            &mut lsw_init,
        ) {
            return false;
        }
        // The second half.
        lv.rho_final.fill(0.0);
        let mut lsw_final = f64::NEG_INFINITY;
        if !self.build(
            depth - 1,
            eps,
            &mut lv.z_final,
            &mut lv.p_sharp_final_beg,
            p_sharp_end,
            &mut lv.rho_final,
            &mut lv.p_final_beg,
            p_end,
            &mut lsw_final,
        ) {
            return false;
        }
        // Multinomial (uniform progressive) sample between the halves.
        let lsw_subtree = log_add_exp(lsw_init, lsw_final);
        *log_sum_weight = log_add_exp(*log_sum_weight, lsw_subtree);
        if lsw_final > lsw_subtree {
            std::mem::swap(z_propose, &mut lv.z_final);
        } else {
            let accept = (lsw_final - lsw_subtree).exp();
            if self.rng.random::<f64>() < accept {
                std::mem::swap(z_propose, &mut lv.z_final);
            }
        }
        // U-turn across the subtree, and across each half extended by the other's nearest
        // point.
        add(&lv.rho_init, &lv.rho_final, &mut lv.rho_subtree);
        for (r, s) in rho.iter_mut().zip(&lv.rho_subtree) {
            *r += s;
        }
        let mut persist = no_u_turn(p_sharp_beg, p_sharp_end, &lv.rho_subtree);
        add(&lv.rho_init, &lv.p_final_beg, &mut lv.rho_ext);
        persist &= no_u_turn(p_sharp_beg, &lv.p_sharp_final_beg, &lv.rho_ext);
        add(&lv.rho_final, &lv.p_init_end, &mut lv.rho_ext);
        persist &= no_u_turn(&lv.p_sharp_init_end, p_sharp_end, &lv.rho_ext);
        persist
    }
}

/// One NUTS transition from `z` (its `q`, `logp` and `grad` set; `logp` finite): draws a
/// momentum, builds the trajectory and leaves the selected point in `z`.
pub(super) fn transition<T: GradLogDensity + ?Sized>(
    z: &mut Point,
    eps: f64,
    inv_metric: &Metric,
    settings: &NutsSettings,
    model: &mut Model<'_, T>,
    rng: &mut ChaCha8Rng,
    scratch: &mut Scratch,
) -> Transition {
    let (max_depth, max_energy_error) = (settings.max_depth, settings.max_energy_error);
    let d = z.q.len();
    sample_momentum(z, inv_metric, rng);
    let h0 = hamiltonian(z, inv_metric);
    let mut z_fwd = z.clone();
    let mut z_bck = z.clone();
    let mut z_sample = z.clone();
    let mut z_propose = z.clone();
    let mut p_sharp = vec![0.0; d];
    sharp(&z.p, inv_metric, &mut p_sharp);
    let (mut p_fwd_fwd, mut p_fwd_bck) = (z.p.clone(), z.p.clone());
    let (mut p_bck_fwd, mut p_bck_bck) = (z.p.clone(), z.p.clone());
    let (mut p_sharp_fwd_fwd, mut p_sharp_fwd_bck) = (p_sharp.clone(), p_sharp.clone());
    let (mut p_sharp_bck_fwd, mut p_sharp_bck_bck) = (p_sharp.clone(), p_sharp);
    let mut rho = z.p.clone();
    let mut log_sum_weight = 0.0;
    let mut tree = Tree {
        scratch,
        model,
        rng,
        inv_metric,
        h0,
        max_energy_error,
        n_leapfrog: 0,
        sum_metro_prob: 0.0,
        divergent: false,
        z: z.clone(),
    };
    let mut depth = 0u32;
    let mut rho_ext = vec![0.0; d];
    while depth < max_depth {
        let mut rho_fwd = vec![0.0; d];
        let mut rho_bck = vec![0.0; d];
        let mut lsw_subtree = f64::NEG_INFINITY;
        let valid = if tree.rng.random::<f64>() > 0.5 {
            tree.z.clone_from(&z_fwd);
            rho_bck.copy_from_slice(&rho);
            p_bck_fwd.copy_from_slice(&p_fwd_fwd);
            p_sharp_bck_fwd.copy_from_slice(&p_sharp_fwd_fwd);
            let v = tree.build(
                depth,
                eps,
                &mut z_propose,
                &mut p_sharp_fwd_bck,
                &mut p_sharp_fwd_fwd,
                &mut rho_fwd,
                &mut p_fwd_bck,
                &mut p_fwd_fwd,
                &mut lsw_subtree,
            );
            z_fwd.clone_from(&tree.z);
            v
        } else {
            tree.z.clone_from(&z_bck);
            rho_fwd.copy_from_slice(&rho);
            p_fwd_bck.copy_from_slice(&p_bck_bck);
            p_sharp_fwd_bck.copy_from_slice(&p_sharp_bck_bck);
            let v = tree.build(
                depth,
                -eps,
                &mut z_propose,
                &mut p_sharp_bck_fwd,
                &mut p_sharp_bck_bck,
                &mut rho_bck,
                &mut p_bck_fwd,
                &mut p_bck_bck,
                &mut lsw_subtree,
            );
            z_bck.clone_from(&tree.z);
            v
        };
        if !valid {
            break;
        }
        depth += 1;
        // Biased progressive sampling: the new subtree replaces the sample with probability
        // min(1, w_new/w_old).
        if lsw_subtree > log_sum_weight {
            z_sample.clone_from(&z_propose);
        } else {
            let accept = (lsw_subtree - log_sum_weight).exp();
            if tree.rng.random::<f64>() < accept {
                z_sample.clone_from(&z_propose);
            }
        }
        log_sum_weight = log_add_exp(log_sum_weight, lsw_subtree);
        add(&rho_bck, &rho_fwd, &mut rho);
        let mut persist = no_u_turn(&p_sharp_bck_bck, &p_sharp_fwd_fwd, &rho);
        add(&rho_bck, &p_fwd_bck, &mut rho_ext);
        persist &= no_u_turn(&p_sharp_bck_bck, &p_sharp_fwd_bck, &rho_ext);
        add(&rho_fwd, &p_bck_fwd, &mut rho_ext);
        persist &= no_u_turn(&p_sharp_bck_fwd, &p_sharp_fwd_fwd, &rho_ext);
        if !persist {
            break;
        }
    }
    let n_leapfrog = tree.n_leapfrog;
    let accept_stat = tree.sum_metro_prob / f64::from(n_leapfrog.max(1));
    let divergent = tree.divergent;
    *z = z_sample;
    Transition {
        accept_stat,
        tree_depth: depth,
        n_leapfrog,
        divergent,
        energy: hamiltonian(z, inv_metric),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{FnGradLogDensity, LogDensity};
    use rand::SeedableRng;

    /// The leapfrog is reversible and nearly conserves `H` on a Gaussian.
    #[test]
    fn leapfrog_reverses_and_conserves_energy() {
        let target = FnGradLogDensity::new(vec![(-50.0, 50.0); 2], |x: &[f64], g: &mut [f64]| {
            g[0] = -x[0];
            g[1] = -4.0 * x[1];
            Some(-0.5 * x[0] * x[0] - 2.0 * x[1] * x[1])
        });
        let tr = LogisticBox::new(target.bounds());
        let mut model = Model::new(&target, &tr);
        let mut z = Point {
            q: vec![0.02, -0.01],
            p: vec![1.0, -0.5],
            grad: vec![0.0; 2],
            logp: 0.0,
        };
        z.logp = model.eval(&z.q.clone(), &mut z.grad);
        let inv = Metric::Diagonal(vec![0.001, 0.0005]);
        let start = z.clone();
        let h0 = hamiltonian(&z, &inv);
        for _ in 0..20 {
            leapfrog(&mut z, 0.3, &inv, &mut model);
        }
        assert!((hamiltonian(&z, &inv) - h0).abs() < 0.05);
        for p in &mut z.p {
            *p = -*p;
        }
        for _ in 0..20 {
            leapfrog(&mut z, 0.3, &inv, &mut model);
        }
        for i in 0..2 {
            assert!((z.q[i] - start.q[i]).abs() < 1e-10);
            assert!((z.p[i] + start.p[i]).abs() < 1e-10);
        }
    }

    #[test]
    fn log_add_exp_edges() {
        let ninf = f64::NEG_INFINITY;
        assert_eq!(log_add_exp(ninf, ninf), ninf);
        assert_eq!(log_add_exp(ninf, 1.5), 1.5);
        assert!((log_add_exp(0.0, 0.0) - 2f64.ln()).abs() < 1e-15);
    }

    /// A transition from a failing region never panics and flags the divergence.
    #[test]
    fn failing_gradient_is_a_divergence() {
        let target = FnGradLogDensity::new(vec![(-5.0, 5.0)], |x: &[f64], g: &mut [f64]| {
            g[0] = -x[0];
            (x[0] < 0.01).then(|| -0.5 * x[0] * x[0])
        });
        let tr = LogisticBox::new(target.bounds());
        let mut model = Model::new(&target, &tr);
        let mut rng = ChaCha8Rng::seed_from_u64(3);
        let mut divergent = 0;
        let mut scratch = Scratch::new(1, 10);
        for _ in 0..50 {
            let mut z = Point {
                q: vec![0.0],
                p: vec![0.0],
                grad: vec![0.0],
                logp: 0.0,
            };
            z.logp = model.eval(&[0.0], &mut z.grad);
            let t = transition(
                &mut z,
                0.5,
                &Metric::Diagonal(vec![1.0]),
                &NutsSettings::default(),
                &mut model,
                &mut rng,
                &mut scratch,
            );
            assert!(z.logp.is_finite());
            divergent += usize::from(t.divergent);
        }
        assert!(divergent > 0);
        assert!(model.failed > 0);
    }
}
