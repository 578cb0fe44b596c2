"""ArviZ reads the chains of `surae identify --method mcmc` on the bundled trial.

`arviz.from_cmdstan` on `chains/chain_<k>.csv` must give the posterior means of
`identify.json` to 1e-9, `arviz.rhat` within 0.002 of its R-hat and `arviz.ess`
(bulk, tail) equal to its ESS to rounding, for every parameter. The `surae` binary comes from `SURAE_BIN`, else `target/release/surae`
under the repository root; without either the test fails (build it first with
`cargo build --release -p cli`).
"""

import json
import os
import subprocess
from pathlib import Path

import arviz as az
import pytest

REPO = Path(__file__).resolve().parents[2]


def surae_bin() -> Path:
    env = os.environ.get("SURAE_BIN")
    candidate = Path(env) if env else REPO / "target" / "release" / "surae"
    if not candidate.is_file():
        pytest.fail(
            f"no surae binary at {candidate}: set SURAE_BIN or run "
            "`cargo build --release -p cli` in the repository"
        )
    return candidate


@pytest.fixture(scope="module")
def mcmc_run(tmp_path_factory):
    out = tmp_path_factory.mktemp("identify_mcmc")
    subprocess.run(
        [str(surae_bin()), "identify", "--method", "mcmc", "--seed", "42",
         "--quiet", "--out", str(out)],
        check=True,
    )
    doc = json.loads((out / "identify.json").read_text())
    chains = sorted((out / "chains").glob("chain_*.csv"),
                    key=lambda p: int(p.stem.split("_")[1]))
    return doc, chains


def test_from_cmdstan_means_and_rhat_match_identify_json(mcmc_run):
    doc, chains = mcmc_run
    assert len(chains) == doc["chains"] >= 2
    idata = az.from_cmdstan(posterior=[str(p) for p in chains])
    post = idata.posterior
    assert post.sizes["chain"] == len(chains)
    assert post.sizes["draw"] == doc["sampling_iterations"]
    rhat = az.rhat(idata)
    ess_bulk = az.ess(idata, method="bulk")
    ess_tail = az.ess(idata, method="tail")
    worst_mean, worst_rhat = 0.0, 0.0
    for name, reported in doc["posterior"].items():
        var = name.replace(".", "_")
        mean = float(post[var].mean())
        worst_mean = max(worst_mean, abs(mean - reported["mean"]))
        assert abs(mean - reported["mean"]) <= 1e-9, (name, mean, reported["mean"])
        r = float(rhat[var])
        worst_rhat = max(worst_rhat, abs(r - reported["rhat"]))
        assert abs(r - reported["rhat"]) <= 0.002, (name, r, reported["rhat"])
        # the same rank-normalised ESS estimators: equal to rounding
        for ess, key in ((ess_bulk, "ess_bulk"), (ess_tail, "ess_tail")):
            e = float(ess[var])
            assert abs(e - reported[key]) <= 1e-9 * reported[key], (name, key, e)
    print(f"largest |mean difference| {worst_mean:.3g}, largest |R-hat difference| {worst_rhat:.3g}")
    # lp__ is a sampler statistic, the per-trial log-likelihood its own group
    assert "lp" in idata.sample_stats
    assert "log_lik" in idata.log_likelihood
    lp = idata.sample_stats["lp"].values
    ll = idata.log_likelihood["log_lik"].values[..., 0]
    diff = lp - ll
    assert abs(diff.max() - diff.min()) < 1e-6  # the constant log prior density


def test_opensim_reads_the_sto_and_identified_osim(tmp_path):
    """OpenSim's own Python package, where it installs (`pip install opensim`), reads
    `simulate --out x.sto` and the `identified.osim` of an identification."""
    osim = pytest.importorskip("opensim", reason="the opensim package is not installed")
    import numpy as np

    exe = str(surae_bin())
    subprocess.run([exe, "simulate", "--out", str(tmp_path / "sim.csv")], check=True)
    subprocess.run([exe, "simulate", "--out", str(tmp_path / "sim.sto")], check=True)
    csv = np.genfromtxt(tmp_path / "sim.csv", delimiter=",", names=True)
    table = osim.TimeSeriesTable(str(tmp_path / "sim.sto"))
    assert table.getNumRows() == len(csv)
    assert table.getTableMetaDataAsString("inDegrees") == "yes"
    time = np.array(table.getIndependentColumn())
    assert np.max(np.abs(time - csv["time_s"])) <= 1e-9
    columns = {
        "ankle_angle_r": csv["ankle_angle_deg"],
        "torque_nm": csv["torque_nm"],
        "torque_sol_nm": csv["torque_sol_nm"],
        "ankle_angle_r_moment": -csv["torque_nm"],
    }
    for label, expected in columns.items():
        got = table.getDependentColumn(label).to_numpy()
        assert np.max(np.abs(got - expected)) <= 1e-9, label

    model_file = REPO / "crates" / "opensim-files" / "tests" / "data" / "leg6.osim"
    out = tmp_path / "sa"
    subprocess.run(
        [exe, "identify", "--method", "sa", "--quiet", "--params", str(model_file),
         "--out", str(out)],
        check=True,
    )
    params = json.loads((out / "identify.json").read_text())["params"]
    model = osim.Model(str(out / "identified.osim"))
    muscles = model.getMuscles()
    for key, name in (("sol", "soleus_r"), ("gm", "med_gas_r"), ("gl", "lat_gas_r")):
        m = muscles.get(name)
        assert m.getMaxIsometricForce() == params[f"{key}.fom_n"]
        assert m.getTendonSlackLength() == params[f"{key}.lst_m"]
        assert abs(np.degrees(m.getPennationAngleAtOptimalFiberLength())
                   - params[f"{key}.alpha_deg"]) < 1e-9
    # a muscle surae does not identify keeps the model's value
    assert muscles.get("tib_ant_r").getMaxIsometricForce() == 905.0
