//! `--with`: catalogued effects whose parameters are identified with the muscles', and the
//! adequacy of an identified model (the diagnosis's residual structure test at the identified
//! point, `"adequacy"` in `identify.json`).

use crate::error::{AppError, AppResult};
use muscle_model::{EffectKind, Effects, ModelParams, ParamId};
use std::collections::BTreeMap;

/// The catalogue's names, for messages.
fn valid_names() -> String {
    EffectKind::ALL
        .iter()
        .map(|k| k.name())
        .collect::<Vec<_>>()
        .join(", ")
}

/// Parses `--with`: catalogued effect names, each kept once, in the order given.
pub(super) fn parse_with(names: Option<&[String]>) -> AppResult<Vec<EffectKind>> {
    let mut kinds = Vec::new();
    for name in names.into_iter().flatten() {
        let name = name.trim();
        let kind = EffectKind::from_name(name).ok_or_else(|| {
            AppError::bad(format!(
                "--with `{name}`: not a catalogued effect; the effects are {}",
                valid_names()
            ))
        })?;
        if !kinds.contains(&kind) {
            kinds.push(kind);
        }
    }
    Ok(kinds)
}

/// `free` followed by the parameters of `kinds` it does not hold yet.
pub(super) fn with_free(mut free: Vec<ParamId>, kinds: &[EffectKind]) -> Vec<ParamId> {
    for &k in kinds {
        for id in ParamId::of_effect(k) {
            if !free.contains(&id) {
                free.push(id);
            }
        }
    }
    free
}

/// `effects` with every effect of `kinds` present: an effect already there keeps its values
/// (the identification starts from them), an absent one is switched on at its null values
/// (which leave the torque unchanged).
pub(super) fn with_effects(mut effects: Effects, kinds: &[EffectKind]) -> Effects {
    for &k in kinds {
        if !effects.is_enabled(k) {
            effects = effects.with_null(k);
        }
    }
    effects
}

/// In a session of several trials, every free parameter is shared by the trials; an effect
/// whose parameters differ between trials (`diagnose::effect_scope`: a torque offset, gravity)
/// cannot be identified that way.
pub(super) fn check_session_scope(kinds: &[EffectKind], trials: usize) -> AppResult {
    if trials < 2 {
        return Ok(());
    }
    let per_trial: Vec<&str> = kinds
        .iter()
        .filter(|k| diagnose::effect_scope(**k) == diagnose::EffectScope::Trial)
        .map(|k| k.name())
        .collect();
    if let Some(first) = per_trial.first() {
        return Err(AppError::bad(format!(
            "--with {}: a per-trial effect (its parameters differ between a session's trials), \
             and a session's identification shares every parameter between its trials; \
             identify each trial on its own with `--trial T --with {first}`",
            per_trial.join(",")
        )));
    }
    Ok(())
}

/// The model at an identified point: `params` and `effects` with the values of `identified`
/// (`identify.json`'s `params`) set.
pub(super) fn identified_point(
    params: &ModelParams,
    effects: &Effects,
    identified: &BTreeMap<String, f64>,
) -> AppResult<(ModelParams, Effects)> {
    let mut params = *params;
    let mut effects = *effects;
    for (name, &v) in identified {
        let id = ParamId::parse(name).map_err(AppError::internal)?;
        id.set(&mut params, &mut effects, v);
    }
    Ok((params, effects))
}

/// The true value of every free parameter, from the truth's parameters and effects (an effect
/// the truth does not carry is at its null value).
pub(super) fn truth_values(free: &[ParamId], truth: &(ModelParams, Effects)) -> Vec<f64> {
    free.iter().map(|id| id.get(&truth.0, &truth.1)).collect()
}

/// The summary's lines on the adequacy of the identified model (`trial`: a session's trial).
pub(super) fn adequacy_lines(
    a: &Result<diagnose::Adequacy, String>,
    trial: Option<&str>,
) -> Vec<String> {
    let whose = trial.map_or(String::new(), |t| format!("trial {t}: "));
    match a {
        Ok(a) => match a.warning() {
            Some(w) => vec![format!("warning: {whose}{w}")],
            None => vec![format!(
                "  {whose}residual structure test: p = {} (evidence {:.1} ≤ {:.0}): no \
                 structure left",
                fmt_p(a.structure_p),
                a.structure_evidence + 0.0,
                a.threshold
            )],
        },
        Err(e) => vec![format!("  {whose}residual structure test not run: {e}")],
    }
}

/// A p-value for the summary: two decimals, or two significant digits when small.
fn fmt_p(p: f64) -> String {
    if p >= 0.01 {
        format!("{p:.2}")
    } else {
        format!("{p:.1e}")
    }
}

/// The diagnosis's settings with the inputs read as the identification read them.
pub(super) fn settings(options: experiment::InputOptions) -> diagnose::DiagnoseSettings {
    diagnose::DiagnoseSettings {
        input_options: options,
        ..diagnose::DiagnoseSettings::default()
    }
}
