//! Whether an identified model leaves structure in its residual: the diagnosis's structure
//! tests (module [`crate::analysis`]) at a given parameter point, for `surae identify`.
//!
//! The trial is prepared as a diagnosis prepares it (the noise model of the unloaded run, or
//! of the residual of a white-noise baseline fit without one; the dynamometer's systematic
//! part subtracted). At the identified point `x̂` the whitened residual `r` and the whitened
//! Jacobian `J` of the identified parameters (forward differences, the diagnosis's step)
//! give the score statistics
//!
//! ```text
//! LM = rᵀP⊥B(BᵀP⊥B)⁻¹BᵀP⊥r / s²,   P⊥ = I − J(JᵀJ)⁻¹Jᵀ,   s² = ‖r‖²/(n − k)
//! ```
//!
//! against the step functions of the motion and of time and each state variable's flexible
//! basis (module [`analysis`](crate::analysis)); the p-value is the Bonferroni minimum of the
//! three tests' tails, and the model *leaves structure* when `−log10 p` exceeds the
//! diagnosis's threshold (3: a false alarm in 10⁻³ correct models).
//!
//! The identified point need not be the whitened least-squares optimum (SA minimises the
//! unweighted squared error): projecting out `J` removes what a small move of the
//! identified parameters would explain, so the test sees only what the model cannot.

use experiment::{PreparedTrial, UnloadedCorrection};
use muscle_model::{Effects, ModelParams, ParamId, Problem};
use serde::Serialize;

use crate::analysis::structure_test;
use crate::context::{self, Target};
use crate::fit::{whitened_jacobian, Fit};
use crate::{DiagnoseError, DiagnoseSettings, DiagnosisRecording};

/// The structure test of an identified model.
#[derive(Clone, Debug, PartialEq, Serialize)]
#[non_exhaustive]
pub struct Adequacy {
    /// Bonferroni p-value of the motion, time and vocabulary structure tests.
    pub structure_p: f64,
    /// `−log10 structure_p`.
    pub structure_evidence: f64,
    /// The evidence above which the model leaves structure (the diagnosis's threshold).
    pub threshold: f64,
    /// Score statistic against the motion's step functions, and its degrees of freedom.
    pub motion_lm: f64,
    /// Degrees of freedom of `motion_lm`.
    pub motion_df: usize,
    /// Score statistic against 1 s time blocks, and its degrees of freedom.
    pub time_lm: f64,
    /// Degrees of freedom of `time_lm`.
    pub time_df: usize,
    /// The vocabulary test: the score statistic against the flexible basis of the state
    /// variable with the smallest p-value.
    pub vocabulary_lm: f64,
    /// Degrees of freedom of `vocabulary_lm`.
    pub vocabulary_df: usize,
    /// The variable of `vocabulary_lm` (`null` when no variable could be tested).
    pub vocabulary_variable: Option<crate::StateVariable>,
    /// Whether `vocabulary_lm`'s basis was the variable's split by the direction of motion.
    pub vocabulary_by_direction: bool,
}

impl Adequacy {
    /// Whether the model leaves structure (`structure_evidence > threshold`).
    pub fn leaves_structure(&self) -> bool {
        self.structure_evidence > self.threshold
    }

    /// The warning a user sees when the model leaves structure, `None` otherwise.
    pub fn warning(&self) -> Option<String> {
        self.leaves_structure().then(|| {
            format!(
                "the model leaves structure in the residual (p = {:.1e}): its parameters may \
                 be biased; run `surae diagnose` on this trial to find what is missing, then \
                 identify with `--with <effect>`",
                self.structure_p
            )
        })
    }
}

/// The structure test of the model `params` + `effects` on a prepared trial (its inputs, raw
/// torque and dynamometer correction, [`PreparedTrial`]), with the parameters `free`
/// projected out.
///
/// # Errors
/// Invalid settings, an unloaded run that does not match, a model that cannot be simulated
/// at the point.
pub fn adequacy(
    prepared: &PreparedTrial,
    params: &ModelParams,
    effects: &Effects,
    free: &[ParamId],
    settings: &DiagnoseSettings,
) -> Result<Adequacy, DiagnoseError> {
    settings.validate()?;
    let (ctx, _) = context::prepared_context(prepared, *params, *effects, settings)?;
    test_ctx(&ctx, free, settings)
}

/// [`adequacy`] of a prepared recording (a session's trial, a CEINMS trial) at its model
/// (`recording.params`, `recording.effects`).
///
/// # Errors
/// As [`adequacy`], and the recording's own checks ([`crate::run_prepared`]).
pub fn adequacy_of_recording(
    recording: &DiagnosisRecording,
    unloaded: Option<&UnloadedCorrection>,
    free: &[ParamId],
    settings: &DiagnoseSettings,
) -> Result<Adequacy, DiagnoseError> {
    settings.validate()?;
    let observed = recording.observed()?;
    let inputs = recording.inputs.clone();
    let seg = context::segment(&inputs, observed.as_deref())?;
    let target = Target {
        torque_nm: &recording.torque_nm,
        observed,
        params: recording.params,
        effects: recording.effects,
        emg: Default::default(),
    };
    test_at(target, unloaded, inputs, seg, free, settings)
}

fn test_at(
    target: Target<'_>,
    unloaded: Option<&UnloadedCorrection>,
    inputs: muscle_model::TrialInputs,
    seg: crate::Segmentation,
    free: &[ParamId],
    settings: &DiagnoseSettings,
) -> Result<Adequacy, DiagnoseError> {
    let (ctx, _) = context::trial_context(target, unloaded, inputs, seg, settings)?;
    test_ctx(&ctx, free, settings)
}

/// The structure test of `ctx`'s base model with the parameters `free` projected out.
fn test_ctx(
    ctx: &crate::fit::Context,
    free: &[ParamId],
    settings: &DiagnoseSettings,
) -> Result<Adequacy, DiagnoseError> {
    let fail = |reason: &str| DiagnoseError::Fit {
        model: "identified".into(),
        reason: reason.into(),
    };
    let problem = Problem::new(
        ctx.inputs.clone(),
        ctx.y.clone(),
        ctx.params,
        ctx.effects,
        free.to_vec(),
    )?;
    let x = problem.base_vector();
    let white = ctx.residual_fn(&problem, &ctx.plan)(&x)
        .ok_or_else(|| fail("the model cannot be simulated at the identified point"))?;
    // the default bounds around the point only set the difference step (a range's 10⁻³; a
    // point on a bound steps inward)
    let jac = whitened_jacobian(ctx, &problem, &x, &white, problem.bounds(), &ctx.lm)
        .ok_or_else(|| fail("the model cannot be simulated near the identified point"))?;
    let white_ss = white.iter().map(|v| v * v).sum();
    let fit = Fit {
        kinds: Vec::new(),
        free: free.to_vec(),
        x: x.clone(),
        pred: Vec::new(),
        jac,
        white,
        white_ss,
        loglik: ctx.plan.log_likelihood(white_ss),
        rms: f64::NAN,
        heldout_rms: f64::NAN,
        heldout_dev: f64::NAN,
        evaluations: 0,
    };
    let t = structure_test(ctx, &fit);
    Ok(Adequacy {
        structure_p: t.p_value,
        structure_evidence: -t.p_value.max(1e-300).log10(),
        threshold: settings.structure_threshold,
        motion_lm: t.motion_lm,
        motion_df: t.motion_df,
        time_lm: t.time_lm,
        time_df: t.time_df,
        vocabulary_lm: t.vocabulary_lm,
        vocabulary_df: t.vocabulary_df,
        vocabulary_variable: t.vocabulary_variable,
        vocabulary_by_direction: t.vocabulary_by_direction,
    })
}
