#!/usr/bin/env python3
"""Independent plain-Python implementation of the surae triceps-surae model.

Two uses:

1. an *independent implementation* the Rust model is checked against (torque per sample);
2. the *benchmark peer*: the same model integrated by ``scipy.integrate.solve_ivp``
   (``method='RK45'``) with a plain-Python right-hand side, timed on the same trial.

Written from the project's specification of the model only, without reading the Rust code:
the equations and constants documented in docs/model.md and the file formats and effects in
docs/formats.md.  Per muscle j in (sol, gm, gl) the state is
``[a, FT~, LM, LMT]``; the fibre velocity is found with ``scipy.optimize.brentq`` on a
bracket that always contains the unique root (no closed form on purpose).

Command line::

    python3 surae_peer.py --trial T.csv [--params P.json] [--effects E.json]
                          [--out torque.csv] [--rtol 1e-6] [--atol 1e-6]
                          [--time] [--repeat 3] [--states] [--check]

Importable functions: ``read_trial``, ``envelope``, ``load_params``, ``load_effects``,
``prepare``, ``simulate``.
"""

from __future__ import annotations

import argparse
import copy
import json
import math
import statistics
import sys
import time

import numpy as np
from scipy.integrate import solve_ivp
from scipy.optimize import brentq
from scipy.signal import butter, sosfiltfilt

MUSCLES = ("sol", "gm", "gl")

NOMINAL = {
    "muscles": {
        "sol": {"fom_n": 3549.0, "lom_m": 0.050, "lst_m": 0.250, "alpha_deg": 25.0,
                "vmax_lom_per_s": 10.0, "lmt_poly_m": [0.29139, 0.04535, -0.00752, -0.00633]},
        "gm": {"fom_n": 1558.0, "lom_m": 0.060, "lst_m": 0.390, "alpha_deg": 17.0,
               "vmax_lom_per_s": 10.0, "lmt_poly_m": [0.45070, 0.04628, -0.00514, -0.00708]},
        "gl": {"fom_n": 683.0, "lom_m": 0.064, "lst_m": 0.380, "alpha_deg": 8.0,
               "vmax_lom_per_s": 10.0, "lmt_poly_m": [0.44706, 0.04720, -0.00564, -0.00717]},
    },
    "activation": {"tau_act_s": 0.015, "tau_deact_s": 0.05, "shape_a": 0.08},
    "curves": {"af": 0.25, "flen": 1.4, "gamma": 0.45, "kpe": 5.0, "e0m": 0.6,
               "e0t": 0.04, "damping": 0.1},
}

# Effects (docs/formats.md, "Effects JSON"): effect name -> {parameter: null value}
EFFECTS = {
    "torque_offset": {"offset_nm": 0.0},
    "passive_joint_torque": {"scale_nm": 0.0, "stiffness_per_rad": 10.0},
    "gravity": {"moment_nm": 0.0, "phase_deg": 0.0},
    "electromechanical_delay": {"delay_ms": 0.0},
    "fatigue": {"rate_per_s": 0.0},
    "antagonist_coactivation": {"gain_nm": 0.0},
    "eccentric_enhancement": {"flen": None},  # None: keep curves.flen
    "viscous_damping": {"b_nm_s_per_rad": 0.0},
    "inertia": {"i_kg_m2": 0.0},
}

ALPHA_CAP = math.radians(84.0)
SIN_CAP = math.sin(ALPHA_CAP)
COS_CAP = math.cos(ALPHA_CAP)

# Tendon curve constants that do not depend on e0t (docs/model.md, section 3)
FTOE = 0.33
KTOE = 3.0


class PeerError(Exception):
    """Bad input (file, JSON, column) or a numerical failure."""


# --------------------------------------------------------------------------- files

REQUIRED = ("time_s", "ankle_angle_deg", "torque_nm", "emg_sol", "emg_gm", "emg_gl")
OPTIONAL = ("emg_ta", "knee_angle_deg")


def read_trial(path):
    """Read a trial CSV (docs/formats.md). Returns dict column -> np.ndarray (float64)."""
    try:
        with open(path, "r", encoding="utf-8") as fh:
            lines = fh.read().splitlines()
    except OSError as exc:
        raise PeerError(f"{path}: cannot read: {exc}") from exc
    header = None
    rows = []
    for lineno, line in enumerate(lines, start=1):
        s = line.strip()
        if not s or s.startswith("#"):
            continue
        fields = [f.strip() for f in s.split(",")]
        if header is None:
            header = fields
            for col in REQUIRED:
                if col not in header:
                    raise PeerError(f"{path}:{lineno}: missing required column '{col}'")
            continue
        if len(fields) != len(header):
            raise PeerError(f"{path}:{lineno}: expected {len(header)} fields, got {len(fields)}")
        try:
            rows.append([float(f) for f in fields])
        except ValueError as exc:
            raise PeerError(f"{path}:{lineno}: not a number ({exc})") from exc
    if header is None or len(rows) < 4:
        raise PeerError(f"{path}: no header or fewer than 4 data rows")
    data = np.asarray(rows, dtype=float)
    out = {name: data[:, i].copy() for i, name in enumerate(header)
           if name in REQUIRED or name in OPTIONAL}
    t = out["time_s"]
    dt = np.diff(t)
    if np.any(dt <= 0):
        raise PeerError(f"{path}: time_s is not strictly increasing")
    h = (t[-1] - t[0]) / (len(t) - 1)
    if np.max(np.abs(dt - h)) > 1e-6 * max(h, 1e-12) + 1e-9:
        raise PeerError(f"{path}: sampling is not uniform (max |dt - mean dt| = "
                        f"{np.max(np.abs(dt - h)):.3g} s)")
    if not np.all(np.isfinite(data)):
        raise PeerError(f"{path}: non-finite value in the data")
    return out


def _merge(base, over, where):
    for key, val in over.items():
        if key not in base:
            raise PeerError(f"{where}: unknown key '{key}'")
        if isinstance(base[key], dict):
            if not isinstance(val, dict):
                raise PeerError(f"{where}.{key}: expected an object")
            _merge(base[key], val, f"{where}.{key}")
        else:
            base[key] = val


def load_params(path=None, obj=None):
    """Nominal parameters (docs/model.md, section 3) with a partial parameters JSON
    (docs/formats.md) merged over them.

    Also accepts flat identified names (``{"sol.lst_m": 0.26}``, at top level or under
    ``"params"`` as in identify.json).
    """
    params = copy.deepcopy(NOMINAL)
    if path is not None:
        try:
            with open(path, "r", encoding="utf-8") as fh:
                obj = json.load(fh)
        except (OSError, ValueError) as exc:
            raise PeerError(f"{path}: {exc}") from exc
    if obj is None:
        return params
    obj = dict(obj)
    flat = dict(obj.pop("params", {}) or {})
    for k in list(obj):
        if "." in k:
            flat[k] = obj.pop(k)
    for k in ("method", "rms_nm", "evaluations", "wall_s", "errors_pct", "posterior"):
        obj.pop(k, None)  # tolerate an identify.json
    _merge(params, obj, str(path or "params"))
    for name, val in flat.items():
        m, _, key = name.partition(".")
        if m not in params["muscles"] or key not in params["muscles"][m]:
            raise PeerError(f"{path or 'params'}: unknown parameter '{name}'")
        params["muscles"][m][key] = float(val)
    return params


def load_effects(path=None, obj=None):
    """Effects JSON (docs/formats.md) -> dict name -> {param: value} for the named effects."""
    if path is not None:
        try:
            with open(path, "r", encoding="utf-8") as fh:
                obj = json.load(fh)
        except (OSError, ValueError) as exc:
            raise PeerError(f"{path}: {exc}") from exc
    effects = {}
    for name, pars in (obj or {}).items():
        if name not in EFFECTS:
            raise PeerError(f"{path or 'effects'}: unknown effect '{name}' "
                            f"(known: {', '.join(EFFECTS)})")
        merged = dict(EFFECTS[name])
        for k, v in (pars or {}).items():
            if k not in merged:
                raise PeerError(f"{path or 'effects'}: effect '{name}' has no parameter '{k}'")
            merged[k] = float(v)
        effects[name] = merged
    return effects


# --------------------------------------------------------------------------- EMG signal

def envelope(x, fs, mvc=None):
    """EMG to envelope: band-pass 10-350 Hz (butter 2 -> 4th-order), rectify, low-pass 2 Hz
    (4th order), both with scipy's default sosfiltfilt; divide by max (or mvc); clip [0, 1]."""
    bp = butter(2, [10.0, 350.0], btype="bandpass", fs=fs, output="sos")
    lp = butter(4, 2.0, btype="low", fs=fs, output="sos")
    env = sosfiltfilt(lp, np.abs(sosfiltfilt(bp, np.asarray(x, dtype=float))))
    ref = float(np.max(env)) if mvc is None else float(mvc)
    if not ref > 0.0:
        raise PeerError("EMG envelope maximum is not positive (flat channel?)")
    return np.clip(env / ref, 0.0, 1.0)


# --------------------------------------------------------------------------- curves

def manal_buchanan(shape_a):
    """Return f_A as a Python closure (Manal & Buchanan 2003 A-model)."""
    if shape_a == 0.0:
        return lambda a: a
    if not 0.0 < shape_a <= 0.12:
        raise PeerError(f"activation.shape_a = {shape_a} outside (0, 0.12]")
    u0 = 0.3085 - shape_a / math.sqrt(2.0)
    a0 = 0.3085 + shape_a / math.sqrt(2.0)
    m = (1.0 - a0) / (1.0 - u0)
    # alpha*ln(beta*u0+1) = a0 and alpha*beta/(beta*u0+1) = m.  With x = beta*u0:
    # (x+1)*ln(x+1)/x = a0/(m*u0) =: g  (g > 1 for A > 0); solve for x.
    g = a0 / (m * u0)
    x = brentq(lambda x: (x + 1.0) * math.log1p(x) / x - g, 1e-12, 1e6, xtol=1e-15, rtol=1e-15)
    beta = x / u0
    alpha = m * (x + 1.0) / beta

    def f_a(a):
        if a >= u0:
            return m * a + (1.0 - m)
        return alpha * math.log(beta * a + 1.0)

    return f_a


class Muscle:
    """Constants of one musculotendon unit (plain attributes, read in the RHS)."""

    def __init__(self, name, mp, curves, flen):
        self.name = name
        self.f0 = float(mp["fom_n"])
        self.lom = float(mp["lom_m"])
        self.lst = float(mp["lst_m"])
        self.alpha0 = math.radians(float(mp["alpha_deg"]))
        self.vmax = float(mp["vmax_lom_per_s"]) * self.lom
        c = [float(v) for v in mp["lmt_poly_m"]]
        if len(c) != 4:
            raise PeerError(f"muscles.{name}.lmt_poly_m must have 4 coefficients")
        self.c0, self.c1, self.c2, self.c3 = c
        self.h = self.lom * math.sin(self.alpha0)
        self.lm_cap = self.h / SIN_CAP  # fibre length at which alpha reaches 84 deg
        self.gamma = float(curves["gamma"])
        self.kpe = float(curves["kpe"])
        self.e0m = float(curves["e0m"])
        self.pe_den = math.exp(self.kpe) - 1.0
        self.e0t = float(curves["e0t"])
        self.etoe = 0.609 * self.e0t
        self.klin = 1.712 / self.e0t
        self.toe_den = math.exp(KTOE) - 1.0
        self.af = float(curves["af"])
        self.flen = float(flen)
        self.cecc = (self.flen - 1.0) * self.af / (2.0 * (1.0 + self.af))
        self.beta = float(curves["damping"])
        if not (self.f0 > 0 and self.lom > 0 and self.lst > 0 and self.vmax > 0 and self.beta > 0):
            raise PeerError(f"muscle {name}: fom_n, lom_m, lst_m, vmax and damping must be > 0")

    # geometry
    def lmt(self, q):
        return self.c0 + q * (self.c1 + q * (self.c2 + q * self.c3))

    def r(self, q):
        return self.c1 + q * (2.0 * self.c2 + q * 3.0 * self.c3)

    # pennation: returns cos(alpha)
    def cos_alpha(self, lm):
        if lm <= self.lm_cap:  # also guards lm <= 0 in rejected trial steps
            return COS_CAP
        s = self.h / lm
        return math.sqrt(1.0 - s * s)

    def fl(self, lt):
        return math.exp(-(lt - 1.0) ** 2 / self.gamma)

    def fpe(self, lt):
        if lt <= 1.0:
            return 0.0
        x = self.kpe * (lt - 1.0) / self.e0m
        return (math.exp(x if x < 700.0 else 700.0) - 1.0) / self.pe_den

    def ft(self, eps):
        if eps <= 0.0:
            return 0.0
        if eps <= self.etoe:
            return FTOE * (math.exp(KTOE * eps / self.etoe) - 1.0) / self.toe_den
        return self.klin * (eps - self.etoe) + FTOE

    def dft(self, eps):
        if eps <= 0.0:
            return 0.0
        if eps <= self.etoe:
            return FTOE * KTOE / self.etoe * math.exp(KTOE * eps / self.etoe) / self.toe_den  # eps <= etoe: no overflow
        return self.klin

    def fv(self, v):
        if v <= -1.0:
            return 0.0
        if v <= 0.0:
            return (1.0 + v) / (1.0 - v / self.af)
        return (self.flen * v + self.cecc) / (v + self.cecc)

    def strain(self, lmt, lm):
        return (lmt - lm * self.cos_alpha(lm) - self.lst) / self.lst

    def fibre_velocity(self, fm, act_fl, fpe):
        """Solve fm = act_fl*fv(v) + fpe + beta*v for v~ (brentq on a guaranteed bracket)."""
        beta = self.beta
        hi = (fm - fpe) / beta  # fv >= 0
        if act_fl <= 0.0:
            return hi
        lo = (fm - fpe - act_fl * self.flen) / beta  # fv <= Flen
        if hi - lo <= 1e-14:
            return hi
        fv = self.fv

        def g(v):
            return act_fl * fv(v) + fpe + beta * v - fm

        return brentq(g, lo, hi, xtol=1e-13, rtol=1e-15, maxiter=200)

    def static_lm(self, act, lmt):
        """LM at static equilibrium (v~ = 0): fT(eps)/cos(alpha) = act*fl + fpe."""
        lom = self.lom

        def g(lm):
            lt = lm / lom
            return self.ft(self.strain(lmt, lm)) / self.cos_alpha(lm) - act * self.fl(lt) - self.fpe(lt)

        lo = self.lm_cap  # pennation at the cap: tendon longest
        hi = lmt  # tendon length <= 0: fT = 0, fpe > 0
        glo, ghi = g(lo), g(hi)
        if glo < 0.0 or ghi > 0.0:
            raise PeerError(f"muscle {self.name}: no static equilibrium in [{lo:.4g}, {hi:.4g}] m "
                            f"at LMT = {lmt:.4g} m")
        lm = brentq(g, lo, hi, xtol=1e-15, rtol=1e-15, maxiter=200)
        if self.ft(self.strain(lmt, lm)) == 0.0:
            # act*fl(l~) = 0 with a slack tendon and l~ <= 1: every fibre length with a slack
            # tendon and no passive force is an equilibrium.  Take the limit act -> 0+, i.e.
            # the fibre length at which the tendon is exactly at slack length.
            d = lmt - self.lst
            lm_slack = math.sqrt(d * d + self.h * self.h) if d > 0.0 else lo
            if lm_slack / lom <= 1.0 and abs(g(lm_slack)) <= 1e-12:
                lm = lm_slack
        return lm


# --------------------------------------------------------------------------- model

def _hermite_slopes(t, q):
    """Central differences inside, one-sided at the ends (numpy.gradient, edge_order=1)."""
    return np.gradient(q, t)


def prepare(trial, params=None, effects=None, envelopes_given=False, mvc=None):
    """Everything that does not change between simulations: envelopes, q, slopes, muscles.

    Returns a ``Model`` ready for ``simulate``.
    """
    params = params if params is not None else load_params()
    effects = effects if effects is not None else {}
    t = np.asarray(trial["time_s"], dtype=float)
    fs = (len(t) - 1) / (t[-1] - t[0])
    env = {}
    for m in MUSCLES:
        x = trial[f"emg_{m}"]
        env[m] = np.clip(x, 0.0, 1.0) if envelopes_given else envelope(x, fs, (mvc or {}).get(m))
    if "antagonist_coactivation" in effects:
        if "emg_ta" not in trial:
            raise PeerError("effect antagonist_coactivation needs an emg_ta column")
        x = trial["emg_ta"]
        env["ta"] = np.clip(x, 0.0, 1.0) if envelopes_given else envelope(x, fs, (mvc or {}).get("ta"))
    q = np.radians(np.asarray(trial["ankle_angle_deg"], dtype=float))
    return Model(t, q, env, params, effects)


class Model:
    def __init__(self, t, q, env, params, effects):
        self.t = t
        self.q = q
        self.qd = _hermite_slopes(t, q)
        self.env = env
        self.params = params
        self.effects = effects
        act = params["activation"]
        self.tau_act = float(act["tau_act_s"])
        self.tau_deact = float(act["tau_deact_s"])
        self.f_a = manal_buchanan(float(act["shape_a"]))
        flen = params["curves"]["flen"]
        ecc = effects.get("eccentric_enhancement")
        if ecc is not None and ecc["flen"] is not None:
            flen = ecc["flen"]
        self.muscles = [Muscle(m, params["muscles"][m], params["curves"], flen) for m in MUSCLES]
        self.delay = effects.get("electromechanical_delay", {}).get("delay_ms", 0.0) / 1000.0
        self.fatigue = effects.get("fatigue", {}).get("rate_per_s", 0.0) if "fatigue" in effects else None
        self.coact = "antagonist_coactivation" in effects

    # ---- plain-Python RHS ------------------------------------------------------
    def make_rhs(self):
        """Build the RHS closure over Python lists (no numpy in the hot path)."""
        t0 = float(self.t[0])
        n = len(self.t)
        h = (float(self.t[-1]) - t0) / (n - 1)
        qs = self.q.tolist()
        ms = self.qd.tolist()
        envs = [self.env[m].tolist() for m in MUSCLES]
        env_ta = self.env["ta"].tolist() if self.coact else None
        delay = self.delay
        k2 = 1.0 / self.tau_deact
        k1 = 1.0 / self.tau_act - k2
        f_a = self.f_a
        muscles = self.muscles
        fat = self.fatigue
        coact = self.coact
        counter = [0]

        def locate(tt):
            x = (tt - t0) / h
            i = int(x)
            if i < 0:
                return 0, 0.0
            if i >= n - 1:
                return n - 2, 1.0
            return i, x - i

        def rhs(t, y):
            counter[0] += 1
            # q(t), qdot(t): cubic Hermite with central-difference slopes
            i, s = locate(t)
            q0 = qs[i]
            q1 = qs[i + 1]
            m0 = ms[i] * h
            m1 = ms[i + 1] * h
            s2 = s * s
            s3 = s2 * s
            q = (2 * s3 - 3 * s2 + 1) * q0 + (s3 - 2 * s2 + s) * m0 + (-2 * s3 + 3 * s2) * q1 + (s3 - s2) * m1
            qd = ((6 * s2 - 6 * s) * (q0 - q1) + (3 * s2 - 4 * s + 1) * m0 + (3 * s2 - 2 * s) * m1) / h
            # u(t - d): linear interpolation, held at the first sample before t0
            j, w = locate(t - delay)
            dy = [0.0] * len(y)
            for k in range(3):
                e = envs[k]
                u = e[j] + w * (e[j + 1] - e[j])
                u = 0.0 if u < 0.0 else (1.0 if u > 1.0 else u)
                b = 4 * k
                a = y[b]
                ft = y[b + 1]
                lm = y[b + 2]
                lmt = y[b + 3]
                mu = muscles[k]
                dy[b] = (u - a) * (k1 * u + k2)
                ahat = f_a(a if a > 0.0 else 0.0)
                ca = mu.cos_alpha(lm)
                lt = lm / mu.lom
                act_fl = ahat * mu.fl(lt)
                if fat is not None:
                    act_fl *= math.exp(-fat * y[12 + k])
                    dy[12 + k] = ahat
                v = mu.fibre_velocity(ft / ca, act_fl, mu.fpe(lt)) * mu.vmax
                vmt = mu.r(q) * qd
                eps = (lmt - lm * ca - mu.lst) / mu.lst
                dy[b + 1] = mu.dft(eps) / mu.lst * (vmt - v / ca)
                dy[b + 2] = v
                dy[b + 3] = vmt
            if coact:
                e = env_ta
                u = e[j] + w * (e[j + 1] - e[j])
                u = 0.0 if u < 0.0 else (1.0 if u > 1.0 else u)
                ia = len(y) - 1
                dy[ia] = (u - y[ia]) * (k1 * u + k2)
            return dy

        return rhs, counter

    def initial_state(self):
        y = []
        q0 = float(self.q[0])
        u0s = []
        # u(0) = env(0 - d) = env(t0) (held before the first sample)
        for k, m in enumerate(MUSCLES):
            u0 = min(max(float(self.env[m][0]), 0.0), 1.0)
            u0s.append(u0)
            mu = self.muscles[k]
            lmt = mu.lmt(q0)
            lm = mu.static_lm(self.f_a(u0), lmt)
            y += [u0, mu.ft(mu.strain(lmt, lm)), lm, lmt]
        if self.fatigue is not None:
            y += [0.0, 0.0, 0.0]
        if self.coact:
            y.append(min(max(float(self.env["ta"][0]), 0.0), 1.0))
        return y

    def simulate(self, rtol=1e-6, atol=1e-6):
        """Integrate over the trial; return dict with torques at every sample, states, stats."""
        rhs, counter = self.make_rhs()
        y0 = self.initial_state()
        t = self.t
        with np.errstate(over="ignore"):  # rejected trial steps may overflow the error norm
            sol = solve_ivp(rhs, (float(t[0]), float(t[-1])), y0, method="RK45",
                            t_eval=t, rtol=rtol, atol=atol)
        if sol.status != 0:
            raise PeerError(f"integration failed: {sol.message}")
        y = sol.y
        q = self.q
        tq = {}
        total = np.zeros_like(t)
        for k, mu in enumerate(self.muscles):
            r = mu.c1 + q * (2.0 * mu.c2 + q * 3.0 * mu.c3)
            tq[mu.name] = y[4 * k + 1] * mu.f0 * r
            total = total + tq[mu.name]
        ef = self.effects
        if "torque_offset" in ef:
            total = total + ef["torque_offset"]["offset_nm"]
        if "passive_joint_torque" in ef:
            p = ef["passive_joint_torque"]
            total = total + p["scale_nm"] * (np.exp(p["stiffness_per_rad"] * q) - 1.0)
        if "gravity" in ef:
            p = ef["gravity"]
            total = total + p["moment_nm"] * np.sin(q - math.radians(p["phase_deg"]))
        if "viscous_damping" in ef:
            total = total + ef["viscous_damping"]["b_nm_s_per_rad"] * self.qd
        if "inertia" in ef:
            total = total - ef["inertia"]["i_kg_m2"] * second_difference(t, q)
        if self.coact:
            total = total - ef["antagonist_coactivation"]["gain_nm"] * y[-1]
        return {"time_s": t, "torque_nm": total, "torque_by_muscle": tq, "y": y,
                "nfev": sol.nfev, "rhs_calls": counter[0], "nsteps": len(sol.t)}


def second_difference(t, q):
    """q'' at the samples: central second difference, copied from the neighbour at the ends."""
    h = (t[-1] - t[0]) / (len(t) - 1)
    qdd = np.empty_like(q)
    qdd[1:-1] = (q[2:] - 2.0 * q[1:-1] + q[:-2]) / (h * h)
    qdd[0] = qdd[1]
    qdd[-1] = qdd[-2]
    return qdd


def invariant_errors(model, res):
    """max |FT~ - fT(eps(LMT, LM))| and max |LMT - LMT(q)| over the samples, per muscle."""
    out = {}
    y = res["y"]
    for k, mu in enumerate(model.muscles):
        ft, lm, lmt = y[4 * k + 1], y[4 * k + 2], y[4 * k + 3]
        e_ft = max(abs(ft[i] - mu.ft(mu.strain(lmt[i], lm[i]))) for i in range(len(ft)))
        e_lmt = float(np.max(np.abs(lmt - mu.lmt(model.q))))
        out[mu.name] = (e_ft, e_lmt)
    return out


def simulate(trial, params=None, effects=None, rtol=1e-6, atol=1e-6, **kw):
    """One-call convenience: envelopes + simulation. Returns the result dict of Model.simulate."""
    return prepare(trial, params, effects, **kw).simulate(rtol=rtol, atol=atol)


def write_csv(path, model, res, states=False):
    cols = ["time_s", "torque_nm", "torque_sol_nm", "torque_gm_nm", "torque_gl_nm"]
    data = [res["time_s"], res["torque_nm"]] + [res["torque_by_muscle"][m] for m in MUSCLES]
    if states:
        for k, m in enumerate(MUSCLES):
            cols += [f"a_{m}", f"ft_{m}", f"lm_{m}_m", f"lmt_{m}_m"]
            data += [res["y"][4 * k + i] for i in range(4)]
    arr = np.column_stack(data)
    with open(path, "w", encoding="utf-8") as fh:
        fh.write(",".join(cols) + "\n")
        for row in arr:
            fh.write(",".join(f"{v:.10g}" for v in row) + "\n")


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--trial", required=True, help="trial CSV (docs/formats.md)")
    ap.add_argument("--params", help="parameters JSON (docs/formats.md), merged over nominal")
    ap.add_argument("--effects", help="effects JSON (docs/formats.md)")
    ap.add_argument("--out", help="output CSV (time_s, torque_nm, torque_sol_nm, ...)")
    ap.add_argument("--rtol", type=float, default=1e-6)
    ap.add_argument("--atol", type=float, default=1e-6, help="solve_ivp atol (scipy default 1e-6)")
    ap.add_argument("--time", action="store_true", help="time the simulation")
    ap.add_argument("--repeat", type=int, default=3, help="repeats for --time (median reported)")
    ap.add_argument("--states", action="store_true", help="also write the 12 states to --out")
    ap.add_argument("--check", action="store_true", help="report the invariants along the run")
    ap.add_argument("--envelopes", action="store_true", help="EMG columns are already envelopes")
    args = ap.parse_args(argv)
    try:
        trial = read_trial(args.trial)
        params = load_params(args.params)
        effects = load_effects(args.effects)
        model = prepare(trial, params, effects, envelopes_given=args.envelopes)
        walls = []
        res = None
        for _ in range(max(1, args.repeat if args.time else 1)):
            t0 = time.perf_counter()
            res = model.simulate(rtol=args.rtol, atol=args.atol)
            walls.append(time.perf_counter() - t0)
    except PeerError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    tau = res["torque_nm"]
    print(f"samples {len(tau)}, torque min {tau.min():.3f} N·m, max {tau.max():.3f} N·m, "
          + ", ".join(f"{m} max {res['torque_by_muscle'][m].max():.2f}" for m in MUSCLES))
    if args.time:
        print(f"wall per simulation: median {statistics.median(walls):.4f} s over {len(walls)} "
              f"(all: {', '.join(f'{w:.4f}' for w in walls)}); RHS calls {res['rhs_calls']} "
              f"(solve_ivp nfev {res['nfev']}); rtol {args.rtol:g}, atol {args.atol:g}")
    if args.check:
        for m, (e_ft, e_lmt) in invariant_errors(model, res).items():
            print(f"{m}: max |FT~ - fT(eps)| = {e_ft:.3e}, max |LMT - LMT(q)| = {e_lmt:.3e} m")
    if args.out:
        write_csv(args.out, model, res, states=args.states)
        print(f"wrote {args.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
