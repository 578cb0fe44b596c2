//! The trial prepared for fitting: model inputs, segmentation of the motion, and the noise
//! model whose systematic part is subtracted from the measured torque and whose random part
//! whitens the residual (docs/diagnosis.md, docs/dynamometer.md).

use experiment::UnloadedCorrection;
use muscle_model::{Effects, ModelParams, TrialInputs};
use numerics::LevenbergMarquardtSettings;

use crate::fit::Context;
use crate::noise::{NoiseModelSource, Transient, TrialNoiseModel, WhitenPlan};
use crate::segment::Segmentation;
use crate::{DiagnoseError, DiagnoseSettings};

/// The segmentation of `inputs`' motion; a recording whose angle never changes over the
/// observed samples (no joint angle) is one hold.
pub(crate) fn segment(
    inputs: &TrialInputs,
    observed: Option<&[bool]>,
) -> Result<Segmentation, DiagnoseError> {
    let q = inputs.angle();
    let seen = |i: usize| observed.is_none_or(|o| o[i]);
    let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
    for (i, v) in q.iter().enumerate() {
        if seen(i) {
            lo = lo.min(*v);
            hi = hi.max(*v);
        }
    }
    if hi - lo <= 1e-9 {
        return Ok(Segmentation::still(inputs.len()));
    }
    segment_motion(inputs)
}

/// The segmentation of a moving angle, the mean sol/gm/gl envelope marking relaxed cycles.
pub(crate) fn segment_motion(inputs: &TrialInputs) -> Result<Segmentation, DiagnoseError> {
    let act = crate::StateVariable::Activation
        .samples(inputs)
        .expect("every trial has the triceps envelopes");
    Segmentation::new(inputs.angle(), inputs.fs(), Some(&act)).map_err(|reason| {
        DiagnoseError::Segmentation {
            recording: "trial",
            reason,
        }
    })
}

/// What a diagnosis fits besides the inputs: the measured torque, the samples it is compared
/// at, and the base model.
pub(crate) struct Target<'a> {
    pub torque_nm: &'a [f64],
    pub observed: Option<Vec<bool>>,
    pub params: ModelParams,
    pub effects: Effects,
    /// The raw-EMG crosstalk tests and the uncorrected inputs (a trial CSV with `emg_ta`).
    pub emg: crate::crosstalk::EmgInputs,
}

/// The fitting context of a trial CSV prepared by [`DiagnoseSettings::prepare`] (every sample
/// compared, its unloaded run's correction when it has one) at the base model `params` +
/// `effects`, with the simulations spent ([`trial_context`]).
pub(crate) fn prepared_context(
    prepared: &experiment::PreparedTrial,
    params: ModelParams,
    effects: Effects,
    settings: &DiagnoseSettings,
) -> Result<(Context, usize), DiagnoseError> {
    let inputs = prepared.inputs.clone();
    let seg = segment_motion(&inputs)?;
    let target = Target {
        torque_nm: prepared.raw_torque(),
        observed: None,
        params,
        effects,
        emg: Default::default(),
    };
    trial_context(target, prepared.unloaded.as_ref(), inputs, seg, settings)
}

/// The fitting context of the trial: the torque with the dynamometer's systematic part
/// subtracted, the noise model that whitens it and the cross-validation folds, with the
/// simulations spent.
///
/// With an unloaded run the noise model is that run's (docs/dynamometer.md); without one, a
/// baseline fitted under white noise leaves a residual from which the model is fitted, its
/// offset set to zero (a dynamometer offset cannot be told from the `torque_offset` effect).
/// The residual is taken from the first to the last observed sample, unobserved samples
/// inside that span set to zero.
pub(crate) fn trial_context(
    target: Target<'_>,
    unloaded: Option<&UnloadedCorrection>,
    inputs: TrialInputs,
    seg: Segmentation,
    settings: &DiagnoseSettings,
) -> Result<(Context, usize), DiagnoseError> {
    let Target {
        torque_nm,
        observed,
        params,
        effects,
        ..
    } = target;
    let n = inputs.len();
    let fs = inputs.fs();
    let times: Vec<f64> = (0..n).map(|i| i as f64 / fs).collect();
    let mut evaluations = 0;
    let lm = settings.lm;
    let cv_lm = LevenbergMarquardtSettings {
        max_iterations: settings.cv_iterations,
        ..settings.lm
    };
    let seen = |i: usize| observed.as_ref().is_none_or(|o| o[i]);
    let make_ctx = |y: Vec<f64>, noise: TrialNoiseModel| -> Context {
        let plan = noise.plan(n, observed.as_deref());
        let folds = settings
            .cv_folds
            .held_out_masks(n, fs, &seg.cycle)
            .into_iter()
            .map(|mut held| {
                for (i, h) in held.iter_mut().enumerate() {
                    *h = *h && seen(i);
                }
                let train: Vec<bool> = held
                    .iter()
                    .enumerate()
                    .map(|(i, h)| !h && seen(i))
                    .collect();
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
            params,
            effects,
            observed: observed.clone(),
            exact_jacobian: settings.exact_jacobian,
        }
    };
    let noise = match unloaded {
        Some(u) => {
            let fu = u.rate_hz;
            if (fu - fs).abs() > 1e-6 * fs || fu.is_nan() {
                return Err(DiagnoseError::Unloaded {
                    reason: format!("sampled at {fu} Hz but the trial at {fs} Hz"),
                });
            }
            TrialNoiseModel::from_correction(&u.correction, NoiseModelSource::Unloaded, u.samples)
        }
        None => {
            // preliminary white-noise baseline, then the noise model from its residual
            let pre_noise = TrialNoiseModel {
                source: NoiseModelSource::TrialResidual,
                offset_nm: 0.0,
                transient: Transient::none(),
                phi: 0.0,
                sd_ar_nm: 0.0,
                sd_white_nm: 1.0,
                remainder_rms_nm: 0.0,
                level_dof: f64::INFINITY,
            };
            let ctx0 = make_ctx(torque_nm.to_vec(), pre_noise);
            let f0 = ctx0.fit(&[], &ctx0.base_muscles(), false)?;
            evaluations += f0.evaluations;
            let mut res = difference(torque_nm, &f0.pred);
            let first = (0..n).find(|&i| seen(i)).unwrap_or(0);
            let last = (0..n).rev().find(|&i| seen(i)).map_or(n, |i| i + 1);
            for (i, r) in res.iter_mut().enumerate() {
                if !seen(i) {
                    *r = 0.0;
                }
            }
            let t_first = first as f64 / fs;
            let events: Vec<f64> = seg
                .events
                .iter()
                .map(|e| e - t_first)
                .filter(|e| *e >= 0.0)
                .collect();
            let correction =
                experiment::DynamometerCorrection::fit(&res[first..last], fs, &events, false)?;
            let mut noise = TrialNoiseModel::from_correction(
                &correction,
                NoiseModelSource::TrialResidual,
                res.len(),
            );
            noise.offset_nm = 0.0;
            noise
        }
    };
    // the systematic part at the trial's own events is what the fits never see
    let y = difference(torque_nm, &noise.systematic(&times, &seg.events));
    Ok((make_ctx(y, noise), evaluations))
}

/// `a − b`, element by element.
fn difference(a: &[f64], b: &[f64]) -> Vec<f64> {
    a.iter().zip(b).map(|(x, y)| x - y).collect()
}
