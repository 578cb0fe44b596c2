//! The identification's results in other tools' formats: the chains for ArviZ (CmdStan CSV,
//! `chains/chain_<k>.csv`, k from 1) and the identified values in a copy of the user's
//! OpenSim model (`identified.osim`). Formats in docs/formats.md.

use super::super::{is_osim, osim_names, read_text, ModelSettings};
use crate::error::{AppError, AppResult};
use crate::output::OutDir;
use muscle_model::ModelParams;
use std::path::PathBuf;

/// Writes one CmdStan-format CSV per chain into `chains/`.
pub(super) fn write_chains(
    out: &OutDir,
    m: &identify_mcmc::McmcIdentification,
    seed: u64,
    trial: &str,
) -> AppResult<Vec<PathBuf>> {
    let mut files = Vec::new();
    if let Some(chains) = m.nuts_chains() {
        let description = [
            "surae identify --method nuts: the No-U-Turn sampler along the model's exact gradient",
            &format!("trial = {trial}"),
            "lp__ = log posterior on the unconstrained coordinates (the logistic transform's Jacobian included)",
        ];
        let names: Vec<&str> = m.names.iter().map(String::as_str).collect();
        for c in 0..chains.stats.len() {
            let mut csv = Vec::new();
            identify_mcmc::write_cmdstan_nuts_chain(chains, &names, c, &description, &mut csv)
                .map_err(AppError::internal)?;
            files.push(out.write(&format!("chains/chain_{}.csv", c + 1), &csv)?);
        }
        return Ok(files);
    }
    let description = [
        "surae identify --method mcmc: random-walk Metropolis-Hastings with mode jumps (not NUTS)",
        &format!("trial = {trial}"),
        "lp__ = log uniform prior on the bounds + log_lik.1; log_lik.1 = log-likelihood of the trial",
    ];
    for c in 0..m.run.log_density.len() {
        let mut csv = Vec::new();
        identify_mcmc::write_cmdstan_chain(m, c, seed, &description, &mut csv)
            .map_err(AppError::internal)?;
        files.push(out.write(&format!("chains/chain_{}.csv", c + 1), &csv)?);
    }
    Ok(files)
}

/// With an `.osim` `--params`, writes `identified.osim`: the model with the identified F0, LST
/// and α0 of sol, gm and gl (the identified parameters), nothing else changed. `None` otherwise.
pub(super) fn write_identified_osim(
    out: &OutDir,
    model: &ModelSettings,
    identified: &ModelParams,
) -> AppResult<Option<PathBuf>> {
    let Some(path) = model.params.as_deref().filter(|p| is_osim(p)) else {
        return Ok(None);
    };
    write_osim_copy(out, path, &osim_names(model)?, identified).map(Some)
}

/// Writes `identified.osim`: the model `path` with `params`' F0, LST and α0 of sol, gm and gl
/// set on the muscles `names`, and nothing else changed.
pub(super) fn write_osim_copy(
    out: &OutDir,
    path: &std::path::Path,
    names: &opensim_files::OsimMuscleNames,
    params: &ModelParams,
) -> AppResult<PathBuf> {
    let text = read_text(path)?;
    let edited =
        opensim_files::write_identified_osim(&text, &path.display().to_string(), names, params)
            .map_err(AppError::bad)?;
    out.write("identified.osim", edited.as_bytes())
}
