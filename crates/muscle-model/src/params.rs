//! Model parameters (the parameters JSON of `docs/formats.md`), nominal values (`docs/model.md`
//! section 3), strict merge and validation.

use crate::error::ModelError;
use serde::{Deserialize, Serialize};
use serde_json::{Map, Value};

/// The three muscles of the triceps surae.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Muscle {
    /// Soleus.
    Sol,
    /// Gastrocnemius medialis.
    Gm,
    /// Gastrocnemius lateralis.
    Gl,
}

impl Muscle {
    /// All muscles in array order (`sol`, `gm`, `gl`).
    pub const ALL: [Muscle; 3] = [Muscle::Sol, Muscle::Gm, Muscle::Gl];

    /// Short name used in files: `sol`, `gm`, `gl`.
    pub fn name(self) -> &'static str {
        match self {
            Muscle::Sol => "sol",
            Muscle::Gm => "gm",
            Muscle::Gl => "gl",
        }
    }

    /// Index into per-muscle arrays.
    pub fn index(self) -> usize {
        self as usize
    }

    /// Parses `sol`, `gm` or `gl`.
    pub fn from_name(s: &str) -> Option<Muscle> {
        Muscle::ALL.into_iter().find(|m| m.name() == s)
    }
}

impl std::fmt::Display for Muscle {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

/// Parameters of one musculotendon unit.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct MuscleParams {
    /// Maximum isometric force `F0` (N).
    pub fom_n: f64,
    /// Optimal fibre length `LOM` (m).
    pub lom_m: f64,
    /// Tendon slack length `LST` (m).
    pub lst_m: f64,
    /// Pennation angle at optimal fibre length `α0` (degrees).
    pub alpha_deg: f64,
    /// Maximum shortening velocity in optimal lengths per second (`vmax = this·LOM`).
    pub vmax_lom_per_s: f64,
    /// Musculotendon length polynomial `c0 + c1 q + c2 q² + c3 q³` (m, q in rad).
    pub lmt_poly_m: [f64; 4],
    /// Knee moment arm `r_knee` (m): the musculotendon shortens by `r_knee·k` at knee flexion
    /// `k` (rad). 0.020 m for the gastrocnemii, which cross the knee; 0 for the soleus.
    pub knee_moment_arm_m: f64,
}

/// Activation dynamics and nonlinearity parameters.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct ActivationParams {
    /// Activation time constant τact (s).
    pub tau_act_s: f64,
    /// Deactivation time constant τdeact (s).
    pub tau_deact_s: f64,
    /// Manal–Buchanan shape `A` in `[0, 0.12]` (0 = identity).
    pub shape_a: f64,
}

/// Normalised curve parameters shared by the three muscles.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct CurveParams {
    /// Force–velocity concentric curvature `Af`.
    pub af: f64,
    /// Eccentric force plateau `Flen` (≥ 1).
    pub flen: f64,
    /// Active force–length width `γ`.
    pub gamma: f64,
    /// Passive fibre exponential shape `kPE`.
    pub kpe: f64,
    /// Passive fibre strain at unit force `e0M`.
    pub e0m: f64,
    /// Tendon strain at unit force `ε0`.
    pub e0t: f64,
    /// Fibre damping `β` (> 0).
    pub damping: f64,
}

impl Default for ActivationParams {
    fn default() -> Self {
        ActivationParams {
            tau_act_s: 0.015,
            tau_deact_s: 0.050,
            shape_a: 0.08,
        }
    }
}

impl Default for CurveParams {
    fn default() -> Self {
        CurveParams {
            af: 0.25,
            flen: 1.4,
            gamma: 0.45,
            kpe: 5.0,
            e0m: 0.6,
            e0t: 0.04,
            damping: 0.1,
        }
    }
}

impl MuscleParams {
    /// Nominal values for `m` (gait2392; `docs/model.md` section 3).
    pub fn nominal(m: Muscle) -> Self {
        let (fom_n, lom_m, lst_m, alpha_deg, lmt_poly_m) = match m {
            Muscle::Sol => (
                3549.0,
                0.050,
                0.250,
                25.0,
                [0.29139, 0.04535, -0.00752, -0.00633],
            ),
            Muscle::Gm => (
                1558.0,
                0.060,
                0.390,
                17.0,
                [0.45070, 0.04628, -0.00514, -0.00708],
            ),
            Muscle::Gl => (
                683.0,
                0.064,
                0.380,
                8.0,
                [0.44706, 0.04720, -0.00564, -0.00717],
            ),
        };
        MuscleParams {
            fom_n,
            lom_m,
            lst_m,
            alpha_deg,
            vmax_lom_per_s: 10.0,
            lmt_poly_m,
            knee_moment_arm_m: match m {
                Muscle::Sol => 0.0,
                Muscle::Gm | Muscle::Gl => KNEE_MOMENT_ARM_M,
            },
        }
    }

    /// Nominal tibialis anterior, a dorsiflexor to add as a fixed muscle named `ta` (driven
    /// by the `ta` envelope): F0 = 905 N, LOM = 0.098 m, LST = 0.223 m and α0 = 5° are
    /// gait2392's `tib_ant_r`. Its length polynomial is an approximation, not a fit to that
    /// model's path: `LMT(q) = 0.3210 − 0.036·q + 0.003·q²` (m), so the moment arm
    /// `r(q) = −0.036 + 0.006·q` runs from −0.039 m at 30° plantarflexion to −0.033 m at 30°
    /// dorsiflexion (published TA moment arms are 3–4 cm), and `LMT(0) ≈ LST + LOM·cos α0`
    /// puts the fibres near their optimal length with the ankle at 0°. The TA does not cross
    /// the knee (knee moment arm 0).
    pub fn nominal_ta() -> Self {
        MuscleParams {
            fom_n: 905.0,
            lom_m: 0.098,
            lst_m: 0.223,
            alpha_deg: 5.0,
            vmax_lom_per_s: 10.0,
            lmt_poly_m: [0.3210, -0.036, 0.003, 0.0],
            knee_moment_arm_m: 0.0,
        }
    }

    /// A muscle whose values must all be given (NaN until set; validation names the first
    /// missing one). `vmax` defaults to 10 LOM/s and the knee moment arm to 0.
    fn unset() -> Self {
        MuscleParams {
            fom_n: f64::NAN,
            lom_m: f64::NAN,
            lst_m: f64::NAN,
            alpha_deg: f64::NAN,
            vmax_lom_per_s: 10.0,
            lmt_poly_m: [f64::NAN; 4],
            knee_moment_arm_m: 0.0,
        }
    }

    /// `true` when no length polynomial is given (every coefficient NaN): the muscle's
    /// musculotendon length and moment arm must come with each trial as series.
    pub fn geometry_from_trial(&self) -> bool {
        self.lmt_poly_m.iter().all(|c| c.is_nan())
    }

    /// Musculotendon length `LMT(q)` (m).
    #[inline]
    pub fn lmt(&self, q: f64) -> f64 {
        crate::geometry::lmt(&self.lmt_poly_m, q)
    }

    /// Moment arm `r(q) = dLMT/dq` (m).
    #[inline]
    pub fn moment_arm(&self, q: f64) -> f64 {
        crate::geometry::moment_arm(&self.lmt_poly_m, q)
    }

    fn validate(&self, name: &str) -> Result<(), ModelError> {
        let key = |k: &str| format!("muscles.{name}.{k}");
        let r = self.knee_moment_arm_m;
        if !(r.is_finite() && r.abs() <= 0.1) {
            return Err(ModelError::invalid(
                key("knee_moment_arm_m"),
                format!("{r} m is outside [-0.1, 0.1] m"),
            ));
        }
        for (k, v) in [
            ("fom_n", self.fom_n),
            ("lom_m", self.lom_m),
            ("lst_m", self.lst_m),
            ("alpha_deg", self.alpha_deg),
            ("vmax_lom_per_s", self.vmax_lom_per_s),
        ] {
            if v.is_nan() {
                return Err(ModelError::invalid(
                    key(k),
                    "is missing (a muscle other than sol, gm and gl needs fom_n, lom_m, lst_m \
                     and alpha_deg)",
                ));
            }
            if k != "alpha_deg" && !(v.is_finite() && v > 0.0) {
                return Err(ModelError::invalid(
                    key(k),
                    format!("{v} must be positive and finite"),
                ));
            }
        }
        let a = self.alpha_deg;
        if !(a.is_finite() && (0.0..60.0).contains(&a)) {
            return Err(ModelError::invalid(
                key("alpha_deg"),
                format!("{a} is outside [0, 60) degrees"),
            ));
        }
        if self.geometry_from_trial() {
            // the musculotendon length and moment arm come with each trial
            return Ok(());
        }
        for (i, c) in self.lmt_poly_m.iter().enumerate() {
            if !c.is_finite() {
                return Err(ModelError::invalid(
                    key(&format!("lmt_poly_m[{i}]")),
                    "must be finite",
                ));
            }
        }
        // Physiological plausibility: generous upper limits that no human
        // calf muscle reaches, so a unit slip (mm for m, kN for N) is caught.
        for (k, v, max, unit) in [
            ("fom_n", self.fom_n, MAX_FOM_N, "N"),
            ("lom_m", self.lom_m, MAX_LENGTH_M, "m"),
            ("lst_m", self.lst_m, MAX_LENGTH_M, "m"),
            (
                "vmax_lom_per_s",
                self.vmax_lom_per_s,
                MAX_VMAX_LOM_PER_S,
                "LOM/s",
            ),
        ] {
            if v > max {
                return Err(ModelError::invalid(
                    key(k),
                    format!("{v} {unit} is not physiological (at most {max} {unit})"),
                ));
            }
        }
        // the musculotendon path must be longer than the fibre over the ankle's range
        for deg in [-50.0f64, -25.0, 0.0, 25.0, 50.0] {
            let l = self.lmt(deg.to_radians());
            if !(l.is_finite() && l > self.lom_m.min(self.lst_m) && l <= 2.0 * MAX_LENGTH_M) {
                return Err(ModelError::invalid(
                    key("lmt_poly_m"),
                    format!(
                        "gives a musculotendon length of {l} m at {deg}° (must be longer than \
                         LOM or LST and at most {} m)",
                        2.0 * MAX_LENGTH_M
                    ),
                ));
            }
        }
        Ok(())
    }
}

/// Knee moment arm of the gastrocnemii (m; gait2392's, rounded).
pub const KNEE_MOMENT_ARM_M: f64 = 0.020;

/// Largest number of fixed (not identified) muscles a model carries besides sol, gm and gl.
pub const MAX_FIXED_MUSCLES: usize = 12;

/// A muscle crossing the ankle whose parameters are fixed (not identified), driven by the EMG
/// envelope of the same name (e.g. `ta`). A dorsiflexor has a negative moment arm.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FixedMuscle {
    /// Name of the muscle and of its envelope channel (interned: the parameters stay `Copy`).
    pub name: &'static str,
    /// Its parameters.
    pub params: MuscleParams,
}

/// The fixed muscles of a model, in the order given (at most [`MAX_FIXED_MUSCLES`]; kept
/// inline so that [`ModelParams`] stays `Copy` and cheap to pass to every evaluation).
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub struct FixedMuscles {
    len: usize,
    items: [Option<FixedMuscle>; MAX_FIXED_MUSCLES],
}

impl FixedMuscles {
    /// Number of fixed muscles.
    pub fn len(&self) -> usize {
        self.len
    }

    /// `true` when the model is the triceps surae alone.
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// The fixed muscles in order.
    pub fn iter(&self) -> impl Iterator<Item = &FixedMuscle> + '_ {
        self.items[..self.len].iter().flatten()
    }

    /// The fixed muscle called `name`.
    pub fn get(&self, name: &str) -> Option<&FixedMuscle> {
        self.iter().find(|f| f.name == name)
    }

    /// Adds muscle `name` or replaces its parameters.
    pub fn insert(&mut self, name: &str, params: MuscleParams) -> Result<(), ModelError> {
        if Muscle::from_name(name).is_some() {
            return Err(ModelError::invalid(
                format!("muscles.{name}"),
                "is identified, not a fixed muscle",
            ));
        }
        if let Some(slot) = self.items[..self.len]
            .iter_mut()
            .flatten()
            .find(|f| f.name == name)
        {
            slot.params = params;
            return Ok(());
        }
        if self.len == MAX_FIXED_MUSCLES {
            return Err(ModelError::invalid(
                format!("muscles.{name}"),
                format!("at most {MAX_FIXED_MUSCLES} fixed muscles besides sol, gm and gl"),
            ));
        }
        self.items[self.len] = Some(FixedMuscle {
            name: intern(name),
            params,
        });
        self.len += 1;
        Ok(())
    }
}

/// A `'static` copy of `name`, made once per distinct name (muscle names are few).
fn intern(name: &str) -> &'static str {
    use std::collections::BTreeSet;
    use std::sync::Mutex;
    static NAMES: Mutex<BTreeSet<&'static str>> = Mutex::new(BTreeSet::new());
    let mut names = NAMES.lock().unwrap_or_else(|e| e.into_inner());
    if let Some(s) = names.get(name) {
        return s;
    }
    let s: &'static str = Box::leak(name.to_owned().into_boxed_str());
    names.insert(s);
    s
}

/// Largest accepted maximum isometric force (N).
pub const MAX_FOM_N: f64 = 20_000.0;
/// Largest accepted optimal fibre length or tendon slack length (m).
pub const MAX_LENGTH_M: f64 = 1.0;
/// Largest accepted maximum shortening velocity (optimal lengths per second).
pub const MAX_VMAX_LOM_PER_S: f64 = 50.0;

fn positive(key: &str, v: f64) -> Result<(), ModelError> {
    if v.is_finite() && v > 0.0 {
        Ok(())
    } else {
        Err(ModelError::invalid(
            key,
            format!("{v} must be positive and finite"),
        ))
    }
}

/// All parameters of the triceps-surae model.
///
/// Serialises to the parameters JSON (`docs/formats.md`). Deserialising accepts any subset of that JSON and merges it
/// over the nominal values (same as [`ModelParams::from_json_str`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ModelParams {
    /// Per muscle, indexed by [`Muscle::index`] (`sol`, `gm`, `gl`).
    pub muscles: [MuscleParams; 3],
    /// Further muscles crossing the ankle, with fixed parameters.
    pub fixed: FixedMuscles,
    /// Activation parameters.
    pub activation: ActivationParams,
    /// Curve parameters.
    pub curves: CurveParams,
}

impl Default for ModelParams {
    fn default() -> Self {
        Self::nominal()
    }
}

const MUSCLE_KEYS: [&str; 7] = [
    "fom_n",
    "lom_m",
    "lst_m",
    "alpha_deg",
    "vmax_lom_per_s",
    "lmt_poly_m",
    "knee_moment_arm_m",
];

fn merge_muscle(
    mp: &mut MuscleParams,
    fields: &Map<String, Value>,
    prefix: &str,
) -> Result<(), ModelError> {
    for (fk, fv) in fields {
        let key = format!("{prefix}.{fk}");
        match fk.as_str() {
            "fom_n" => mp.fom_n = number(fv, &key)?,
            "lom_m" => mp.lom_m = number(fv, &key)?,
            "lst_m" => mp.lst_m = number(fv, &key)?,
            "alpha_deg" => mp.alpha_deg = number(fv, &key)?,
            "vmax_lom_per_s" => mp.vmax_lom_per_s = number(fv, &key)?,
            "knee_moment_arm_m" => mp.knee_moment_arm_m = number(fv, &key)?,
            "lmt_poly_m" => {
                let arr = fv
                    .as_array()
                    .ok_or_else(|| ModelError::invalid(&key, "expected an array of 4 numbers"))?;
                if arr.len() != 4 {
                    return Err(ModelError::invalid(
                        &key,
                        format!("expected 4 coefficients, got {}", arr.len()),
                    ));
                }
                for (i, c) in arr.iter().enumerate() {
                    mp.lmt_poly_m[i] = number(c, &format!("{key}[{i}]"))?;
                }
            }
            _ => return Err(unknown(&key, &MUSCLE_KEYS)),
        }
    }
    Ok(())
}
const ACTIVATION_KEYS: [&str; 3] = ["tau_act_s", "tau_deact_s", "shape_a"];
const CURVE_KEYS: [&str; 7] = ["af", "flen", "gamma", "kpe", "e0m", "e0t", "damping"];

impl ModelParams {
    /// The nominal parameters (`docs/model.md` section 3).
    pub fn nominal() -> Self {
        ModelParams {
            muscles: Muscle::ALL.map(MuscleParams::nominal),
            fixed: FixedMuscles::default(),
            activation: ActivationParams::default(),
            curves: CurveParams::default(),
        }
    }

    /// The parameters of muscle `m`.
    pub fn muscle(&self, m: Muscle) -> &MuscleParams {
        &self.muscles[m.index()]
    }

    /// Mutable parameters of muscle `m`.
    pub fn muscle_mut(&mut self, m: Muscle) -> &mut MuscleParams {
        &mut self.muscles[m.index()]
    }

    /// Parses a (partial) parameters JSON document and merges it over the nominal values.
    pub fn from_json_str(s: &str) -> Result<Self, ModelError> {
        Self::nominal().merged_json_str(s)
    }

    /// Merges a (partial) parameters JSON document over `self`, then validates.
    pub fn merged_json_str(&self, s: &str) -> Result<Self, ModelError> {
        let v: Value = serde_json::from_str(s).map_err(|e| ModelError::Json {
            message: e.to_string(),
        })?;
        self.merged_json(&v)
    }

    /// Merges a (partial) parameters JSON value over `self`, then validates.
    ///
    /// Unknown keys, unknown muscles, non-numbers and non-physical values are errors naming
    /// the key (e.g. `muscles.sol.lst_m`).
    pub fn merged_json(&self, v: &Value) -> Result<Self, ModelError> {
        let mut out = *self;
        let top = as_object(v, "(top level)")?;
        for (k, val) in top {
            match k.as_str() {
                "muscles" => {
                    let ms = as_object(val, "muscles")?;
                    for (mk, mv) in ms {
                        let prefix = format!("muscles.{mk}");
                        let fields = as_object(mv, &prefix)?;
                        match Muscle::from_name(mk) {
                            Some(m) => merge_muscle(&mut out.muscles[m.index()], fields, &prefix)?,
                            None => {
                                // a further muscle: merged over its earlier values, else every
                                // value but vmax and the knee moment arm must be given
                                let mut mp = match out.fixed.get(mk) {
                                    Some(f) => f.params,
                                    None => MuscleParams::unset(),
                                };
                                merge_muscle(&mut mp, fields, &prefix)?;
                                out.fixed.insert(mk, mp)?;
                            }
                        }
                    }
                }
                "activation" => {
                    let fields = as_object(val, "activation")?;
                    for (fk, fv) in fields {
                        let key = format!("activation.{fk}");
                        let slot = match fk.as_str() {
                            "tau_act_s" => &mut out.activation.tau_act_s,
                            "tau_deact_s" => &mut out.activation.tau_deact_s,
                            "shape_a" => &mut out.activation.shape_a,
                            _ => return Err(unknown(&key, &ACTIVATION_KEYS)),
                        };
                        *slot = number(fv, &key)?;
                    }
                }
                "curves" => {
                    let fields = as_object(val, "curves")?;
                    for (fk, fv) in fields {
                        let key = format!("curves.{fk}");
                        let slot = match fk.as_str() {
                            "af" => &mut out.curves.af,
                            "flen" => &mut out.curves.flen,
                            "gamma" => &mut out.curves.gamma,
                            "kpe" => &mut out.curves.kpe,
                            "e0m" => &mut out.curves.e0m,
                            "e0t" => &mut out.curves.e0t,
                            "damping" => &mut out.curves.damping,
                            _ => return Err(unknown(&key, &CURVE_KEYS)),
                        };
                        *slot = number(fv, &key)?;
                    }
                }
                _ => return Err(unknown(k, &["muscles", "activation", "curves"])),
            }
        }
        out.validate()?;
        Ok(out)
    }

    /// Checks every value is physical; the error names the first offending key.
    ///
    /// Rules: forces, lengths, `vmax`, time constants, `Af`, `γ`, `kPE`, `e0M`, `ε0` and the
    /// damping `β` are positive; `α0 ∈ [0°, 60°)`; `A ∈ [0, 0.12]`; `Flen ∈ [1, 10]`.
    pub fn validate(&self) -> Result<(), ModelError> {
        for m in Muscle::ALL {
            self.muscles[m.index()].validate(m.name())?;
        }
        for f in self.fixed.iter() {
            f.params.validate(f.name)?;
        }
        for (k, v) in [
            ("activation.tau_act_s", self.activation.tau_act_s),
            ("activation.tau_deact_s", self.activation.tau_deact_s),
        ] {
            positive(k, v)?;
            if !(1e-3..=1.0).contains(&v) {
                return Err(ModelError::invalid(
                    k,
                    format!("{v} s is outside [0.001, 1] s"),
                ));
            }
        }
        let a = self.activation.shape_a;
        if !(a.is_finite() && (0.0..=0.12).contains(&a)) {
            return Err(ModelError::invalid(
                "activation.shape_a",
                format!("{a} is outside [0, 0.12]"),
            ));
        }
        let c = &self.curves;
        positive("curves.af", c.af)?;
        positive("curves.gamma", c.gamma)?;
        positive("curves.kpe", c.kpe)?;
        positive("curves.e0m", c.e0m)?;
        positive("curves.e0t", c.e0t)?;
        positive("curves.damping", c.damping)?;
        for (k, v, lo, hi) in [
            ("curves.af", c.af, 0.01, 1.0),
            ("curves.gamma", c.gamma, 0.01, 5.0),
            ("curves.kpe", c.kpe, 0.1, 50.0),
            ("curves.e0m", c.e0m, 0.01, 5.0),
            ("curves.e0t", c.e0t, 0.001, 0.5),
            ("curves.damping", c.damping, 1e-3, 10.0),
        ] {
            if !(lo..=hi).contains(&v) {
                return Err(ModelError::invalid(
                    k,
                    format!("{v} is outside the plausible range [{lo}, {hi}]"),
                ));
            }
        }
        if !(c.flen.is_finite() && (1.0..=10.0).contains(&c.flen)) {
            return Err(ModelError::invalid(
                "curves.flen",
                format!("{} is outside [1, 10]", c.flen),
            ));
        }
        Ok(())
    }

    /// The parameters JSON value of these parameters (all keys).
    pub fn to_json_value(&self) -> Value {
        serde_json::to_value(self).unwrap_or(Value::Null)
    }
}

impl Serialize for ModelParams {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        use serde::ser::SerializeMap;
        /// sol, gm, gl, then the fixed muscles in their order.
        struct Muscles<'a>(&'a ModelParams);
        impl Serialize for Muscles<'_> {
            fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
                let mut map = s.serialize_map(Some(3 + self.0.fixed.len()))?;
                for m in Muscle::ALL {
                    map.serialize_entry(m.name(), &self.0.muscles[m.index()])?;
                }
                for f in self.0.fixed.iter() {
                    map.serialize_entry(f.name, &f.params)?;
                }
                map.end()
            }
        }
        #[derive(Serialize)]
        struct Out<'a> {
            muscles: Muscles<'a>,
            activation: &'a ActivationParams,
            curves: &'a CurveParams,
        }
        Out {
            muscles: Muscles(self),
            activation: &self.activation,
            curves: &self.curves,
        }
        .serialize(s)
    }
}

impl<'de> Deserialize<'de> for ModelParams {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        let v = Value::deserialize(d)?;
        ModelParams::nominal()
            .merged_json(&v)
            .map_err(serde::de::Error::custom)
    }
}

fn as_object<'a>(v: &'a Value, key: &str) -> Result<&'a Map<String, Value>, ModelError> {
    v.as_object()
        .ok_or_else(|| ModelError::invalid(key, "expected a JSON object"))
}

fn number(v: &Value, key: &str) -> Result<f64, ModelError> {
    v.as_f64()
        .ok_or_else(|| ModelError::invalid(key, format!("expected a number, got {v}")))
}

fn unknown(key: &str, expected: &[&str]) -> ModelError {
    ModelError::UnknownKey {
        key: key.to_string(),
        expected: expected.join(", "),
    }
}
