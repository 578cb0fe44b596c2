"""envelope and simulate against `surae envelope` / `surae simulate` on the bundled trial."""

import json

import numpy as np
import pytest

import surae
from conftest import read_csv_columns


@pytest.fixture(scope="module")
def trial():
    return surae.bundled_trial()


def raw_emg(trial):
    return np.vstack([trial["emg_sol"], trial["emg_gm"], trial["emg_gl"]])


def test_bundled_trial_matches_the_fixture_file(repo, trial):
    cols = read_csv_columns(repo / "fixtures" / "seed" / "trial.csv")
    assert set(cols) == set(trial) - {"fs"}
    for name, values in cols.items():
        np.testing.assert_array_equal(trial[name], values)
    t = trial["time_s"]
    assert trial["fs"] == pytest.approx((len(t) - 1) / (t[-1] - t[0]), rel=1e-12)
    unloaded = surae.bundled_unloaded()
    cols = read_csv_columns(repo / "fixtures" / "seed" / "unloaded.csv")
    for name, values in cols.items():
        np.testing.assert_array_equal(unloaded[name], values)


def test_envelope_equals_the_cli(cli, tmp_path, trial):
    out = tmp_path / "envelope.csv"
    r = cli("envelope", "--out", out)
    assert r.returncode == 0, r.stderr
    ref = read_csv_columns(out)
    env = surae.envelope(raw_emg(trial), trial["fs"])
    assert env.shape == (3, len(trial["time_s"]))
    for k, name in enumerate(["emg_sol", "emg_gm", "emg_gl"]):
        # the CLI writes shortest round-trip decimals: equal to the last bit
        np.testing.assert_array_equal(env[k], ref[name])


def test_envelope_one_channel_and_mvc(trial):
    both = surae.envelope(raw_emg(trial), trial["fs"])
    one = surae.envelope(trial["emg_gm"], trial["fs"])
    assert one.ndim == 1
    np.testing.assert_array_equal(one, both[1])
    # an MVC reference twice the unnormalised maximum halves the peak
    peak = surae.envelope(trial["emg_gm"], trial["fs"], mvc=1e9)
    big = peak.max() * 1e9
    half = surae.envelope(trial["emg_gm"], trial["fs"], mvc=2 * big)
    assert half.max() == pytest.approx(0.5, rel=1e-9)


def test_simulate_equals_the_cli(cli, tmp_path, trial):
    out = tmp_path / "simulate.csv"
    r = cli("simulate", "--out", out)
    assert r.returncode == 0, r.stderr
    ref = read_csv_columns(out)
    env = surae.envelope(raw_emg(trial), trial["fs"])
    sim = surae.simulate(
        trial["ankle_angle_deg"], env, trial["fs"], t0=trial["time_s"][0]
    )
    for name in ["torque_nm", "torque_sol_nm", "torque_gm_nm", "torque_gl_nm"]:
        diff = np.max(np.abs(sim[name] - ref[name]))
        assert diff <= 1e-9, f"{name}: max |python - cli| = {diff:.3e} N·m"
    np.testing.assert_array_equal(sim["ankle_angle_deg"], ref["ankle_angle_deg"])
    np.testing.assert_allclose(sim["time_s"], ref["time_s"], rtol=0, atol=1e-9)


def test_simulate_params_and_effects_equal_the_cli(cli, tmp_path, trial):
    params = {"muscles": {"sol": {"fom_n": 3000.0}, "gm": {"lst_m": 0.40}}}
    effects = {"torque_offset": {"offset_nm": -3.0}, "electromechanical_delay": {"delay_ms": 40}}
    (tmp_path / "p.json").write_text(json.dumps(params))
    (tmp_path / "e.json").write_text(json.dumps(effects))
    out = tmp_path / "simulate.csv"
    r = cli("simulate", "--params", tmp_path / "p.json", "--effects", tmp_path / "e.json", "--out", out)
    assert r.returncode == 0, r.stderr
    ref = read_csv_columns(out)
    env = surae.envelope(raw_emg(trial), trial["fs"])
    fs, t0 = trial["fs"], trial["time_s"][0]
    by_dict = surae.simulate(trial["ankle_angle_deg"], env, fs, params, effects, t0=t0)
    by_file = surae.simulate(
        trial["ankle_angle_deg"], env, fs, str(tmp_path / "p.json"), tmp_path / "e.json", t0=t0
    )
    nominal = surae.simulate(trial["ankle_angle_deg"], env, fs, t0=t0)
    assert np.max(np.abs(by_dict["torque_nm"] - ref["torque_nm"])) <= 1e-9
    np.testing.assert_array_equal(by_dict["torque_nm"], by_file["torque_nm"])
    # the parameters and effects are used
    assert np.max(np.abs(nominal["torque_nm"] - by_dict["torque_nm"])) > 1.0


def test_simulate_envelopes_as_dict_or_array(trial):
    env = surae.envelope(raw_emg(trial), trial["fs"])
    a = surae.simulate(trial["ankle_angle_deg"], env, trial["fs"])
    d = surae.simulate(
        trial["ankle_angle_deg"],
        {"emg_sol": env[0], "gm": env[1], "gl": list(env[2])},
        trial["fs"],
    )
    np.testing.assert_array_equal(a["torque_nm"], d["torque_nm"])
    np.testing.assert_allclose(
        a["torque_nm"], a["torque_sol_nm"] + a["torque_gm_nm"] + a["torque_gl_nm"], atol=1e-9
    )


def test_simulate_with_a_fixed_tibialis_and_a_flexed_knee(trial):
    fs = trial["fs"]
    env = surae.envelope(raw_emg(trial), fs)
    n = env.shape[1]
    angle = trial["ankle_angle_deg"]
    base = surae.simulate(angle, env, fs)
    ta = {"fom_n": 905, "lom_m": 0.098, "lst_m": 0.223, "alpha_deg": 5,
          "lmt_poly_m": [0.321, -0.036, 0.003, 0.0]}
    envelopes = {"sol": env[0], "gm": env[1], "gl": env[2], "ta": np.full(n, 0.3)}
    with_ta = surae.simulate(angle, envelopes, fs, params={"muscles": {"ta": ta}})
    assert (with_ta["torque_ta_nm"] <= 0).all()
    assert with_ta["torque_ta_nm"].min() < -5.0
    np.testing.assert_allclose(
        with_ta["torque_nm"], base["torque_nm"] + with_ta["torque_ta_nm"], atol=1e-6
    )
    flexed = surae.simulate(angle, env, fs, knee_angle_deg=90.0)
    np.testing.assert_array_equal(flexed["torque_sol_nm"], base["torque_sol_nm"])
    assert flexed["torque_gm_nm"].max() < 0.9 * base["torque_gm_nm"].max()
