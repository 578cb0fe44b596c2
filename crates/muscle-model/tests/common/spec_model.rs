//! An independent implementation of the four-state musculotendon model of `docs/model.md`
//! (activation, Manal–Buchanan nonlinearity, Thelen curves, constant-thickness pennation,
//! fibre damping) with the knee term, written from the formulas and integrated with
//! fixed-step classic RK4. It uses no crate code: only plain numbers come from the crate's
//! parameters and inputs.
//!
//! Per muscle, with `q` and the knee angle `k` linear between samples:
//!
//! ```text
//! LMT(0) = P(q₀) − r_knee·k₀,   L̇MT = vMT = P'(q)·q̇ − r_knee·k̇
//! ȧ = (u − a)(k1·u + k2),   dF̃T/dt = fT'(ε)/LST·(vMT − vM/cos α),   L̇M = vM
//! τ = Σ F̃T·F0·P'(qᵢ)
//! ```

/// The curve and activation constants of `docs/model.md` (nominal).
const GAMMA: f64 = 0.45;
const KPE: f64 = 5.0;
const E0M: f64 = 0.6;
const E0T: f64 = 0.04;
const AF: f64 = 0.25;
const FLEN: f64 = 1.4;
const DAMPING: f64 = 0.1;
const TAU_ACT: f64 = 0.015;
const TAU_DEACT: f64 = 0.050;
const SHAPE_A: f64 = 0.08;

/// One muscle's constants.
#[derive(Clone, Copy, Debug)]
pub struct SpecMuscle {
    pub f0: f64,
    pub lom: f64,
    pub lst: f64,
    pub alpha0_deg: f64,
    pub poly: [f64; 4],
    pub knee_arm: f64,
}

struct Shape {
    u0: f64,
    slope: f64,
    alpha: f64,
    beta: f64,
}

fn shape() -> Shape {
    let s = std::f64::consts::FRAC_1_SQRT_2 * SHAPE_A;
    let (u0, a0) = (0.3085 - s, 0.3085 + s);
    let slope = (1.0 - a0) / (1.0 - u0);
    // value and slope continuous at u0: α·ln(β·u0 + 1) = a0, α·β/(β·u0 + 1) = slope
    let g = |b: f64| a0 * b / ((b * u0 + 1.0) * (b * u0 + 1.0).ln()) - slope;
    let (mut lo, mut hi) = (1e-9_f64, 1e6_f64);
    for _ in 0..300 {
        let mid = (lo * hi).sqrt();
        if g(mid) > 0.0 {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    let beta = (lo * hi).sqrt();
    Shape {
        u0,
        slope,
        alpha: a0 / (beta * u0 + 1.0).ln(),
        beta,
    }
}

fn activation_hat(s: &Shape, a: f64) -> f64 {
    if a >= s.u0 {
        s.slope * a + 1.0 - s.slope
    } else {
        s.alpha * (s.beta * a + 1.0).ln()
    }
}

fn tendon(eps: f64) -> (f64, f64) {
    let toe = 0.609 * E0T;
    let klin = 1.712 / E0T;
    let e3 = 3f64.exp() - 1.0;
    if eps <= 0.0 {
        (0.0, 0.0)
    } else if eps <= toe {
        let x = (3.0 * eps / toe).exp();
        (0.33 * (x - 1.0) / e3, 0.33 * 3.0 / toe * x / e3)
    } else {
        (klin * (eps - toe) + 0.33, klin)
    }
}

fn force_length(l: f64) -> f64 {
    (-(l - 1.0) * (l - 1.0) / GAMMA).exp()
}

fn passive(l: f64) -> f64 {
    if l > 1.0 {
        ((KPE * (l - 1.0) / E0M).exp() - 1.0) / (KPE.exp() - 1.0)
    } else {
        0.0
    }
}

fn force_velocity(v: f64) -> f64 {
    if v < -1.0 {
        0.0
    } else if v <= 0.0 {
        (1.0 + v) / (1.0 - v / AF)
    } else {
        let c = (FLEN - 1.0) * AF / (2.0 * (1.0 + AF));
        (FLEN * v + c) / (v + c)
    }
}

impl SpecMuscle {
    fn cos_alpha(&self, lm: f64) -> f64 {
        let h = self.lom * self.alpha0_deg.to_radians().sin();
        let s = (h / lm).min(84f64.to_radians().sin());
        (1.0 - s * s).sqrt()
    }

    fn lmt(&self, q: f64) -> f64 {
        let c = self.poly;
        c[0] + c[1] * q + c[2] * q * q + c[3] * q * q * q
    }

    /// `P'(q)` (m).
    pub fn arm(&self, q: f64) -> f64 {
        let c = self.poly;
        c[1] + 2.0 * c[2] * q + 3.0 * c[3] * q * q
    }

    /// Fibre velocity (m/s) by bisection of `F̃T/cos α = â·fl·fv(ṽ) + fpe + β·ṽ`.
    fn fibre_velocity(&self, s: &Shape, a: f64, ft: f64, lm: f64) -> f64 {
        let l = lm / self.lom;
        let ah = activation_hat(s, a.clamp(0.0, 1.0));
        let target = ft / self.cos_alpha(lm);
        let (mut lo, mut hi) = (-1e3, 1e3);
        for _ in 0..100 {
            let v = 0.5 * (lo + hi);
            if ah * force_length(l) * force_velocity(v) + passive(l) + DAMPING * v > target {
                hi = v;
            } else {
                lo = v;
            }
        }
        0.5 * (lo + hi) * 10.0 * self.lom
    }

    /// `[a, F̃T, LM, LMT]` at static equilibrium for excitation `u` and length `lmt`.
    fn equilibrium(&self, s: &Shape, u: f64, lmt: f64) -> [f64; 4] {
        let a = u.clamp(0.0, 1.0);
        let ah = activation_hat(s, a);
        let strain = |lm: f64| (lmt - lm * self.cos_alpha(lm) - self.lst) / self.lst;
        let g = |lm: f64| {
            let l = lm / self.lom;
            tendon(strain(lm)).0 / self.cos_alpha(lm) - ah * force_length(l) - passive(l)
        };
        let h = self.lom * self.alpha0_deg.to_radians().sin();
        let (mut lo, mut hi) = (
            (h / 84f64.to_radians().sin()).max(0.01 * self.lom),
            3.0 * self.lom,
        );
        for _ in 0..200 {
            let mid = 0.5 * (lo + hi);
            if g(mid) > 0.0 {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        let lm = 0.5 * (lo + hi);
        [a, tendon(strain(lm)).0, lm, lmt]
    }
}

/// The torque of `muscles` (each with its envelope) on a trial of angle `q` and knee angle
/// `knee` (rad) sampled at `fs`, RK4 with `substeps` steps per sample interval.
pub fn spec_torque(
    muscles: &[(SpecMuscle, &[f64])],
    q: &[f64],
    knee: &[f64],
    fs: f64,
    substeps: usize,
) -> Vec<f64> {
    let s = shape();
    let n = q.len();
    let h = 1.0 / (fs * substeps as f64);
    let k2 = 1.0 / TAU_DEACT;
    let k1 = 1.0 / TAU_ACT - k2;
    let mut tau = vec![0.0; n];
    for &(m, env) in muscles {
        let mut y = m.equilibrium(&s, env[0], m.lmt(q[0]) - m.knee_arm * knee[0]);
        tau[0] += y[1] * m.f0 * m.arm(q[0]);
        for i in 0..n - 1 {
            let qd = (q[i + 1] - q[i]) * fs;
            let kd = (knee[i + 1] - knee[i]) * fs;
            let f = |x: f64, y: &[f64; 4]| -> [f64; 4] {
                let u = (env[i] + x * (env[i + 1] - env[i])).clamp(0.0, 1.0);
                let qq = q[i] + x * (q[i + 1] - q[i]);
                let vmt = m.arm(qq) * qd - m.knee_arm * kd;
                let vm = m.fibre_velocity(&s, y[0], y[1], y[2]);
                let cos = m.cos_alpha(y[2]);
                let eps = (y[3] - y[2] * cos - m.lst) / m.lst;
                [
                    (u - y[0]) * (k1 * u + k2),
                    tendon(eps).1 / m.lst * (vmt - vm / cos),
                    vm,
                    vmt,
                ]
            };
            let ds = 1.0 / substeps as f64;
            for k in 0..substeps {
                let x0 = k as f64 * ds;
                let step = |y: &[f64; 4], d: &[f64; 4], c: f64| -> [f64; 4] {
                    std::array::from_fn(|j| y[j] + c * d[j])
                };
                let d1 = f(x0, &y);
                let d2 = f(x0 + 0.5 * ds, &step(&y, &d1, 0.5 * h));
                let d3 = f(x0 + 0.5 * ds, &step(&y, &d2, 0.5 * h));
                let d4 = f(x0 + ds, &step(&y, &d3, h));
                for j in 0..4 {
                    y[j] += h / 6.0 * (d1[j] + 2.0 * d2[j] + 2.0 * d3[j] + d4[j]);
                }
            }
            tau[i + 1] += y[1] * m.f0 * m.arm(q[i + 1]);
        }
    }
    tau
}
