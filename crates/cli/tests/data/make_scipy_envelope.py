"""Makes the scipy reference for the CLI envelope test (run once; outputs are committed).

A raw EMG recording that is not one of the fixtures: 1000 Hz, 2.5 s, four channels
(with emg_ta), different carriers and drives, and the envelope pipeline of docs/model.md computed with
scipy (butter(..., output='sos') + sosfiltfilt defaults, rectify, 2 Hz low-pass,
normalise by the channel maximum, clip to [0, 1]).

    pip install numpy scipy && python3 make_scipy_envelope.py
"""
import numpy as np
import scipy
from scipy.signal import butter, sosfiltfilt

fs = 1000.0
n = 2500
t = np.arange(n) / fs
rng = np.random.default_rng(20261121)
carrier_band = butter(4, [20, 450], "bandpass", fs=fs, output="sos")
drives = {
    "emg_sol": 0.05 + 0.95 * np.clip(np.sin(np.pi * t / 2.5), 0, 1) ** 2,
    "emg_gm": 0.04 + 0.6 * (t > 0.4) * (1 - np.exp(-(t - 0.4).clip(0) / 0.2)),
    "emg_gl": 0.03 + 0.5 * np.exp(-((t - 1.2) / 0.5) ** 2),
    "emg_ta": 0.02 + 0.08 * (t > 1.5),
}
gains = {"emg_sol": 0.31, "emg_gm": 0.77, "emg_gl": 0.12, "emg_ta": 0.05}
raw = {}
for k, d in drives.items():
    c = sosfiltfilt(carrier_band, rng.standard_normal(n))
    c /= np.sqrt(np.mean(c ** 2))
    raw[k] = np.round(gains[k] * d * c, 6)
angle = 15.0 - 35.0 * 0.5 * (1 - np.cos(np.pi * t / 2.5))
torque = np.round(100 * np.sin(np.pi * t / 2.5), 3)

bp = butter(2, [10, 350], "bandpass", fs=fs, output="sos")
lp = butter(4, 2, "low", fs=fs, output="sos")
env = {}
for k, x in raw.items():
    e = sosfiltfilt(lp, np.abs(sosfiltfilt(bp, x)))
    env[k] = np.clip(e / e.max(), 0, 1)

cols = ["emg_sol", "emg_gm", "emg_gl", "emg_ta"]
with open("external_trial.csv", "w") as f:
    f.write("# synthetic raw EMG at 1000 Hz for the CLI envelope test (make_scipy_envelope.py)\n")
    f.write("time_s,ankle_angle_deg,torque_nm," + ",".join(cols) + "\n")
    for i in range(n):
        f.write(",".join([repr(float(t[i])), repr(float(round(angle[i], 7))), repr(float(torque[i]))]
                         + [repr(float(raw[c][i])) for c in cols]) + "\n")
with open("external_envelope_scipy.csv", "w") as f:
    f.write(f"# scipy {scipy.__version__} envelopes (docs/model.md pipeline) of external_trial.csv\n")
    f.write("time_s," + ",".join(cols) + "\n")
    for i in range(n):
        f.write(",".join([repr(float(t[i]))] + [repr(float(env[c][i])) for c in cols]) + "\n")
