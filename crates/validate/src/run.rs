//! Running the folds: calibrate on each fold's training parts, predict its held-out parts with
//! the calibrated model, the linear baseline and each peer, and score them.

use std::collections::BTreeMap;
use std::time::Instant;

use identify_sa::{
    identify_set, identify_set_with_search, search_set, NoObserver, SaIdentifySettings,
    SearchSettings,
};
use muscle_model::{Effects, ModelParams, Problem, ProblemSet};
use rayon::prelude::*;
use serde::Serialize;

use crate::baseline::LinearBaseline;
use crate::folds::{folds, Fold, FoldScheme, TrialPart};
use crate::scale::{moment_scale, MomentScale};
use crate::score::FitScore;
use crate::shape::{held_out_shape, HeldOutShape, PartResidual};
use crate::strides::{stride_scores, stride_spans, StrideScore};
use crate::ValidateError;

/// One trial of the session: its problem (the session's model, free parameters, bounds and
/// sample weights on this trial), its condition label and, when known, its strides (where
/// they start and end, samples, and which ones the recording checks flagged) so a held-out
/// part is also scored stride by stride ([`StrideScore`]).
#[derive(Clone, Copy, Debug)]
pub struct ValidationTrial<'a> {
    /// The trial's name.
    pub name: &'a str,
    /// Its condition label, if any.
    pub condition: Option<&'a str>,
    /// Its problem.
    pub problem: &'a Problem,
    /// The first sample of each of its strides, if known.
    pub stride_starts: Option<&'a [usize]>,
    /// Where each stride ends (the next foot strike, exclusive), parallel to `stride_starts`;
    /// `None`: each ends where the next starts and the last, whose end is unknown, is not
    /// scored.
    pub stride_ends: Option<&'a [usize]>,
    /// Whether the recording checks flagged each stride, parallel to `stride_starts`; `None`:
    /// none is.
    pub stride_flagged: Option<&'a [bool]>,
}

/// Parameters from elsewhere (another tool's calibration, a subject's uncalibrated model),
/// predicted as given on every held-out part.
#[derive(Clone, Debug)]
pub struct Peer {
    /// Its name in the report.
    pub name: String,
    /// Its parameters.
    pub params: ModelParams,
    /// Its effects.
    pub effects: Effects,
}

/// How the folds are run.
#[derive(Clone, Debug)]
#[non_exhaustive]
pub struct ValidateSettings {
    /// The calibration of every fold.
    pub sa: SaIdentifySettings,
    /// The calibrated share of each trial for [`FoldScheme::LaterStrides`]. Default 0.5.
    pub later_fraction: f64,
    /// The linear baseline's largest delay (ms). Default 150.
    pub max_delay_ms: f64,
    /// Its delay grid's step (ms). Default 10.
    pub delay_step_ms: f64,
    /// Where a fold's calibration searches when its training parts have strides: windows of
    /// them spread over the parts ([`identify_sa::search_set`]), the result polished on every
    /// training sample. `None` searches on every training sample. Default: the search
    /// settings' defaults.
    pub search: Option<SearchSettings>,
}

impl Default for ValidateSettings {
    fn default() -> Self {
        Self {
            sa: SaIdentifySettings::default(),
            later_fraction: 0.5,
            max_delay_ms: 150.0,
            delay_step_ms: 10.0,
            search: Some(SearchSettings::default()),
        }
    }
}

/// One held-out part's scores.
#[derive(Clone, Debug, PartialEq, Serialize)]
#[non_exhaustive]
pub struct HeldOutScore {
    /// The trial.
    pub trial: String,
    /// Its first and last held-out sample's times (s).
    pub span_s: (f64, f64),
    /// Samples judged (positive weight).
    pub samples: usize,
    /// The calibrated model.
    pub model: FitScore,
    /// The linear baseline calibrated on the same parts.
    pub linear: FitScore,
    /// Each peer, by name.
    pub peers: BTreeMap<String, FitScore>,
    /// Every stride of the trial that lies inside the held-out samples, scored alone (empty
    /// when the trial's strides are not known).
    pub strides: Vec<StrideScore>,
    /// Whether the held-out residual keeps a reproducible shape ([`HeldOutShape`]).
    pub shape: HeldOutShape,
    /// The scale of the model's moment the part asks for, cross-validated within it
    /// ([`MomentScale`]; `None` when it cannot be cut in two).
    pub scale: Option<MomentScale>,
    /// The held-out samples (indices into the trial).
    #[serde(skip)]
    pub samples_range: std::ops::Range<usize>,
    /// The calibrated model's moment over them (N·m).
    #[serde(skip)]
    pub model_nm: Vec<f64>,
    /// The linear baseline's moment over them (N·m).
    #[serde(skip)]
    pub linear_nm: Vec<f64>,
}

/// One fold's calibration and scores.
#[derive(Clone, Debug, PartialEq, Serialize)]
#[non_exhaustive]
pub struct FoldResult {
    /// Its scheme.
    pub scheme: FoldScheme,
    /// Its name.
    pub name: String,
    /// The trials that calibrated it.
    pub calibrated_on: Vec<String>,
    /// The calibrated free parameters, by name.
    pub params: BTreeMap<String, f64>,
    /// RMS error on the calibration parts (N·m).
    pub calibration_rms_nm: f64,
    /// Each calibration chain's RMS error (N·m): chains that agree found the same minimum.
    pub chain_rms_nm: Vec<f64>,
    /// Simulations spent.
    pub evaluations: u64,
    /// The linear baseline fitted on the same parts.
    pub linear: LinearBaseline,
    /// The held-out parts.
    pub held_out: Vec<HeldOutScore>,
    /// Wall-clock time of the fold (s).
    pub wall_s: f64,
}

/// One scheme's folds summarised: the mean over held-out parts.
#[derive(Clone, Debug, PartialEq, Serialize)]
#[non_exhaustive]
pub struct SchemeSummary {
    /// The scheme.
    pub scheme: FoldScheme,
    /// Held-out parts scored.
    pub parts: usize,
    /// Mean score of the calibrated model.
    pub model: FitScore,
    /// Mean score of the linear baseline.
    pub linear: FitScore,
    /// Mean score of each peer.
    pub peers: BTreeMap<String, FitScore>,
}

/// Every fold of a validation, and each scheme's summary.
#[derive(Clone, Debug, PartialEq, Serialize)]
#[non_exhaustive]
pub struct Validation {
    /// The folds, scheme by scheme.
    pub folds: Vec<FoldResult>,
    /// One summary per scheme run.
    pub schemes: Vec<SchemeSummary>,
}

/// Runs `schemes` over `trials` (module docs), folds in parallel. The result does not depend
/// on the number of threads.
///
/// # Errors
/// A scheme the session cannot form ([`folds`]), a trial whose model cannot be built with a
/// peer's parameters, a calibration or baseline that fails.
pub fn validate(
    trials: &[ValidationTrial<'_>],
    schemes: &[FoldScheme],
    peers: &[Peer],
    settings: &ValidateSettings,
) -> Result<Validation, ValidateError> {
    let mut all = Vec::new();
    for s in schemes {
        all.extend(folds(*s, trials, settings.later_fraction)?);
    }
    let peer_predictions = peer_predictions(trials, peers)?;
    let results: Vec<Result<FoldResult, ValidateError>> = all
        .par_iter()
        .map(|f| run_fold(f, trials, &peer_predictions, settings))
        .collect();
    let folds = results.into_iter().collect::<Result<Vec<_>, _>>()?;
    let schemes = schemes
        .iter()
        .map(|s| summarise(*s, &folds, peers))
        .collect();
    Ok(Validation { folds, schemes })
}

/// A peer's name and its moment on each trial of the session.
type PeerMoments = (String, Vec<Vec<f64>>);

/// Each peer's moment on each trial.
fn peer_predictions(
    trials: &[ValidationTrial<'_>],
    peers: &[Peer],
) -> Result<Vec<PeerMoments>, ValidateError> {
    peers
        .iter()
        .map(|peer| {
            let per_trial = trials
                .iter()
                .map(|t| {
                    let fail = |source| ValidateError::Model {
                        trial: format!("{} with {}", t.name, peer.name),
                        source,
                    };
                    let p = t.problem;
                    let q = Problem::new(
                        p.inputs().clone(),
                        p.measured().to_vec(),
                        peer.params,
                        peer.effects,
                        p.free().to_vec(),
                    )
                    .map_err(fail)?
                    .with_settings(*p.settings());
                    q.predict(&q.base_vector()).map_err(fail)
                })
                .collect::<Result<Vec<_>, _>>()?;
            Ok((peer.name.clone(), per_trial))
        })
        .collect()
}

/// `problem` weighted to the samples of `part` (its own weights inside, 0 outside) and cut
/// after them: the samples after a part cannot change its simulation, so they are not
/// integrated; the samples before it are kept, weighted 0, as its lead-in.
fn restricted(problem: &Problem, part: &TrialPart) -> Result<Problem, muscle_model::ModelError> {
    problem
        .clone()
        .with_weights(judged_weights(problem, part))?
        .window(0..part.samples.end, 0)
}

/// The segments of `part` its shape is tested by: the trial's strides wholly inside it that the
/// recording checks did not flag, or the part itself when it holds none.
fn part_segments(
    trial: &ValidationTrial<'_>,
    part: &std::ops::Range<usize>,
) -> Vec<std::ops::Range<usize>> {
    let n = trial.problem.inputs().len();
    let inside: Vec<std::ops::Range<usize>> = stride_spans(trial)
        .into_iter()
        .filter(|(a, b, flagged)| {
            !flagged && a < b && *a >= part.start && *b <= part.end && *b <= n
        })
        .map(|(a, b, _)| a..b)
        .collect();
    if inside.is_empty() {
        vec![part.clone()]
    } else {
        inside
    }
}

/// The weights that judge `part` of `problem`: its own weights inside the part, 0 outside.
fn judged_weights(problem: &Problem, part: &TrialPart) -> Vec<f64> {
    (0..problem.inputs().len())
        .map(|i| {
            if part.samples.contains(&i) {
                problem.weights().map_or(1.0, |w| w[i])
            } else {
                0.0
            }
        })
        .collect()
}

fn run_fold(
    fold: &Fold,
    trials: &[ValidationTrial<'_>],
    peer_predictions: &[PeerMoments],
    settings: &ValidateSettings,
) -> Result<FoldResult, ValidateError> {
    let t0 = Instant::now();
    let model_error = |k: usize| {
        let name = trials[k].name.to_string();
        move |source| ValidateError::Model {
            trial: name,
            source,
        }
    };
    let train: Vec<Problem> = fold
        .train
        .iter()
        .map(|part| restricted(trials[part.trial].problem, part).map_err(model_error(part.trial)))
        .collect::<Result<_, _>>()?;
    let set = ProblemSet::new(train).map_err(|source| ValidateError::Model {
        trial: format!("fold {}", fold.name),
        source,
    })?;
    let calibration_error = |source| ValidateError::Calibration {
        fold: fold.name.clone(),
        source,
    };
    let cycles: Vec<Option<&[usize]>> = fold
        .train
        .iter()
        .map(|part| trials[part.trial].stride_starts)
        .collect();
    let search = match &settings.search {
        Some(s) if cycles.iter().any(Option::is_some) => {
            search_set(&set, &cycles, s).map_err(calibration_error)?
        }
        _ => None,
    };
    let fit = match &search {
        Some(search) => identify_set_with_search(&set, search, &settings.sa, &NoObserver),
        None => identify_set(&set, &settings.sa, &NoObserver),
    }
    .map_err(calibration_error)?;
    let problems: Vec<&Problem> = trials.iter().map(|t| t.problem).collect();
    let linear = LinearBaseline::fit(
        &problems,
        &fold.train,
        settings.max_delay_ms,
        settings.delay_step_ms,
    )?;
    // every trial a part of the fold reads, predicted once at the calibrated point
    let mut predictions: BTreeMap<usize, Vec<f64>> = BTreeMap::new();
    for part in fold.train.iter().chain(&fold.test) {
        if let std::collections::btree_map::Entry::Vacant(e) = predictions.entry(part.trial) {
            let p = trials[part.trial].problem;
            e.insert(p.predict(&fit.x).map_err(model_error(part.trial))?);
        }
    }
    let train_weights: Vec<Vec<f64>> = fold
        .train
        .iter()
        .map(|part| judged_weights(trials[part.trial].problem, part))
        .collect();
    let training: Vec<PartResidual<'_>> = fold
        .train
        .iter()
        .zip(&train_weights)
        .map(|(part, w)| PartResidual {
            measured: trials[part.trial].problem.measured(),
            predicted: &predictions[&part.trial],
            weights: w,
            segments: part_segments(&trials[part.trial], &part.samples),
        })
        .collect();
    let mut held_out = Vec::with_capacity(fold.test.len());
    for part in &fold.test {
        let p = trials[part.trial].problem;
        let predicted = &predictions[&part.trial];
        let w = judged_weights(p, part);
        let y = p.measured();
        let times = p.inputs().times();
        let peers = peer_predictions
            .iter()
            .map(|(name, per_trial)| (name.clone(), FitScore::of(y, &per_trial[part.trial], &w)))
            .collect();
        let linear_nm = linear.predict(p);
        let peer_nm: Vec<(&str, &[f64])> = peer_predictions
            .iter()
            .map(|(name, per_trial)| (name.as_str(), per_trial[part.trial].as_slice()))
            .collect();
        let strides = stride_scores(
            &trials[part.trial],
            &part.samples,
            &w,
            predicted,
            &linear_nm,
            &peer_nm,
        );
        let segments = part_segments(&trials[part.trial], &part.samples);
        let scale = moment_scale(y, predicted, &w, &segments);
        let shape = held_out_shape(
            &PartResidual {
                measured: y,
                predicted,
                weights: &w,
                segments,
            },
            &training,
        );
        held_out.push(HeldOutScore {
            trial: trials[part.trial].name.to_string(),
            span_s: (
                times[part.samples.start],
                times[part.samples.end.saturating_sub(1)],
            ),
            samples: w.iter().filter(|v| **v > 0.0).count(),
            model: FitScore::of(y, predicted, &w),
            linear: FitScore::of(y, &linear_nm, &w),
            peers,
            strides,
            shape,
            scale,
            samples_range: part.samples.clone(),
            model_nm: predicted[part.samples.clone()].to_vec(),
            linear_nm: linear_nm[part.samples.clone()].to_vec(),
        });
    }
    let chain_rms_nm = fit
        .chains
        .iter()
        .map(|c| (c.cost / set.weight_sum()).sqrt())
        .collect();
    Ok(FoldResult {
        scheme: fold.scheme,
        name: fold.name.clone(),
        calibrated_on: fold
            .train
            .iter()
            .map(|p| trials[p.trial].name.to_string())
            .collect(),
        params: fit.params.clone(),
        calibration_rms_nm: fit.rms_nm,
        chain_rms_nm,
        evaluations: fit.evaluations,
        linear,
        held_out,
        wall_s: t0.elapsed().as_secs_f64(),
    })
}

fn summarise(scheme: FoldScheme, folds: &[FoldResult], peers: &[Peer]) -> SchemeSummary {
    let parts: Vec<&HeldOutScore> = folds
        .iter()
        .filter(|f| f.scheme == scheme)
        .flat_map(|f| &f.held_out)
        .collect();
    let mean = |f: &dyn Fn(&HeldOutScore) -> FitScore| {
        FitScore::mean(&parts.iter().map(|h| f(h)).collect::<Vec<_>>())
    };
    SchemeSummary {
        scheme,
        parts: parts.len(),
        model: mean(&|h| h.model),
        linear: mean(&|h| h.linear),
        peers: peers
            .iter()
            .map(|p| (p.name.clone(), mean(&|h| h.peers[&p.name])))
            .collect(),
    }
}
