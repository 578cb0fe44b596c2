//! The functions on arrays: EMG envelopes, the model torque, and the bundled trial.
//!
//! `envelope` applies the command line's filter chain to each channel: band-pass 10–350 Hz
//! zero-phase, `|·|`, low-pass 2 Hz zero-phase, then ÷ the channel's maximum (or an MVC
//! reference) and clamp to `[0, 1]`. `simulate` converts the angle to radians
//! (`q = deg · π/180`), takes the envelopes as given (clamped to `[0, 1]`) and integrates the
//! model exactly as `surae simulate` does, so the same angle, envelopes and rate give the same
//! torque to the last bit.

use crate::bad;
use crate::convert::{array, channels, json_arg, vec1, JsonArg};
use muscle_model::{Effects, ModelParams, SimSettings, TrialInputs};
use numpy::PyArray2;
use pyo3::prelude::*;
use pyo3::types::PyDict;
use signal::{normalise, EnvelopeFilter, EnvelopeSettings, Normalisation};

/// Normalised EMG envelope(s) of raw EMG sampled at `fs` Hz.
///
/// `emg` is one channel (1-D) or several (2-D, shape (channels, samples)); the result has the
/// same shape. `mvc` (optional): a number, or one per channel, dividing the envelope instead of
/// its maximum over the recording. Equals the columns that `surae envelope` writes.
#[pyfunction]
#[pyo3(signature = (emg, fs, mvc=None))]
pub fn envelope<'py>(
    py: Python<'py>,
    emg: &Bound<'py, PyAny>,
    fs: f64,
    mvc: Option<&Bound<'py, PyAny>>,
) -> PyResult<Bound<'py, PyAny>> {
    let (chans, one_d) = channels(emg, "emg")?;
    let mvc: Vec<Option<f64>> = match mvc.filter(|m| !m.is_none()) {
        None => vec![None; chans.len()],
        Some(m) => match m.extract::<f64>() {
            Ok(v) => vec![Some(v); chans.len()],
            Err(_) => {
                let v = vec1(m, "mvc")?;
                if v.len() != chans.len() {
                    return Err(bad(format!(
                        "mvc: {} values for {} channels",
                        v.len(),
                        chans.len()
                    )));
                }
                v.into_iter().map(Some).collect()
            }
        },
    };
    let out = py.detach(|| -> Result<Vec<Vec<f64>>, String> {
        let filter = EnvelopeFilter::new(fs, &EnvelopeSettings::default())
            .map_err(|e| format!("fs {fs}: cannot design the EMG filters: {e}"))?;
        chans
            .iter()
            .zip(&mvc)
            .enumerate()
            .map(|(k, (raw, mvc))| {
                let name = if one_d {
                    "emg".to_string()
                } else {
                    format!("emg channel {k}")
                };
                channel_envelope(&filter, raw, *mvc).map_err(|e| format!("{name}: {e}"))
            })
            .collect()
    });
    let out = out.map_err(bad)?;
    if one_d {
        let v = out.into_iter().next().unwrap_or_default();
        Ok(array(py, v).into_any())
    } else {
        Ok(PyArray2::from_vec2(py, &out)
            .map_err(|e| bad(format!("emg: {e}")))?
            .into_any())
    }
}

/// One channel: the checks and steps of the command line's envelope.
fn channel_envelope(
    filter: &EnvelopeFilter,
    raw: &[f64],
    mvc: Option<f64>,
) -> Result<Vec<f64>, String> {
    if let Some(i) = raw.iter().position(|x| !x.is_finite()) {
        return Err(format!("sample {i} is not a finite number"));
    }
    if raw.iter().all(|&x| x == 0.0) {
        return Err("EMG channel is all zeros (disconnected electrode?)".into());
    }
    let mut env = filter
        .envelope(raw)
        .map_err(|e| format!("cannot make the EMG envelope: {e}"))?;
    // a constant or drifting channel has nothing in the band: normalising its numerical
    // noise would fake activity
    let raw_amp = raw.iter().fold(0.0f64, |a, x| a.max(x.abs()));
    let env_max = env.iter().fold(0.0f64, |a, x| a.max(*x));
    if env_max.is_nan() || env_max <= 1e-9 * raw_amp {
        return Err(
            "no EMG activity in the 10–350 Hz band (a constant or drifting channel?)".into(),
        );
    }
    let reference = mvc.map_or(Normalisation::TrialMax, Normalisation::Mvc);
    normalise(&mut env, reference).map_err(|e| format!("cannot make the EMG envelope: {e}"))?;
    Ok(env)
}

/// The envelopes argument of `simulate`: a dict (`sol`, `gm`, `gl`, optional `ta` and any
/// further muscle of the model by its name; an `emg_` prefix is accepted) or an array of shape
/// (3, n) or (4, n) in the order sol, gm, gl, ta.
/// The envelopes of sol, gm, gl, of ta when given, and of further muscles by name.
type Envelopes = ([Vec<f64>; 3], Option<Vec<f64>>, Vec<(String, Vec<f64>)>);

fn envelopes_arg(obj: &Bound<'_, PyAny>, params: &ModelParams) -> PyResult<Envelopes> {
    let mut slots: [Option<Vec<f64>>; 4] = Default::default();
    let mut others = Vec::new();
    const NAMES: [&str; 4] = ["sol", "gm", "gl", "ta"];
    if let Ok(d) = obj.cast::<PyDict>() {
        for (k, v) in d.iter() {
            let key: String = k
                .extract()
                .map_err(|_| bad("emg_envelopes: keys must be strings"))?;
            let short = key.strip_prefix("emg_").unwrap_or(&key);
            let position = NAMES.iter().position(|n| *n == short);
            if position.is_none() && params.fixed.get(short).is_none() {
                return Err(bad(format!(
                    "emg_envelopes: unknown key '{key}' (sol, gm, gl, ta, or a further muscle \
                     of params)"
                )));
            }
            let values = vec1(&v, &format!("emg_envelopes['{key}']"))?;
            match position {
                Some(i) => slots[i] = Some(values),
                None => others.push((short.to_string(), values)),
            }
        }
    } else {
        let (rows, one_d) = channels(obj, "emg_envelopes")?;
        if one_d || !(rows.len() == 3 || rows.len() == 4) {
            return Err(bad(
                "emg_envelopes: expected a dict or an array of shape (3, n) (sol, gm, gl) or \
                 (4, n) (… ta)",
            ));
        }
        for (slot, r) in slots.iter_mut().zip(rows) {
            *slot = Some(r);
        }
    }
    let [sol, gm, gl, ta] = slots;
    let need = |v: Option<Vec<f64>>, n: &str| {
        v.ok_or_else(|| bad(format!("emg_envelopes: missing '{n}'")))
    };
    Ok((
        [need(sol, "sol")?, need(gm, "gm")?, need(gl, "gl")?],
        ta,
        others,
    ))
}

/// Model parameters from a `params` argument (nominal when absent).
pub(crate) fn params_arg(arg: Option<JsonArg>) -> PyResult<ModelParams> {
    match arg {
        None => Ok(ModelParams::nominal()),
        Some(JsonArg::Path(p)) => {
            let v = surae_app::read_json(&p).map_err(crate::failure_to_py)?;
            ModelParams::nominal()
                .merged_json(&v)
                .map_err(|e| bad(format!("{}: {e}", p.display())))
        }
        Some(JsonArg::Value(v)) => ModelParams::nominal()
            .merged_json(&v)
            .map_err(|e| bad(format!("params: {e}"))),
    }
}

/// Effects from an `effects` argument (none when absent).
pub(crate) fn effects_arg(arg: Option<JsonArg>) -> PyResult<Effects> {
    match arg {
        None => Ok(Effects::none()),
        Some(JsonArg::Path(p)) => {
            let v = surae_app::read_json(&p).map_err(crate::failure_to_py)?;
            Effects::from_json(&v).map_err(|e| bad(format!("{}: {e}", p.display())))
        }
        Some(JsonArg::Value(v)) => Effects::from_json(&v).map_err(|e| bad(format!("effects: {e}"))),
    }
}

/// The model's joint torque for an ankle angle (degrees, dorsiflexion > 0) and normalised
/// envelopes sampled at `fs` Hz, with optional parameters and effects (dicts or JSON files in
/// the command line's formats; `params` may add fixed muscles, each driven by the envelope of
/// its name) and an optional knee flexion (degrees: a number or an array like `angle_deg`).
/// Returns a dict of arrays: `time_s` (`t0 + i/fs`), `ankle_angle_deg`, `torque_nm`, and
/// `torque_<muscle>_nm` for sol, gm, gl and every fixed muscle.
#[pyfunction]
#[pyo3(signature = (
    angle_deg, emg_envelopes, fs, params=None, effects=None, *, t0=0.0, knee_angle_deg=None
))]
#[allow(clippy::too_many_arguments)]
pub fn simulate<'py>(
    py: Python<'py>,
    angle_deg: &Bound<'py, PyAny>,
    emg_envelopes: &Bound<'py, PyAny>,
    fs: f64,
    params: Option<&Bound<'py, PyAny>>,
    effects: Option<&Bound<'py, PyAny>>,
    t0: f64,
    knee_angle_deg: Option<&Bound<'py, PyAny>>,
) -> PyResult<Bound<'py, PyDict>> {
    let angle_deg = vec1(angle_deg, "angle_deg")?;
    let params = params_arg(json_arg(params, "params")?)?;
    let (env, env_ta, others) = envelopes_arg(emg_envelopes, &params)?;
    let knee_rad: Option<Vec<f64>> = match knee_angle_deg.filter(|k| !k.is_none()) {
        None => None,
        Some(k) => {
            let deg = match k.extract::<f64>() {
                Ok(v) => vec![v; angle_deg.len()],
                Err(_) => vec1(k, "knee_angle_deg")?,
            };
            Some(deg.iter().map(|d| d.to_radians()).collect())
        }
    };
    for (e, n) in env.iter().zip(["sol", "gm", "gl"]) {
        if e.len() != angle_deg.len() {
            return Err(bad(format!(
                "emg_envelopes['{n}']: {} samples but angle_deg has {}",
                e.len(),
                angle_deg.len()
            )));
        }
    }
    let effects = effects_arg(json_arg(effects, "effects")?)?;
    let angle_rad: Vec<f64> = angle_deg.iter().map(|d| d.to_radians()).collect();
    let sim = py.detach(|| -> Result<_, String> {
        let mut inputs = TrialInputs::new(fs, t0, angle_rad, env, env_ta)
            .map_err(|e| format!("invalid model inputs: {e}"))?;
        for (name, e) in others {
            inputs = inputs
                .with_envelope(&name, e)
                .map_err(|e| format!("invalid model inputs: {e}"))?;
        }
        if let Some(k) = knee_rad {
            inputs = inputs
                .with_knee_angle(k)
                .map_err(|e| format!("invalid model inputs: {e}"))?;
        }
        let sim = muscle_model::simulate(&inputs, &params, &effects, &SimSettings::default())
            .map_err(|e| format!("simulation failed: {e}"))?;
        Ok((inputs.times().to_vec(), sim))
    });
    let (times, sim) = sim.map_err(bad)?;
    let out = PyDict::new(py);
    out.set_item("time_s", array(py, times))?;
    out.set_item("ankle_angle_deg", array(py, angle_deg))?;
    out.set_item("torque_nm", array(py, sim.torque))?;
    for m in sim.muscles {
        out.set_item(format!("torque_{}_nm", m.name), array(py, m.torque))?;
    }
    Ok(out)
}

/// The bundled trial (the one every command uses without a trial file) as a dict of arrays:
/// the trial file's columns (`time_s`, `ankle_angle_deg`, `torque_nm`, `emg_sol`, `emg_gm`,
/// `emg_gl`) and its sampling rate `fs` (Hz).
#[pyfunction]
pub fn bundled_trial(py: Python<'_>) -> PyResult<Bound<'_, PyDict>> {
    let t = surae_app::bundled::seed_trial()
        .map_err(|e| pyo3::exceptions::PyRuntimeError::new_err(e.to_string()))?;
    let out = PyDict::new(py);
    out.set_item("fs", t.sample_rate_hz())?;
    out.set_item("time_s", array(py, t.time_s))?;
    out.set_item("ankle_angle_deg", array(py, t.ankle_angle_deg))?;
    out.set_item("torque_nm", array(py, t.torque_nm))?;
    out.set_item("emg_sol", array(py, t.emg_sol))?;
    out.set_item("emg_gm", array(py, t.emg_gm))?;
    out.set_item("emg_gl", array(py, t.emg_gl))?;
    if let Some(ta) = t.emg_ta {
        out.set_item("emg_ta", array(py, ta))?;
    }
    if let Some(k) = t.knee_angle_deg {
        out.set_item("knee_angle_deg", array(py, k))?;
    }
    Ok(out)
}

/// The bundled trial's unloaded run (the dynamometer moving with nothing attached) as a dict
/// of arrays: `time_s`, `ankle_angle_deg`, `torque_nm`, and `fs` (Hz).
#[pyfunction]
pub fn bundled_unloaded(py: Python<'_>) -> PyResult<Bound<'_, PyDict>> {
    let u = surae_app::bundled::seed_unloaded()
        .map_err(|e| pyo3::exceptions::PyRuntimeError::new_err(e.to_string()))?;
    let out = PyDict::new(py);
    out.set_item("fs", u.sample_rate_hz())?;
    out.set_item("time_s", array(py, u.time_s))?;
    out.set_item("ankle_angle_deg", array(py, u.ankle_angle_deg))?;
    out.set_item("torque_nm", array(py, u.torque_nm))?;
    Ok(out)
}
