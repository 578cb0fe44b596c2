#!/usr/bin/env python3
"""Synthetic `seed`-protocol trial for testing surae_peer.py (not the project's fixtures; the
protocol is described in docs/formats.md, "Synthetic trials").

0.5 s hold at +15°, trapezoidal 30 °/s sweep to −20° (50 ms constant-acceleration ramps),
sweep back to +15°, 0.4 s hold; 2048 Hz.  Raw EMG = band-limited (20-450 Hz) Gaussian noise
times a smooth drive (0.03 at rest -> 1 during the first hold, back to 0.03 in the final hold).
Torque column zeros.  Deterministic from --seed.

    python3 gen_test_trial.py --out trial.csv [--seed 1]
"""

import argparse
import math

import numpy as np
from scipy.signal import butter, sosfiltfilt

FS = 2048.0
Q_HIGH, Q_LOW = 15.0, -20.0
SPEED = 30.0
RAMP = 0.05
HOLD0, HOLD1 = 0.5, 0.4
REST = 0.03


def sweep_position(s, q_from, q_to):
    """Position (deg) s seconds into a trapezoidal sweep; total duration D/v + ramp."""
    d = abs(q_to - q_from)
    sign = 1.0 if q_to > q_from else -1.0
    acc = SPEED / RAMP
    total = d / SPEED + RAMP
    if s <= 0.0:
        x = 0.0
    elif s < RAMP:
        x = 0.5 * acc * s * s
    elif s < total - RAMP:
        x = 0.5 * SPEED * RAMP + SPEED * (s - RAMP)
    elif s < total:
        r = total - s
        x = d - 0.5 * acc * r * r
    else:
        x = d
    return q_from + sign * x


def smoothstep(x):
    x = min(max(x, 0.0), 1.0)
    return 0.5 - 0.5 * math.cos(math.pi * x)


def make_trial(seed=1):
    sweep = (Q_HIGH - Q_LOW) / SPEED + RAMP
    t_end = HOLD0 + 2 * sweep + HOLD1
    n = int(round(t_end * FS)) + 1
    t = np.arange(n) / FS
    q = np.empty(n)
    drive = np.empty(n)
    t_rel = HOLD0 + 2 * sweep  # start of the final hold
    for i, ti in enumerate(t):
        if ti < HOLD0:
            q[i] = Q_HIGH
        elif ti < HOLD0 + sweep:
            q[i] = sweep_position(ti - HOLD0, Q_HIGH, Q_LOW)
        elif ti < HOLD0 + 2 * sweep:
            q[i] = sweep_position(ti - HOLD0 - sweep, Q_LOW, Q_HIGH)
        else:
            q[i] = Q_HIGH
        rise = smoothstep((ti - 0.05) / 0.35)  # 0.05 s .. 0.40 s
        fall = 1.0 - smoothstep((ti - t_rel - 0.02) / 0.25)
        drive[i] = REST + (1.0 - REST) * min(rise, fall)
    rng = np.random.default_rng(seed)
    band = butter(4, [20.0, 450.0], btype="bandpass", fs=FS, output="sos")
    emg = {}
    for name, amp, d in (("sol", 3e-4, drive), ("gm", 2.5e-4, drive), ("gl", 2e-4, drive),
                         ("ta", 1e-4, REST + 0.15 * drive)):
        noise = sosfiltfilt(band, rng.standard_normal(n))
        noise /= np.std(noise)
        emg[name] = amp * d * noise
    return {"time_s": t, "ankle_angle_deg": q, "torque_nm": np.zeros(n),
            "emg_sol": emg["sol"], "emg_gm": emg["gm"], "emg_gl": emg["gl"],
            "emg_ta": emg["ta"], "knee_angle_deg": np.zeros(n)}


def write_trial(path, trial, seed):
    cols = list(trial)
    with open(path, "w", encoding="utf-8") as fh:
        fh.write(f"# synthetic seed-protocol trial from bench/peer/gen_test_trial.py, seed {seed}\n")
        fh.write(f"# fs {FS:g} Hz; EMG in volts (raw); torque column is zero\n")
        fh.write(",".join(cols) + "\n")
        arr = np.column_stack([trial[c] for c in cols])
        for row in arr:
            fh.write(",".join(f"{v:.12g}" for v in row) + "\n")


def main():
    ap = argparse.ArgumentParser(description="write a synthetic seed-protocol trial CSV")
    ap.add_argument("--out", required=True)
    ap.add_argument("--seed", type=int, default=1)
    args = ap.parse_args()
    write_trial(args.out, make_trial(args.seed), args.seed)
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
