//! Synthetic trials with hidden effects of realistic magnitude (for the tests, the confusion study and demos).
//!
//! | effect | drawn magnitude (uniform) | headline number |
//! |---|---|---|
//! | `torque_offset` | `|c|` ∈ [3, 10] N·m, random sign | `offset_nm` |
//! | `passive_joint_torque` | `k` ∈ [5, 15] /rad, torque at +15° ∈ [5, 20] N·m | torque at +15° |
//! | `gravity` | `m` ∈ [−10, −3] N·m, `φ` ∈ [−30°, 30°] | `moment_nm·cos φ` (the `sin q` part) |
//! | `electromechanical_delay` | `d` ∈ [20, 80] ms | `delay_ms` |
//! | `fatigue` | `k` ∈ [0.01, 0.05] /s (1–5 %/s of force at full activation) | `rate_per_s` |
//! | `antagonist_coactivation` | `g` ∈ [3, 10] N·m (peak TA torque) | `gain_nm` |
//! | `eccentric_enhancement` | `Flen` ∈ [1.6, 1.9] | `flen` |
//! | `viscous_damping` | `|b|` ∈ [2, 8] N·m·s/rad, random sign | `b_nm_s_per_rad` |
//! | `inertia` | `I` ∈ [0.05, 0.3] kg·m² | `i_kg_m2` |
//!
//! True muscle parameters are drawn uniformly in the identification bounds
//! (docs/model.md)
//! ([`experiment::random_params`]); protocol `relaxed+2`, the default dynamometer noise
//! (docs/dynamometer.md), unloaded run supplied.
//! Gravity is drawn where it is identifiable on this protocol: with `φ` near ±90° the term is
//! `m·cos q`, which over the 35° range differs from a constant by less than 6 % (a
//! `torque_offset` in disguise); with `m > 0` and small `φ`, `m·sin q` rises with dorsiflexion
//! like the passive fibre force and is absorbed by shorter tendon slack lengths (LST), leaving
//! only its mean, an offset. See docs/diagnosis.md.

use experiment::{random_params, synthesize, Protocol, SynthConfig, Synthetic};
use muscle_model::{EffectKind, Effects, ModelParams};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use crate::DiagnoseError;

/// Angle (rad) at which the passive joint torque magnitude is stated (+15°).
pub const PASSIVE_REFERENCE_RAD: f64 = crate::score::PASSIVE_REFERENCE_RAD;

/// Draws the parameters of one effect at a realistic magnitude (see the module table).
pub fn draw_effect(kind: EffectKind, rng: &mut impl Rng) -> [f64; 2] {
    let u = |rng: &mut dyn rand::RngCore, lo: f64, hi: f64| lo + (hi - lo) * rng.random::<f64>();
    let sign = |rng: &mut dyn rand::RngCore| if rng.random::<bool>() { 1.0 } else { -1.0 };
    match kind {
        EffectKind::TorqueOffset => [sign(rng) * u(rng, 3.0, 10.0), 0.0],
        EffectKind::PassiveJointTorque => {
            let k = u(rng, 5.0, 15.0);
            let t = u(rng, 5.0, 20.0);
            [t / ((k * PASSIVE_REFERENCE_RAD).exp() - 1.0), k]
        }
        EffectKind::Gravity => [-u(rng, 3.0, 10.0), u(rng, -30.0, 30.0)],
        EffectKind::ElectromechanicalDelay => [u(rng, 20.0, 80.0), 0.0],
        EffectKind::Fatigue => [u(rng, 0.01, 0.05), 0.0],
        EffectKind::AntagonistCoactivation => [u(rng, 3.0, 10.0), 0.0],
        EffectKind::EccentricEnhancement => [u(rng, 1.6, 1.9), 0.0],
        EffectKind::ViscousDamping => [sign(rng) * u(rng, 2.0, 8.0), 0.0],
        EffectKind::Inertia => [u(rng, 0.05, 0.3), 0.0],
    }
}

/// The true parameters `truth` of `kind` written the way the fit `fitted` (same order) writes
/// them, so the two can be compared: for `gravity`, `m·sin(q − φ) = (−m)·sin(q − φ − 180°)`,
/// so the truth takes the fit's sign of `m`, and `φ` (an angle) the turn nearest the fitted
/// phase. Other effects are returned unchanged.
pub fn align_to_fit(kind: EffectKind, truth: [f64; 2], fitted: [f64; 2]) -> [f64; 2] {
    let mut t = truth;
    if kind == EffectKind::Gravity {
        if fitted[0] * t[0] < 0.0 {
            t = [-t[0], t[1] + 180.0];
        }
        t[1] += 360.0 * ((fitted[1] - t[1]) / 360.0).round();
    }
    t
}

/// The headline magnitude of an effect's parameters (see the module table).
pub fn headline(kind: EffectKind, v: [f64; 2]) -> f64 {
    match kind {
        EffectKind::PassiveJointTorque => v[0] * ((v[1] * PASSIVE_REFERENCE_RAD).exp() - 1.0),
        EffectKind::Gravity => v[0] * v[1].to_radians().cos(),
        _ => v[0],
    }
}

/// A synthetic trial with hidden effects.
#[derive(Clone, Debug)]
pub struct HiddenTrial {
    /// Trial, unloaded run and truth.
    pub synthetic: Synthetic,
    /// The hidden effects.
    pub effects: Effects,
    /// The true muscle parameters.
    pub params: ModelParams,
    /// The seed.
    pub seed: u64,
}

/// Makes a `relaxed+2` trial hiding `kinds` (drawn magnitudes), random true parameters and
/// noise, all from `seed`; `with_ta` adds an `emg_ta` channel (forced on for
/// `antagonist_coactivation`).
///
/// # Errors
/// A failed synthesis.
pub fn hidden_trial(
    kinds: &[EffectKind],
    with_ta: bool,
    seed: u64,
) -> Result<HiddenTrial, DiagnoseError> {
    hidden_trial_on(kinds, with_ta, seed, "relaxed+2".parse()?)
}

/// [`hidden_trial`] on another protocol (the same seed draws the same parameters and
/// effects on every protocol).
///
/// # Errors
/// A failed synthesis.
pub fn hidden_trial_on(
    kinds: &[EffectKind],
    with_ta: bool,
    seed: u64,
    protocol: Protocol,
) -> Result<HiddenTrial, DiagnoseError> {
    hidden_trial_drawn(kinds, with_ta, seed, protocol, draw_effect)
}

/// A trial of `protocol` hiding `kinds`, each drawn by `draw` after the true muscle parameters
/// from the seed's generator.
fn hidden_trial_drawn(
    kinds: &[EffectKind],
    with_ta: bool,
    seed: u64,
    protocol: Protocol,
    draw: impl Fn(EffectKind, &mut ChaCha8Rng) -> [f64; 2],
) -> Result<HiddenTrial, DiagnoseError> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let params = random_params(&mut rng, &ModelParams::nominal());
    let mut effects = Effects::none();
    for k in kinds {
        effects.set_values(*k, draw(*k, &mut rng));
    }
    effects.validate()?;
    let mut cfg = SynthConfig::new(protocol, seed)
        .with_params(params)
        .with_effects(effects);
    cfg.emg.include_ta = with_ta;
    let synthetic = synthesize(&cfg)?;
    Ok(HiddenTrial {
        synthetic,
        effects,
        params,
        seed,
    })
}

/// Draws an effect like [`draw_effect`] but with its size set to `size`: `|offset|`, passive
/// torque at +15°, `|moment|`, delay (ms), rate (/s), gain (N·m), `Flen − 1.4`, `|b|`, `I`.
pub fn draw_effect_sized(kind: EffectKind, size: f64, rng: &mut impl Rng) -> [f64; 2] {
    sized_like(kind, draw_effect(kind, rng), size)
}

/// The sizes ([`draw_effect_sized`]) of the detection-limit study of docs/diagnosis.md, per
/// effect: from below its detection limit to the bottom of its realistic range or past it.
pub fn limit_sizes() -> Vec<(EffectKind, Vec<f64>)> {
    vec![
        (EffectKind::TorqueOffset, vec![0.5, 1.0, 2.0, 3.0, 5.0]),
        (EffectKind::PassiveJointTorque, vec![1.0, 2.0, 3.5, 5.0]),
        (EffectKind::Gravity, vec![1.0, 2.0, 3.0, 5.0, 8.0]),
        (
            EffectKind::ElectromechanicalDelay,
            vec![3.0, 6.0, 10.0, 20.0],
        ),
        (EffectKind::Fatigue, vec![0.002, 0.005, 0.01]),
        (
            EffectKind::AntagonistCoactivation,
            vec![0.5, 1.0, 2.0, 3.0, 5.0, 8.0, 10.0],
        ),
        (EffectKind::EccentricEnhancement, vec![0.03, 0.06, 0.1, 0.2]),
        (EffectKind::ViscousDamping, vec![0.5, 1.0, 2.0, 4.0]),
        (EffectKind::Inertia, vec![0.01, 0.02, 0.05, 0.1, 0.2, 0.3]),
    ]
}

/// The measured detection limit of each effect on `relaxed+2`, in the units of
/// [`draw_effect_sized`]: the smallest size of [`limit_sizes`] named alone in at least 19 of 20
/// trials (the table "Measured detection limits on relaxed+2" of docs/diagnosis.md, where the
/// study that measured them is named).
pub fn documented_limit(kind: EffectKind) -> f64 {
    match kind {
        EffectKind::TorqueOffset => 2.0,
        EffectKind::PassiveJointTorque => 5.0,
        EffectKind::Gravity => 8.0,
        EffectKind::ElectromechanicalDelay => 10.0,
        EffectKind::Fatigue => 0.01,
        EffectKind::AntagonistCoactivation => 8.0,
        EffectKind::EccentricEnhancement => 0.2,
        EffectKind::ViscousDamping => 4.0,
        EffectKind::Inertia => 0.2,
    }
}

/// The largest size [`draw_effect`] draws, in the units of [`draw_effect_sized`] (the module
/// table).
fn largest_drawn(kind: EffectKind) -> f64 {
    match kind {
        EffectKind::TorqueOffset | EffectKind::Gravity | EffectKind::AntagonistCoactivation => 10.0,
        EffectKind::PassiveJointTorque => 20.0,
        EffectKind::ElectromechanicalDelay => 80.0,
        EffectKind::Fatigue => 0.05,
        EffectKind::EccentricEnhancement => 0.5,
        EffectKind::ViscousDamping => 8.0,
        EffectKind::Inertia => 0.3,
    }
}

/// The size of an effect's parameters `v` in the units of [`draw_effect_sized`]: `|offset|`,
/// passive torque at +15°, `|moment|`, delay (ms), rate (/s), gain (N·m), `Flen − 1.4`, `|b|`,
/// `I`.
pub fn effect_size(kind: EffectKind, v: [f64; 2]) -> f64 {
    match kind {
        EffectKind::PassiveJointTorque => headline(kind, v),
        EffectKind::EccentricEnhancement => v[0] - 1.4,
        _ => v[0].abs(),
    }
}

/// Draws an effect like [`draw_effect`] (its shape: sign, phase, stiffness) with its size
/// uniform between its documented detection limit ([`documented_limit`]) and the top of its
/// realistic range, or over the whole range where the limit lies below it: the trials on
/// which the diagnosis claims to name the effect.
pub fn draw_effect_above_limit(kind: EffectKind, rng: &mut impl Rng) -> [f64; 2] {
    let v = draw_effect(kind, rng);
    let limit = documented_limit(kind);
    if effect_size(kind, v) >= limit {
        return v;
    }
    let top = largest_drawn(kind);
    let size = limit + (top - limit) * rng.random::<f64>();
    sized_like(kind, v, size)
}

/// `v` with its size set to `size` and its shape kept ([`draw_effect_sized`]'s units).
fn sized_like(kind: EffectKind, mut v: [f64; 2], size: f64) -> [f64; 2] {
    match kind {
        EffectKind::PassiveJointTorque => {
            v[0] = size / ((v[1] * PASSIVE_REFERENCE_RAD).exp() - 1.0)
        }
        EffectKind::EccentricEnhancement => v[0] = 1.4 + size,
        EffectKind::TorqueOffset | EffectKind::Gravity | EffectKind::ViscousDamping => {
            v[0] = v[0].signum() * size
        }
        _ => v[0] = size,
    }
    v
}

/// Like [`hidden_trial`] (`relaxed+2`) with every effect at or above its documented detection
/// limit ([`draw_effect_above_limit`]).
///
/// # Errors
/// A failed synthesis.
pub fn hidden_trial_above_limits(
    kinds: &[EffectKind],
    with_ta: bool,
    seed: u64,
) -> Result<HiddenTrial, DiagnoseError> {
    hidden_trial_drawn(
        kinds,
        with_ta,
        seed,
        "relaxed+2".parse()?,
        draw_effect_above_limit,
    )
}

/// Like [`hidden_trial`] with one effect of a given size ([`draw_effect_sized`]).
///
/// # Errors
/// A failed synthesis or an effect out of its bounds.
pub fn hidden_trial_sized(
    kind: EffectKind,
    size: f64,
    seed: u64,
) -> Result<HiddenTrial, DiagnoseError> {
    hidden_trial_sized_on(kind, size, seed, "relaxed+2".parse()?)
}

/// [`hidden_trial_sized`] on another protocol (e.g. `relaxed+8`: how the detection limits
/// fall with more cycles). The same seed draws the same parameters and effect on every
/// protocol; the noise records differ in length.
///
/// # Errors
/// A failed synthesis or an effect out of its bounds.
pub fn hidden_trial_sized_on(
    kind: EffectKind,
    size: f64,
    seed: u64,
    protocol: Protocol,
) -> Result<HiddenTrial, DiagnoseError> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let params = random_params(&mut rng, &ModelParams::nominal());
    let mut effects = Effects::none();
    effects.set_values(kind, draw_effect_sized(kind, size, &mut rng));
    effects.validate()?;
    let cfg = SynthConfig::new(protocol, seed)
        .with_params(params)
        .with_effects(effects);
    let synthetic = synthesize(&cfg)?;
    Ok(HiddenTrial {
        synthetic,
        effects,
        params,
        seed,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn effects_drawn_above_their_limits_keep_their_shape_between_the_limit_and_the_range_top() {
        let mut rng = ChaCha8Rng::seed_from_u64(4);
        for kind in EffectKind::ALL {
            let (mut below_limit, mut largest) = (0, 0.0f64);
            for _ in 0..200 {
                let plain = draw_effect(kind, &mut rng.clone());
                let v = draw_effect_above_limit(kind, &mut rng);
                let size = effect_size(kind, plain);
                below_limit += usize::from(size < documented_limit(kind));
                largest = largest.max(size);
                // the plain draw's size where it reaches the limit, its shape (the second
                // parameter, the sign of the first) always
                let above = effect_size(kind, v);
                assert!(
                    above >= documented_limit(kind) - 1e-12 && above <= largest_drawn(kind) + 1e-12,
                    "{}: size {above}",
                    kind.name()
                );
                if size >= documented_limit(kind) {
                    assert_eq!(v, plain, "{}", kind.name());
                }
                assert_eq!(v[1], plain[1], "{}", kind.name());
                assert_eq!(v[0].signum(), plain[0].signum(), "{}", kind.name());
            }
            // `largest_drawn` is the top of `draw_effect`'s range
            let top = largest_drawn(kind);
            assert!(
                largest <= top + 1e-12 && largest > 0.9 * top,
                "{}: {largest}",
                kind.name()
            );
            // gravity and the antagonist are drawn below their limits most of the time
            if matches!(
                kind,
                EffectKind::Gravity | EffectKind::AntagonistCoactivation
            ) {
                assert!(below_limit > 100, "{}: {below_limit}", kind.name());
            }
        }
    }

    #[test]
    fn a_longer_protocol_hides_the_same_effect_in_the_same_subject() {
        let kind = EffectKind::AntagonistCoactivation;
        let short = hidden_trial_sized(kind, 3.0, 5900).unwrap();
        let long = hidden_trial_sized_on(kind, 3.0, 5900, "relaxed+4".parse().unwrap()).unwrap();
        assert_eq!(short.params, long.params);
        assert_eq!(short.effects, long.effects);
        let (n2, n4) = (
            short.synthetic.trial.time_s.len(),
            long.synthetic.trial.time_s.len(),
        );
        assert!(n4 > n2 + 2 * 4000, "relaxed+2 {n2} samples, relaxed+4 {n4}");
        // the default protocol is relaxed+2
        let same = hidden_trial_on(&[kind], true, 5900, "relaxed+2".parse().unwrap()).unwrap();
        let again = hidden_trial(&[kind], true, 5900).unwrap();
        assert_eq!(
            same.synthetic.trial.torque_nm,
            again.synthetic.trial.torque_nm
        );
    }
}

/// Effects outside the catalogue (docs/diagnosis-method.md, "Beyond the catalogue"), hidden in a
/// `relaxed+2` trial with no catalogued effect:
///
/// | effect | added to the recording | drawn size (uniform) | lives in |
/// |---|---|---|---|
/// | `coulomb_friction` | `τ += c·tanh(q̇/1°/s)` (bearing friction) | `c` ∈ [2, 4] N·m | direction |
/// | `torque_drift` | `τ += d·(t − t₀)/T` (torque cell drift over the trial) | `|d|` ∈ [3, 6] N·m, random sign | time |
/// | `emg_crosstalk` | `emg_sol += f·emg_ta` (raw, before filtering), TA drive 0.3 (0.5 in eccentric sweeps) | `f` ∈ [0.3, 0.6] | activation |
/// | `strap_slip` | `τ += s` from a time in the middle 40 % of the trial on (the foot settles in its strap) | `|s|` ∈ [3, 5] N·m, random sign | time |
///
/// Crosstalk raises the soleus envelope most where the triceps is quiet, so its torque is a
/// function of the triceps activation; the TA's own torque is left out (that is the catalogued
/// antagonist effect).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Uncatalogued {
    /// Coulomb friction in the dynamometer's bearing.
    CoulombFriction,
    /// A linear drift of the torque cell.
    TorqueDrift,
    /// TA crosstalk into the soleus electrode.
    EmgCrosstalk,
    /// A step in the torque when the foot settles in its strap.
    StrapSlip,
}

impl Uncatalogued {
    /// All of them.
    pub const ALL: [Uncatalogued; 4] = [
        Uncatalogued::CoulombFriction,
        Uncatalogued::TorqueDrift,
        Uncatalogued::EmgCrosstalk,
        Uncatalogued::StrapSlip,
    ];

    /// Name.
    pub fn name(self) -> &'static str {
        match self {
            Uncatalogued::CoulombFriction => "coulomb_friction",
            Uncatalogued::TorqueDrift => "torque_drift",
            Uncatalogued::EmgCrosstalk => "emg_crosstalk",
            Uncatalogued::StrapSlip => "strap_slip",
        }
    }

    /// The state variable its torque is a function of (what `depends_on` should name first).
    pub fn lives_in(self) -> crate::StateVariable {
        match self {
            Uncatalogued::CoulombFriction => crate::StateVariable::Direction,
            Uncatalogued::TorqueDrift | Uncatalogued::StrapSlip => crate::StateVariable::Time,
            Uncatalogued::EmgCrosstalk => crate::StateVariable::Activation,
        }
    }
}

/// A trial hiding an uncatalogued effect.
#[derive(Clone, Debug)]
pub struct UncataloguedTrial {
    /// The trial (no catalogued effect) with the effect added.
    pub hidden: HiddenTrial,
    /// The effect.
    pub kind: Uncatalogued,
    /// Its drawn size (N·m, or the crosstalk fraction).
    pub size: f64,
    /// The effect and its size in words.
    pub description: String,
    /// When the torque steps (s after the trial's first sample): a strap slip's time.
    pub step_at_s: Option<f64>,
}

/// Makes a `relaxed+2` trial from `seed` (random true parameters, noise, unloaded run) and
/// hides `kind` in it (module table; its size drawn from a stream of its own).
///
/// # Errors
/// A failed synthesis.
pub fn uncatalogued_trial(
    kind: Uncatalogued,
    seed: u64,
) -> Result<UncataloguedTrial, DiagnoseError> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let params = random_params(&mut rng, &ModelParams::nominal());
    let mut cfg = SynthConfig::new("relaxed+2".parse()?, seed).with_params(params);
    if kind == Uncatalogued::EmgCrosstalk {
        cfg.emg.include_ta = true;
        cfg.emg.ta_rest_level = 0.3;
        cfg.emg.ta_concentric_level = 0.3;
        cfg.emg.ta_eccentric_level = 0.5;
    }
    let mut synthetic = synthesize(&cfg)?;
    let mut draw = ChaCha8Rng::seed_from_u64(seed ^ 0x0c47_a10e);
    let sign = |r: &mut ChaCha8Rng| if r.random::<bool>() { 1.0 } else { -1.0 };
    let trial = &mut synthetic.trial;
    let t0 = trial.time_s[0];
    let span = trial.time_s[trial.time_s.len() - 1] - t0;
    let mut step_at_s = None;
    let (size, description) = match kind {
        Uncatalogued::CoulombFriction => {
            let c = 2.0 + 2.0 * draw.random::<f64>();
            let vel = synthetic.inputs.velocity();
            for (y, w) in trial.torque_nm.iter_mut().zip(vel) {
                *y += c * (w.to_degrees() / 1.0).tanh();
            }
            (c, format!("Coulomb friction {c:.2} N·m"))
        }
        Uncatalogued::TorqueDrift => {
            let d = sign(&mut draw) * (3.0 + 3.0 * draw.random::<f64>());
            for (y, t) in trial.torque_nm.iter_mut().zip(&trial.time_s) {
                *y += d * (t - t0) / span;
            }
            (d, format!("torque drift {d:+.2} N·m over the trial"))
        }
        Uncatalogued::EmgCrosstalk => {
            let f = 0.3 + 0.3 * draw.random::<f64>();
            let ta = trial.emg_ta.clone().unwrap_or_default();
            for (s, a) in trial.emg_sol.iter_mut().zip(&ta) {
                *s += f * a;
            }
            (f, format!("TA crosstalk {f:.2} × emg_ta into emg_sol"))
        }
        Uncatalogued::StrapSlip => {
            let s = sign(&mut draw) * (3.0 + 2.0 * draw.random::<f64>());
            let at = t0 + span * (0.3 + 0.4 * draw.random::<f64>());
            for (y, t) in trial.torque_nm.iter_mut().zip(&trial.time_s) {
                if *t >= at {
                    *y += s;
                }
            }
            step_at_s = Some(at - t0);
            (s, format!("strap slip {s:+.2} N·m at {:.1} s", at - t0))
        }
    };
    Ok(UncataloguedTrial {
        hidden: HiddenTrial {
            synthetic,
            effects: Effects::none(),
            params,
            seed,
        },
        kind,
        size,
        description,
        step_at_s,
    })
}

mod generated;
pub use generated::{
    generated_trial, GeneratedEffect, GeneratedShape, GeneratedTrial, GENERATED_VARIABLES,
};
