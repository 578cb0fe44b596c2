//! `identify`, `diagnose` and `design`: the application library's jobs, the ones the command
//! line runs, with their JSON result returned as a dict. Equality with `surae identify` /
//! `surae diagnose` therefore holds by construction (apart from `wall_s`, a measured time).
//!
//! Inputs given as dicts (a trial or unloaded run as columns, parameters / effects / truth as
//! JSON objects) go to the job in memory ([`surae_app::InMemory`]), checked as the file readers
//! check a file; messages and the result name them `<trial dict>`, `<params dict>`, … where the
//! command line names the file. Without `out` the job writes no file: its result comes back
//! through the observer ([`surae_app::JobObserver::result_json`]).

use crate::bad;
use crate::convert::{json_arg, json_to_py, path_arg, vec1, JsonArg};
use crate::run::{run_command, ProgressMode};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use std::path::PathBuf;
use surae_app::{
    AppResult, DesignJob, DiagnoseJob, IdentifyJob, InMemory, KneeSettings, Method, ModelSettings,
    Reporter,
};

/// A JSON argument: a file the job reads, or an object it takes in memory as `<what dict>`.
fn json_input(
    obj: Option<&Bound<'_, PyAny>>,
    what: &str,
) -> PyResult<(Option<PathBuf>, Option<InMemory<serde_json::Value>>)> {
    Ok(match json_arg(obj, what)? {
        None => (None, None),
        Some(JsonArg::Path(p)) => (Some(p), None),
        Some(JsonArg::Value(v)) => (None, Some(InMemory::new(v, format!("<{what} dict>")))),
    })
}

/// The output folder: `out` when given; without it none, and the job writes no file.
fn out_arg(out: Option<&Bound<'_, PyAny>>) -> PyResult<Option<PathBuf>> {
    match out.filter(|o| !o.is_none()) {
        Some(o) => path_arg(o, "out").map(Some),
        None => Ok(None),
    }
}

/// Columns of a dict, by the names of the file format; `fs` is accepted (and not used: the
/// time column sets the rate) so that `bundled_trial()`'s dict can be passed back.
fn columns(
    d: &Bound<'_, PyDict>,
    what: &str,
    required: &[&str],
    optional: &[&str],
) -> PyResult<Vec<Option<Vec<f64>>>> {
    let names: Vec<&str> = required.iter().chain(optional).copied().collect();
    let mut out: Vec<Option<Vec<f64>>> = vec![None; names.len()];
    for (k, v) in d.iter() {
        let key: String = k
            .extract()
            .map_err(|_| bad(format!("{what}: keys must be strings")))?;
        if key == "fs" {
            continue;
        }
        let Some(i) = names.iter().position(|n| *n == key) else {
            return Err(bad(format!(
                "{what}: unknown column '{key}' (expected {})",
                names.join(", ")
            )));
        };
        out[i] = Some(vec1(&v, &format!("{what}['{key}']"))?);
    }
    for (i, n) in required.iter().enumerate() {
        if out[i].is_none() {
            return Err(bad(format!("{what}: missing column '{n}'")));
        }
    }
    Ok(out)
}

/// A trial argument: `None` (the bundled trial), a CSV path, or a dict of columns (taken in
/// memory as `<trial dict>`).
fn trial_arg(
    obj: Option<&Bound<'_, PyAny>>,
) -> PyResult<(Option<PathBuf>, Option<InMemory<experiment::Trial>>)> {
    let Some(obj) = obj.filter(|o| !o.is_none()) else {
        return Ok((None, None));
    };
    let Ok(d) = obj.cast::<PyDict>() else {
        return path_arg(obj, "trial").map(|p| (Some(p), None));
    };
    let mut c = columns(
        d,
        "trial",
        &experiment::TRIAL_REQUIRED,
        &experiment::TRIAL_OPTIONAL,
    )?
    .into_iter();
    let mut next = || c.next().flatten();
    let trial = experiment::Trial {
        time_s: next().unwrap_or_default(),
        ankle_angle_deg: next().unwrap_or_default(),
        torque_nm: next().unwrap_or_default(),
        emg_sol: next().unwrap_or_default(),
        emg_gm: next().unwrap_or_default(),
        emg_gl: next().unwrap_or_default(),
        emg_ta: next(),
        knee_angle_deg: next(),
        ..experiment::Trial::default()
    };
    Ok((None, Some(InMemory::new(trial, "<trial dict>"))))
}

/// An unloaded-run argument: `None`, a CSV path, or a dict of columns (in memory as
/// `<unloaded dict>`).
fn unloaded_arg(
    obj: Option<&Bound<'_, PyAny>>,
) -> PyResult<(Option<PathBuf>, Option<InMemory<experiment::Unloaded>>)> {
    let Some(obj) = obj.filter(|o| !o.is_none()) else {
        return Ok((None, None));
    };
    let Ok(d) = obj.cast::<PyDict>() else {
        return path_arg(obj, "unloaded").map(|p| (Some(p), None));
    };
    let mut c = columns(d, "unloaded", &experiment::UNLOADED_REQUIRED, &[])?.into_iter();
    let mut next = || c.next().flatten().unwrap_or_default();
    let run = experiment::Unloaded {
        time_s: next(),
        ankle_angle_deg: next(),
        torque_nm: next(),
        ..experiment::Unloaded::default()
    };
    Ok((None, Some(InMemory::new(run, "<unloaded dict>"))))
}

/// Runs a job and returns its JSON result as a dict.
fn run_to_dict<'py, F>(
    py: Python<'py>,
    progress: ProgressMode,
    job: F,
) -> PyResult<Bound<'py, PyAny>>
where
    F: FnOnce(&Reporter) -> AppResult + Send + 'static,
{
    let text = run_command(py, progress, job)?;
    json_to_py(py, &text)
}

/// Identifies LST, F0 and α0 of sol, gm and gl, as `surae identify` does, and returns the
/// `identify.json` it writes as a dict (equal to the command line's but for `wall_s`).
///
/// trial: a trial CSV path, or a dict of its columns (time_s, ankle_angle_deg, torque_nm,
///     emg_sol, emg_gm, emg_gl, optional emg_ta, knee_angle_deg; an fs key is ignored).
///     None: the bundled trial, with its unloaded run and truth.
/// unloaded: the unloaded run, a CSV path or a dict (time_s, ankle_angle_deg, torque_nm);
///     not defaulted when trial is given.
/// method: "sa" (simulated annealing with a polish), "mcmc" (Metropolis-Hastings) or "nuts"
///     (the No-U-Turn sampler along the model's exact gradient).
/// seed: seed of every random choice.
/// truth: true parameters (dict or JSON file); adds errors_pct.
/// max_iterations: MCMC only, a cap on the iterations per chain (nuts: warm-up plus draws).
/// params, effects: the fixed model, dicts or JSON files (as for simulate).
/// emg_is_envelope: the EMG columns already hold envelopes in [0, 1].
/// knee_angle_deg: a constant knee flexion (degrees) for a trial without a knee_angle_deg
///     column.
/// session: a session manifest path (docs/formats.md) in place of trial: its trials
///     identified together (method "sa"), with the manifest's parameters.
/// free: with session, the parameters identified (e.g. ["sol.lst_m", "activation.shape_a"]).
/// with_effects: catalogued effects whose parameters are identified with the muscles' (e.g.
///     ["electromechanical_delay"], as `surae identify --with`; uniform priors on their ranges).
/// chains: "sa" only, the number of annealing chains (starts; default 4).
/// out: folder keeping identify.json, the figures and report.html (default: no files are
///     written).
/// progress: None/False shows nothing; True one line on sys.stderr; a callable is called as
///     progress(label, position, total, message).
///
/// Runs with the GIL released; Ctrl-C stops it, raises KeyboardInterrupt and writes no result.
/// Bad input raises surae.InputError with the command line's message.
#[pyfunction]
#[pyo3(signature = (
    trial=None, unloaded=None, method="sa", seed=42, *, truth=None, max_iterations=None,
    params=None, effects=None, emg_is_envelope=false, knee_angle_deg=None, session=None,
    free=None, with_effects=None, chains=None, out=None, progress=None
))]
#[allow(clippy::too_many_arguments)]
pub fn identify<'py>(
    py: Python<'py>,
    trial: Option<&Bound<'py, PyAny>>,
    unloaded: Option<&Bound<'py, PyAny>>,
    method: &str,
    seed: u64,
    truth: Option<&Bound<'py, PyAny>>,
    max_iterations: Option<usize>,
    params: Option<&Bound<'py, PyAny>>,
    effects: Option<&Bound<'py, PyAny>>,
    emg_is_envelope: bool,
    knee_angle_deg: Option<f64>,
    session: Option<&Bound<'py, PyAny>>,
    free: Option<Vec<String>>,
    with_effects: Option<Vec<String>>,
    chains: Option<u32>,
    out: Option<&Bound<'py, PyAny>>,
    progress: Option<&Bound<'py, PyAny>>,
) -> PyResult<Bound<'py, PyAny>> {
    let method = match method {
        "sa" => Method::Sa,
        "mcmc" => Method::Mcmc,
        "nuts" => Method::Nuts,
        other => {
            return Err(bad(format!(
                "method '{other}': expected 'sa', 'mcmc' or 'nuts'"
            )))
        }
    };
    let progress = ProgressMode::from_arg(progress)?;
    let (trial, trial_data) = trial_arg(trial)?;
    let (unloaded, unloaded_data) = unloaded_arg(unloaded)?;
    let (truth, truth_data) = json_input(truth, "truth")?;
    let (params, params_data) = json_input(params, "params")?;
    let (effects, effects_data) = json_input(effects, "effects")?;
    let out = out_arg(out)?;
    let session = match session.filter(|s| !s.is_none()) {
        Some(s) => Some(path_arg(s, "session")?),
        None => None,
    };
    let args = IdentifyJob {
        method,
        trial,
        session,
        free,
        with_effects,
        chains,
        unloaded,
        seed,
        truth,
        max_iterations,
        model: ModelSettings {
            params,
            effects,
            params_data,
            effects_data,
            emg_is_envelope,
            knee: KneeSettings { knee_angle_deg },
            ..ModelSettings::default()
        },
        discard_files: out.is_none(),
        out,
        trial_data,
        unloaded_data,
        truth_data,
    };
    run_to_dict(py, progress, move |rep| surae_app::identify(args, rep))
}

/// What the model gets wrong, as `surae diagnose` finds it; returns the `diagnosis.json` it
/// writes as a dict (equal to the command line's but for `wall_s`).
///
/// trial, unloaded, emg_is_envelope, knee_angle_deg, out, progress: as for identify (the
///     diagnosis takes no seed: it is deterministic);
/// out keeps diagnosis.json, the figures and report.html.
/// session: a session manifest path in place of trial: every trial diagnosed on its own with
///     the session's model (params: a parameters file or an identify.json set over it);
///     returns diagnosis_session.json (each trial's diagnosis.json stays in out/<trial>).
#[pyfunction]
#[allow(clippy::too_many_arguments)]
#[pyo3(signature = (
    trial=None, unloaded=None, *, emg_is_envelope=false, knee_angle_deg=None,
    session=None, params=None, out=None, progress=None
))]
pub fn diagnose<'py>(
    py: Python<'py>,
    trial: Option<&Bound<'py, PyAny>>,
    unloaded: Option<&Bound<'py, PyAny>>,
    emg_is_envelope: bool,
    knee_angle_deg: Option<f64>,
    session: Option<&Bound<'py, PyAny>>,
    params: Option<&Bound<'py, PyAny>>,
    out: Option<&Bound<'py, PyAny>>,
    progress: Option<&Bound<'py, PyAny>>,
) -> PyResult<Bound<'py, PyAny>> {
    let progress = ProgressMode::from_arg(progress)?;
    let (trial, trial_data) = trial_arg(trial)?;
    let (unloaded, unloaded_data) = unloaded_arg(unloaded)?;
    let session = match session.filter(|s| !s.is_none()) {
        Some(s) => Some(path_arg(s, "session")?),
        None => None,
    };
    let (params, params_data) = json_input(params, "params")?;
    let out = out_arg(out)?;
    let args = DiagnoseJob {
        trial,
        unloaded,
        session,
        params,
        emg_is_envelope,
        knee: KneeSettings { knee_angle_deg },
        discard_files: out.is_none(),
        out,
        trial_data,
        unloaded_data,
        params_data,
    };
    run_to_dict(py, progress, move |rep| surae_app::diagnose(args, rep))
}

// The defaults are written as literals so that Python's signature shows them; they are the
// command line's, which these assertions hold them to.
const _: () = assert!(::design::OFFSET_PRIOR_SD_NM == 0.5);
const _: () = assert!(::design::DEFAULT_EMG_DRAWS == 16);
const _: () = assert!(::design::DEFAULT_EMG_SEED == 1);

/// The expected posterior sd of each of the 9 muscle parameters for candidate protocols, as
/// `surae design` computes it before anyone is tested; returns the `design.json` it writes as
/// a dict.
///
/// protocols: the candidate protocols, each a comma-separated list of trials
///     `knee<deg>@<speed>` with an optional `x<cycles>` (e.g. "knee0@30,knee90@30,knee0@60").
/// unloaded: an unloaded run (CSV path or dict) whose AR(1)+white noise replaces the synthetic
///     dynamometer's.
/// params: the design point (dict or parameters JSON / .osim path); nominal by default.
/// offset_sd: prior sd (N·m) of each trial's constant torque offset; 0 treats it as known.
/// emg_draws, emg_seed: how many synthetic EMG realisations the information is averaged over,
///     and the first seed.
/// out: folder keeping design.json and design.svg (default: no files are written).
/// progress: as for identify.
#[pyfunction]
#[pyo3(signature = (
    protocols, *, unloaded=None, params=None, offset_sd=0.5, emg_draws=16, emg_seed=1,
    out=None, progress=None
))]
#[allow(clippy::too_many_arguments)]
pub fn design<'py>(
    py: Python<'py>,
    protocols: Vec<String>,
    unloaded: Option<&Bound<'py, PyAny>>,
    params: Option<&Bound<'py, PyAny>>,
    offset_sd: f64,
    emg_draws: usize,
    emg_seed: u64,
    out: Option<&Bound<'py, PyAny>>,
    progress: Option<&Bound<'py, PyAny>>,
) -> PyResult<Bound<'py, PyAny>> {
    if protocols.is_empty() {
        return Err(bad("protocols: give at least one protocol".to_string()));
    }
    let progress = ProgressMode::from_arg(progress)?;
    let (unloaded, unloaded_data) = unloaded_arg(unloaded)?;
    let (params, params_data) = json_input(params, "params")?;
    let out = out_arg(out)?;
    let args = DesignJob {
        protocol: protocols,
        unloaded,
        params,
        osim_muscles: Vec::new(),
        offset_sd,
        emg_draws,
        emg_seed,
        discard_files: out.is_none(),
        out,
        unloaded_data,
        params_data,
    };
    run_to_dict(py, progress, move |rep| surae_app::design(args, rep))
}
