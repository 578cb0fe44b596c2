//! Diagnosis of what the simulation gets wrong (SPEC §7 `surae diagnose`): residual analysis,
//! ranking and fitting of the SPEC §6 model extensions, and their held-out gain.
//!
//! # Method
//!
//! 1. **Noise** ([`noise`]): on the unloaded run, fit the dynamometer's systematic part
//!    `c + Σ_e e^{−(t−e)/τ}(B sin 2πf(t−e) + C cos 2πf(t−e))` (offset + event transients) and
//!    an AR(1)+white random part; subtract the systematic part (at the trial's own events)
//!    from the measured torque. Whitening by the Kalman innovations `ν_t/√S_t` makes the
//!    least squares exact generalised least squares, with
//!    `log L = −½ Σ (ln 2π S_t + ν_t²/S_t)`.
//! 2. **Baseline** ([`lm`]): bounded Levenberg–Marquardt on the 9 muscle parameters from
//!    nominal and from Latin-hypercube starts (the lowest whitened cost wins), whitened
//!    residual, finite-difference Jacobian.
//! 3. **Ranking** ([`score`]): for every eligible extension, the score test
//!    `LM = rᵀP⊥S(SᵀP⊥S)⁻¹SᵀP⊥r/s²` from its sensitivity `S` at the null value;
//!    evidence `LM − p ln n`.
//! 4. **Refit** the leaders (muscle + effect parameters) and cross-validate cycle-wise
//!    (each cycle held out in turn: zero weight, states still simulated over the whole trial;
//!    a trial with fewer than three cycles is cut into 0.5 s blocks in 5 folds instead,
//!    [`CvFolds`]).
//!    The held-out error is measured twice: the pooled RMS of the held-out samples, and
//!    the **held-out deviance** `Σ ν_t²/S_t` over them (the fold fit's residual whitened by
//!    the noise model over the whole trial, the likelihood's own weighting).
//!    An extension is **accepted** when its held-out deviance is lower than the current
//!    model's, its held-out RMS is not higher, **and** `ΔBIC = BIC_ext − BIC_base < −10`;
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
//!    motion: cycle × sweep direction × angle bin, hold halves; of time: 1 s blocks) tested
//!    against the final residual by score tests, `LM ~ χ²(df)` under a correct model;
//!    structure is unexplained when the Bonferroni p-value is below 10⁻³.
//! 7. **Uncertainty** ([`profile`]): 68 % profile-likelihood intervals of every parameter of
//!    the final model, `{θ : (min_{others} ‖r‖² − ‖r̂‖²)/s² ≤ 1}` with the others refitted,
//!    cut at the bounds; the uncertainty reported is the half-width. The Gauss–Newton
//!    standard errors `√diag(s²(JᵀJ)⁻¹)` are kept beside them (`laplace_se`) and decide the
//!    confounding test; they were several times too small for the pennation angles and tendon
//!    slack lengths (docs/diagnosis.md).
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

pub mod analysis;
mod error;
pub mod fit;
pub mod lm;
pub mod noise;
pub mod power;
pub mod profile;
mod report;
pub mod scenarios;
pub mod score;
pub mod segment;

use std::collections::BTreeMap;
use std::ops::ControlFlow;
use std::time::Instant;

use experiment::{model_inputs, InputOptions, Trial, Unloaded};
use muscle_model::{EffectKind, Muscle, ParamId};
use numerics::LevenbergMarquardtSettings;
use rayon::prelude::*;

pub use analysis::{AcfPoint, Bin, ResidualAnalysis, Series};
pub use error::DiagnoseError;
pub use noise::{NoiseModelSource, Transient, TrialNoiseModel};
pub use report::{
    detection_limit_unit, CandidateReport, Diagnosis, Gain, ModelReport, NearTie, ParamInterval,
    Verdict,
};
pub use segment::{PhaseLabel, Segmentation};

use fit::{Context, Fit};
use noise::WhitenPlan;
use profile::ProfileInterval;
pub use profile::ProfileSettings;

/// Settings of a diagnosis. `Default` is the documented decision rule (docs/diagnosis.md).
#[derive(Clone, Debug, PartialEq)]
pub struct DiagnoseSettings {
    /// Effects considered (those whose inputs exist: `antagonist_coactivation` needs `emg_ta`).
    pub candidates: Vec<EffectKind>,
    /// Most effects added.
    pub max_effects: usize,
    /// Candidates refitted per round (best evidence first).
    pub refits_per_round: usize,
    /// After the forward rounds, with two or more causes: try replacing each cause by another
    /// effect (drop it, refit, one more forward round) and keep a replacement that lowers the
    /// BIC by more than the ΔBIC margin without raising the held-out error.
    pub exchange: bool,
    /// When no single extension passes in a round, fit the two with the strongest in-sample
    /// evidence jointly and accept both if the pair passes (effects that only generalise
    /// together).
    pub pairs: bool,
    /// Minimum score statistic for a refit.
    pub min_score_lm: f64,
    /// An added effect must lower the held-out deviance ([`CandidateReport::heldout_dev_gain`],
    /// χ² units) by at least this, without raising the held-out RMS.
    pub min_heldout_dev_gain: f64,
    /// Held-out margin of the tie rules (near ties, a simpler model named instead): two
    /// models' held-out RMS differ by less than this share (%) …
    pub min_heldout_gain_pct: f64,
    /// … or less than this (N·m), whichever is larger.
    pub min_heldout_gain_nm: f64,
    /// ΔBIC must be below this.
    pub max_delta_bic: f64,
    /// Cosine above which an extension is confounded with the model's parameters.
    pub confound_cos: f64,
    /// Structure evidence (`−log10` of the structure tests' p-value) above which
    /// `unexplained_structure` is set; 3 = false-alarm rate 10⁻³ per trial on a correct model.
    pub structure_threshold: f64,
    /// How the EMG columns become envelopes.
    pub input_options: InputOptions,
    /// Levenberg–Marquardt settings of the full fits.
    pub lm: LevenbergMarquardtSettings,
    /// Levenberg–Marquardt iterations of a cross-validation refit.
    pub cv_iterations: usize,
    /// How the samples are split into cross-validation folds.
    pub cv_folds: CvFolds,
    /// Starts of the baseline fit besides the nominal parameters: Latin-hypercube points in
    /// the SPEC §8 box (run in parallel; the lowest whitened cost wins). A single start can
    /// stop in a local minimum (e.g. sol F0 at its bound), whose misfit then passes for a
    /// catalogued effect or for unexplained structure.
    pub baseline_extra_starts: usize,
    /// Starts of every extended fit besides the current fit and the nominal muscle
    /// parameters: Latin-hypercube points of the muscle parameters (the effect parameters
    /// start where the score test puts them). Without them a candidate's refit could stay in
    /// a worse local minimum than a competitor's and lose to an effect that is not there.
    pub extended_extra_starts: usize,
    /// Seed of the Latin-hypercube starts.
    pub start_seed: u64,
    /// Profile-likelihood intervals of the final model's parameters (module [`profile`]).
    pub profile: ProfileSettings,
}

/// Cross-validation folds of the held-out error.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum CvFolds {
    /// Every cycle (a concentric sweep and the eccentric sweep after it) is held out in turn;
    /// the holds outside the cycles are never held out.
    Cycles,
    /// The trial is cut into consecutive blocks of `block_s` seconds; block `b` belongs to fold
    /// `b mod folds`, so every fold holds out pieces of every phase.
    Blocks {
        /// Block length (s), much longer than the noise's correlation time (30 ms).
        block_s: f64,
        /// Number of folds (at least 2).
        folds: usize,
    },
    /// [`CvFolds::Cycles`] when the trial has at least [`MIN_CV_CYCLES`] cycles, else
    /// [`CvFolds::Blocks`] of 0.5 s in 5 folds. Holding out the only cycle of a one-cycle trial
    /// (the `seed` protocol, the dissertation's) leaves nothing but holds to fit: the held-out
    /// error then measures extrapolation from rest to a maximal contraction, not the model.
    Auto,
}

/// Fewest cycles for cycle-wise cross-validation under [`CvFolds::Auto`].
pub const MIN_CV_CYCLES: usize = 3;

impl CvFolds {
    /// [`CvFolds::Auto`] resolved for a trial with `cycles` cycles (others unchanged).
    pub fn resolve(&self, cycles: usize) -> CvFolds {
        match *self {
            CvFolds::Auto if cycles >= MIN_CV_CYCLES => CvFolds::Cycles,
            CvFolds::Auto => CvFolds::Blocks {
                block_s: 0.5,
                folds: 5,
            },
            other => other,
        }
    }

    /// A short description, e.g. `3 cycles held out in turn`, `5 folds of 0.5 s blocks`.
    pub fn describe(&self, cycles: usize) -> String {
        match self.resolve(cycles) {
            CvFolds::Blocks { block_s, folds } => format!("{folds} folds of {block_s} s blocks"),
            _ if cycles == 1 => "the cycle held out".into(),
            _ => format!("{cycles} cycles held out in turn"),
        }
    }

    /// The held-out mask of every fold for `n` samples at `fs` Hz, given the cycle of each
    /// sample (`None` outside the cycles).
    pub fn held_out_masks(&self, n: usize, fs: f64, cycle: &[Option<usize>]) -> Vec<Vec<bool>> {
        let cycles = cycle.iter().flatten().max().map_or(0, |m| m + 1);
        match self.resolve(cycles) {
            CvFolds::Auto | CvFolds::Cycles => (0..cycles)
                .map(|k| cycle.iter().map(|c| *c == Some(k)).collect())
                .collect(),
            CvFolds::Blocks { block_s, folds } => {
                let len = ((block_s * fs).round() as usize).max(1);
                (0..folds)
                    .map(|k| (0..n).map(|i| (i / len) % folds == k).collect())
                    .collect()
            }
        }
    }
}

impl Default for DiagnoseSettings {
    fn default() -> Self {
        DiagnoseSettings {
            candidates: EffectKind::ALL.to_vec(),
            max_effects: 3,
            refits_per_round: 3,
            exchange: true,
            pairs: true,
            min_score_lm: 6.0,
            min_heldout_dev_gain: 0.0,
            min_heldout_gain_pct: 2.0,
            min_heldout_gain_nm: 0.02,
            max_delta_bic: -10.0,
            confound_cos: 0.98,
            structure_threshold: 3.0,
            input_options: InputOptions::default(),
            lm: LevenbergMarquardtSettings::default(),
            cv_iterations: 8,
            cv_folds: CvFolds::Auto,
            baseline_extra_starts: 5,
            extended_extra_starts: 4,
            start_seed: 0x5eed_d1a9,
            profile: ProfileSettings::default(),
        }
    }
}

/// DiagnosisStage reported to the observer.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum DiagnosisStage {
    /// Fitting the noise model.
    Noise,
    /// Fitting the baseline.
    Baseline,
    /// Ranking and refitting candidates in a round.
    Round(usize),
    /// Residual analysis.
    Analysis,
}

/// DiagnosisProgress report.
#[derive(Clone, Debug, PartialEq)]
pub struct DiagnosisProgress {
    /// DiagnosisStage.
    pub stage: DiagnosisStage,
    /// Human message.
    pub message: String,
    /// Simulations so far.
    pub evaluations: usize,
}

/// An observer that never stops the diagnosis.
pub fn no_observer(_: &DiagnosisProgress) -> ControlFlow<()> {
    ControlFlow::Continue(())
}

fn notify(
    obs: &mut dyn FnMut(&DiagnosisProgress) -> ControlFlow<()>,
    stage: DiagnosisStage,
    message: String,
    evaluations: usize,
) -> Result<(), DiagnoseError> {
    match obs(&DiagnosisProgress {
        stage,
        message,
        evaluations,
    }) {
        ControlFlow::Continue(()) => Ok(()),
        ControlFlow::Break(()) => Err(DiagnoseError::Cancelled),
    }
}

/// Refit result of one candidate.
struct Refit<'a> {
    kind: EffectKind,
    fit: &'a Fit,
    delta_bic: f64,
    gain_nm: f64,
    gain_pct: f64,
    /// Fall of the held-out deviance (χ² units).
    dev_gain: f64,
}

/// A candidate's fit judged against the current model.
fn judge<'a>(fit: &'a Fit, current: &Fit, nobs: usize) -> Refit<'a> {
    let gain_nm = current.heldout_rms - fit.heldout_rms;
    Refit {
        kind: *fit.kinds.last().expect("an extended fit adds an effect"),
        fit,
        delta_bic: fit.bic(nobs) - current.bic(nobs),
        gain_nm,
        gain_pct: 100.0 * gain_nm / current.heldout_rms,
        dev_gain: current.heldout_dev - fit.heldout_dev,
    }
}

/// Whether a refit generalises: it lowers the held-out deviance by at least
/// [`DiagnoseSettings::min_heldout_dev_gain`] and does not raise the held-out RMS.
fn generalises(r: &Refit, settings: &DiagnoseSettings) -> bool {
    r.dev_gain >= settings.min_heldout_dev_gain && r.gain_nm >= 0.0
}

/// Diagnoses a measured trial (and its unloaded run when available).
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
    let t0 = Instant::now();
    check_settings(settings)?;
    let (inputs, seg) = prepare(trial, settings)?;
    let n = inputs.len();
    let fs = inputs.fs();
    notify(
        observer,
        DiagnosisStage::Noise,
        "fitting the noise model".into(),
        0,
    )?;
    let times: Vec<f64> = (0..n).map(|i| i as f64 / fs).collect();
    let nominal = nominal_muscles();
    let mut evaluations = 0;
    let lm = settings.lm;
    let cv_lm = LevenbergMarquardtSettings {
        max_iterations: settings.cv_iterations,
        ..settings.lm
    };
    let make_ctx = |y: Vec<f64>, noise: TrialNoiseModel| -> Context {
        let plan = noise.plan(n, None);
        let folds = settings
            .cv_folds
            .held_out_masks(n, fs, &seg.cycle)
            .into_iter()
            .map(|held| {
                let train: Vec<bool> = held.iter().map(|h| !h).collect();
                let p: WhitenPlan = noise.plan(n, Some(&train));
                (held, p)
            })
            .collect();
        Context {
            inputs: inputs.clone(),
            y,
            noise,
            seg: seg.clone(),
            plan,
            folds,
            lm,
            cv_lm,
            extended_extra_starts: settings.extended_extra_starts,
            start_seed: settings.start_seed,
        }
    };
    let (noise, y) = match unloaded {
        Some(u) => {
            let fu = u.sample_rate_hz();
            if (fu - fs).abs() > 1e-6 * fs || fu.is_nan() {
                return Err(DiagnoseError::Unloaded {
                    reason: format!("sampled at {fu} Hz but the trial at {fs} Hz"),
                });
            }
            let correction = experiment::DynamometerCorrection::from_unloaded(u).map_err(|e| {
                DiagnoseError::Unloaded {
                    reason: e.to_string(),
                }
            })?;
            let noise = TrialNoiseModel::from_correction(
                &correction,
                NoiseModelSource::Unloaded,
                u.torque_nm.len(),
            );
            let sys = noise.systematic(&times, &seg.events);
            let y: Vec<f64> = trial
                .torque_nm
                .iter()
                .zip(&sys)
                .map(|(a, b)| a - b)
                .collect();
            (noise, y)
        }
        None => {
            // preliminary white-noise baseline, then the noise model from its residual
            let pre_noise = TrialNoiseModel {
                source: NoiseModelSource::TrialResidual,
                offset_nm: 0.0,
                transient: noise::Transient::none(),
                phi: 0.0,
                sd_ar_nm: 0.0,
                sd_white_nm: 1.0,
                remainder_rms_nm: 0.0,
                level_dof: f64::INFINITY,
            };
            let ctx0 = make_ctx(trial.torque_nm.clone(), pre_noise);
            let f0 = ctx0.fit(&[], &nominal, false)?;
            evaluations += f0.evaluations;
            let res: Vec<f64> = trial
                .torque_nm
                .iter()
                .zip(&f0.pred)
                .map(|(a, b)| a - b)
                .collect();
            let correction = experiment::DynamometerCorrection::fit(&res, fs, &seg.events, false)?;
            let mut noise = TrialNoiseModel::from_correction(
                &correction,
                NoiseModelSource::TrialResidual,
                res.len(),
            );
            noise.offset_nm = 0.0;
            let sys = noise.systematic(&times, &seg.events);
            let y: Vec<f64> = trial
                .torque_nm
                .iter()
                .zip(&sys)
                .map(|(a, b)| a - b)
                .collect();
            (noise, y)
        }
    };
    let ctx = make_ctx(y, noise);
    notify(
        observer,
        DiagnosisStage::Baseline,
        "fitting the baseline (9 muscle parameters)".into(),
        evaluations,
    )?;
    let mut starts = vec![nominal.to_vec()];
    let box9: Vec<(f64, f64)> = ctx.problem(&[])?.bounds().to_vec();
    starts.extend(fit::latin_hypercube(
        &box9,
        settings.baseline_extra_starts,
        settings.start_seed,
    ));
    let mut baseline = ctx.fit_from(&[], &starts, true)?;
    evaluations += baseline.evaluations;
    let nobs = ctx.plan.n_obs();
    let eligible: Vec<EffectKind> = settings
        .candidates
        .iter()
        .copied()
        .filter(|k| *k != EffectKind::AntagonistCoactivation || inputs.envelope_ta().is_some())
        .collect();

    let mut current = baseline.clone();
    let mut reports: BTreeMap<EffectKind, CandidateReport> = BTreeMap::new();
    let mut confounded: Vec<String> = Vec::new();
    // near ties of each cause, from the round that named it (replaced by the exchange pass's)
    let mut ties: BTreeMap<EffectKind, Vec<NearTie>> = BTreeMap::new();
    for round in 0..settings.max_effects {
        notify(
            observer,
            DiagnosisStage::Round(round),
            format!("round {}: ranking extensions", round + 1),
            evaluations,
        )?;
        let mut scores = score::score_all(&ctx, &current, &eligible);
        evaluations += 4 * scores.len();
        scores.sort_by(|a, b| b.evidence.total_cmp(&a.evidence));
        for s in &scores {
            // nearly collinear with the model's parameters and still asked for by the
            // residual: refitted like the others; reported as confounded unless accepted
            let conf = s.cos_baseline > settings.confound_cos && s.lm >= settings.min_score_lm;
            reports.insert(
                s.kind,
                CandidateReport {
                    effect: s.kind.name().into(),
                    evidence: s.evidence,
                    score_lm: s.lm,
                    heldout_rms_nm: None,
                    delta_bic: None,
                    heldout_gain_pct: None,
                    heldout_dev_gain: None,
                    cos_to_model: s.cos_baseline,
                    round,
                    accepted: false,
                    confounded: conf,
                    fitted: None,
                    detection_limit: None,
                },
            );
        }
        let leaders: Vec<&score::Score> = scores
            .iter()
            .filter(|s| s.lm >= settings.min_score_lm)
            .take(settings.refits_per_round)
            .collect();
        if leaders.is_empty() {
            break;
        }
        let refits: Vec<Result<Fit, DiagnoseError>> = leaders
            .par_iter()
            .map(|s| {
                let mut kinds = current.kinds.clone();
                kinds.push(s.kind);
                ctx.fit(&kinds, &score::extended_start(&current, s), true)
            })
            .collect();
        let mut fits: Vec<Fit> = Vec::new();
        for r in refits {
            match r {
                Ok(f) => {
                    evaluations += f.evaluations;
                    fits.push(f);
                }
                Err(DiagnoseError::Fit { .. }) | Err(DiagnoseError::Model(_)) => {}
                Err(e) => return Err(e),
            }
        }
        // Judge the candidates against the current fit. Before one is accepted, the current
        // model is refitted from the leader's values of its own parameters: when that beats
        // the current fit, part of the leader's gain was a better optimum of parameters the
        // current model already has (e.g. a delay of 3 ms on a no-effect trial), so the
        // current fit is replaced and the candidates are judged again.
        let mut rechecked = false;
        let best = loop {
            let judged: Vec<Refit> = fits.iter().map(|f| judge(f, &current, nobs)).collect();
            let mut passing: Vec<&Refit> = Vec::new();
            for r in &judged {
                if let Some(rep) = reports.get_mut(&r.kind) {
                    rep.heldout_rms_nm = Some(r.fit.heldout_rms);
                    rep.delta_bic = Some(r.delta_bic);
                    rep.heldout_gain_pct = Some(r.gain_pct);
                    rep.heldout_dev_gain = Some(r.dev_gain);
                    rep.fitted = Some(effect_values(r.fit, r.kind));
                }
                let clear = clear_of_null(r.fit, r.kind, &reports, settings, nobs);
                if generalises(r, settings) && r.delta_bic < settings.max_delta_bic && clear {
                    passing.push(r);
                }
            }
            passing.sort_by(|a, b| a.delta_bic.total_cmp(&b.delta_bic));
            // Parsimony: a passing candidate with fewer parameters that the data cannot tell
            // from the best one leads instead (the fewest parameters, then the lowest BIC).
            if let Some(first) = passing.first().copied() {
                if let Some(i) = (1..passing.len())
                    .filter(|&i| simpler_tie(passing[i].fit, first.fit, settings, nobs))
                    .min_by_key(|&i| (passing[i].fit.k(), i))
                {
                    let r = passing.remove(i);
                    passing.insert(0, r);
                }
            }
            let Some(lead) = passing.first() else {
                break None;
            };
            let lead_ties = |lead: &Refit| -> Vec<NearTie> {
                passing[1..]
                    .iter()
                    .filter_map(|r| near_tie(lead.kind, lead.fit, r.kind, r.fit, settings, nobs))
                    .collect()
            };
            if rechecked {
                ties.insert(lead.kind, lead_ties(lead));
                break Some(lead.kind);
            }
            rechecked = true;
            let x0: Vec<f64> = current
                .free
                .iter()
                .map(|id| {
                    let i = lead.fit.free.iter().position(|f| f == id);
                    i.map_or(0.0, |i| lead.fit.x[i])
                })
                .collect();
            let alt = ctx.fit_from(&current.kinds, &[x0], true)?;
            evaluations += alt.evaluations;
            if alt.white_ss < current.white_ss {
                if current.kinds.is_empty() {
                    baseline = alt.clone();
                }
                current = alt;
                continue;
            }
            ties.insert(lead.kind, lead_ties(lead));
            break Some(lead.kind);
        };
        let Some(best_kind) = best else {
            // No single extension generalises, but two may only together: each alone leaves
            // the other's error in the held-out cycles (a delay with fatigue). The two with the
            // strongest in-sample evidence are fitted jointly and both accepted when the pair
            // passes against the current model and each of its halves.
            if settings.pairs && current.kinds.len() + 2 <= settings.max_effects {
                let (pair, ev) = joint_pair(&ctx, &current, &fits, settings, nobs, &reports)?;
                evaluations += ev;
                if let Some(pair) = pair {
                    for k in &pair.kinds[current.kinds.len()..] {
                        if let Some(rep) = reports.get_mut(k) {
                            rep.accepted = true;
                        }
                    }
                    current = pair;
                    continue;
                }
            }
            break;
        };
        let Some(best) = fits
            .into_iter()
            .find(|f| f.kinds.last() == Some(&best_kind))
        else {
            break;
        };
        if let Some(rep) = reports.get_mut(&best_kind) {
            rep.accepted = true;
        }
        current = best;
    }
    if settings.exchange && current.kinds.len() >= 2 {
        notify(
            observer,
            DiagnosisStage::Round(settings.max_effects),
            "checking each cause against the alternatives".into(),
            evaluations,
        )?;
        let (fit, ev) = exchange(
            &ctx,
            current,
            &eligible,
            settings,
            nobs,
            &mut reports,
            &mut ties,
        )?;
        evaluations += ev;
        current = fit;
    }
    for rep in reports.values_mut() {
        if rep.confounded && !rep.accepted && !confounded.contains(&rep.effect) {
            confounded.push(rep.effect.clone());
        }
        if rep.accepted {
            rep.confounded = false;
        }
    }
    notify(
        observer,
        DiagnosisStage::Analysis,
        "residual analysis".into(),
        evaluations,
    )?;
    notify(
        observer,
        DiagnosisStage::Analysis,
        "detection limits of the effects not named".into(),
        evaluations,
    )?;
    let limits = score::detection_limits(&ctx, &current, &eligible, settings.max_delta_bic);
    for (kind, limit, ev) in limits {
        evaluations += ev;
        if let Some(rep) = reports.get_mut(&kind) {
            rep.detection_limit = Some(limit);
        }
    }
    let ra = analysis::analyse(&ctx, &baseline, &current, settings.structure_threshold);
    let unexplained = ra.structure_evidence > settings.structure_threshold;
    let causes: Vec<String> = current.kinds.iter().map(|k| k.name().to_string()).collect();
    let verdict = if causes.is_empty() && !unexplained {
        Verdict::Adequate
    } else {
        Verdict::Deficient
    };
    let near_ties: Vec<NearTie> = current
        .kinds
        .iter()
        .filter_map(|k| ties.remove(k))
        .flatten()
        .filter(|t| !causes.contains(&t.alternative))
        .collect();
    let mut candidates: Vec<CandidateReport> = reports.into_values().collect();
    candidates.sort_by(|a, b| {
        b.accepted
            .cmp(&a.accepted)
            .then(b.evidence.total_cmp(&a.evidence))
    });
    notify(
        observer,
        DiagnosisStage::Analysis,
        "profile-likelihood intervals".into(),
        evaluations,
    )?;
    let intervals = profile_intervals(&ctx, &current, nobs, &settings.profile)?;
    evaluations += intervals
        .iter()
        .map(|(_, iv)| iv.evaluations)
        .sum::<usize>();
    // the baseline's own intervals only when it is the final model
    let base_intervals: &[(usize, ProfileInterval)] = if current.kinds.is_empty() {
        &intervals
    } else {
        &[]
    };
    let base_rep = model_report(&baseline, nobs, false, base_intervals);
    let ext_rep = model_report(&current, nobs, true, &intervals);
    let gain = Gain {
        heldout_rms_reduction_pct: 100.0 * (1.0 - current.heldout_rms / baseline.heldout_rms),
        heldout_deviance_reduction: baseline.heldout_dev - current.heldout_dev,
        delta_bic: current.bic(nobs) - baseline.bic(nobs),
        delta_log_likelihood: current.loglik - baseline.loglik,
        rms_reduction_pct: 100.0 * (1.0 - current.rms / baseline.rms),
    };
    Ok(Diagnosis {
        verdict,
        causes,
        unexplained_structure: unexplained,
        baseline: base_rep,
        extended: ext_rep,
        gain,
        candidates,
        confounded,
        near_ties,
        noise: ctx.noise,
        cv_folds: settings.cv_folds.describe(ctx.seg.cycles.len()),
        residual_analysis: ra,
        evaluations,
        wall_s: t0.elapsed().as_secs_f64(),
    })
}

/// The model inputs of `trial` and the segmentation of its motion (the mean envelope marks
/// the relaxed cycle).
fn prepare(
    trial: &Trial,
    settings: &DiagnoseSettings,
) -> Result<(muscle_model::TrialInputs, Segmentation), DiagnoseError> {
    let inputs = model_inputs(trial, &settings.input_options)?;
    let act: Vec<f64> = (0..inputs.len())
        .map(|i| {
            Muscle::ALL
                .iter()
                .map(|m| inputs.envelope(*m)[i])
                .sum::<f64>()
                / 3.0
        })
        .collect();
    let seg = Segmentation::new(inputs.angle(), inputs.fs(), Some(&act)).map_err(|reason| {
        DiagnoseError::Segmentation {
            recording: "trial",
            reason,
        }
    })?;
    Ok((inputs, seg))
}

/// The nominal values of the 9 identified muscle parameters (the baseline's first start).
fn nominal_muscles() -> [f64; 9] {
    ParamId::identified().map(|p| {
        p.get(
            &muscle_model::ModelParams::nominal(),
            &muscle_model::Effects::none(),
        )
    })
}

/// `alt` (the model with `alternative` instead of `cause`) as a near tie of `cause` in `named`
/// (the model that names it): their BICs differ by
/// less than the ΔBIC margin, `alt` has no more parameters or a lower BIC, and `alt`'s held-out
/// RMS is not higher by the held-out margin ([`DiagnoseSettings::min_heldout_gain_pct`],
/// [`DiagnoseSettings::min_heldout_gain_nm`]).
fn near_tie(
    cause: EffectKind,
    named: &Fit,
    alternative: EffectKind,
    alt: &Fit,
    settings: &DiagnoseSettings,
    nobs: usize,
) -> Option<NearTie> {
    let d = alt.bic(nobs) - named.bic(nobs);
    let worse = alt.heldout_rms - named.heldout_rms;
    // a more complex alternative that is also worse only pays its extra parameters (a
    // gravity term at φ ≈ ±90° contains an offset): not an ambiguity
    let tie = d.abs() < -settings.max_delta_bic
        && (alt.k() <= named.k() || d < 0.0)
        && worse < heldout_margin(settings, named.heldout_rms);
    (tie && alternative != cause).then(|| NearTie {
        cause: cause.name().into(),
        alternative: alternative.name().into(),
        delta_bic: d,
        heldout_rms_nm: alt.heldout_rms,
    })
}

/// Whether effect `kind` of `fit` may be accepted as far as collinearity goes: an extension
/// nearly collinear with the model's parameters (cosine above
/// [`DiagnoseSettings::confound_cos`]) must also be estimated ≥ 3 standard errors from its
/// null.
fn clear_of_null(
    fit: &Fit,
    kind: EffectKind,
    reports: &BTreeMap<EffectKind, CandidateReport>,
    settings: &DiagnoseSettings,
    nobs: usize,
) -> bool {
    let collinear = reports
        .get(&kind)
        .is_some_and(|rep| rep.cos_to_model > settings.confound_cos);
    !collinear || effect_significance(fit, kind, nobs) >= 3.0
}

/// The held-out margin of the tie rules for a model with held-out RMS `heldout` (N·m):
/// max(2 %, 0.02 N·m) by default.
fn heldout_margin(settings: &DiagnoseSettings, heldout: f64) -> f64 {
    (settings.min_heldout_gain_pct / 100.0 * heldout).max(settings.min_heldout_gain_nm)
}

/// The joint fit of the two refits of a round with the lowest ΔBIC below the margin (when no
/// single one passed): returned when it passes the held-out and ΔBIC rules against `current`
/// and its BIC also beats each single refit by the margin (both halves are needed), with the
/// simulations spent.
fn joint_pair(
    ctx: &Context,
    current: &Fit,
    fits: &[Fit],
    settings: &DiagnoseSettings,
    nobs: usize,
    reports: &BTreeMap<EffectKind, CandidateReport>,
) -> Result<(Option<Fit>, usize), DiagnoseError> {
    let mut strong: Vec<&Fit> = fits
        .iter()
        .filter(|f| f.bic(nobs) - current.bic(nobs) < settings.max_delta_bic)
        .collect();
    strong.sort_by(|a, b| a.bic(nobs).total_cmp(&b.bic(nobs)));
    let [a, b] = match strong.as_slice() {
        [a, b, ..] => [*a, *b],
        _ => return Ok((None, 0)),
    };
    let (ka, kb) = (
        *a.kinds.last().expect("a refit adds an effect"),
        *b.kinds.last().expect("a refit adds an effect"),
    );
    let mut kinds = current.kinds.clone();
    kinds.extend([ka, kb]);
    let mut x0 = current.x.clone();
    for (f, k) in [(a, ka), (b, kb)] {
        x0.extend(
            f.free
                .iter()
                .zip(&f.x)
                .filter(|(id, _)| matches!(id, ParamId::Effect(e, _) if *e == k))
                .map(|(_, v)| *v),
        );
    }
    let pair = match ctx.fit(&kinds, &x0, true) {
        Ok(f) => f,
        Err(DiagnoseError::Fit { .. }) | Err(DiagnoseError::Model(_)) => return Ok((None, 0)),
        Err(e) => return Err(e),
    };
    let ev = pair.evaluations;
    let r = judge(&pair, current, nobs);
    let halves = [a, b]
        .iter()
        .all(|f| pair.bic(nobs) - f.bic(nobs) < settings.max_delta_bic);
    let clear = [ka, kb]
        .iter()
        .all(|k| clear_of_null(&pair, *k, reports, settings, nobs));
    let passes =
        generalises(&r, settings) && r.delta_bic < settings.max_delta_bic && halves && clear;
    Ok((passes.then_some(pair), ev))
}

/// The exchange pass over a model with two or more effects (forward selection is greedy: an
/// effect accepted early can stand in for two that come later, e.g. a gravity term fitted to
/// an offset while a fatigue drift was still missing, and is then kept).
///
/// Each cause of the forward rounds in turn is dropped, the rest refitted, and one forward
/// round run on that model (scores, then refits of the leaders other than the dropped cause).
/// The best refit replaces the model when its held-out error is not higher and its BIC is
/// lower by more than the ΔBIC margin ([`DiagnoseSettings::max_delta_bic`]), or lower at all
/// when it has fewer parameters (an offset for a two-parameter gravity term). The other
/// refits within the margin are recorded in `ties` as near ties of the cause. Returns the
/// final model and the simulations spent.
fn exchange(
    ctx: &Context,
    mut current: Fit,
    eligible: &[EffectKind],
    settings: &DiagnoseSettings,
    nobs: usize,
    reports: &mut BTreeMap<EffectKind, CandidateReport>,
    ties: &mut BTreeMap<EffectKind, Vec<NearTie>>,
) -> Result<(Fit, usize), DiagnoseError> {
    let mut evaluations = 0;
    for dropped in current.kinds.clone() {
        let rest: Vec<EffectKind> = current
            .kinds
            .iter()
            .copied()
            .filter(|k| *k != dropped)
            .collect();
        let x0: Vec<f64> = current
            .free
            .iter()
            .zip(&current.x)
            .filter(|(id, _)| !matches!(id, ParamId::Effect(k, _) if *k == dropped))
            .map(|(_, v)| *v)
            .collect();
        let reduced = ctx.fit(&rest, &x0, false)?;
        evaluations += reduced.evaluations;
        let mut scores: Vec<score::Score> = score::score_all(ctx, &reduced, eligible)
            .into_iter()
            .filter(|s| s.kind != dropped && !rest.contains(&s.kind))
            .collect();
        evaluations += 4 * scores.len();
        scores.sort_by(|a, b| b.evidence.total_cmp(&a.evidence));
        let leaders: Vec<&score::Score> = scores
            .iter()
            .filter(|s| s.lm >= settings.min_score_lm)
            .take(settings.refits_per_round)
            .collect();
        let refits: Vec<Result<Fit, DiagnoseError>> = leaders
            .par_iter()
            .map(|s| {
                let mut kinds = rest.clone();
                kinds.push(s.kind);
                ctx.fit(&kinds, &score::extended_start(&reduced, s), true)
            })
            .collect();
        let mut alts: Vec<(Fit, &score::Score)> = Vec::new();
        for (r, s) in refits.into_iter().zip(&leaders) {
            match r {
                Ok(f) => {
                    evaluations += f.evaluations;
                    alts.push((f, s));
                }
                Err(DiagnoseError::Fit { .. }) | Err(DiagnoseError::Model(_)) => {}
                Err(e) => return Err(e),
            }
        }
        // by the same margin as an added effect, or as a simpler model the data cannot tell
        // from the current one (an offset for a gravity term); other alternatives within the
        // margins are near ties
        let mut best: Option<usize> = None;
        for (i, (f, _)) in alts.iter().enumerate() {
            if replaces(f, &current, settings, nobs)
                && best.is_none_or(|b| f.bic(nobs) < alts[b].0.bic(nobs))
            {
                best = Some(i);
            }
        }
        let Some(best) = best else {
            let found = alts
                .iter()
                .filter_map(|(f, s)| near_tie(dropped, &current, s.kind, f, settings, nobs))
                .collect();
            ties.insert(dropped, found);
            continue;
        };
        let (fit, s) = alts.swap_remove(best);
        ties.remove(&dropped);
        // the replaced model is a near tie of the new one when it is within the margin
        let found = std::iter::once((&current, dropped))
            .chain(alts.iter().map(|(f, a)| (f, a.kind)))
            .filter_map(|(f, k)| near_tie(s.kind, &fit, k, f, settings, nobs))
            .collect();
        ties.insert(s.kind, found);
        if let Some(rep) = reports.get_mut(&dropped) {
            rep.accepted = false;
        }
        if let Some(rep) = reports.get_mut(&s.kind) {
            rep.accepted = true;
            rep.evidence = s.evidence;
            rep.score_lm = s.lm;
            rep.heldout_rms_nm = Some(fit.heldout_rms);
            rep.delta_bic = Some(fit.bic(nobs) - reduced.bic(nobs));
            // the dropped-cause model was not cross-validated
            rep.heldout_gain_pct = None;
            rep.heldout_dev_gain = None;
            rep.fitted = Some(effect_values(&fit, s.kind));
        }
        current = fit;
    }
    Ok((current, evaluations))
}

/// Whether the exchange pass's refit `alt` replaces `current`: its held-out RMS is not higher
/// and its BIC is lower by more than the ΔBIC margin, or it has fewer parameters and the data
/// cannot tell the two apart ([`simpler_tie`]).
fn replaces(alt: &Fit, current: &Fit, settings: &DiagnoseSettings, nobs: usize) -> bool {
    let d = alt.bic(nobs) - current.bic(nobs);
    (d < settings.max_delta_bic && alt.heldout_rms <= current.heldout_rms)
        || simpler_tie(alt, current, settings, nobs)
}

/// Whether `simple`, with fewer parameters than `complex`, cannot be told from it: a BIC
/// higher by less than the margin (or lower) and a held-out RMS not higher by the held-out
/// margin (max(2 %, 0.02 N·m) of `complex`'s). The simpler model is then named, in a round of
/// the forward selection as in the exchange pass, and the other is reported as a near tie.
fn simpler_tie(simple: &Fit, complex: &Fit, settings: &DiagnoseSettings, nobs: usize) -> bool {
    let d = simple.bic(nobs) - complex.bic(nobs);
    let worse = simple.heldout_rms - complex.heldout_rms;
    simple.k() < complex.k()
        && d < -settings.max_delta_bic
        && worse < heldout_margin(settings, complex.heldout_rms)
}

fn check_settings(s: &DiagnoseSettings) -> Result<(), DiagnoseError> {
    let bad = |name: &'static str, reason: &str| {
        Err(DiagnoseError::Settings {
            name,
            reason: reason.into(),
        })
    };
    if s.refits_per_round == 0 {
        return bad("refits_per_round", "must be at least 1");
    }
    if !(s.min_heldout_gain_pct.is_finite() && s.min_heldout_gain_pct >= 0.0) {
        return bad("min_heldout_gain_pct", "must be finite and ≥ 0");
    }
    if !(s.min_heldout_gain_nm.is_finite() && s.min_heldout_gain_nm >= 0.0) {
        return bad("min_heldout_gain_nm", "must be finite and ≥ 0");
    }
    if !s.max_delta_bic.is_finite() {
        return bad("max_delta_bic", "must be finite");
    }
    if !s.min_heldout_dev_gain.is_finite() {
        return bad("min_heldout_dev_gain", "must be finite");
    }
    if !(s.confound_cos > 0.0 && s.confound_cos <= 1.0) {
        return bad("confound_cos", "must be in (0, 1]");
    }
    if let CvFolds::Blocks { block_s, folds } = s.cv_folds {
        if !(block_s.is_finite() && block_s > 0.0) || folds < 2 {
            return bad(
                "cv_folds",
                "blocks need a finite block length > 0 and at least 2 folds",
            );
        }
    }
    let p = &s.profile;
    if !(p.level.is_finite() && p.level > 0.0 && p.tol > 0.0 && p.ftol_rel >= 0.0)
        || p.max_refits == 0
        || p.lm_iterations == 0
    {
        return bad(
            "profile",
            "level and tol > 0, ftol_rel ≥ 0, max_refits and lm_iterations ≥ 1",
        );
    }
    if s.lm.max_iterations == 0 || !(s.lm.fd_step > 0.0 && s.lm.fd_step < 0.5) {
        return bad("lm", "max_iterations ≥ 1 and 0 < fd_step < 0.5");
    }
    Ok(())
}

fn effect_values(fit: &Fit, kind: EffectKind) -> BTreeMap<String, f64> {
    let mut m = BTreeMap::new();
    for (id, v) in fit.free.iter().zip(&fit.x) {
        if let ParamId::Effect(k, i) = id {
            if *k == kind {
                m.insert(kind.params()[*i].name.to_string(), *v);
            }
        }
    }
    m
}

/// Largest `|θ − null|/SE` over the effect's parameters in a fit.
fn effect_significance(fit: &Fit, kind: EffectKind, nobs: usize) -> f64 {
    let se = standard_errors(fit, nobs);
    let null = kind.null_values();
    fit.free
        .iter()
        .zip(&fit.x)
        .zip(&se)
        .filter_map(|((id, v), s)| match id {
            ParamId::Effect(k, i) if *k == kind && *s > 0.0 => Some((v - null[*i]).abs() / s),
            _ => None,
        })
        .fold(0.0, f64::max)
}

/// Scale of the whitened residual, `s² = max(1, ‖r‖²/(n − p))` (1 when the noise model is right).
fn residual_scale(fit: &Fit, nobs: usize) -> f64 {
    (fit.white_ss / (nobs - fit.k()).max(1) as f64).max(1.0)
}

/// The 68 % profile-likelihood interval of every parameter of `fit` (index into `fit.x`,
/// interval), computed in parallel; the first step out is the Laplace standard error.
///
/// The Laplace standard errors `√diag(s²(JᵀJ)⁻¹)` of the pennation angles and tendon slack
/// lengths are far too small: the cost is flat along curved valleys in which the muscles
/// trade off against each other, and the forward-difference Jacobian sees only the local
/// curvature. On `diag_one 20240609 '{"antagonist_coactivation":{"gain_nm":9.32}}' --ta` sol
/// α0 had a Laplace SE of 0.16° against an MCMC posterior SD of 1.74° and a profile half-width
/// of 1.82° (docs/diagnosis.md).
fn profile_intervals(
    ctx: &Context,
    fit: &Fit,
    nobs: usize,
    settings: &ProfileSettings,
) -> Result<Vec<(usize, ProfileInterval)>, DiagnoseError> {
    ctx.profiles(
        fit,
        residual_scale(fit, nobs),
        &standard_errors(fit, nobs),
        settings,
    )
}

fn standard_errors(fit: &Fit, nobs: usize) -> Vec<f64> {
    let jtj = fit.jac.tr_mul(&fit.jac);
    let p = fit.k();
    let s2 = residual_scale(fit, nobs);
    match jtj.clone().try_inverse() {
        Some(inv) => (0..p).map(|i| (s2 * inv[(i, i)]).max(0.0).sqrt()).collect(),
        None => {
            let svd = jtj.svd(true, true);
            match svd.pseudo_inverse(1e-12) {
                Ok(inv) => (0..p).map(|i| (s2 * inv[(i, i)]).max(0.0).sqrt()).collect(),
                Err(_) => vec![f64::NAN; p],
            }
        }
    }
}

/// Reports a gravity term with its phase in `[−90°, 90°)`: `m·sin(q − φ)` equals
/// `(−m)·sin(q − φ ∓ 180°)`, and the fit lands on either form; the one whose phase is nearest
/// zero reads as "a weight of moment `m` at angle `φ`" (the moment's interval is negated and
/// its ends swapped, the phase's shifted by the half turn).
fn canonical_gravity(
    effects: &mut BTreeMap<String, BTreeMap<String, f64>>,
    intervals: &mut BTreeMap<String, BTreeMap<String, ParamInterval>>,
) {
    let name = EffectKind::Gravity.name();
    let Some(g) = effects.get_mut(name) else {
        return;
    };
    let (Some(&m), Some(&phi)) = (g.get("moment_nm"), g.get("phase_deg")) else {
        return;
    };
    let shift = if phi >= 90.0 {
        -180.0
    } else if phi < -90.0 {
        180.0
    } else {
        return;
    };
    g.insert("moment_nm".into(), -m);
    g.insert("phase_deg".into(), phi + shift);
    if let Some(iv) = intervals.get_mut(name) {
        if let Some(m) = iv.get_mut("moment_nm") {
            *m = ParamInterval {
                lower: -m.upper,
                upper: -m.lower,
                lower_at_bound: m.upper_at_bound,
                upper_at_bound: m.lower_at_bound,
                laplace_se: m.laplace_se,
            };
        }
        if let Some(p) = iv.get_mut("phase_deg") {
            p.lower += shift;
            p.upper += shift;
        }
    }
}

/// The report of `fit`; a parameter with a profile interval in `intervals` gets its
/// half-width as uncertainty (else the Laplace standard error).
fn model_report(
    fit: &Fit,
    nobs: usize,
    extended: bool,
    intervals: &[(usize, ProfileInterval)],
) -> ModelReport {
    let se = standard_errors(fit, nobs);
    let mut params = BTreeMap::new();
    let mut punc = BTreeMap::new();
    let mut effects: BTreeMap<String, BTreeMap<String, f64>> = BTreeMap::new();
    let mut eunc: BTreeMap<String, BTreeMap<String, f64>> = BTreeMap::new();
    let mut eint: BTreeMap<String, BTreeMap<String, ParamInterval>> = BTreeMap::new();
    let mut pint: BTreeMap<String, ParamInterval> = BTreeMap::new();
    let interval = |j: usize| intervals.iter().find(|(ix, _)| *ix == j).map(|(_, iv)| iv);
    for (j, ((id, v), s)) in fit.free.iter().zip(&fit.x).zip(&se).enumerate() {
        match id {
            ParamId::Effect(k, i) => {
                let pn = k.params()[*i].name.to_string();
                effects
                    .entry(k.name().into())
                    .or_default()
                    .insert(pn.clone(), *v);
                let iv = interval(j);
                let unc = iv.map_or(*s, |iv| iv.half_width());
                eunc.entry(k.name().into())
                    .or_default()
                    .insert(pn.clone(), unc);
                if let Some(iv) = iv {
                    eint.entry(k.name().into())
                        .or_default()
                        .insert(pn, ParamInterval::new(iv, *s));
                }
            }
            _ => {
                params.insert(id.name(), *v);
                let iv = interval(j);
                punc.insert(id.name(), iv.map_or(*s, |iv| iv.half_width()));
                if let Some(iv) = iv {
                    pint.insert(id.name(), ParamInterval::new(iv, *s));
                }
            }
        }
    }
    canonical_gravity(&mut effects, &mut eint);
    ModelReport {
        effects: extended.then_some(effects),
        params,
        rms_nm: fit.rms,
        heldout_rms_nm: fit.heldout_rms,
        log_likelihood: fit.loglik,
        bic: fit.bic(nobs),
        n_params: fit.k(),
        effect_uncertainty: extended.then_some(eunc),
        effect_interval: extended.then_some(eint),
        param_interval: (!intervals.is_empty()).then_some(pint),
        param_uncertainty: punc,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn iv(lower: f64, upper: f64, lower_at_bound: bool) -> ParamInterval {
        ParamInterval {
            lower,
            upper,
            lower_at_bound,
            upper_at_bound: false,
            laplace_se: 0.5,
        }
    }

    /// A fit with `k` free parameters, the last effect `kind`, BIC `bic` at `NOBS`
    /// observations and held-out RMS `heldout`.
    fn fit(kind: EffectKind, k: usize, bic: f64, heldout: f64) -> Fit {
        let penalty = k as f64 * (NOBS as f64).ln();
        Fit {
            kinds: vec![kind],
            free: Vec::new(),
            x: vec![0.0; k],
            pred: Vec::new(),
            white: Vec::new(),
            white_ss: 0.0,
            loglik: (penalty - bic) / 2.0,
            rms: 1.0,
            jac: nalgebra::DMatrix::zeros(0, 0),
            heldout_rms: heldout,
            heldout_dev: f64::NAN,
            evaluations: 0,
        }
    }
    const NOBS: usize = 6827;

    #[test]
    fn a_refit_generalises_when_the_heldout_deviance_falls_and_the_rms_does_not_rise() {
        let s = DiagnoseSettings::default();
        let mut base = fit(EffectKind::Inertia, 9, 0.0, 1.40);
        base.heldout_dev = 15_000.0;
        let mut ext = fit(EffectKind::Inertia, 10, -20.0, 1.40);
        ext.heldout_dev = 14_980.0;
        // the same RMS (an inertia term lives in 50 ms ramps) and 20 units of deviance
        assert!(generalises(&judge(&ext, &base, NOBS), &s));
        ext.heldout_dev = 15_000.5;
        assert!(!generalises(&judge(&ext, &base, NOBS), &s));
        ext.heldout_dev = 14_980.0;
        ext.heldout_rms = 1.401;
        assert!(!generalises(&judge(&ext, &base, NOBS), &s));
        ext.heldout_rms = 1.39;
        let strict = DiagnoseSettings {
            min_heldout_dev_gain: 25.0,
            ..s
        };
        assert!(!generalises(&judge(&ext, &base, NOBS), &strict));
        assert!(check_settings(&DiagnoseSettings {
            min_heldout_dev_gain: f64::NAN,
            ..DiagnoseSettings::default()
        })
        .is_err());
    }

    #[test]
    fn near_ties_lie_within_both_margins() {
        let s = DiagnoseSettings::default();
        let (off, grav) = (EffectKind::TorqueOffset, EffectKind::Gravity);
        // gravity named; an offset (one parameter fewer) 2.5 BIC units worse, held-out 1 %
        // higher: a tie, reported with its sign
        let named = fit(grav, 11, 100.0, 1.50);
        assert!((named.bic(NOBS) - 100.0).abs() < 1e-9);
        let t = near_tie(grav, &named, off, &fit(off, 10, 102.5, 1.515), &s, NOBS).unwrap();
        assert_eq!(
            (t.cause.as_str(), t.alternative.as_str()),
            ("gravity", "torque_offset")
        );
        assert!((t.delta_bic - 2.5).abs() < 1e-9 && t.heldout_rms_nm == 1.515);
        // outside the ΔBIC margin on either side, held-out 2 % worse, or the cause itself
        for (alt, kind) in [
            (fit(off, 10, 110.5, 1.50), off),
            (fit(off, 10, 89.5, 1.50), off),
            (fit(off, 10, 101.0, 1.531), off),
            (fit(grav, 11, 100.0, 1.50), grav),
        ] {
            assert!(near_tie(grav, &named, kind, &alt, &s, NOBS).is_none());
        }
        // offset named: a gravity term (one parameter more) better by less than the margin is
        // a tie; one that is worse only pays for its extra parameter and is not
        let named = fit(off, 10, 100.0, 1.50);
        let t = near_tie(off, &named, grav, &fit(grav, 11, 91.0, 1.49), &s, NOBS).unwrap();
        assert!((t.delta_bic + 9.0).abs() < 1e-9);
        assert!(near_tie(off, &named, grav, &fit(grav, 11, 102.5, 1.50), &s, NOBS).is_none());
    }

    #[test]
    fn a_simpler_model_the_data_cannot_tell_apart_is_named() {
        let s = DiagnoseSettings::default();
        let (off, grav) = (EffectKind::TorqueOffset, EffectKind::Gravity);
        let complex = fit(grav, 11, 100.0, 1.50);
        // one parameter fewer, a BIC less than the margin worse and a held-out RMS less than
        // the held-out margin (3 % of 1.50 here) higher: the simpler one is named
        assert!(simpler_tie(&fit(off, 10, 99.0, 1.50), &complex, &s, NOBS));
        assert!(simpler_tie(&fit(off, 10, 109.5, 1.52), &complex, &s, NOBS));
        // … but not past either margin, and never with as many parameters
        assert!(!simpler_tie(&fit(off, 10, 110.5, 1.50), &complex, &s, NOBS));
        assert!(!simpler_tie(&fit(off, 10, 100.0, 1.54), &complex, &s, NOBS));
        assert!(!simpler_tie(
            &fit(grav, 11, 95.0, 1.40),
            &fit(grav, 11, 100.0, 1.50),
            &s,
            NOBS
        ));
    }

    #[test]
    fn exchange_replaces_by_the_margin_or_by_a_simpler_tie() {
        let s = DiagnoseSettings::default();
        let (off, grav) = (EffectKind::TorqueOffset, EffectKind::Gravity);
        let current = fit(grav, 11, 100.0, 1.50);
        // one parameter fewer inside both margins (1100713: an offset named as gravity)
        assert!(replaces(&fit(off, 10, 99.0, 1.50), &current, &s, NOBS));
        assert!(replaces(&fit(off, 10, 105.0, 1.45), &current, &s, NOBS));
        // … but not past the BIC margin or with a held-out error higher by its margin
        assert!(!replaces(&fit(off, 10, 110.5, 1.40), &current, &s, NOBS));
        assert!(!replaces(&fit(off, 10, 80.0, 1.56), &current, &s, NOBS));
        // as many or more parameters: only past the margin and with a held-out RMS that is
        // not higher (1100704: gravity 2.5 units better than an offset does not replace it)
        let current = fit(off, 10, 100.0, 1.50);
        assert!(!replaces(&fit(grav, 11, 97.5, 1.45), &current, &s, NOBS));
        assert!(replaces(&fit(grav, 11, 89.0, 1.50), &current, &s, NOBS));
        assert!(!replaces(&fit(grav, 11, 80.0, 1.51), &current, &s, NOBS));
    }

    #[test]
    fn gravity_is_reported_with_its_phase_near_zero() {
        let g = |m: f64, phi: f64| {
            let e = BTreeMap::from([(
                "gravity".to_string(),
                BTreeMap::from([("moment_nm".to_string(), m), ("phase_deg".to_string(), phi)]),
            )]);
            let i = BTreeMap::from([(
                "gravity".to_string(),
                BTreeMap::from([
                    ("moment_nm".to_string(), iv(m - 1.0, m + 2.0, true)),
                    ("phase_deg".to_string(), iv(phi - 3.0, phi + 4.0, false)),
                ]),
            )]);
            (e, i)
        };
        for (m, phi, want_phi) in [(6.0, 178.0, -2.0), (6.0, -175.0, 5.0), (6.0, 90.0, -90.0)] {
            let (mut e, mut i) = g(m, phi);
            canonical_gravity(&mut e, &mut i);
            assert_eq!(e["gravity"]["moment_nm"], -m);
            assert_eq!(e["gravity"]["phase_deg"], want_phi);
            let im = i["gravity"]["moment_nm"];
            assert_eq!((im.lower, im.upper), (-m - 2.0, -m + 1.0));
            assert!(!im.lower_at_bound && im.upper_at_bound);
            let ip = i["gravity"]["phase_deg"];
            assert_eq!((ip.lower, ip.upper), (want_phi - 3.0, want_phi + 4.0));
            // the term itself is unchanged
            for q in [-0.3_f64, 0.0, 0.4] {
                let before = m * (q - phi.to_radians()).sin();
                let after = -m * (q - want_phi.to_radians()).sin();
                assert!((before - after).abs() < 1e-12);
            }
        }
        // already canonical: untouched
        let (mut e, mut i) = g(-4.0, 10.0);
        let (e0, i0) = (e.clone(), i.clone());
        canonical_gravity(&mut e, &mut i);
        assert_eq!((e, i), (e0, i0));
    }
}
