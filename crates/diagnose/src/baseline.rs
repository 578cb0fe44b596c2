//! The baseline: the 9 muscle parameters fitted without any candidate effect, by bounded
//! Levenberg–Marquardt from their base values (the nominal ones for a trial CSV) and from
//! Latin-hypercube starts (the lowest whitened cost wins).

use muscle_model::EffectKind;

use crate::fit::{latin_hypercube, Context, Fit};
use crate::{DiagnoseError, DiagnoseSettings};

/// The baseline fit of `ctx` (cross-validated); its `evaluations` count the simulations spent.
pub(crate) fn fit_baseline(
    ctx: &Context,
    settings: &DiagnoseSettings,
) -> Result<Fit, DiagnoseError> {
    let mut starts = vec![ctx.base_muscles().to_vec()];
    let box9: Vec<(f64, f64)> = ctx.problem(&[])?.bounds().to_vec();
    starts.extend(latin_hypercube(
        &box9,
        settings.baseline_extra_starts,
        settings.start_seed,
    ));
    ctx.fit_from(&[], &starts, true)
}

/// The candidate effects whose inputs the trial has (`antagonist_coactivation` needs the
/// tibialis anterior's EMG, the effects of [`needs_joint_angle`] a moving angle) and that the
/// base model does not already carry.
pub(crate) fn eligible_candidates(ctx: &Context, settings: &DiagnoseSettings) -> Vec<EffectKind> {
    let still = !angle_moves(ctx);
    settings
        .candidates
        .iter()
        .copied()
        .filter(|k| *k != EffectKind::AntagonistCoactivation || ctx.inputs.envelope_ta().is_some())
        .filter(|k| !(still && needs_joint_angle(*k)))
        .filter(|k| !ctx.effects.is_enabled(*k))
        .collect()
}

/// The candidates of `settings` left out because the trial has no joint angle.
pub(crate) fn untestable_without_angle(
    ctx: &Context,
    settings: &DiagnoseSettings,
) -> Vec<EffectKind> {
    if angle_moves(ctx) {
        return Vec::new();
    }
    settings
        .candidates
        .iter()
        .copied()
        .filter(|k| needs_joint_angle(*k))
        .collect()
}

/// Whether the effect's torque is a function of the ankle angle `q`, its velocity or its
/// acceleration (passive joint torque `s·(e^{kq} − 1)`, gravity `m·sin(q − φ)`, damping
/// `b·q̇`, inertia `−I·q̈`). With a constant angle their sensitivities vanish (passive,
/// damping, inertia) or are a constant that the offset already is (gravity): the data say
/// nothing about them.
pub(crate) fn needs_joint_angle(kind: EffectKind) -> bool {
    matches!(
        kind,
        EffectKind::PassiveJointTorque
            | EffectKind::Gravity
            | EffectKind::ViscousDamping
            | EffectKind::Inertia
    )
}

/// Whether the ankle angle changes over the observed samples (a recording without one, such
/// as a CEINMS trial, carries a constant zero angle).
pub(crate) fn angle_moves(ctx: &Context) -> bool {
    let q = ctx.inputs.angle();
    let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
    for (i, v) in q.iter().enumerate() {
        if ctx.is_observed(i) {
            lo = lo.min(*v);
            hi = hi.max(*v);
        }
    }
    hi - lo > 1e-9
}
