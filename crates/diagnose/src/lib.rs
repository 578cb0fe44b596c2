//! Diagnosis of what the simulation gets wrong (`surae diagnose`): residual analysis, ranking
//! and fitting of the catalogued model extensions (docs/model.md), and their held-out gain.
//! docs/diagnosis.md describes the method and its calibration, docs/formats.md the report.
//!
//! # Method
//!
//! 0. **EMG crosstalk** (`crosstalk`): with a raw `emg_ta` channel, each triceps channel's
//!    share of the TA's raw signal is tested (weighted least squares over 100 ms blocks,
//!    [`experiment::emg_crosstalk`]) and, when `p < 10⁻⁵`, removed from the raw signal before the
//!    envelopes are made ([`experiment::PreparedTrial`]); the final model is refitted on the uncorrected envelopes to measure
//!    what the correction is worth ([`EmgCorrection`]).
//! 1. **Noise** ([`noise`]): on the unloaded run, fit the dynamometer's systematic part
//!    `c + Σ_e e^{−(t−e)/τ}(B sin 2πf(t−e) + C cos 2πf(t−e))` (offset + event transients) and
//!    an AR(1)+white random part; subtract the systematic part (at the trial's own events)
//!    from the measured torque. Whitening by the Kalman innovations `ν_t/√S_t` makes the
//!    least squares exact generalised least squares, with
//!    `log L = −½ Σ (ln 2π S_t + ν_t²/S_t)`.
//! 2. **Baseline** ([`lm`], `baseline`): bounded Levenberg–Marquardt on the 9 muscle parameters from
//!    nominal and from Latin-hypercube starts (the lowest whitened cost wins), whitened
//!    residual, finite-difference Jacobian.
//! 3. **Ranking** (`score`): for every eligible extension, the score test
//!    `LM = rᵀP⊥S(SᵀP⊥S)⁻¹SᵀP⊥r/s²` from its sensitivity `S` at the null value;
//!    evidence `LM − p ln n`.
//! 4. **Refit** the leaders (`selection`, its rules in `rules`) (muscle + effect parameters) and cross-validate cycle-wise
//!    (each cycle held out in turn with the hold after it, so that every sample is held out
//!    once: zero weight, states still simulated over the whole trial;
//!    a trial with fewer than three cycles is cut into 0.5 s blocks in 5 folds instead,
//!    [`CvFolds`]).
//!    The held-out error is measured twice: the pooled RMS of the held-out samples, and
//!    the **held-out deviance** `Σ ν_t²/S_t` over them (the fold fit's residual whitened by
//!    the noise model over the whole trial, the likelihood's own weighting).
//!    An extension is **accepted** when its held-out deviance is lower than the current
//!    model's **and** `ΔBIC = BIC_ext − BIC_base < −10` (the held-out RMS is reported, not
//!    judged: the noise's slow part sets it);
//!    the best accepted one (lowest ΔBIC) joins the model and the ranking is repeated on the
//!    new residual (greedy forward selection). Refits start from the current fit, from
//!    nominal and from Latin-hypercube muscle parameters; before a candidate is accepted the
//!    current model is refitted from the candidate's values, so that a better optimum of
//!    parameters it already has is not credited to the new effect. When no
//!    single extension passes, the two strongest are fitted jointly (they may only generalise
//!    together). With two or more causes, an **exchange** pass drops each cause in turn and
//!    lets the others' alternatives replace it by more than the ΔBIC margin. In a round and in
//!    the exchange, a candidate with fewer parameters that the data cannot tell from the best
//!    one (BIC less than the margin higher, held-out RMS not higher by the held-out margin) is
//!    named instead. Alternatives within both margins of a named cause are reported as
//!    **near ties** ([`NearTie`]): the trial cannot tell them apart (an offset and a gravity
//!    term over a 35° range of motion). A gravity term is fitted in linear coordinates
//!    `A·sin q + B·cos q` and reported as `m·sin(q − φ)`; its phase is held in the
//!    cross-validation folds.
//! 5. **Confounding**: an extension whose signature has `cos > 0.98` with the span of the
//!    model's parameter sensitivities is reported in `confounded`, never named.
//! 6. **Unexplained structure** ([`analysis`]): two generic step-function models (of the
//!    motion: cycle × sweep direction × angle bin, hold halves; of time: 1 s blocks) and each
//!    state variable's flexible basis tested against the final residual by score tests,
//!    `LM ~ χ²(df)` under a correct model;
//!    structure is unexplained when the Bonferroni p-value is below 10⁻³. The causes named
//!    are reviewed against flexible terms in their own variables, and structure left is traced
//!    to the state variable it depends on ([`flexible`]).
//! 7. **Uncertainty** (`profile`): 68 % profile-likelihood intervals of every parameter of
//!    the final model, `{θ : (min_{others} ‖r‖² − ‖r̂‖²)/s² ≤ 1}` with the others refitted,
//!    cut at the bounds; the uncertainty reported is the half-width. The Gauss–Newton
//!    standard errors `√diag(s²(JᵀJ)⁻¹)` are kept beside them (`laplace_se`) and decide the
//!    confounding test; they are several times too small for the pennation angles and tendon
//!    slack lengths (docs/diagnosis.md).
//!
//! # Sessions
//!
//! [`diagnose_session`] diagnoses several trials of one subject together: shared muscle
//! parameters, the subject's effects shared and each trial's setup effects its own
//! ([`effect_scope`]), the gain measured by leaving one trial out (docs/diagnosis.md,
//! "Sessions").
//!
//! # Example
//!
//! ```no_run
//! use experiment::{synthesize, Protocol, SynthConfig};
//! use muscle_model::Effects;
//!
//! let effects = Effects::from_json_str(r#"{"electromechanical_delay": {"delay_ms": 40}}"#)?;
//! let cfg = SynthConfig::new("relaxed+2".parse::<Protocol>()?, 11).with_effects(effects);
//! let syn = synthesize(&cfg)?;
//! let d = diagnose::run(&syn.trial, Some(&syn.unloaded), &diagnose::DiagnoseSettings::default(),
//!                       &mut diagnose::no_observer)?;
//! assert_eq!(d.causes, vec!["electromechanical_delay".to_string()]);
//! for line in d.summary_lines() { println!("{line}"); }
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

// Index loops mirror the equations (several arrays per index); the boxed β → value maps are
// one-line closures.
#![allow(clippy::needless_range_loop, clippy::type_complexity)]

mod adequacy;
pub mod analysis;
mod assemble;
mod baseline;
mod context;
mod crosstalk;
mod error;
mod estimates;
mod fit;
pub mod flexible;
mod given_params;
mod held_out_shape;
pub mod lm;
pub mod noise;
pub mod power;
mod profile;
mod progress;
mod recording;
mod report;
mod rules;
#[cfg(feature = "test-support")]
pub mod scenarios;
mod score;
pub mod segment;
mod selection;
mod session;
mod settings;

use std::ops::ControlFlow;
use std::time::Instant;

use experiment::{PreparedTrial, Trial, Unloaded, UnloadedCorrection};
use muscle_model::{Effects, ModelParams};

pub use adequacy::{adequacy, adequacy_of_recording, Adequacy};
pub use analysis::{AcfPoint, Bin, ResidualAnalysis, Series};
pub use crosstalk::{crosstalk_summary_line, EmgCorrection};
pub use error::DiagnoseError;
pub use flexible::{
    FlexibleExtension, FlexibleTerm, Replacement, SearchedValue, StateVariable, Unexplained,
    VariableGain,
};
pub use given_params::{GivenParamsFit, TrialGivenParamsFit};
pub use held_out_shape::{
    HeldOutShapeCheck, HeldOutShapePart, SessionHeldOutShape, TrialHeldOutShape,
    HELD_OUT_SHAPE_EVIDENCE,
};
pub use noise::{NoiseModelSource, Transient, TrialNoiseModel};
pub use profile::ProfileSettings;
pub use progress::{no_observer, DiagnosisProgress, DiagnosisStage};
pub use recording::DiagnosisRecording;
pub use report::{
    detection_limit_unit, CandidateReport, Diagnosis, Gain, ModelReport, NearTie, NotTestable,
    ParamInterval, Verdict, NO_JOINT_ANGLE,
};
pub use segment::{PhaseLabel, Segmentation};
pub use session::{
    diagnose_session, effect_scope, EffectScope, HeldoutScheme, SessionCandidate, SessionCause,
    SessionDiagnosis, SessionHeldout, SessionMember, SessionTrialFit, TrialHeldout,
};
pub use settings::{CvFolds, DiagnoseSettings, MIN_CV_CYCLES};

use progress::notify;

/// Diagnoses a measured trial (and its unloaded run when available): the model's inputs
/// from the trial, nominal muscle parameters, no effect, every sample compared.
///
/// # Errors
/// Invalid trial or unloaded run (EMG columns, no motion, sampling rates that differ),
/// invalid settings, a baseline that cannot be simulated, or a stop by the observer.
pub fn run(
    trial: &Trial,
    unloaded: Option<&Unloaded>,
    settings: &DiagnoseSettings,
    observer: &mut dyn FnMut(&DiagnosisProgress) -> ControlFlow<()>,
) -> Result<Diagnosis, DiagnoseError> {
    run_with_model(
        trial,
        unloaded,
        &ModelParams::nominal(),
        &Effects::none(),
        settings,
        observer,
    )
}

/// [`run`] with base parameters `params` (the start and bounds' centre of the 9 identified
/// muscle parameters; every other value, fixed muscles included, held) and base effects
/// `effects` (carried at their values, not candidates), as a session's trial CSV is
/// diagnosed with the session's model.
///
/// # Errors
/// As [`run`].
pub fn run_with_model(
    trial: &Trial,
    unloaded: Option<&Unloaded>,
    params: &ModelParams,
    effects: &Effects,
    settings: &DiagnoseSettings,
    observer: &mut dyn FnMut(&DiagnosisProgress) -> ControlFlow<()>,
) -> Result<Diagnosis, DiagnoseError> {
    settings.validate()?;
    let prepared = settings.prepare(trial, unloaded)?;
    run_trial(&prepared, params, effects, settings, observer)
}

/// [`run_with_model`] on a trial already prepared ([`DiagnoseSettings::prepare`], or as the
/// identification prepared it with the same input options): its crosstalk decision, model
/// inputs and dynamometer correction are used as they are.
///
/// # Errors
/// As [`run`].
pub fn run_trial(
    prepared: &PreparedTrial,
    params: &ModelParams,
    effects: &Effects,
    settings: &DiagnoseSettings,
    observer: &mut dyn FnMut(&DiagnosisProgress) -> ControlFlow<()>,
) -> Result<Diagnosis, DiagnoseError> {
    let t0 = Instant::now();
    // Settings and inputs: refuse what the decision rule cannot use before any simulation.
    settings.validate()?;
    let inputs = prepared.inputs.clone();
    let seg = context::segment_motion(&inputs)?;
    // The TA's crosstalk was removed from the raw triceps EMG before the envelopes were
    // made; the uncorrected envelopes say what the correction was worth.
    let target = context::Target {
        torque_nm: prepared.raw_torque(),
        observed: None,
        params: *params,
        effects: *effects,
        emg: crosstalk::EmgInputs {
            checks: prepared.crosstalk.clone(),
            uncorrected: prepared.uncorrected_inputs.clone(),
        },
    };
    diagnose_target(
        target,
        prepared.unloaded.as_ref(),
        inputs,
        seg,
        settings,
        observer,
        t0,
    )
}

/// Diagnoses a recording given as model inputs ([`DiagnosisRecording`]), such as a CEINMS
/// trial: no unloaded run (the noise model is fitted to the baseline's residual), samples of
/// weight 0 left out of every fit, score, test and held-out error, and, when the angle never
/// changes over the compared samples, the effects that need a joint angle reported in
/// [`Diagnosis::not_testable`] instead of being tested.
///
/// # Errors
/// Invalid settings, a torque or weights whose length is not the inputs', a weight that is
/// not finite or not ≥ 0, no sample of positive weight, a moving angle that cannot be
/// segmented, a baseline that cannot be simulated, or a stop by the observer.
pub fn run_prepared(
    recording: &DiagnosisRecording,
    settings: &DiagnoseSettings,
    observer: &mut dyn FnMut(&DiagnosisProgress) -> ControlFlow<()>,
) -> Result<Diagnosis, DiagnoseError> {
    settings.validate()?;
    run_member(recording, None, settings, observer)
}

/// [`run_prepared`] with the recording's unloaded run (a session's trial CSV, its inputs as
/// the session prepared them).
pub(crate) fn run_member(
    recording: &DiagnosisRecording,
    unloaded: Option<&UnloadedCorrection>,
    settings: &DiagnoseSettings,
    observer: &mut dyn FnMut(&DiagnosisProgress) -> ControlFlow<()>,
) -> Result<Diagnosis, DiagnoseError> {
    let t0 = Instant::now();
    let observed = recording.observed()?;
    let inputs = recording.inputs.clone();
    let seg = context::segment(&inputs, observed.as_deref())?;
    let target = context::Target {
        torque_nm: &recording.torque_nm,
        observed,
        params: recording.params,
        effects: recording.effects,
        emg: crosstalk::EmgInputs::default(),
    };
    diagnose_target(target, unloaded, inputs, seg, settings, observer, t0)
}

/// Drops the causes `replaced` from the selected model (refitted without them, from its own
/// values) and from the accepted candidates; returns the simulations spent.
fn drop_causes(
    ctx: &fit::Context,
    selection: &mut selection::Selection,
    replaced: &[Replacement],
) -> Result<usize, DiagnoseError> {
    if replaced.is_empty() {
        return Ok(0);
    }
    let drop: Vec<muscle_model::EffectKind> = replaced
        .iter()
        .filter_map(|x| muscle_model::EffectKind::from_name(&x.effect))
        .collect();
    let (kinds, x) = flexible::without_effects(&selection.model, &drop);
    let mut evaluations = 0;
    selection.model = if kinds.is_empty() {
        selection.baseline.clone()
    } else {
        let f = ctx.fit(&kinds, &x, true)?;
        evaluations += f.evaluations;
        f
    };
    for k in &drop {
        if let Some(rep) = selection.reports.get_mut(k) {
            rep.accepted = false;
        }
        selection.ties.remove(k);
    }
    Ok(evaluations)
}

/// The stages of a diagnosis (module docs) on prepared inputs.
fn diagnose_target(
    mut target: context::Target<'_>,
    unloaded: Option<&UnloadedCorrection>,
    inputs: muscle_model::TrialInputs,
    seg: Segmentation,
    settings: &DiagnoseSettings,
    observer: &mut dyn FnMut(&DiagnosisProgress) -> ControlFlow<()>,
    t0: Instant,
) -> Result<Diagnosis, DiagnoseError> {
    let emg = std::mem::take(&mut target.emg);
    // Noise: the dynamometer's systematic part leaves the torque, its random part whitens
    // the residual of every fit.
    notify(
        observer,
        DiagnosisStage::Noise,
        "fitting the noise model".into(),
        0,
    )?;
    let (ctx, mut evaluations) = context::trial_context(target, unloaded, inputs, seg, settings)?;

    // Baseline: the 9 muscle parameters without any effect.
    notify(
        observer,
        DiagnosisStage::Baseline,
        "fitting the baseline (9 muscle parameters)".into(),
        evaluations,
    )?;
    let baseline = baseline::fit_baseline(&ctx, settings)?;
    evaluations += baseline.evaluations;
    let nobs = ctx.plan.n_obs();
    let eligible = baseline::eligible_candidates(&ctx, settings);
    let not_testable = baseline::untestable_without_angle(&ctx, settings);

    // Selection: forward rounds of score test, refit and cross-validation, then the exchange.
    let mut selection = selection::select(
        &ctx,
        baseline,
        &eligible,
        settings,
        nobs,
        observer,
        &mut evaluations,
    )?;

    // Beyond the catalogue: a named cause that a flexible term in its own variable explains
    // better is not named (no false story).
    let replaced = review_named_causes(&ctx, &mut selection, settings, observer, &mut evaluations)?;

    // The structure left in the final residual, and what it depends on.
    let (ra, unexplained) = explain_structure(
        &ctx,
        &mut selection,
        &eligible,
        replaced,
        settings,
        observer,
        &mut evaluations,
    )?;

    // What the crosstalk correction was worth: the final model on the uncorrected envelopes.
    let emg_correction = match emg.uncorrected {
        Some(raw) => Some(correction_worth(
            &ctx,
            &selection.model,
            raw,
            &emg.checks,
            settings,
            observer,
            &mut evaluations,
        )?),
        None => None,
    };

    // The smallest detectable size of every effect not named.
    detection_limits(
        &ctx,
        &mut selection,
        &eligible,
        settings,
        observer,
        &mut evaluations,
    )?;

    // Uncertainty: profile-likelihood intervals of the final model's parameters.
    notify(
        observer,
        DiagnosisStage::Analysis,
        "profile-likelihood intervals".into(),
        evaluations,
    )?;
    let intervals = estimates::profile_intervals(&ctx, &selection.model, nobs, &settings.profile)?;
    evaluations += intervals
        .iter()
        .map(|(_, iv)| iv.evaluations)
        .sum::<usize>();

    // Report.
    let mut diagnosis = assemble::diagnosis(
        ctx,
        selection,
        ra,
        unexplained,
        &intervals,
        settings,
        evaluations,
    );
    diagnosis.not_testable = not_testable
        .into_iter()
        .map(|k| NotTestable {
            effect: k.name().to_string(),
            reason: NO_JOINT_ANGLE.to_string(),
        })
        .collect();
    // A correction worth as much as a flexible term makes the recording's model deficient.
    if let Some(c) = &emg_correction {
        mark_uncorrected_activation(&mut diagnosis, c, settings);
    }
    diagnosis.emg_crosstalk = emg.checks;
    diagnosis.emg_correction = emg_correction;
    diagnosis.wall_s = t0.elapsed().as_secs_f64();
    Ok(diagnosis)
}

/// The review of the named causes against flexible terms (no false story, module `flexible`):
/// a cause that a flexible term in its own variable explains better is dropped from the
/// selection; returns the causes replaced.
fn review_named_causes(
    ctx: &fit::Context,
    selection: &mut selection::Selection,
    settings: &DiagnoseSettings,
    observer: &mut dyn FnMut(&DiagnosisProgress) -> ControlFlow<()>,
    evaluations: &mut usize,
) -> Result<Vec<Replacement>, DiagnoseError> {
    if !settings.flexible_terms || selection.model.kinds.is_empty() {
        return Ok(Vec::new());
    }
    notify(
        observer,
        DiagnosisStage::Analysis,
        "reviewing the named causes against flexible terms".into(),
        *evaluations,
    )?;
    // a review that cannot be fitted replaces nothing
    let (mut replaced, ev) = flexible::review_causes(
        ctx,
        &selection.model,
        settings.flexible_margin_bic,
        ctx.plan.n_obs(),
    )
    .unwrap_or_default();
    *evaluations += ev;
    *evaluations += drop_causes(ctx, selection, &replaced)?;
    // then the causes left against a flexible term in any variable, held out
    if settings.heldout_contest && !selection.model.kinds.is_empty() {
        let (more, ev) = flexible::heldout_contest(
            ctx,
            &selection.model,
            settings.min_flexible_gain,
            settings.flexible_margin_bic,
            ctx.plan.n_obs(),
        )
        .unwrap_or_default();
        *evaluations += ev;
        *evaluations += drop_causes(ctx, selection, &more)?;
        replaced.extend(more);
    }
    Ok(replaced)
}

/// The residual analysis of the final model and what its structure depends on: the
/// vocabulary's flexible terms ranked, the model extended with the best; a named cause the
/// extension makes unnecessary is dropped and the smaller model characterised again.
fn explain_structure(
    ctx: &fit::Context,
    selection: &mut selection::Selection,
    eligible: &[muscle_model::EffectKind],
    mut replaced: Vec<Replacement>,
    settings: &DiagnoseSettings,
    observer: &mut dyn FnMut(&DiagnosisProgress) -> ControlFlow<()>,
    evaluations: &mut usize,
) -> Result<(ResidualAnalysis, Option<Unexplained>), DiagnoseError> {
    notify(
        observer,
        DiagnosisStage::Analysis,
        "residual analysis".into(),
        *evaluations,
    )?;
    let mut ra = analysis::analyse(
        ctx,
        &selection.baseline,
        &selection.model,
        settings.structure_threshold,
    );
    let mut unexplained = None;
    while settings.flexible_terms
        && (ra.structure_evidence > settings.structure_threshold || !replaced.is_empty())
    {
        notify(
            observer,
            DiagnosisStage::Analysis,
            "ranking flexible terms in the state variables".into(),
            *evaluations,
        )?;
        // an extension that cannot be fitted leaves the structure unexplained and unranked
        let c = flexible::characterise(
            ctx,
            &selection.model,
            eligible,
            replaced.clone(),
            settings.min_flexible_gain,
            settings.flexible_margin_bic,
            ctx.plan.n_obs(),
        )
        .unwrap_or_else(|_| flexible::Characterisation {
            unexplained: Unexplained {
                depends_on: Vec::new(),
                ranking: Vec::new(),
                extension: None,
                catalogued_shape: None,
                replaced: replaced.clone(),
            },
            unneeded: Vec::new(),
            evaluations: 0,
        });
        *evaluations += c.evaluations;
        if c.unneeded.is_empty() {
            unexplained = Some(c.unexplained);
            break;
        }
        *evaluations += drop_causes(ctx, selection, &c.unneeded)?;
        replaced.extend(c.unneeded);
        ra = analysis::analyse(
            ctx,
            &selection.baseline,
            &selection.model,
            settings.structure_threshold,
        );
    }
    Ok((ra, unexplained))
}

/// The final model `model` on the EMG without the crosstalk correction (`raw`).
fn correction_worth(
    ctx: &fit::Context,
    model: &fit::Fit,
    raw: muscle_model::TrialInputs,
    checks: &[experiment::CrosstalkCheck],
    settings: &DiagnoseSettings,
    observer: &mut dyn FnMut(&DiagnosisProgress) -> ControlFlow<()>,
    evaluations: &mut usize,
) -> Result<EmgCorrection, DiagnoseError> {
    notify(
        observer,
        DiagnosisStage::Analysis,
        "the final model on the EMG without the crosstalk correction".into(),
        *evaluations,
    )?;
    let (c, ev) = crosstalk::correction_worth(ctx, model, raw, checks, settings)?;
    *evaluations += ev;
    Ok(c)
}

/// The detection limit, and its shape, of every effect not named, into the candidates'
/// reports.
fn detection_limits(
    ctx: &fit::Context,
    selection: &mut selection::Selection,
    eligible: &[muscle_model::EffectKind],
    settings: &DiagnoseSettings,
    observer: &mut dyn FnMut(&DiagnosisProgress) -> ControlFlow<()>,
    evaluations: &mut usize,
) -> Result<(), DiagnoseError> {
    notify(
        observer,
        DiagnosisStage::Analysis,
        "detection limits of the effects not named".into(),
        *evaluations,
    )?;
    let limits = score::detection_limits_with_shapes(
        ctx,
        &selection.model,
        eligible,
        settings.max_delta_bic,
        settings
            .flexible_terms
            .then_some(settings.flexible_margin_bic),
    );
    for l in limits {
        *evaluations += l.evaluations;
        if let Some(rep) = selection.reports.get_mut(&l.kind) {
            rep.detection_limit = Some(l.limit);
            rep.detection_limit_shape = l.shape;
        }
    }
    Ok(())
}

/// Marks the diagnosis deficient when the crosstalk correction `c` was worth as much as a
/// flexible term: what it leaves lives in the triceps activation the model was given.
fn mark_uncorrected_activation(
    diagnosis: &mut Diagnosis,
    c: &EmgCorrection,
    settings: &DiagnoseSettings,
) {
    if c.heldout_deviance_gain > settings.min_flexible_gain {
        diagnosis.verdict = Verdict::Deficient;
        let u = diagnosis.unexplained.get_or_insert_with(|| Unexplained {
            depends_on: Vec::new(),
            ranking: Vec::new(),
            extension: None,
            catalogued_shape: None,
            replaced: Vec::new(),
        });
        u.depends_on.retain(|v| *v != StateVariable::Activation);
        u.depends_on.insert(0, StateVariable::Activation);
    }
}
