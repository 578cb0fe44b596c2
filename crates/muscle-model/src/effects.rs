//! The model's optional effects (`docs/model.md` section 5, `docs/formats.md` "Effects JSON"):
//! typed parameters, null values, bounds and the Effects JSON.
//!
//! Every effect is absent by default; an effect present at its null value changes nothing
//! (bit-for-bit). Effects compose freely.

use crate::error::ModelError;
use crate::params::ModelParams;
use serde::{Deserialize, Serialize};
use serde_json::{Map, Value};

/// Description of one effect parameter: name, null value and admissible (fitting) bounds.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct ParamSpec {
    /// Parameter name in the Effects JSON (e.g. `delay_ms`).
    pub name: &'static str,
    /// Value at which the effect has no effect (for `eccentric_enhancement.flen`: the nominal
    /// `Flen` 1.4; the effect then reproduces a model whose `curves.flen` is 1.4).
    pub null: f64,
    /// Lower bound (inclusive); values below are rejected.
    pub lower: f64,
    /// Upper bound (inclusive); values above are rejected.
    pub upper: f64,
}

const fn spec(name: &'static str, null: f64, lower: f64, upper: f64) -> ParamSpec {
    ParamSpec {
        name,
        null,
        lower,
        upper,
    }
}

/// The catalogue of effects a diagnosis can name.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum EffectKind {
    /// `τ += c`.
    TorqueOffset,
    /// `τ += s·(exp(k·q) − 1)`.
    PassiveJointTorque,
    /// `τ += m·sin(q − φ)`.
    Gravity,
    /// `u(t) = env(t − d)`.
    ElectromechanicalDelay,
    /// Active force × `exp(−k·∫₀ᵗ â dt)`.
    Fatigue,
    /// `τ −= g·a_TA(t)`.
    AntagonistCoactivation,
    /// `Flen` free.
    EccentricEnhancement,
    /// `τ += b·q̇`.
    ViscousDamping,
    /// `τ −= I·q̈`.
    Inertia,
}

impl EffectKind {
    /// All effects in catalogue order.
    pub const ALL: [EffectKind; 9] = [
        EffectKind::TorqueOffset,
        EffectKind::PassiveJointTorque,
        EffectKind::Gravity,
        EffectKind::ElectromechanicalDelay,
        EffectKind::Fatigue,
        EffectKind::AntagonistCoactivation,
        EffectKind::EccentricEnhancement,
        EffectKind::ViscousDamping,
        EffectKind::Inertia,
    ];

    /// Name in the Effects JSON (`torque_offset`, ...).
    pub fn name(self) -> &'static str {
        match self {
            EffectKind::TorqueOffset => "torque_offset",
            EffectKind::PassiveJointTorque => "passive_joint_torque",
            EffectKind::Gravity => "gravity",
            EffectKind::ElectromechanicalDelay => "electromechanical_delay",
            EffectKind::Fatigue => "fatigue",
            EffectKind::AntagonistCoactivation => "antagonist_coactivation",
            EffectKind::EccentricEnhancement => "eccentric_enhancement",
            EffectKind::ViscousDamping => "viscous_damping",
            EffectKind::Inertia => "inertia",
        }
    }

    /// Parses an effect name.
    pub fn from_name(s: &str) -> Option<EffectKind> {
        EffectKind::ALL.into_iter().find(|k| k.name() == s)
    }

    /// The parameters of this effect with null values and bounds.
    ///
    /// Bounds are the effects' physical constraints where there are any
    /// (`stiffness_per_rad ∈ [3, 20]`, `delay_ms ∈ [0, 150]`, `flen ∈ [1, 2]`, non-negative
    /// scale, rate and gain), otherwise a generous physiological range (`docs/model.md`
    /// section 5).
    pub fn params(self) -> &'static [ParamSpec] {
        const OFFSET: [ParamSpec; 1] = [spec("offset_nm", 0.0, -50.0, 50.0)];
        const PASSIVE: [ParamSpec; 2] = [
            spec("scale_nm", 0.0, 0.0, 20.0),
            spec("stiffness_per_rad", 8.0, 3.0, 20.0),
        ];
        const GRAVITY: [ParamSpec; 2] = [
            spec("moment_nm", 0.0, -30.0, 30.0),
            spec("phase_deg", 0.0, -180.0, 180.0),
        ];
        const DELAY: [ParamSpec; 1] = [spec("delay_ms", 0.0, 0.0, 150.0)];
        const FATIGUE: [ParamSpec; 1] = [spec("rate_per_s", 0.0, 0.0, 2.0)];
        const ANTAGONIST: [ParamSpec; 1] = [spec("gain_nm", 0.0, 0.0, 100.0)];
        const ECCENTRIC: [ParamSpec; 1] = [spec("flen", 1.4, 1.0, 2.0)];
        const VISCOUS: [ParamSpec; 1] = [spec("b_nm_s_per_rad", 0.0, -10.0, 10.0)];
        const INERTIA: [ParamSpec; 1] = [spec("i_kg_m2", 0.0, -1.0, 1.0)];
        match self {
            EffectKind::TorqueOffset => &OFFSET,
            EffectKind::PassiveJointTorque => &PASSIVE,
            EffectKind::Gravity => &GRAVITY,
            EffectKind::ElectromechanicalDelay => &DELAY,
            EffectKind::Fatigue => &FATIGUE,
            EffectKind::AntagonistCoactivation => &ANTAGONIST,
            EffectKind::EccentricEnhancement => &ECCENTRIC,
            EffectKind::ViscousDamping => &VISCOUS,
            EffectKind::Inertia => &INERTIA,
        }
    }

    /// Index of parameter `name` in [`EffectKind::params`].
    pub fn param_index(self, name: &str) -> Option<usize> {
        self.params().iter().position(|p| p.name == name)
    }

    /// Null values of all parameters (unused trailing slots are 0).
    pub fn null_values(self) -> [f64; 2] {
        let mut v = [0.0; 2];
        for (i, p) in self.params().iter().enumerate() {
            v[i] = p.null;
        }
        v
    }
}

impl std::fmt::Display for EffectKind {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

/// `torque_offset`: `τ += offset_nm`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct TorqueOffset {
    /// Constant added torque (N·m).
    pub offset_nm: f64,
}
/// `passive_joint_torque`: `τ += scale_nm·(exp(stiffness_per_rad·q) − 1)`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct PassiveJointTorque {
    /// Scale `s` ≥ 0 (N·m).
    pub scale_nm: f64,
    /// Exponential stiffness `k` ∈ [3, 20] (1/rad).
    pub stiffness_per_rad: f64,
}
/// `gravity`: `τ += moment_nm·sin(q − phase)`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct Gravity {
    /// Gravitational moment amplitude `m` (N·m).
    pub moment_nm: f64,
    /// Phase `φ` (degrees).
    pub phase_deg: f64,
}
/// `electromechanical_delay`: `u(t) = env(t − d)`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct ElectromechanicalDelay {
    /// Delay `d` ∈ [0, 150] ms.
    pub delay_ms: f64,
}
/// `fatigue`: active force × `exp(−k ∫₀ᵗ â dt)`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct Fatigue {
    /// Rate `k` ≥ 0 (1/s).
    pub rate_per_s: f64,
}
/// `antagonist_coactivation`: `τ −= gain_nm·a_TA(t)`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct AntagonistCoactivation {
    /// Gain `g` ≥ 0 (N·m at full TA activation).
    pub gain_nm: f64,
}
/// `eccentric_enhancement`: `Flen` replaced by this value.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct EccentricEnhancement {
    /// Eccentric plateau `Flen` ∈ [1, 2].
    pub flen: f64,
}
/// `viscous_damping`: `τ += b·q̇`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct ViscousDamping {
    /// Damping `b` (N·m·s/rad).
    pub b_nm_s_per_rad: f64,
}
/// `inertia`: `τ −= I·q̈`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct Inertia {
    /// Moment of inertia `I` (kg·m²).
    pub i_kg_m2: f64,
}

/// A set of enabled extensions (each `None` = absent).
///
/// Serialises to, and deserialises strictly from, the Effects JSON
/// `{"<effect name>": {"<param>": value, ...}, ...}`. Parameters omitted for a named effect take
/// their null values.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Effects {
    /// `torque_offset`.
    pub torque_offset: Option<TorqueOffset>,
    /// `passive_joint_torque`.
    pub passive_joint_torque: Option<PassiveJointTorque>,
    /// `gravity`.
    pub gravity: Option<Gravity>,
    /// `electromechanical_delay`.
    pub electromechanical_delay: Option<ElectromechanicalDelay>,
    /// `fatigue`.
    pub fatigue: Option<Fatigue>,
    /// `antagonist_coactivation`.
    pub antagonist_coactivation: Option<AntagonistCoactivation>,
    /// `eccentric_enhancement`.
    pub eccentric_enhancement: Option<EccentricEnhancement>,
    /// `viscous_damping`.
    pub viscous_damping: Option<ViscousDamping>,
    /// `inertia`.
    pub inertia: Option<Inertia>,
}

impl Effects {
    /// No effect enabled (the baseline model).
    pub fn none() -> Self {
        Effects::default()
    }

    /// Whether `kind` is present.
    pub fn is_enabled(&self, kind: EffectKind) -> bool {
        self.values(kind).is_some()
    }

    /// The enabled effects in catalogue order.
    pub fn enabled(&self) -> Vec<EffectKind> {
        EffectKind::ALL
            .into_iter()
            .filter(|k| self.is_enabled(*k))
            .collect()
    }

    /// Parameter values of `kind` in [`EffectKind::params`] order, if present.
    pub fn values(&self, kind: EffectKind) -> Option<[f64; 2]> {
        match kind {
            EffectKind::TorqueOffset => self.torque_offset.map(|e| [e.offset_nm, 0.0]),
            EffectKind::PassiveJointTorque => self
                .passive_joint_torque
                .map(|e| [e.scale_nm, e.stiffness_per_rad]),
            EffectKind::Gravity => self.gravity.map(|e| [e.moment_nm, e.phase_deg]),
            EffectKind::ElectromechanicalDelay => {
                self.electromechanical_delay.map(|e| [e.delay_ms, 0.0])
            }
            EffectKind::Fatigue => self.fatigue.map(|e| [e.rate_per_s, 0.0]),
            EffectKind::AntagonistCoactivation => {
                self.antagonist_coactivation.map(|e| [e.gain_nm, 0.0])
            }
            EffectKind::EccentricEnhancement => self.eccentric_enhancement.map(|e| [e.flen, 0.0]),
            EffectKind::ViscousDamping => self.viscous_damping.map(|e| [e.b_nm_s_per_rad, 0.0]),
            EffectKind::Inertia => self.inertia.map(|e| [e.i_kg_m2, 0.0]),
        }
    }

    /// Enables `kind` with parameter values `v` (in [`EffectKind::params`] order), without
    /// validation (see [`Effects::validate`]).
    pub fn set_values(&mut self, kind: EffectKind, v: [f64; 2]) {
        match kind {
            EffectKind::TorqueOffset => self.torque_offset = Some(TorqueOffset { offset_nm: v[0] }),
            EffectKind::PassiveJointTorque => {
                self.passive_joint_torque = Some(PassiveJointTorque {
                    scale_nm: v[0],
                    stiffness_per_rad: v[1],
                })
            }
            EffectKind::Gravity => {
                self.gravity = Some(Gravity {
                    moment_nm: v[0],
                    phase_deg: v[1],
                })
            }
            EffectKind::ElectromechanicalDelay => {
                self.electromechanical_delay = Some(ElectromechanicalDelay { delay_ms: v[0] })
            }
            EffectKind::Fatigue => self.fatigue = Some(Fatigue { rate_per_s: v[0] }),
            EffectKind::AntagonistCoactivation => {
                self.antagonist_coactivation = Some(AntagonistCoactivation { gain_nm: v[0] })
            }
            EffectKind::EccentricEnhancement => {
                self.eccentric_enhancement = Some(EccentricEnhancement { flen: v[0] })
            }
            EffectKind::ViscousDamping => {
                self.viscous_damping = Some(ViscousDamping {
                    b_nm_s_per_rad: v[0],
                })
            }
            EffectKind::Inertia => self.inertia = Some(Inertia { i_kg_m2: v[0] }),
        }
    }

    /// Removes `kind`.
    pub fn disable(&mut self, kind: EffectKind) {
        match kind {
            EffectKind::TorqueOffset => self.torque_offset = None,
            EffectKind::PassiveJointTorque => self.passive_joint_torque = None,
            EffectKind::Gravity => self.gravity = None,
            EffectKind::ElectromechanicalDelay => self.electromechanical_delay = None,
            EffectKind::Fatigue => self.fatigue = None,
            EffectKind::AntagonistCoactivation => self.antagonist_coactivation = None,
            EffectKind::EccentricEnhancement => self.eccentric_enhancement = None,
            EffectKind::ViscousDamping => self.viscous_damping = None,
            EffectKind::Inertia => self.inertia = None,
        }
    }

    /// Enables `kind` at its null values (no change to the simulated torque).
    #[must_use]
    pub fn with_null(mut self, kind: EffectKind) -> Self {
        self.set_values(kind, kind.null_values());
        self
    }

    /// Sets one parameter (enabling the effect at null values first if absent) after checking
    /// its bounds.
    pub fn set_param(
        &mut self,
        kind: EffectKind,
        param: &str,
        value: f64,
    ) -> Result<(), ModelError> {
        let i = kind
            .param_index(param)
            .ok_or_else(|| ModelError::UnknownKey {
                key: format!("{}.{param}", kind.name()),
                expected: param_names(kind),
            })?;
        check_bounds(kind, i, value)?;
        let mut v = self.values(kind).unwrap_or_else(|| kind.null_values());
        v[i] = value;
        self.set_values(kind, v);
        Ok(())
    }

    /// The value in effect for a parameter: its value when the effect is present, else its
    /// null value (for `eccentric_enhancement.flen`, `params.curves.flen`).
    pub fn effective_value(&self, kind: EffectKind, index: usize, params: &ModelParams) -> f64 {
        match self.values(kind) {
            Some(v) => v[index],
            None if kind == EffectKind::EccentricEnhancement => params.curves.flen,
            None => kind.null_values()[index],
        }
    }

    /// Checks every present parameter against its bounds; the error names `effect.param`.
    pub fn validate(&self) -> Result<(), ModelError> {
        for kind in EffectKind::ALL {
            if let Some(v) = self.values(kind) {
                for (i, &x) in v.iter().take(kind.params().len()).enumerate() {
                    check_bounds(kind, i, x)?;
                }
            }
        }
        Ok(())
    }

    /// Parses the Effects JSON strictly (unknown effect or parameter names and values out of
    /// bounds are errors naming them).
    pub fn from_json_str(s: &str) -> Result<Self, ModelError> {
        let v: Value = serde_json::from_str(s).map_err(|e| ModelError::Json {
            message: e.to_string(),
        })?;
        Self::from_json(&v)
    }

    /// Parses an Effects JSON value (see [`Effects::from_json_str`]).
    pub fn from_json(v: &Value) -> Result<Self, ModelError> {
        let top = v
            .as_object()
            .ok_or_else(|| ModelError::invalid("(top level)", "expected a JSON object"))?;
        let mut out = Effects::none();
        for (name, params) in top {
            let kind = EffectKind::from_name(name).ok_or_else(|| ModelError::UnknownKey {
                key: name.clone(),
                expected: EffectKind::ALL.map(|k| k.name()).join(", "),
            })?;
            let obj: &Map<String, Value> = params
                .as_object()
                .ok_or_else(|| ModelError::invalid(name, "expected a JSON object of parameters"))?;
            let mut vals = kind.null_values();
            for (pname, pv) in obj {
                let key = format!("{name}.{pname}");
                let i = kind
                    .param_index(pname)
                    .ok_or_else(|| ModelError::UnknownKey {
                        key: key.clone(),
                        expected: param_names(kind),
                    })?;
                vals[i] = pv.as_f64().ok_or_else(|| {
                    ModelError::invalid(&key, format!("expected a number, got {pv}"))
                })?;
                check_bounds(kind, i, vals[i])?;
            }
            out.set_values(kind, vals);
        }
        Ok(out)
    }

    /// The Effects JSON value of the enabled effects.
    pub fn to_json_value(&self) -> Value {
        let mut top = Map::new();
        for kind in EffectKind::ALL {
            if let Some(v) = self.values(kind) {
                let mut obj = Map::new();
                for (i, p) in kind.params().iter().enumerate() {
                    obj.insert(p.name.to_string(), Value::from(v[i]));
                }
                top.insert(kind.name().to_string(), Value::Object(obj));
            }
        }
        Value::Object(top)
    }
}

impl Serialize for Effects {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        self.to_json_value().serialize(s)
    }
}

impl<'de> Deserialize<'de> for Effects {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        let v = Value::deserialize(d)?;
        Effects::from_json(&v).map_err(serde::de::Error::custom)
    }
}

fn param_names(kind: EffectKind) -> String {
    kind.params()
        .iter()
        .map(|p| p.name)
        .collect::<Vec<_>>()
        .join(", ")
}

fn check_bounds(kind: EffectKind, i: usize, v: f64) -> Result<(), ModelError> {
    let p = &kind.params()[i];
    if v.is_finite() && v >= p.lower && v <= p.upper {
        Ok(())
    } else {
        Err(ModelError::invalid(
            format!("{}.{}", kind.name(), p.name),
            format!("{v} is outside [{}, {}]", p.lower, p.upper),
        ))
    }
}
