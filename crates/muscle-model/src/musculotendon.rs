//! One musculotendon unit: state derivative (contraction dynamics, `docs/model.md` section 2)
//! and the static-equilibrium initial state.

use crate::activation::Activation;
use crate::curves::Curves;
use crate::effects::Effects;
use crate::geometry::{lmt, moment_arm, Pennation};
use crate::params::{ModelParams, Muscle, MuscleParams};

/// Length of a unit's state vector: `[a, F̃T, LM, LMT, ∫â dt]`.
pub const STATE_DIM: usize = 5;
/// Index of the neural activation `a` in the state.
pub const IX_A: usize = 0;
/// Index of the normalised tendon force `F̃T`.
pub const IX_FT: usize = 1;
/// Index of the fibre length `LM` (m).
pub const IX_LM: usize = 2;
/// Index of the musculotendon length `LMT` (m).
pub const IX_LMT: usize = 3;
/// Index of the activation integral `∫₀ᵗ â dt` (s; used by the `fatigue` effect).
pub const IX_FATIGUE: usize = 4;

/// Lower limit of the fibre length as a fraction of `LOM` (in addition to the pennation cap).
pub const MIN_FIBRE_FRACTION: f64 = 0.01;

/// A musculotendon unit with all constants precomputed.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MuscleUnit {
    /// The muscle's name (`sol`, `gm`, `gl` or a fixed muscle's), also the name of its
    /// envelope channel and of its geometry series in a trial.
    pub name: &'static str,
    /// `F0` (N).
    pub f0: f64,
    /// `LOM` (m).
    pub lom: f64,
    /// `LST` (m).
    pub lst: f64,
    /// `vmax` (m/s).
    pub vmax: f64,
    /// Geometry polynomial (zeros when the geometry comes from each trial).
    pub poly: [f64; 4],
    /// Knee moment arm `r_knee` (m): `LMT(q, k) = P(q) − r_knee·k` with polynomial geometry.
    pub knee_moment_arm: f64,
    /// The musculotendon length and moment arm come from each trial's geometry series (the
    /// muscle has no length polynomial).
    pub geometry_from_trial: bool,
    /// Constant-thickness pennation.
    pub pennation: Pennation,
    /// Fibre-length floor `max(h/sin 84°, 0.01·LOM)` (m): at the floor the fibre cannot
    /// shorten further (`vM = max(vM, 0)`).
    pub lm_min: f64,
    /// Curve constants.
    pub curves: Curves,
    /// Activation dynamics and nonlinearity.
    pub activation: Activation,
    /// Fatigue rate `k` (1/s; 0 without the effect).
    pub fatigue_rate: f64,
}

/// Quantities derived from a state (for plots, tests and diagnostics).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct UnitDetail {
    /// Muscle activation `â = f_A(a)`.
    pub a_hat: f64,
    /// Pennation angle α (rad).
    pub alpha_rad: f64,
    /// Normalised fibre length `l̃`.
    pub l_norm: f64,
    /// Normalised fibre velocity `ṽ`.
    pub v_norm: f64,
    /// Tendon strain `ε`.
    pub tendon_strain: f64,
    /// `fT(ε(LMT, LM))`, equal to the `F̃T` state along exact trajectories.
    pub tendon_force_from_lengths: f64,
}

impl MuscleUnit {
    /// The unit of muscle `m` under `params` and `effects` (`fatigue`, `eccentric_enhancement`).
    pub fn new(params: &ModelParams, m: Muscle, effects: &Effects) -> Self {
        Self::of(m.name(), params.muscle(m), params, effects)
    }

    /// The unit of every muscle of `params`: sol, gm, gl, then the fixed muscles in order.
    pub fn all(params: &ModelParams, effects: &Effects) -> Vec<MuscleUnit> {
        let mut units: Vec<MuscleUnit> = Muscle::ALL
            .iter()
            .map(|&m| Self::new(params, m, effects))
            .collect();
        units.extend(
            params
                .fixed
                .iter()
                .map(|f| Self::of(f.name, &f.params, params, effects)),
        );
        units
    }

    /// The unit of the muscle `name` with parameters `p`, under the activation and curves of
    /// `params` and `effects`.
    pub fn of(
        name: &'static str,
        p: &MuscleParams,
        params: &ModelParams,
        effects: &Effects,
    ) -> Self {
        let flen = effects
            .eccentric_enhancement
            .map_or(params.curves.flen, |e| e.flen);
        let pennation = Pennation::new(p.lom_m, p.alpha_deg);
        // NaN coefficients mark trial geometry; zeros keep the unit comparable (cache keys)
        let geometry_from_trial = p.geometry_from_trial();
        MuscleUnit {
            name,
            f0: p.fom_n,
            lom: p.lom_m,
            lst: p.lst_m,
            vmax: p.vmax_lom_per_s * p.lom_m,
            poly: if geometry_from_trial {
                [0.0; 4]
            } else {
                p.lmt_poly_m
            },
            knee_moment_arm: p.knee_moment_arm_m,
            geometry_from_trial,
            pennation,
            lm_min: pennation.lm_cap.max(MIN_FIBRE_FRACTION * p.lom_m),
            curves: Curves::new(&params.curves, flen),
            activation: Activation::new(&params.activation),
            fatigue_rate: effects.fatigue.map_or(0.0, |f| f.rate_per_s),
        }
    }

    /// The identified muscle this unit is, if it is one of sol, gm, gl.
    pub fn muscle(&self) -> Option<Muscle> {
        Muscle::from_name(self.name)
    }

    /// `LMT(q)` (m), knee extended.
    #[inline]
    pub fn lmt(&self, q: f64) -> f64 {
        lmt(&self.poly, q)
    }

    /// `r(q)` (m).
    #[inline]
    pub fn moment_arm(&self, q: f64) -> f64 {
        moment_arm(&self.poly, q)
    }

    /// Tendon strain for musculotendon length `lmt` and fibre length `lm`.
    #[inline]
    pub fn tendon_strain(&self, lmt: f64, lm: f64) -> f64 {
        let lt = lmt - lm * self.pennation.cos_alpha(lm);
        (lt - self.lst) / self.lst
    }

    /// Fibre velocity `vM` (m/s) for state `y`: the unique solution of
    /// `F̃T/cos α = â·fl·fv(ṽ) + fpe + β·ṽ`, with the fibre-length floor applied.
    #[inline]
    pub fn fibre_velocity(&self, y: &[f64; STATE_DIM]) -> f64 {
        let lm = y[IX_LM];
        let cos = self.pennation.cos_alpha(lm);
        let l = lm / self.lom;
        let a_hat = self.activation.nonlinearity.apply(y[IX_A]);
        let fatigue = if self.fatigue_rate > 0.0 {
            (-self.fatigue_rate * y[IX_FATIGUE]).exp()
        } else {
            1.0
        };
        let act = a_hat * self.curves.fl(l) * fatigue;
        let fm = y[IX_FT] / cos;
        let v = self.curves.solve_velocity(act, fm - self.curves.fpe(l));
        let vm = v * self.vmax;
        if lm <= self.lm_min && vm < 0.0 {
            0.0
        } else {
            vm
        }
    }

    /// State derivative for excitation `u`, angle `q` and angular velocity `qd`
    /// ([`crate::Formulation::FourState`]: the four states integrated as written).
    #[inline]
    pub fn derivative(
        &self,
        u: f64,
        q: f64,
        qd: f64,
        y: &[f64; STATE_DIM],
        dy: &mut [f64; STATE_DIM],
    ) {
        self.derivative_vmt(u, self.moment_arm(q) * qd, y, dy);
    }

    /// State derivative for excitation `u` and musculotendon velocity `vmt` (m/s), whatever
    /// the geometry (polynomial with or without the knee term, or a series).
    #[inline]
    pub fn derivative_vmt(
        &self,
        u: f64,
        vmt: f64,
        y: &[f64; STATE_DIM],
        dy: &mut [f64; STATE_DIM],
    ) {
        let a = y[IX_A];
        let lm = y[IX_LM];
        let cos = self.pennation.cos_alpha(lm);
        let vm = self.fibre_velocity(y);
        let lt = y[IX_LMT] - lm * cos;
        let eps = (lt - self.lst) / self.lst;
        dy[IX_A] = self.activation.rate(u, a);
        dy[IX_FT] = self.curves.dft(eps) / self.lst * (vmt - vm / cos);
        dy[IX_LM] = vm;
        dy[IX_LMT] = vmt;
        dy[IX_FATIGUE] = self.activation.nonlinearity.apply(a);
    }

    /// The state on the invariant manifold at angle `q`: `LMT = LMT(q)` and
    /// `F̃T = fT(ε(LMT, LM))`, other components of `y` unchanged.
    #[inline]
    pub fn project(&self, q: f64, y: &mut [f64; STATE_DIM]) {
        self.project_lmt(self.lmt(q), y);
    }

    /// The state on the invariant manifold at musculotendon length `lmt`.
    #[inline]
    pub fn project_lmt(&self, lmt: f64, y: &mut [f64; STATE_DIM]) {
        y[IX_LMT] = lmt;
        y[IX_FT] = self.curves.ft(self.tendon_strain(lmt, y[IX_LM]));
    }

    /// State derivative of the [`crate::Formulation::Reduced`] system: `F̃T` and `LMT` are not
    /// integrated (their derivatives are 0) but taken from the invariants at `q`.
    #[inline]
    pub fn derivative_reduced(
        &self,
        u: f64,
        q: f64,
        y: &[f64; STATE_DIM],
        dy: &mut [f64; STATE_DIM],
    ) {
        self.derivative_reduced_lmt(u, self.lmt(q), y, dy);
    }

    /// [`MuscleUnit::derivative_reduced`] at musculotendon length `lmt`.
    #[inline]
    pub fn derivative_reduced_lmt(
        &self,
        u: f64,
        lmt: f64,
        y: &[f64; STATE_DIM],
        dy: &mut [f64; STATE_DIM],
    ) {
        let mut yp = *y;
        self.project_lmt(lmt, &mut yp);
        let a = y[IX_A];
        dy[IX_A] = self.activation.rate(u, a);
        dy[IX_FT] = 0.0;
        dy[IX_LM] = self.fibre_velocity(&yp);
        dy[IX_LMT] = 0.0;
        dy[IX_FATIGUE] = self.activation.nonlinearity.apply(a);
    }

    /// Static-equilibrium state at `t = 0`: `a = u`, `LMT = LMT(q)`, `LM` solving
    /// `fT(ε)/cos α = â·fl(l̃) + fpe(l̃)` (ṽ = 0), `F̃T = fT(ε)`, `∫â = 0`.
    ///
    /// The equation is solved by bisection on `LM` between the fibre-length floor and the
    /// length at which the tendon goes slack. If the tendon is slack even at the floor the
    /// fibre starts at the floor with `F̃T = 0`.
    pub fn equilibrium_state(&self, u: f64, q: f64) -> [f64; STATE_DIM] {
        self.equilibrium_state_lmt(u, self.lmt(q))
    }

    /// [`MuscleUnit::equilibrium_state`] at musculotendon length `lmt` (m).
    pub fn equilibrium_state_lmt(&self, u: f64, lmt: f64) -> [f64; STATE_DIM] {
        let a = u.clamp(0.0, 1.0);
        let a_hat = self.activation.nonlinearity.apply(a);
        let h = self.pennation.h;
        let g = |lm: f64| {
            let cos = self.pennation.cos_alpha(lm);
            let l = lm / self.lom;
            let eps = self.tendon_strain(lmt, lm);
            self.curves.ft(eps) / cos - a_hat * self.curves.fl(l) - self.curves.fpe(l)
        };
        let lo0 = self.lm_min;
        let lm = if g(lo0) <= 0.0 {
            lo0
        } else {
            let slack = lmt - self.lst;
            // the tendon is slack for LM beyond sqrt(slack² + h²); g ≤ 0 there
            let mut hi = if slack > 0.0 {
                (slack * slack + h * h).sqrt().max(lo0)
            } else {
                lo0
            };
            let mut lo = lo0;
            if g(hi) > 0.0 {
                // cannot happen (g(hi) = −â·fl − fpe ≤ 0) except through rounding: widen
                while g(hi) > 0.0 && hi < 1e3 {
                    hi *= 2.0;
                }
            }
            for _ in 0..200 {
                let mid = 0.5 * (lo + hi);
                if mid <= lo || mid >= hi {
                    break;
                }
                if g(mid) > 0.0 {
                    lo = mid;
                } else {
                    hi = mid;
                }
            }
            0.5 * (lo + hi)
        };
        let ft = self.curves.ft(self.tendon_strain(lmt, lm));
        let mut y = [0.0; STATE_DIM];
        y[IX_A] = a;
        y[IX_FT] = ft;
        y[IX_LM] = lm;
        y[IX_LMT] = lmt;
        y
    }

    /// Derived quantities of state `y`.
    pub fn detail(&self, y: &[f64; STATE_DIM]) -> UnitDetail {
        let lm = y[IX_LM];
        let eps = self.tendon_strain(y[IX_LMT], lm);
        UnitDetail {
            a_hat: self.activation.nonlinearity.apply(y[IX_A]),
            alpha_rad: self.pennation.alpha(lm),
            l_norm: lm / self.lom,
            v_norm: self.fibre_velocity(y) / self.vmax,
            tendon_strain: eps,
            tendon_force_from_lengths: self.curves.ft(eps),
        }
    }
}
