"""Type stubs of the native module ``surae._surae`` (re-exported by ``surae``)."""

import os
from typing import Any, Callable, Dict, Literal, Mapping, Optional, Sequence, Union

import numpy as np
import numpy.typing as npt

__all__ = [
    "InputError",
    "bundled_trial",
    "bundled_unloaded",
    "design",
    "diagnose",
    "envelope",
    "identify",
    "simulate",
]

_ArrayLike = npt.ArrayLike
_FloatArray = npt.NDArray[np.float64]
_PathLike = Union[str, "os.PathLike[str]"]
_JsonArg = Union[_PathLike, Mapping[str, Any]]
_ColumnsArg = Union[_PathLike, Mapping[str, _ArrayLike]]
_ProgressArg = Union[bool, Callable[[str, int, int, str], Any], None]

class InputError(ValueError):
    """Unusable input: the message is the command line's one-line error (file, line and
    column, or key / column name)."""

def envelope(
    emg: _ArrayLike,
    fs: float,
    mvc: Union[float, Sequence[float], None] = None,
) -> _FloatArray:
    """Normalised EMG envelope(s) of raw EMG sampled at ``fs`` Hz.

    Band-pass 10-350 Hz (zero-phase), rectify, low-pass 2 Hz (zero-phase), divide by the
    channel's maximum (or by ``mvc``) and clamp to [0, 1]: the columns ``surae envelope``
    writes.

    emg: one channel (1-D) or several (2-D, shape (channels, samples)); the result has the
        same shape.
    fs: sampling rate in Hz.
    mvc: a reference (one number, or one per channel) dividing the envelope instead of its
        maximum over the recording, in the raw EMG's unit after filtering and rectification.
    """

def simulate(
    angle_deg: _ArrayLike,
    emg_envelopes: Union[Mapping[str, _ArrayLike], _ArrayLike],
    fs: float,
    params: Optional[_JsonArg] = None,
    effects: Optional[_JsonArg] = None,
    *,
    t0: float = 0.0,
    knee_angle_deg: Optional[Union[float, _ArrayLike]] = None,
) -> Dict[str, _FloatArray]:
    """The model's joint torque, as ``surae simulate`` computes it.

    angle_deg: ankle angle in degrees (dorsiflexion > 0), one value per sample.
    emg_envelopes: normalised envelopes in [0, 1]: a dict with keys ``sol``, ``gm``, ``gl``,
        optionally ``ta`` and one per further muscle of ``params`` (an ``emg_`` prefix is
        accepted), or an array of shape (3, n) (sol, gm, gl) or (4, n) (sol, gm, gl, ta).
    fs: sampling rate in Hz.
    params: model parameters as a dict or a parameters JSON file (any subset; the rest is
        nominal).
    effects: effects as a dict or an effects JSON file, ``{"<effect>": {"<param>": value}}``.
    t0: time of the first sample in seconds.
    knee_angle_deg: knee flexion in degrees (0 extended), a number or one value per sample;
        the gastrocnemii shorten by 0.020 m per radian of flexion.

    Returns a dict of arrays: ``time_s`` (``t0 + i/fs``), ``ankle_angle_deg``, ``torque_nm``,
    and ``torque_<muscle>_nm`` for sol, gm, gl and every further muscle (N·m, plantarflexion
    > 0; a dorsiflexor's torque is negative).
    """

def bundled_trial() -> Dict[str, Any]:
    """The bundled trial (the default of every command) as a dict: the trial file's columns
    ``time_s``, ``ankle_angle_deg``, ``torque_nm``, ``emg_sol``, ``emg_gm``, ``emg_gl`` (numpy
    arrays) and ``fs``, its sampling rate in Hz."""

def bundled_unloaded() -> Dict[str, Any]:
    """The bundled trial's unloaded run as a dict: ``time_s``, ``ankle_angle_deg``,
    ``torque_nm`` (numpy arrays) and ``fs`` (Hz)."""

def identify(
    trial: Optional[_ColumnsArg] = None,
    unloaded: Optional[_ColumnsArg] = None,
    method: Literal["sa", "mcmc"] = "sa",
    seed: int = 42,
    *,
    truth: Optional[_JsonArg] = None,
    max_iterations: Optional[int] = None,
    params: Optional[_JsonArg] = None,
    effects: Optional[_JsonArg] = None,
    emg_is_envelope: bool = False,
    knee_angle_deg: Optional[float] = None,
    session: Optional[_PathLike] = None,
    free: Optional[Sequence[str]] = None,
    with_effects: Optional[Sequence[str]] = None,
    chains: Optional[int] = None,
    out: Optional[_PathLike] = None,
    progress: _ProgressArg = None,
) -> Dict[str, Any]:
    """Identify LST, F0 and alpha0 of sol, gm and gl; returns ``identify.json`` as a dict.

    Runs the code of ``surae identify`` and returns the JSON it writes, so the values equal
    the command line's for the same inputs and seed (``wall_s`` is a measured time).

    trial: a trial CSV path, or a dict of its columns (``time_s``, ``ankle_angle_deg``,
        ``torque_nm``, ``emg_sol``, ``emg_gm``, ``emg_gl``, optional ``emg_ta``,
        ``knee_angle_deg``; an ``fs`` key is ignored). None: the bundled trial, with its
        unloaded run and truth.
    unloaded: the unloaded run, as a CSV path or a dict (``time_s``, ``ankle_angle_deg``,
        ``torque_nm``). Never defaulted when ``trial`` is given.
    method: ``"sa"`` (simulated annealing with a polish) or ``"mcmc"`` (Metropolis-Hastings).
    seed: seed of every random choice.
    truth: true parameters (dict or JSON file), adds ``errors_pct``.
    max_iterations: MCMC only, cap on the iterations per chain.
    params, effects: the fixed model (dicts or JSON files), as for :func:`simulate`.
    emg_is_envelope: the trial's EMG columns already hold envelopes in [0, 1].
    knee_angle_deg: a constant knee flexion in degrees, for a trial without a
        ``knee_angle_deg`` column.
    session: a session manifest path, in place of ``trial``: its trials (trial CSVs or CEINMS
        trial folders) identified together by ``"sa"``, with the manifest's parameters.
    free: with ``session``, the parameters identified, e.g. ``["sol.lst_m",
        "activation.shape_a"]`` (default: LST, F0 and alpha0 of sol, gm and gl).
    with_effects: catalogued effects whose parameters are identified with the muscles', e.g.
        ``["electromechanical_delay"]`` (``surae identify --with``; uniform priors on their
        ranges). They appear in ``params`` (``"electromechanical_delay.delay_ms"``) and, for
        MCMC, in ``posterior``.
    chains: ``"sa"`` only, the number of annealing chains (starts); default 4 (a
        session with the recording defaults adds 4 when the best two disagree by more than 1 %).
    out: folder for ``identify.json``, the figures and ``report.html`` (and the chain files of
        MCMC); by default no file is written.
    progress: None (default) or False shows nothing; True writes one line on ``sys.stderr``,
        updated in place; a callable is called as ``progress(label, position, total,
        message)``.

    The work runs with the GIL released; Ctrl-C stops it and raises KeyboardInterrupt (no
    results are written).
    """

def diagnose(
    trial: Optional[_ColumnsArg] = None,
    unloaded: Optional[_ColumnsArg] = None,
    *,
    emg_is_envelope: bool = False,
    knee_angle_deg: Optional[float] = None,
    session: Optional[_PathLike] = None,
    params: Optional[_JsonArg] = None,
    out: Optional[_PathLike] = None,
    progress: _ProgressArg = None,
) -> Dict[str, Any]:
    """What the model gets wrong; returns ``diagnosis.json`` as a dict.

    Runs the code of ``surae diagnose``: residual analysis, the named cause(s), the extended
    model and its held-out gain. Arguments as for :func:`identify`; ``out`` receives
    ``diagnosis.json``, the figures and ``report.html``.

    session: a session manifest path in place of ``trial``: every trial is diagnosed on its
        own with the session's model; returns ``diagnosis_session.json`` (each trial's
        ``diagnosis.json`` is in ``out/<trial>``). params: with ``session``, a parameters
        file, dict or ``identify.json`` set over the session's parameters.
    """

def design(
    protocols: Sequence[str],
    *,
    unloaded: Optional[_ColumnsArg] = None,
    params: Optional[_JsonArg] = None,
    offset_sd: float = 0.5,
    emg_draws: int = 16,
    emg_seed: int = 1,
    out: Optional[_PathLike] = None,
    progress: _ProgressArg = None,
) -> Dict[str, Any]:
    """Expected posterior sds of the 9 muscle parameters for candidate protocols, before
    anyone is tested; returns ``design.json`` as a dict.

    Runs the code of ``surae design``: the Fisher information of the model with the
    dynamometer's AR(1)+white noise, summed over each protocol's trials.

    protocols: each a comma-separated list of trials ``knee<deg>@<speed>`` with an optional
        ``x<cycles>``, e.g. ``"knee0@30,knee90@30,knee0@60"``.
    unloaded: an unloaded run (path or dict) whose noise replaces the synthetic one.
    params: the design point (dict or parameters JSON / ``.osim`` path); nominal by default.
    offset_sd: prior sd (N·m) of each trial's constant torque offset; 0 treats it as known.
    emg_draws, emg_seed: number of synthetic EMG realisations averaged, and the first seed.
    out: folder keeping ``design.json`` and ``design.svg`` (default: no file is written).
    progress: as for :func:`identify`.
    """
