//! gait2392 musculotendon-length polynomials, moment arms and constant-thickness pennation.

/// Pennation is capped at this angle (degrees).
pub const MAX_PENNATION_DEG: f64 = 84.0;

/// `LMT(q) = c0 + c1·q + c2·q² + c3·q³` (m, q in rad, q > 0 dorsiflexion).
#[inline]
pub fn lmt(c: &[f64; 4], q: f64) -> f64 {
    c[0] + q * (c[1] + q * (c[2] + q * c[3]))
}

/// Moment arm `r(q) = dLMT/dq = c1 + 2c2·q + 3c3·q²` (m; > 0 means plantarflexion torque).
#[inline]
pub fn moment_arm(c: &[f64; 4], q: f64) -> f64 {
    c[1] + q * (2.0 * c[2] + 3.0 * q * c[3])
}

/// Constant-thickness pennation: `h = LOM·sin α0`, `sin α = h/LM`, α capped at 84°.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Pennation {
    /// Fibre "thickness" `h = LOM·sin α0` (m).
    pub h: f64,
    /// Fibre length below which α is capped, `h / sin 84°` (m).
    pub lm_cap: f64,
    cos_cap: f64,
}

impl Pennation {
    /// Pennation of a muscle with optimal length `lom` (m) and `α0` in degrees.
    pub fn new(lom: f64, alpha0_deg: f64) -> Self {
        let h = lom * alpha0_deg.to_radians().sin();
        let cap = MAX_PENNATION_DEG.to_radians();
        Pennation {
            h,
            lm_cap: h / cap.sin(),
            cos_cap: cap.cos(),
        }
    }

    /// `cos α` at fibre length `lm` (m).
    #[inline]
    pub fn cos_alpha(&self, lm: f64) -> f64 {
        if lm <= self.lm_cap {
            self.cos_cap
        } else {
            let s = self.h / lm;
            (1.0 - s * s).sqrt()
        }
    }

    /// Pennation angle α (rad) at fibre length `lm`.
    pub fn alpha(&self, lm: f64) -> f64 {
        self.cos_alpha(lm).acos()
    }
}
