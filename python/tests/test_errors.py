"""Bad input raises surae.InputError with the command line's one-line message, never a panic."""

import numpy as np
import pytest

import surae


def cli_message(result):
    """The CLI's one-line error without its `error: ` prefix (exit code 2 checked)."""
    assert result.returncode == 2, result.stderr
    line = result.stderr.strip()
    assert "\n" not in line
    assert line.startswith("error: ")
    return line[len("error: "):]


def bad_trial(tmp_path):
    path = tmp_path / "bad.csv"
    path.write_text(
        "time_s,ankle_angle_deg,torque_nm,emg_sol,emg_gm,emg_gl\n"
        "0,1,2,0.1,0.2,0.3\n"
        "0.001,1,oops,0.1,0.2,0.3\n"
    )
    return path


@pytest.mark.parametrize("command", ["identify", "diagnose"])
def test_malformed_trial_message_equals_the_cli(cli, tmp_path, command):
    trial = bad_trial(tmp_path)
    extra = ["--method", "sa"] if command == "identify" else []
    expected = cli_message(cli(command, *extra, "--trial", trial, "--out", tmp_path / "o"))
    fn = surae.identify if command == "identify" else surae.diagnose
    with pytest.raises(surae.InputError) as e:
        fn(trial, out=tmp_path / "p")
    assert str(e.value) == expected
    assert "bad.csv:3" in expected


def test_missing_file_and_bad_json_messages_equal_the_cli(cli, tmp_path):
    expected = cli_message(cli("identify", "--method", "sa", "--trial", tmp_path / "none.csv", "--out", tmp_path / "o"))
    with pytest.raises(surae.InputError) as e:
        surae.identify(tmp_path / "none.csv")
    assert str(e.value) == expected

    params = tmp_path / "params.json"
    params.write_text('{"muscles": {"sol": {"fom_n": 3000,}}}')
    expected = cli_message(cli("identify", "--method", "sa", "--params", params, "--out", tmp_path / "o"))
    with pytest.raises(surae.InputError) as e:
        surae.identify(params=params)
    assert str(e.value) == expected
    assert "params.json:1:" in expected


def test_dict_inputs_are_named_in_messages():
    with pytest.raises(surae.InputError, match=r"^<params dict>: .*muscles\.sol\.nope"):
        surae.identify(params={"muscles": {"sol": {"nope": 1}}})
    with pytest.raises(surae.InputError, match="missing column 'emg_gl'"):
        t = surae.bundled_trial()
        del t["emg_gl"]
        surae.identify(t)
    with pytest.raises(surae.InputError, match="unknown column 'emg_xx'"):
        t = surae.bundled_trial()
        t["emg_xx"] = t["emg_gl"]
        surae.diagnose(t)
    with pytest.raises(surae.InputError, match="^method 'lm': expected 'sa', 'mcmc' or 'nuts'$"):
        surae.identify(method="lm")


def test_array_inputs():
    t = surae.bundled_trial()
    fs = t["fs"]
    with pytest.raises(surae.InputError, match="all zeros"):
        surae.envelope(np.zeros(5000), fs)
    nan = t["emg_sol"].copy()
    nan[10] = np.nan
    with pytest.raises(surae.InputError, match="^emg: sample 10 is not a finite number$"):
        surae.envelope(nan, fs)
    with pytest.raises(surae.InputError, match="expected a 1-D array or a 2-D array"):
        surae.envelope(np.ones((2, 2, 2)), fs)
    with pytest.raises(surae.InputError, match="not an array of numbers"):
        surae.envelope(["a", "b"], fs)
    env = np.full((3, 100), 0.2)
    with pytest.raises(surae.InputError, match=r"emg_envelopes\['gm'\]: 99 samples but angle_deg has 100"):
        surae.simulate(np.zeros(100), {"sol": env[0], "gm": env[1][:99], "gl": env[2]}, fs)
    with pytest.raises(surae.InputError, match="unknown key 'soleus'"):
        surae.simulate(np.zeros(100), {"soleus": env[0]}, fs)
    with pytest.raises(surae.InputError, match="effects: .*"):
        surae.simulate(np.zeros(100), env, fs, effects={"no_such_effect": {}})
    with pytest.raises(surae.InputError, match="fs"):
        surae.simulate(np.zeros(100), env, -1.0)
    with pytest.raises(surae.InputError, match="progress: expected"):
        surae.diagnose(progress="yes")


def test_unknown_with_effect_message_equals_the_cli(cli, tmp_path):
    expected = cli_message(cli("identify", "--method", "sa", "--with", "friction", "--out", tmp_path / "o"))
    with pytest.raises(surae.InputError) as e:
        surae.identify(with_effects=["friction"])
    assert str(e.value) == expected
    assert "friction" in expected and "electromechanical_delay" in expected
