//! The baseline: the 9 muscle parameters fitted without any effect, by bounded
//! Levenberg–Marquardt from the nominal values and from Latin-hypercube starts (the lowest
//! whitened cost wins).

use muscle_model::{EffectKind, ParamId};

use crate::fit::{latin_hypercube, Context, Fit};
use crate::{DiagnoseError, DiagnoseSettings};

/// The nominal values of the 9 identified muscle parameters (the baseline's first start).
pub(crate) fn nominal_muscles() -> [f64; 9] {
    ParamId::identified().map(|p| {
        p.get(
            &muscle_model::ModelParams::nominal(),
            &muscle_model::Effects::none(),
        )
    })
}

/// The baseline fit of `ctx` (cross-validated); its `evaluations` count the simulations spent.
pub(crate) fn fit_baseline(
    ctx: &Context,
    settings: &DiagnoseSettings,
) -> Result<Fit, DiagnoseError> {
    let nominal = nominal_muscles();
    let mut starts = vec![nominal.to_vec()];
    let box9: Vec<(f64, f64)> = ctx.problem(&[])?.bounds().to_vec();
    starts.extend(latin_hypercube(
        &box9,
        settings.baseline_extra_starts,
        settings.start_seed,
    ));
    ctx.fit_from(&[], &starts, true)
}

/// The candidate effects whose inputs the trial has (`antagonist_coactivation` needs the
/// tibialis anterior's EMG).
pub(crate) fn eligible_candidates(ctx: &Context, settings: &DiagnoseSettings) -> Vec<EffectKind> {
    settings
        .candidates
        .iter()
        .copied()
        .filter(|k| *k != EffectKind::AntagonistCoactivation || ctx.inputs.envelope_ta().is_some())
        .collect()
}
