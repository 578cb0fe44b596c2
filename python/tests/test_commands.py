"""identify and diagnose against `surae identify` / `surae diagnose`; progress and stopping."""

import os
import signal
import tempfile

import pytest

import surae
from conftest import read_json, without


def test_identify_sa_equals_the_cli(cli, tmp_path):
    r = cli("identify", "--method", "sa", "--seed", "42", "--quiet", "--out", tmp_path)
    assert r.returncode == 0, r.stderr
    ref = read_json(tmp_path / "identify.json")
    got = surae.identify(method="sa", seed=42)
    # everything but the measured wall time, to the last digit of the JSON
    assert without(got, "wall_s") == without(ref, "wall_s")
    assert got["method"] == "sa" and len(got["params"]) == 9


def test_identify_mcmc_equals_the_cli(cli, tmp_path):
    # capped so the test takes seconds; the cap is part of both runs
    r = cli(
        "identify", "--method", "mcmc", "--max-iterations", "3000", "--quiet",
        "--out", tmp_path,
    )
    assert r.returncode == 0, r.stderr
    ref = read_json(tmp_path / "identify.json")
    got = surae.identify(method="mcmc", max_iterations=3000)
    assert without(got, "wall_s") == without(ref, "wall_s")
    assert got["stop"] == "CapReached" and len(got["posterior"]) == 9


def test_identify_from_dicts_equals_the_cli_on_files(cli, repo, tmp_path):
    seed = repo / "fixtures" / "seed"
    r = cli(
        "identify", "--method", "sa", "--trial", seed / "trial.csv",
        "--unloaded", seed / "unloaded.csv", "--truth", seed / "truth.json",
        "--quiet", "--out", tmp_path,
    )
    assert r.returncode == 0, r.stderr
    ref = read_json(tmp_path / "identify.json")
    truth = read_json(seed / "truth.json")
    got = surae.identify(
        surae.bundled_trial(), surae.bundled_unloaded(), "sa", 42, truth=truth
    )
    assert got["trial"] == "<trial dict>"
    assert got["noise"]["unloaded"] == "<unloaded dict>"
    for key in ["params", "rms_nm", "rms_raw_nm", "evaluations", "sa", "errors_pct", "dynamometer"]:
        assert got[key] == ref[key], key


def test_identify_with_effects_equals_the_cli(cli, repo, tmp_path):
    fx = repo / "fixtures" / "electromechanical_delay"
    r = cli(
        "identify", "--method", "sa", "--trial", fx / "trial.csv",
        "--unloaded", fx / "unloaded.csv", "--with", "electromechanical_delay",
        "--quiet", "--out", tmp_path,
    )
    assert r.returncode == 0, r.stderr
    ref = read_json(tmp_path / "identify.json")
    got = surae.identify(
        str(fx / "trial.csv"), str(fx / "unloaded.csv"), "sa",
        with_effects=["electromechanical_delay"],
    )
    assert got["with"] == ["electromechanical_delay"]
    # the hidden delay is 40 ms
    assert abs(got["params"]["electromechanical_delay.delay_ms"] - 40.0) < 5.0
    for key in ["params", "rms_nm", "evaluations", "adequacy", "effects"]:
        assert got[key] == ref[key], key


def test_identify_writes_out_when_asked(tmp_path):
    got = surae.identify(seed=7, out=tmp_path / "fit")
    assert read_json(tmp_path / "fit" / "identify.json") == got
    assert (tmp_path / "fit" / "report.html").stat().st_size > 0
    assert got["seed"] == 7


def test_diagnose_equals_the_cli(cli, tmp_path):
    r = cli("diagnose", "--quiet", "--out", tmp_path)
    assert r.returncode == 0, r.stderr
    ref = read_json(tmp_path / "diagnosis.json")
    got = surae.diagnose()
    assert without(got, "wall_s") == without(ref, "wall_s")
    assert "verdict" in got


def test_progress_callback_sees_the_stages():
    seen = []
    surae.diagnose(progress=lambda label, pos, total, msg: seen.append((label, msg)))
    assert seen, "no progress reported"
    assert all(label == "diag" for label, _ in seen)
    assert len({msg for _, msg in seen}) >= 2


def test_an_exception_in_the_callback_stops_the_run_and_writes_nothing(tmp_path):
    class Stop(Exception):
        pass

    def cb(label, pos, total, msg):
        raise Stop(msg)

    with pytest.raises(Stop):
        surae.identify(method="sa", out=tmp_path / "x", progress=cb)
    assert not (tmp_path / "x" / "identify.json").exists()
    # the module is usable afterwards
    assert surae.identify(method="sa")["method"] == "sa"


def test_ctrl_c_raises_keyboard_interrupt_and_writes_nothing(tmp_path):
    # SIGINT at the first progress update: what Ctrl-C does. raise_signal delivers it to the
    # calling (main) thread. Python's own handler is installed for the test: a process started
    # in the background of a non-interactive shell inherits SIGINT ignored, and Python then
    # leaves it ignored.
    def cb(label, pos, total, msg):
        signal.raise_signal(signal.SIGINT)

    previous = signal.signal(signal.SIGINT, signal.default_int_handler)
    try:
        with pytest.raises(KeyboardInterrupt):
            surae.diagnose(out=tmp_path / "d", progress=cb)
    finally:
        signal.signal(signal.SIGINT, previous)
    assert not (tmp_path / "d" / "diagnosis.json").exists()
    assert "verdict" in surae.diagnose()


def test_command_line_warnings_become_python_warnings(repo, tmp_path):
    lines = (repo / "fixtures" / "seed" / "trial.csv").read_text().splitlines()
    out = []
    for line in lines:
        if line.startswith("#"):
            out.append(line)
        elif line.startswith("time_s"):
            out.append(line + ",foo")
        else:
            out.append(line + ",1")
    trial = tmp_path / "trial.csv"
    trial.write_text("\n".join(out) + "\n")
    with pytest.warns(UserWarning, match="ignored unknown columns: foo"):
        d = surae.diagnose(trial, surae.bundled_unloaded())
    assert d["trial"] == str(trial)


def test_identify_session_equals_the_cli(cli, repo, tmp_path):
    seed = repo / "fixtures" / "seed"
    manifest = tmp_path / "session.json"
    manifest.write_text(
        '{"trials": [{"name": "seed", "trial": "%s", "unloaded": "%s"}]}'
        % (seed / "trial.csv", seed / "unloaded.csv")
    )
    out = tmp_path / "cli"
    r = cli(
        "identify", "--method", "sa", "--session", manifest, "--chains", "2", "--quiet",
        "--out", out,
    )
    assert r.returncode == 0, r.stderr
    ref = read_json(out / "identify.json")
    got = surae.identify(session=manifest, method="sa", chains=2)
    assert without(got, "wall_s") == without(ref, "wall_s")
    assert [t["name"] for t in got["trials"]] == ["seed"]
    # a session of one trial identifies what the trial does
    alone = surae.identify(seed / "trial.csv", seed / "unloaded.csv", method="sa", chains=2)
    assert got["params"] == alone["params"]


def test_design_equals_the_cli(cli, tmp_path):
    protocols = ["knee0@30", "knee0@30,knee90@30"]
    args = []
    for p in protocols:
        args += ["--protocol", p]
    r = cli("design", *args, "--emg-draws", "2", "--quiet", "--out", tmp_path)
    assert r.returncode == 0, r.stderr
    ref = read_json(tmp_path / "design.json")
    got = surae.design(protocols, emg_draws=2)
    assert got == ref
    rows = got["protocols"]
    assert [row["protocol"] for row in rows] == protocols
    # the flexed knee adds information on every parameter
    for name, sd in rows[1]["sd_pct"].items():
        assert sd < rows[0]["sd_pct"][name], name


def test_without_out_nothing_is_written(tmp_path, monkeypatch):
    # the dicts go to the job in memory and no out folder is made: the working folder and the
    # temporary folder stay as they were
    monkeypatch.chdir(tmp_path)
    tmp = tempfile.gettempdir()
    before = set(os.listdir(tmp))
    params = {"muscles": {"sol": {"fom_n": 3000.0}}}
    got = surae.design(["knee0@30"], emg_draws=1, params=params, unloaded=surae.bundled_unloaded())
    assert got["params"] == "<params dict>"
    assert got["noise"]["source"] == "<unloaded dict>"
    assert list(tmp_path.iterdir()) == []
    made = {n for n in set(os.listdir(tmp)) - before if n.startswith("surae")}
    assert made == set()


def test_design_rejects_a_bad_protocol():
    with pytest.raises(surae.InputError, match="elbow"):
        surae.design(["knee0@30,elbow"])


def test_two_threads_run_side_by_side_with_their_own_progress():
    # each call has its own observer: two diagnoses at once give the single run's result, and
    # each callback sees only its own run's updates
    import threading

    alone = without(surae.diagnose(), "wall_s")
    results, seen = {}, {0: [], 1: []}

    def run(k):
        results[k] = surae.diagnose(progress=lambda *u: seen[k].append(u))

    threads = [threading.Thread(target=run, args=(k,)) for k in (0, 1)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    for k in (0, 1):
        assert without(results[k], "wall_s") == alone
        assert seen[k], "each run reports its progress"
        assert all(u[0].startswith("diag") for u in seen[k])
