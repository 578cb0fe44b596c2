#!/usr/bin/env python3
"""Self-checks of surae_peer.py on a synthetic seed-protocol trial.  Run: python3 test_peer.py

Also checks the envelope against scipy's outputs in
crates/signal/tests/data/scipy_reference.json (the reference the Rust signal crate is tested
against).
"""

import json
import math
import os
import sys

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)

import gen_test_trial  # noqa: E402
import surae_peer as p  # noqa: E402

FAILS = []


def check(name, cond, detail=""):
    print(("ok   " if cond else "FAIL ") + name + (f"  ({detail})" if detail else ""))
    if not cond:
        FAILS.append(name)


def main():
    trial = gen_test_trial.make_trial(seed=1)

    # 1. Manal-Buchanan: continuity of value and slope at u0, f(0)=0, f(1)=1.
    for shape in (0.01, 0.08, 0.12):
        f = p.manal_buchanan(shape)
        u0 = 0.3085 - shape / math.sqrt(2)
        dv = abs(f(u0 - 1e-9) - f(u0 + 1e-9))
        s_lo = (f(u0 - 1e-7) - f(u0 - 2e-7)) / 1e-7
        s_hi = (f(u0 + 2e-7) - f(u0 + 1e-7)) / 1e-7
        check(f"manal_buchanan A={shape} continuous", dv < 1e-8 and abs(s_lo - s_hi) < 1e-5
              and abs(f(0.0)) < 1e-15 and abs(f(1.0) - 1) < 1e-15, f"jump {dv:.1e}, slopes {s_lo:.6f}/{s_hi:.6f}")

    # 2. Curves: fv slope at 0+ is twice the slope at 0-; tendon curve nearly C1 at etoe.
    mu = p.Muscle("sol", p.NOMINAL["muscles"]["sol"], p.NOMINAL["curves"], 1.4)
    d = 1e-7
    s_ecc = (mu.fv(d) - 1) / d
    s_con = (1 - mu.fv(-d)) / d
    check("fv eccentric slope = 2x concentric at 0", abs(s_ecc / s_con - 2) < 1e-4, f"{s_ecc:.4f}/{s_con:.4f}")
    check("fT continuous at eps_toe", abs(mu.ft(mu.etoe - 1e-12) - mu.ft(mu.etoe + 1e-12)) < 1e-9)

    # 3. Fibre-velocity solve satisfies its equation over a grid of states.
    worst = 0.0
    for fm in (0.0, 0.2, 1.0, 1.6, 3.0):
        for act_fl in (0.0, 0.05, 0.5, 1.0):
            for fpe in (0.0, 0.3):
                v = mu.fibre_velocity(fm, act_fl, fpe)
                worst = max(worst, abs(act_fl * mu.fv(v) + fpe + mu.beta * v - fm))
    check("fibre velocity residual", worst < 1e-12, f"max residual {worst:.1e}")

    # 4. Baseline simulation: invariants and torque sanity.
    model = p.prepare(trial)
    res = model.simulate(rtol=1e-8, atol=1e-10)
    inv = p.invariant_errors(model, res)
    e_ft = max(v[0] for v in inv.values())
    e_lmt = max(v[1] for v in inv.values())
    check("invariant FT = fT(eps) (rtol 1e-8)", e_ft < 1e-5, f"{e_ft:.2e}")
    check("invariant LMT = LMT(q) (rtol 1e-8)", e_lmt < 1e-8, f"{e_lmt:.2e} m")
    tau = res["torque_nm"]
    check("peak plantarflexion torque in 100-300 N·m", 100 < tau.max() < 300, f"{tau.max():.1f} N·m")
    check("sum of muscle torques = total (no effects)",
          np.max(np.abs(sum(res["torque_by_muscle"].values()) - tau)) < 1e-9)

    # 5. Effects: zero-effect at the null value, and each changes torque when switched on.
    null = {name: {k: v for k, v in pars.items() if v is not None} for name, pars in p.EFFECTS.items()}
    null["eccentric_enhancement"] = {"flen": 1.4}
    base = model.simulate(rtol=1e-8, atol=1e-10)["torque_nm"]
    # Effects without extra states must reproduce the baseline bit-for-bit (same steps);
    # fatigue and coactivation add ODE states, which changes the step sequence, so they are
    # compared within the integrator's own error at rtol 1e-8 (measured ~1e-3 N·m).
    stateless = {k: v for k, v in null.items() if k not in ("fatigue", "antagonist_coactivation")}
    r0 = p.prepare(trial, effects=p.load_effects(obj=stateless)).simulate(rtol=1e-8, atol=1e-10)["torque_nm"]
    check("stateless effects at null value = baseline", np.max(np.abs(r0 - base)) < 1e-9,
          f"max diff {np.max(np.abs(r0 - base)):.1e}")
    r0 = p.prepare(trial, effects=p.load_effects(obj=null)).simulate(rtol=1e-8, atol=1e-10)["torque_nm"]
    check("all effects at null value = baseline within integrator error", np.max(np.abs(r0 - base)) < 2e-3,
          f"max diff {np.max(np.abs(r0 - base)):.1e} N·m")
    on = {"torque_offset": {"offset_nm": 5.0},
          "passive_joint_torque": {"scale_nm": 1.0, "stiffness_per_rad": 8.0},
          "gravity": {"moment_nm": 3.0, "phase_deg": 10.0},
          "electromechanical_delay": {"delay_ms": 40.0},
          "fatigue": {"rate_per_s": 0.1},
          "antagonist_coactivation": {"gain_nm": 10.0},
          "eccentric_enhancement": {"flen": 1.8},
          "viscous_damping": {"b_nm_s_per_rad": 2.0},
          "inertia": {"i_kg_m2": 0.05}}
    for name, pars in on.items():
        r = p.prepare(trial, effects=p.load_effects(obj={name: pars})).simulate(rtol=1e-8, atol=1e-10)
        diff = r["torque_nm"] - base
        check(f"effect {name} changes torque", np.max(np.abs(diff)) > 0.1, f"max |diff| {np.max(np.abs(diff)):.2f} N·m")
    r = p.prepare(trial, effects=p.load_effects(obj={"torque_offset": {"offset_nm": 5.0}})).simulate(
        rtol=1e-8, atol=1e-10)
    check("torque_offset adds exactly c", np.max(np.abs(r["torque_nm"] - base - 5.0)) < 1e-9)
    r = p.prepare(trial, effects=p.load_effects(obj={"fatigue": {"rate_per_s": 0.1}})).simulate(
        rtol=1e-8, atol=1e-10)
    check("fatigue lowers late torque", r["torque_nm"][-1000] < base[-1000])

    # 6. Parameters: partial nested JSON and flat identified names agree.
    pa = p.load_params(obj={"muscles": {"sol": {"lst_m": 0.2525}}})
    pb = p.load_params(obj={"params": {"sol.lst_m": 0.2525}})
    check("flat and nested parameter names agree", pa == pb and pa["muscles"]["gm"]["lst_m"] == 0.39)
    r = p.prepare(trial, params=pa).simulate(rtol=1e-8, atol=1e-10)
    check("+1% soleus LST lowers the torque", r["torque_nm"].max() < base.max())

    # 7. Envelope against scipy reference vectors.
    ref_path = os.path.join(HERE, "..", "..", "crates", "signal", "tests", "data", "scipy_reference.json")
    with open(ref_path, encoding="utf-8") as fh:
        e = json.load(fh)["envelope"]
    got = p.envelope(np.asarray(e["raw"]), e["fs"])
    want = np.asarray(e["normalized"])
    check("envelope = scipy reference", np.max(np.abs(got - want)) < 1e-10,
          f"max diff {np.max(np.abs(got - want)):.1e}")

    print(f"{len(FAILS)} failure(s)")
    return 1 if FAILS else 0


if __name__ == "__main__":
    sys.exit(main())
