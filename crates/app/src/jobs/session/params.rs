//! A session's parameters: a parameters file of any kind (parameters JSON, `.osim`, CEINMS
//! subject XML, `identify.json`) and the manifest's with `--params` over them.

use super::super::{read_json, read_text, ModelSettings};
use crate::error::{AppError, AppResult};
use muscle_model::{Effects, ModelParams, Muscle, ParamId};
use serde_json::Value;
use session::SessionManifest;
use std::path::{Path, PathBuf};

/// The parameters of a parameters file: a parameters JSON (over the nominal values), an
/// OpenSim `.osim` model, a CEINMS subject XML (its muscles `fixed`, CEINMS names, become
/// fixed muscles), or an `identify.json`, whose identified values are set over `base` (with
/// its effects when it has them).
pub fn load_params_file(
    path: &Path,
    osim: &opensim_files::OsimMuscleNames,
    fixed: &[String],
    base: &ModelParams,
) -> AppResult<(ModelParams, Option<Effects>)> {
    read_params_file(path, osim, fixed, base).map(|f| (f.params, f.effects))
}

/// A parameters file read by [`read_params_file`].
struct ParamsFromFile {
    params: ModelParams,
    effects: Option<Effects>,
    /// The triceps' forces before a CEINMS subject's strength coefficients; `None` for a file
    /// without them.
    unscaled_fom_n: Option<[f64; 3]>,
}

/// [`load_params_file`], with a CEINMS subject's forces before its strength coefficients.
fn read_params_file(
    path: &Path,
    osim: &opensim_files::OsimMuscleNames,
    fixed: &[String],
    base: &ModelParams,
) -> AppResult<ParamsFromFile> {
    let ext = path
        .extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase)
        .unwrap_or_default();
    let plain = |(params, effects)| ParamsFromFile {
        params,
        effects,
        unscaled_fom_n: None,
    };
    match ext.as_str() {
        "osim" => {
            let text = read_text(path)?;
            let p = opensim_files::osim_params(
                &text,
                &path.display().to_string(),
                osim,
                &ModelParams::nominal(),
            )
            .map_err(AppError::bad)?;
            Ok(plain((p, None)))
        }
        "xml" => {
            let subject = ceinms_files::read_subject(path).map_err(AppError::bad)?;
            let p = experiment::ceinms_model_params(&subject, fixed).map_err(AppError::bad)?;
            Ok(ParamsFromFile {
                params: p.params,
                effects: None,
                unscaled_fom_n: Some(p.unscaled_fom_n),
            })
        }
        _ => params_of_json(&read_json(path)?, base, &path.display().to_string()).map(plain),
    }
}

/// The parameters of a JSON object named `name`: a parameters object over the nominal values,
/// or an `identify.json`, whose identified values are set over `base` (with its effects).
pub fn params_of_json(
    value: &Value,
    base: &ModelParams,
    name: &str,
) -> AppResult<(ModelParams, Option<Effects>)> {
    if value.get("method").is_some() && value.get("params").is_some() {
        return identified_over(value, base, name).map(|(p, e)| (p, Some(e)));
    }
    let p = ModelParams::nominal()
        .merged_json(value)
        .map_err(|e| AppError::bad(format!("{name}: {e}")))?;
    Ok((p, None))
}

/// The values of an `identify.json`'s `params` set over `base` (and over its `effects`, or
/// none).
fn identified_over(
    doc: &Value,
    base: &ModelParams,
    name: &str,
) -> AppResult<(ModelParams, Effects)> {
    let mut effects = match doc.get("effects") {
        Some(v) => {
            Effects::from_json(v).map_err(|e| AppError::bad(format!("{name}: effects: {e}")))?
        }
        None => Effects::none(),
    };
    let mut params = *base;
    let map = doc["params"]
        .as_object()
        .ok_or_else(|| AppError::bad(format!("{name}: params: expected an object")))?;
    for (k, v) in map {
        let id = ParamId::parse(k).map_err(|e| AppError::bad(format!("{name}: params: {e}")))?;
        let x = v
            .as_f64()
            .ok_or_else(|| AppError::bad(format!("{name}: params.{k}: expected a number")))?;
        id.set(&mut params, &mut effects, x);
    }
    params
        .validate()
        .map_err(|e| AppError::bad(format!("{name}: {e}")))?;
    Ok((params, effects))
}

/// The session's parameters and effects: the manifest's, with `--params` (a parameters file,
/// an `.osim` or CEINMS subject, or an `identify.json`) over them and `--effects` replacing
/// theirs; with the OpenSim names its model files use.
pub(super) fn session_params(
    manifest: &SessionManifest,
    model: &ModelSettings,
    ceinms_muscles: &[String],
    read: &mut Vec<PathBuf>,
) -> AppResult<SessionParams> {
    let osim = opensim_files::OsimMuscleNames::renamed(
        manifest
            .osim_muscles
            .iter()
            .map(|(k, v)| (k.as_str(), v.as_str())),
    )
    .map_err(|e| AppError::bad(format!("{}: {e}", manifest.path.display())))?;
    let mut params = ModelParams::nominal();
    let mut effects_from_params = None;
    let mut unscaled = None;
    if let Some(p) = &manifest.params {
        read.push(p.clone());
        let f = read_params_file(p, &osim, ceinms_muscles, &params)?;
        params = f.params;
        effects_from_params = f.effects;
        unscaled = f.unscaled_fom_n;
    }
    if let Some(d) = &model.params_data {
        let (pp, e) = params_of_json(&d.value, &params, &d.label)?;
        params = pp;
        effects_from_params = e.or(effects_from_params);
        unscaled = None;
    } else if let Some(p) = &model.params {
        read.push(p.clone());
        let f = read_params_file(p, &osim, ceinms_muscles, &params)?;
        params = f.params;
        effects_from_params = f.effects.or(effects_from_params);
        unscaled = f.unscaled_fom_n;
    }
    let reference_fom_n = unscaled.unwrap_or_else(|| Muscle::ALL.map(|m| params.muscle(m).fom_n));
    let effects_path = model.effects.as_ref().or(manifest.effects.as_ref());
    let effects = match (&model.effects_data, effects_path) {
        (Some(d), _) => super::super::effects_of_json(&d.value, &d.label)?,
        (None, Some(p)) => {
            read.push(p.clone());
            super::super::read_effects(p)?
        }
        (None, None) => effects_from_params.unwrap_or_else(Effects::none),
    };
    Ok(SessionParams {
        osim,
        params,
        effects,
        reference_fom_n,
    })
}

/// The parameters a session shares, as [`session_params`] reads them.
pub(super) struct SessionParams {
    pub(super) osim: opensim_files::OsimMuscleNames,
    pub(super) params: ModelParams,
    pub(super) effects: Effects,
    /// The triceps' forces the recording defaults' F0 bounds scale: a CEINMS subject's maximum
    /// isometric forces before its strength coefficients, else the parameters' own F0.
    pub(super) reference_fom_n: [f64; 3],
}
