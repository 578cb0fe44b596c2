//! A seeded generator of effects outside the catalogue, for measuring how the diagnosis
//! generalises to shapes its rules were not written for.
//!
//! Each trial is a `relaxed+2` trial with random true muscle parameters, the synthetic
//! dynamometer noise and its unloaded run (as [`super::uncatalogued_trial`]), plus one drawn
//! disturbance of the measured torque or of one EMG channel:
//!
//! * **a function of one state variable** `x` (angle, velocity, direction, acceleration, time,
//!   triceps activation), through its trial quantiles `u = clamp((x − q₀₅)/(q₉₅ − q₀₅), 0, 1)`,
//!   of one of three shapes, size `s`:
//!   - *smooth* `s · (2σ((u − c)/w) − 1)`, `σ` the logistic, `c ∈ [0.3, 0.7]`, `w ∈ [0.05, 0.3]`;
//!   - *stepped* `s · [u > c]`;
//!   - *periodic* `s · sin(2π k u + φ)`, `k ∈ {1, 2, 3}`; in time, a frequency of 0.2–2 Hz not
//!     locked to the motion cycle;
//!
//!   direction is `s · tanh(ω / ω₀)` with `ω₀` of 0.5–5 °/s whatever the shape. The
//!   acceleration is zero on every sweep and hold, so its quantiles coincide: it is mapped
//!   through its full range (±600 °/s² at the reversals) instead, and its function is taken
//!   from its value at rest, `f(u) − f(u_rest)`, which would otherwise be a constant offset
//!   (a catalogued cause) on nine tenths of the trial;
//! * **a product of two** such variables' centred quantiles, `s · (2u₁ − 1)(2u₂ − 1)`;
//! * **an EMG-side disturbance**: one triceps channel's raw EMG multiplied by `1 + g` from a
//!   drawn time on (an electrode that shifts), `g ∈ ±[0.3, 0.6]`.
//!
//! Torque sizes `|s|` are drawn in 3–6 N·m, well above the noise of about 1 N·m, and every
//! torque disturbance is scaled so that `|s|` is its peak. The truth a
//! diagnosis should report: not a catalogued cause (none is hidden), `deficient` with
//! `unexplained`, and `depends_on` led by the variable the effect lives in (either of a
//! product's two; time or activation for the EMG gain).

use experiment::{random_params, synthesize, SynthConfig};
use muscle_model::{Effects, Muscle};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use super::HiddenTrial;
use crate::{DiagnoseError, StateVariable};

/// The variables a generated effect may live in.
pub const GENERATED_VARIABLES: [StateVariable; 6] = [
    StateVariable::Angle,
    StateVariable::Velocity,
    StateVariable::Direction,
    StateVariable::Acceleration,
    StateVariable::Time,
    StateVariable::Activation,
];

/// The shape of a generated function of one variable.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum GeneratedShape {
    /// A logistic rise over the variable's range.
    Smooth,
    /// A step at a threshold.
    Stepped,
    /// A sine over the variable's range (in time: at a frequency of its own).
    Periodic,
}

impl GeneratedShape {
    /// Name.
    pub fn name(self) -> &'static str {
        match self {
            GeneratedShape::Smooth => "smooth",
            GeneratedShape::Stepped => "stepped",
            GeneratedShape::Periodic => "periodic",
        }
    }
}

/// What a generated trial hides.
#[derive(Clone, Debug, PartialEq)]
pub enum GeneratedEffect {
    /// A torque that is a function of one variable.
    Single {
        /// The variable.
        variable: StateVariable,
        /// The shape.
        shape: GeneratedShape,
    },
    /// A torque that is the product of two variables' centred quantiles.
    Product(StateVariable, StateVariable),
    /// One triceps channel's raw EMG multiplied by `1 + gain` from `from_s` on.
    EmgGain {
        /// The muscle.
        muscle: Muscle,
        /// The relative change.
        gain: f64,
        /// When it starts (s after the trial's first sample).
        from_s: f64,
    },
}

impl GeneratedEffect {
    /// The family's name: `angle_smooth`, `velocity×time`, `emg_gain`, ….
    pub fn family(&self) -> String {
        match self {
            GeneratedEffect::Single { variable, shape } => {
                format!("{}_{}", variable.name(), shape.name())
            }
            GeneratedEffect::Product(a, b) => format!("{}×{}", a.name(), b.name()),
            GeneratedEffect::EmgGain { .. } => "emg_gain".to_string(),
        }
    }

    /// Whether `v` is a right leading variable of `depends_on` for this effect.
    pub fn lives_in(&self, v: StateVariable) -> bool {
        match self {
            GeneratedEffect::Single { variable, .. } => *variable == v,
            GeneratedEffect::Product(a, b) => *a == v || *b == v,
            GeneratedEffect::EmgGain { .. } => {
                matches!(v, StateVariable::Time | StateVariable::Activation)
            }
        }
    }
}

/// A trial hiding one generated effect.
#[derive(Clone, Debug)]
pub struct GeneratedTrial {
    /// The trial (no catalogued effect) with the effect added.
    pub hidden: HiddenTrial,
    /// The effect.
    pub effect: GeneratedEffect,
    /// Its size: N·m for a torque, the relative gain for the EMG.
    pub size: f64,
    /// The effect, its size and parameters in words.
    pub description: String,
    /// The torque added to the trial at every sample (N·m), peaking at `|size|`; `None` for
    /// the EMG gain, which changes the EMG instead.
    pub disturbance_nm: Option<Vec<f64>>,
}

/// The trial quantile `q` (0–1) of `x`, by sorting a copy.
fn quantile(x: &[f64], q: f64) -> f64 {
    let mut s: Vec<f64> = x.to_vec();
    s.sort_by(f64::total_cmp);
    let i = (q * (s.len() - 1) as f64).round() as usize;
    s[i.min(s.len() - 1)]
}

/// A variable mapped to `[0, 1]`, and the value it rests at.
struct UnitScaled {
    u: Vec<f64>,
    /// `u` at the variable's median, when the variable sits there most of the trial.
    rest: Option<f64>,
}

/// `x` mapped to `[0, 1]` through its 5 % and 95 % quantiles (flat at the ends), so that a
/// few extreme samples do not squeeze the rest. A variable that sits at one value most of the
/// trial (the acceleration: zero on every sweep and hold, ±600 °/s² at the reversals) has its
/// quantiles at that value; it is mapped through its full range instead, since between equal
/// quantiles the map would follow the sign of the rounding error.
fn unit_scaled(x: &[f64]) -> UnitScaled {
    let (lo, hi) = (quantile(x, 0.05), quantile(x, 0.95));
    let (min, max) = x
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| {
            (a.min(*v), b.max(*v))
        });
    let at_rest = hi - lo < 0.01 * (max - min);
    let (lo, span) = if at_rest {
        (min, (max - min).max(1e-12))
    } else {
        (lo, (hi - lo).max(1e-12))
    };
    let map = |v: f64| ((v - lo) / span).clamp(0.0, 1.0);
    UnitScaled {
        u: x.iter().map(|v| map(*v)).collect(),
        rest: at_rest.then(|| map(quantile(x, 0.5))),
    }
}

/// Makes a `relaxed+2` trial from `seed` and hides one generated effect in it (module docs;
/// the effect and its parameters are drawn from a stream of their own).
///
/// # Errors
/// A failed synthesis.
pub fn generated_trial(seed: u64) -> Result<GeneratedTrial, DiagnoseError> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let params = random_params(&mut rng, &muscle_model::ModelParams::nominal());
    let cfg = SynthConfig::new("relaxed+2".parse()?, seed).with_params(params);
    let mut synthetic = synthesize(&cfg)?;
    let mut draw = ChaCha8Rng::seed_from_u64(seed ^ 0x6e4e_7a7e);
    let sign = if draw.random::<bool>() { 1.0 } else { -1.0 };
    let size = sign * (3.0 + 3.0 * draw.random::<f64>());
    let t0 = synthetic.trial.time_s[0];
    let span = synthetic.trial.time_s[synthetic.trial.time_s.len() - 1] - t0;
    let inputs = &synthetic.inputs;
    let n = synthetic.trial.torque_nm.len().min(inputs.len());
    // the trial's own clock from 0; the others as the flexible terms see them
    let series = |v: StateVariable| -> Vec<f64> {
        let mut x = v
            .samples(inputs)
            .expect("the generated variables exist in every trial");
        x.truncate(n);
        if v == StateVariable::Time {
            let first = x[0];
            x.iter_mut().for_each(|t| *t -= first);
        }
        x
    };
    // 0–5: one variable (smooth, stepped or periodic); 6: a product; 7: the EMG gain
    let family = draw.random_range(0..8_usize);
    let (effect, added, description): (GeneratedEffect, Option<Vec<f64>>, String) = if family < 6 {
        let variable = GENERATED_VARIABLES[draw.random_range(0..GENERATED_VARIABLES.len())];
        let shape = [
            GeneratedShape::Smooth,
            GeneratedShape::Stepped,
            GeneratedShape::Periodic,
        ][draw.random_range(0..3_usize)];
        let x = series(variable);
        let (c, w) = (
            0.3 + 0.4 * draw.random::<f64>(),
            0.05 + 0.25 * draw.random::<f64>(),
        );
        let (k, phi) = (
            draw.random_range(1..=3_u32),
            std::f64::consts::TAU * draw.random::<f64>(),
        );
        let freq_hz = 0.2 + 1.8 * draw.random::<f64>();
        // °/s, as the velocity's samples
        let omega0 = 0.5 + 4.5 * draw.random::<f64>();
        let (torque, words): (Vec<f64>, String) = if variable == StateVariable::Direction {
            (
                x.iter().map(|w| size * (w / omega0).tanh()).collect(),
                format!("ω0 {omega0:.1} °/s"),
            )
        } else if variable == StateVariable::Time && shape == GeneratedShape::Periodic {
            (
                x.iter()
                    .map(|t| size * (std::f64::consts::TAU * freq_hz * t + phi).sin())
                    .collect(),
                format!("{freq_hz:.2} Hz"),
            )
        } else {
            let scaled = unit_scaled(&x);
            let (f, words): (Box<dyn Fn(f64) -> f64>, String) = match shape {
                GeneratedShape::Smooth => (
                    Box::new(move |u| size * (2.0 / (1.0 + (-(u - c) / w).exp()) - 1.0)),
                    format!("c {c:.2} w {w:.2}"),
                ),
                GeneratedShape::Stepped => (
                    Box::new(move |u| if u > c { size } else { 0.0 }),
                    format!("step at quantile {c:.2}"),
                ),
                GeneratedShape::Periodic => (
                    Box::new(move |u| {
                        size * (std::f64::consts::TAU * f64::from(k) * u + phi).sin()
                    }),
                    format!("{k} periods"),
                ),
            };
            // a variable at rest most of the trial carries the effect away from rest only: its
            // value at rest would be a constant offset, a catalogued cause
            let at_rest = scaled.rest.map_or(0.0, &f);
            (scaled.u.iter().map(|u| f(*u) - at_rest).collect(), words)
        };
        (
            GeneratedEffect::Single { variable, shape },
            Some(torque),
            format!(
                "torque {}_{} {size:+.2} N·m ({words})",
                variable.name(),
                shape.name()
            ),
        )
    } else if family == 6 {
        let a = draw.random_range(0..GENERATED_VARIABLES.len());
        let b = (a + 1 + draw.random_range(0..GENERATED_VARIABLES.len() - 1))
            % GENERATED_VARIABLES.len();
        let (va, vb) = (GENERATED_VARIABLES[a], GENERATED_VARIABLES[b]);
        let (ua, ub) = (unit_scaled(&series(va)).u, unit_scaled(&series(vb)).u);
        let torque = ua
            .iter()
            .zip(&ub)
            .map(|(x, y)| size * (2.0 * x - 1.0) * (2.0 * y - 1.0))
            .collect();
        (
            GeneratedEffect::Product(va, vb),
            Some(torque),
            format!("torque {}×{} {size:+.2} N·m", va.name(), vb.name()),
        )
    } else {
        let muscle = Muscle::ALL[draw.random_range(0..3_usize)];
        let gain = sign * (0.3 + 0.3 * draw.random::<f64>());
        let from_s = span * (0.3 + 0.4 * draw.random::<f64>());
        let trial = &mut synthetic.trial;
        let channel = match muscle {
            Muscle::Sol => &mut trial.emg_sol,
            Muscle::Gm => &mut trial.emg_gm,
            Muscle::Gl => &mut trial.emg_gl,
        };
        for (e, t) in channel.iter_mut().zip(&trial.time_s) {
            if t - t0 >= from_s {
                *e *= 1.0 + gain;
            }
        }
        (
            GeneratedEffect::EmgGain {
                muscle,
                gain,
                from_s,
            },
            None,
            format!(
                "emg_{} × {:.2} from {from_s:.1} s",
                muscle.name(),
                1.0 + gain
            ),
        )
    };
    let size = match &effect {
        GeneratedEffect::EmgGain { gain, .. } => *gain,
        _ => size,
    };
    // scaled so that `size` is the disturbance's peak, whatever its shape
    let disturbance_nm = added.map(|torque| {
        let peak = torque.iter().fold(0.0_f64, |m, a| m.max(a.abs()));
        let scale = if peak > 0.0 { size.abs() / peak } else { 0.0 };
        let scaled: Vec<f64> = torque.iter().map(|a| a * scale).collect();
        for (y, a) in synthetic.trial.torque_nm.iter_mut().zip(&scaled) {
            *y += a;
        }
        scaled
    });
    Ok(GeneratedTrial {
        hidden: HiddenTrial {
            synthetic,
            effects: Effects::none(),
            params,
            seed,
        },
        effect,
        size,
        description,
        disturbance_nm,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_same_seed_gives_the_same_trial_and_seeds_cover_every_family() {
        let a = generated_trial(11).unwrap();
        let b = generated_trial(11).unwrap();
        assert_eq!(a.effect, b.effect);
        assert_eq!(
            a.hidden.synthetic.trial.torque_nm,
            b.hidden.synthetic.trial.torque_nm
        );
        let mut kinds = std::collections::BTreeSet::new();
        for seed in 0..60 {
            let t = generated_trial(seed).unwrap();
            kinds.insert(match t.effect {
                GeneratedEffect::Single { .. } => 0,
                GeneratedEffect::Product(a, b) => {
                    assert_ne!(a, b);
                    1
                }
                GeneratedEffect::EmgGain { .. } => 2,
            });
            // the torque added peaks at the size; the EMG gain adds none
            match (&t.effect, &t.disturbance_nm) {
                (GeneratedEffect::EmgGain { .. }, d) => assert!(d.is_none(), "seed {seed}"),
                (_, Some(d)) => {
                    let peak = d.iter().fold(0.0_f64, |m, a| m.max(a.abs()));
                    assert!((peak - t.size.abs()).abs() < 1e-9, "seed {seed}: {peak}");
                }
                (_, None) => panic!("seed {seed}: a torque effect without its torque"),
            }
        }
        assert_eq!(kinds.len(), 3);
    }

    #[test]
    fn a_torque_effect_adds_its_size_and_an_emg_gain_leaves_the_torque() {
        for seed in 0..40 {
            let t = generated_trial(seed).unwrap();
            let plain = experiment::synthesize(
                &SynthConfig::new("relaxed+2".parse().unwrap(), seed).with_params(t.hidden.params),
            )
            .unwrap();
            let diff: Vec<f64> = t
                .hidden
                .synthetic
                .trial
                .torque_nm
                .iter()
                .zip(&plain.trial.torque_nm)
                .map(|(a, b)| a - b)
                .collect();
            let peak = diff.iter().fold(0.0_f64, |m, d| m.max(d.abs()));
            match t.effect {
                GeneratedEffect::EmgGain { .. } => {
                    assert_eq!(peak, 0.0, "{}", t.description);
                    assert_ne!(t.hidden.synthetic.trial.emg_sol.len(), 0);
                }
                _ => assert!(
                    (peak - t.size.abs()).abs() < 1e-9,
                    "{}: {peak}",
                    t.description
                ),
            }
        }
    }

    #[test]
    fn a_function_of_the_acceleration_lives_at_the_reversals_not_in_the_rounding() {
        // zero to rounding error on the sweeps and holds, ±600 °/s² at the reversals
        let x: Vec<f64> = (0..1000)
            .map(|i| match i % 100 {
                0..=4 => 600.0,
                5..=9 => -600.0,
                j if j % 2 == 0 => 1e-13,
                _ => -1e-13,
            })
            .collect();
        let s = unit_scaled(&x);
        let rest = s.rest.expect("the variable rests at zero");
        assert!((rest - 0.5).abs() < 1e-9, "{rest}");
        for (u, v) in s.u.iter().zip(&x) {
            let want = if *v > 1.0 {
                1.0
            } else if *v < -1.0 {
                0.0
            } else {
                rest
            };
            assert!((u - want).abs() < 1e-9, "{v} maps to {u}");
        }
        // a variable that moves keeps its quantile map
        let moving: Vec<f64> = (0..1000).map(f64::from).collect();
        let m = unit_scaled(&moving);
        assert!(m.rest.is_none());
        assert_eq!(
            (m.u[0], m.u[500], m.u[999]),
            (0.0, (500.0 - 50.0) / 899.0, 1.0)
        );

        // every generated function of the acceleration is zero where the joint does not
        // accelerate and reaches its size at the reversals
        let mut seen = 0;
        for seed in 0..60 {
            let t = generated_trial(seed).unwrap();
            if !matches!(
                t.effect,
                GeneratedEffect::Single {
                    variable: StateVariable::Acceleration,
                    ..
                }
            ) {
                continue;
            }
            seen += 1;
            let acc = StateVariable::Acceleration
                .samples(&t.hidden.synthetic.inputs)
                .unwrap();
            let d = t.disturbance_nm.as_ref().unwrap();
            let (mut at_rest, mut peak_moving) = (0.0_f64, 0.0_f64);
            for (a, v) in acc.iter().zip(d) {
                if a.abs() < 1e-6 {
                    at_rest = at_rest.max(v.abs());
                } else {
                    peak_moving = peak_moving.max(v.abs());
                }
            }
            assert!(
                at_rest < 1e-9,
                "seed {seed}, {}: {at_rest} at rest",
                t.description
            );
            assert!(
                (peak_moving - t.size.abs()).abs() < 1e-9,
                "seed {seed}, {}: {peak_moving}",
                t.description
            );
        }
        assert!(
            seen >= 3,
            "{seen} functions of the acceleration in 60 seeds"
        );
    }
}
