//! The joint model of several trials: one vector of parameters read by every trial's
//! simulation, its whitened least-squares fit and its leave-one-trial-out prediction.
//!
//! The vector is `[9 muscle parameters | the parameters of each term]`, a term being an effect
//! shared by the trials ([`Term::trial`] `None`) or an effect of one trial. Trial `m` is
//! simulated with the muscle parameters, the shared terms it can test and its own terms; its
//! residual `y_m − τ_m(x)` is whitened by its own noise model, and the fit minimises
//! `Σ_m ‖W_m(y_m − τ_m(x))‖²`, the sum of the trials' log-likelihoods
//! `log L = Σ_m log L_m`. A gravity term is carried in its linear coordinates
//! `A·sin q + B·cos q` (see `crate::fit`), read by its trial as `m·sin(q − φ)`.
//!
//! **Leave one trial out.** For each trial `j`, the parameters the other trials read are
//! refitted on them (from the full fit, at most [`crate::DiagnoseSettings::cv_iterations`]
//! iterations); the parameters only trial `j` reads (its own terms: its offset, its gravity
//! term) cannot be learnt from the others, so they are fitted on trial `j` with every other
//! parameter held at the fold's values, and trial `j` is then predicted. The held-out RMS is
//! pooled over every trial's samples and the held-out deviance `Σ ν_t²/S_t` sums each trial's
//! held-out residual whitened by its own noise model.

use std::ops::Range;

use muscle_model::{EffectKind, ParamId, Problem};
use nalgebra::DMatrix;
use numerics::LevenbergMarquardtSettings;
use rayon::prelude::*;

use crate::fit::{free_params, gravity_to_polar, Context, Fit};
use crate::lm::minimise;
use crate::DiagnoseError;

/// One trial of the session, prepared for fitting.
pub(crate) struct Member {
    /// The trial's name in the session.
    pub name: String,
    /// Its inputs, torque, noise model and base model.
    pub ctx: Context,
    /// The candidate effects the trial can test.
    pub eligible: Vec<EffectKind>,
}

/// An effect of the joint model: shared by the trials (`trial: None`) or of one trial.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
pub(crate) struct Term {
    pub kind: EffectKind,
    pub trial: Option<usize>,
}

/// Where each term's parameters sit in the joint vector.
#[derive(Clone, Debug)]
pub(crate) struct Layout {
    pub terms: Vec<Term>,
    offsets: Vec<usize>,
    pub dim: usize,
}

/// Number of identified muscle parameters at the head of the vector.
const MUSCLES: usize = 9;

impl Layout {
    pub fn new(terms: Vec<Term>) -> Self {
        let mut offsets = Vec::with_capacity(terms.len());
        let mut dim = MUSCLES;
        for t in &terms {
            offsets.push(dim);
            dim += t.kind.params().len();
        }
        Layout {
            terms,
            offsets,
            dim,
        }
    }

    /// This layout with `t` added last.
    pub fn with(&self, t: Term) -> Self {
        let mut terms = self.terms.clone();
        terms.push(t);
        Layout::new(terms)
    }

    /// The slots of term `i`.
    pub fn slots(&self, i: usize) -> Range<usize> {
        self.offsets[i]..self.offsets[i] + self.terms[i].kind.params().len()
    }

    /// The term owning slot `s` (`None` for a muscle parameter).
    fn term_of(&self, s: usize) -> Option<usize> {
        (0..self.terms.len()).find(|&i| self.slots(i).contains(&s))
    }
}

/// A fitted joint model.
#[derive(Clone, Debug)]
pub(crate) struct JointFit {
    pub layout: Layout,
    pub x: Vec<f64>,
    /// Per trial, the model's torque.
    pub pred: Vec<Vec<f64>>,
    /// The trials' whitened residuals, stacked.
    pub white: Vec<f64>,
    pub white_ss: f64,
    pub loglik: f64,
    /// Whitened Jacobian (rows stacked as `white`, columns in the joint vector's units).
    pub jac: DMatrix<f64>,
    /// Per trial, the in-sample RMS (N·m).
    pub rms: Vec<f64>,
    /// Leave-one-trial-out prediction (with two or more trials, when asked for).
    pub heldout: Option<Heldout>,
    pub evaluations: usize,
}

impl JointFit {
    pub fn k(&self) -> usize {
        self.x.len()
    }
    pub fn bic(&self, n: usize) -> f64 {
        -2.0 * self.loglik + self.k() as f64 * (n as f64).ln()
    }
}

/// The leave-one-trial-out prediction of a joint model.
#[derive(Clone, Debug)]
pub(crate) struct Heldout {
    /// RMS of the held-out residual pooled over every trial's compared samples (N·m).
    pub rms: f64,
    /// Held-out deviance summed over the trials (χ² units).
    pub dev: f64,
    /// Per trial, the RMS of its prediction by the others (N·m).
    pub per_trial_rms: Vec<f64>,
}

/// The trials of a session and the settings of their fits.
pub(crate) struct Joint<'a> {
    pub members: &'a [Member],
    pub muscle_bounds: Vec<(f64, f64)>,
    pub base_muscles: [f64; 9],
    pub lm: LevenbergMarquardtSettings,
    pub cv_lm: LevenbergMarquardtSettings,
    /// First row of each trial in the stacked residual.
    pub rows: Vec<usize>,
}

impl<'a> Joint<'a> {
    /// # Errors
    /// A model that cannot be built on the first trial.
    pub fn new(members: &'a [Member]) -> Result<Self, DiagnoseError> {
        let first = &members[0].ctx;
        let muscle_bounds = first.problem(&[])?.bounds().to_vec();
        let mut rows = Vec::with_capacity(members.len());
        let mut at = 0;
        for m in members {
            rows.push(at);
            at += m.ctx.y.len();
        }
        Ok(Joint {
            members,
            muscle_bounds,
            base_muscles: first.base_muscles(),
            lm: first.lm,
            cv_lm: first.cv_lm,
            rows,
        })
    }

    /// Compared samples over every trial.
    pub fn n_obs(&self) -> usize {
        self.members.iter().map(|m| m.ctx.plan.n_obs()).sum()
    }

    /// Whether trial `m` reads term `t`.
    pub fn reads(&self, t: &Term, m: usize) -> bool {
        match t.trial {
            Some(k) => k == m,
            None => self.members[m].eligible.contains(&t.kind),
        }
    }

    fn reads_slot(&self, layout: &Layout, m: usize, s: usize) -> bool {
        layout
            .term_of(s)
            .is_none_or(|i| self.reads(&layout.terms[i], m))
    }

    /// The slots trial `m` reads, in the order of its own parameter vector.
    pub fn member_slots(&self, layout: &Layout, m: usize) -> Vec<usize> {
        (0..layout.dim)
            .filter(|&s| self.reads_slot(layout, m, s))
            .collect()
    }

    /// The effects trial `m` is simulated with.
    pub fn member_kinds(&self, layout: &Layout, m: usize) -> Vec<EffectKind> {
        layout
            .terms
            .iter()
            .filter(|t| self.reads(t, m))
            .map(|t| t.kind)
            .collect()
    }

    /// Trial `m`'s parameter vector (gravity as `(m, φ°)`) from the joint vector `x`.
    pub fn member_x(&self, layout: &Layout, m: usize, x: &[f64]) -> Vec<f64> {
        let mut v = x[..MUSCLES].to_vec();
        for (i, t) in layout.terms.iter().enumerate() {
            if !self.reads(t, m) {
                continue;
            }
            let s = layout.slots(i);
            if t.kind == EffectKind::Gravity {
                let (mo, phi) = gravity_to_polar(x[s.start], x[s.start + 1]);
                v.extend([mo, phi]);
            } else {
                v.extend_from_slice(&x[s]);
            }
        }
        v
    }

    /// Bounds of the joint vector (a gravity term's `A` and `B` both within the moment's).
    pub fn bounds(&self, layout: &Layout) -> Vec<(f64, f64)> {
        let mut b = self.muscle_bounds.clone();
        for t in &layout.terms {
            let ps = t.kind.params();
            if t.kind == EffectKind::Gravity {
                b.extend([(ps[0].lower, ps[0].upper); 2]);
            } else {
                b.extend(ps.iter().map(|p| (p.lower, p.upper)));
            }
        }
        b
    }

    fn problems(&self, layout: &Layout) -> Result<Vec<Problem>, DiagnoseError> {
        (0..self.members.len())
            .map(|m| self.members[m].ctx.problem(&self.member_kinds(layout, m)))
            .collect()
    }

    /// The stacked whitened residual of trials `on` at the joint vector `x` with the slots
    /// `free` set to `z`.
    #[allow(clippy::too_many_arguments)]
    fn residual(
        &self,
        problems: &[Problem],
        layout: &Layout,
        on: &[usize],
        free: &[usize],
        x: &[f64],
        z: &[f64],
    ) -> Option<Vec<f64>> {
        let mut full = x.to_vec();
        for (s, v) in free.iter().zip(z) {
            full[*s] = *v;
        }
        let mut out = Vec::new();
        for &m in on {
            let ctx = &self.members[m].ctx;
            let pred = problems[m].predict(&self.member_x(layout, m, &full)).ok()?;
            let e: Vec<f64> = ctx.y.iter().zip(&pred).map(|(a, b)| a - b).collect();
            let mut w = vec![0.0; e.len()];
            ctx.plan.whiten(&e, &mut w);
            out.extend(w);
        }
        out.iter().all(|v| v.is_finite()).then_some(out)
    }

    /// Fits the model of `layout` on every trial from each start (in parallel; the lowest
    /// whitened cost wins, ties to the earliest), with its leave-one-trial-out prediction when
    /// `heldout` and there are two or more trials.
    ///
    /// # Errors
    /// A model that cannot be built, or simulated at any start.
    pub fn fit(
        &self,
        layout: &Layout,
        starts: &[Vec<f64>],
        heldout: bool,
    ) -> Result<JointFit, DiagnoseError> {
        let problems = self.problems(layout)?;
        let bounds = self.bounds(layout);
        let on: Vec<usize> = (0..self.members.len()).collect();
        let free: Vec<usize> = (0..layout.dim).collect();
        let f = |z: &[f64]| self.residual(&problems, layout, &on, &free, z, z);
        let outcomes: Vec<_> = starts
            .par_iter()
            .map(|x0| minimise(&f, x0, &bounds, &self.lm))
            .collect();
        // a residual evaluation simulates every trial
        let evaluations: usize = outcomes
            .iter()
            .flatten()
            .map(|o| o.evaluations * on.len())
            .sum();
        let best = outcomes
            .into_iter()
            .flatten()
            .reduce(|best, o| if o.cost < best.cost { o } else { best })
            .ok_or_else(|| DiagnoseError::Fit {
                model: self.model_name(layout),
                reason: "the model cannot be simulated at the start point".into(),
            })?;
        let mut pred = Vec::with_capacity(self.members.len());
        let mut rms = Vec::with_capacity(self.members.len());
        let mut loglik = 0.0;
        for (m, member) in self.members.iter().enumerate() {
            let p = problems[m].predict(&self.member_x(layout, m, &best.x))?;
            rms.push(member.ctx.observed_rms(&member.ctx.y, &p));
            let rows = self.rows[m]..self.rows[m] + member.ctx.y.len();
            let ss: f64 = best.residual[rows].iter().map(|v| v * v).sum();
            loglik += member.ctx.plan.log_likelihood(ss);
            pred.push(p);
        }
        let mut fit = JointFit {
            layout: layout.clone(),
            x: best.x,
            pred,
            white: best.residual,
            white_ss: best.cost,
            loglik,
            jac: best.jacobian,
            rms,
            heldout: None,
            evaluations,
        };
        if heldout && self.members.len() >= 2 {
            let (h, ev) = self.leave_one_out(&problems, layout, &fit.x);
            fit.heldout = Some(h);
            fit.evaluations += ev;
        }
        Ok(fit)
    }

    /// The leave-one-trial-out prediction of the model of `layout` fitted at `x` (module docs)
    /// and the simulations it used.
    fn leave_one_out(&self, problems: &[Problem], layout: &Layout, x: &[f64]) -> (Heldout, usize) {
        let bounds = self.bounds(layout);
        let n = self.members.len();
        let per: Vec<(f64, usize, f64, usize)> = (0..n)
            .into_par_iter()
            .map(|j| {
                let others: Vec<usize> = (0..n).filter(|&m| m != j).collect();
                let mut ev = 0;
                let fold: Vec<usize> = (0..layout.dim)
                    .filter(|&s| others.iter().any(|&m| self.reads_slot(layout, m, s)))
                    .collect();
                let xf = self.refit(problems, layout, &others, &fold, x, &bounds, &self.cv_lm);
                ev += xf.1;
                let own: Vec<usize> = (0..layout.dim)
                    .filter(|&s| self.reads_slot(layout, j, s) && !fold.contains(&s))
                    .collect();
                let xj = if own.is_empty() {
                    xf.0
                } else {
                    let r = self.refit(problems, layout, &[j], &own, &xf.0, &bounds, &self.lm);
                    ev += r.1;
                    r.0
                };
                let ctx = &self.members[j].ctx;
                let pred = problems[j]
                    .predict(&self.member_x(layout, j, &xj))
                    .unwrap_or_else(|_| vec![0.0; ctx.y.len()]);
                let e: Vec<f64> = ctx.y.iter().zip(&pred).map(|(a, b)| a - b).collect();
                let mut w = vec![0.0; e.len()];
                ctx.plan.whiten(&e, &mut w);
                let (mut ss, mut cnt) = (0.0, 0usize);
                for (i, v) in e.iter().enumerate() {
                    if ctx.is_observed(i) {
                        ss += v * v;
                        cnt += 1;
                    }
                }
                let dev: f64 = w.iter().map(|v| v * v).sum();
                (ss, cnt, dev, ev)
            })
            .collect();
        let ss: f64 = per.iter().map(|p| p.0).sum();
        let cnt: usize = per.iter().map(|p| p.1).sum();
        let h = Heldout {
            rms: (ss / cnt.max(1) as f64).sqrt(),
            dev: per.iter().map(|p| p.2).sum(),
            per_trial_rms: per
                .iter()
                .map(|p| (p.0 / p.1.max(1) as f64).sqrt())
                .collect(),
        };
        (h, per.iter().map(|p| p.3).sum())
    }

    /// `x` with the slots `free` refitted on trials `on` (the rest held), and the simulations;
    /// `x` itself when the fit cannot start.
    #[allow(clippy::too_many_arguments)]
    fn refit(
        &self,
        problems: &[Problem],
        layout: &Layout,
        on: &[usize],
        free: &[usize],
        x: &[f64],
        bounds: &[(f64, f64)],
        lm: &LevenbergMarquardtSettings,
    ) -> (Vec<f64>, usize) {
        let z0: Vec<f64> = free.iter().map(|&s| x[s]).collect();
        let b: Vec<(f64, f64)> = free.iter().map(|&s| bounds[s]).collect();
        let f = |z: &[f64]| self.residual(problems, layout, on, free, x, z);
        match minimise(&f, &z0, &b, lm) {
            Some(o) => {
                let mut v = x.to_vec();
                for (s, z) in free.iter().zip(&o.x) {
                    v[*s] = *z;
                }
                (v, o.evaluations * on.len())
            }
            None => (x.to_vec(), 0),
        }
    }

    /// Trial `m`'s part of a joint fit as a one-trial fit: its effects, parameter vector,
    /// prediction, whitened residual, and the Jacobian's rows of the trial and columns of the
    /// parameters it reads.
    pub fn member_view(&self, fit: &JointFit, m: usize) -> Fit {
        let ctx = &self.members[m].ctx;
        let kinds = self.member_kinds(&fit.layout, m);
        let rows = self.rows[m]..self.rows[m] + ctx.y.len();
        let cols = self.member_slots(&fit.layout, m);
        let jac = DMatrix::from_fn(rows.len(), cols.len(), |i, j| {
            fit.jac[(rows.start + i, cols[j])]
        });
        let white = fit.white[rows].to_vec();
        let white_ss = white.iter().map(|v| v * v).sum();
        Fit {
            free: free_params(&kinds),
            x: self.member_x(&fit.layout, m, &fit.x),
            kinds,
            pred: fit.pred[m].clone(),
            loglik: ctx.plan.log_likelihood(white_ss),
            white,
            white_ss,
            rms: fit.rms[m],
            jac,
            heldout_rms: f64::NAN,
            heldout_dev: f64::NAN,
            evaluations: 0,
        }
    }

    /// `baseline+delay+offset@trial`, for errors.
    pub fn model_name(&self, layout: &Layout) -> String {
        let mut s = String::from("baseline");
        for t in &layout.terms {
            s.push('+');
            s.push_str(t.kind.name());
            if let Some(k) = t.trial {
                s.push('@');
                s.push_str(&self.members[k].name);
            }
        }
        s
    }

    /// The values of term `i` of `fit` by parameter name (gravity as moment and phase).
    pub fn term_values(&self, fit: &JointFit, i: usize) -> std::collections::BTreeMap<String, f64> {
        let t = fit.layout.terms[i];
        let s = fit.layout.slots(i);
        let mut v: Vec<f64> = fit.x[s.clone()].to_vec();
        if t.kind == EffectKind::Gravity {
            let (mo, phi) = gravity_to_polar(v[0], v[1]);
            v = vec![mo, phi];
        }
        t.kind
            .params()
            .iter()
            .zip(v)
            .map(|(p, v)| (p.name.to_string(), v))
            .collect()
    }

    /// The 9 muscle parameters of `fit` by name.
    pub fn muscle_values(fit: &JointFit) -> std::collections::BTreeMap<String, f64> {
        ParamId::identified()
            .iter()
            .zip(&fit.x)
            .map(|(p, v)| (p.name(), *v))
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::{Layout, Term};
    use muscle_model::EffectKind;

    #[test]
    fn terms_follow_the_muscle_parameters_in_order() {
        let layout = Layout::new(vec![
            Term {
                kind: EffectKind::ElectromechanicalDelay,
                trial: None,
            },
            Term {
                kind: EffectKind::TorqueOffset,
                trial: Some(1),
            },
        ])
        .with(Term {
            kind: EffectKind::Gravity,
            trial: Some(0),
        });
        assert_eq!(layout.dim, 13);
        assert_eq!(
            (0..3).map(|i| layout.slots(i)).collect::<Vec<_>>(),
            [9..10, 10..11, 11..13]
        );
        assert_eq!(layout.term_of(3), None);
        assert_eq!(layout.term_of(9), Some(0));
        assert_eq!(layout.term_of(12), Some(2));
        assert_eq!(layout.term_of(13), None);
    }
}
