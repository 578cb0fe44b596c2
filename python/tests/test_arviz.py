"""ArviZ reads the chains of `surae identify --method mcmc` on the bundled trial.

`arviz.from_cmdstan` on `chains/chain_<k>.csv` must give the posterior means of
`identify.json` to 1e-9 and `arviz.rhat` within 0.002 of its R-hat, for every
parameter. The `surae` binary comes from `SURAE_BIN`, else `target/release/surae`
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
    worst_mean, worst_rhat = 0.0, 0.0
    for name, reported in doc["posterior"].items():
        var = name.replace(".", "_")
        mean = float(post[var].mean())
        worst_mean = max(worst_mean, abs(mean - reported["mean"]))
        assert abs(mean - reported["mean"]) <= 1e-9, (name, mean, reported["mean"])
        r = float(rhat[var])
        worst_rhat = max(worst_rhat, abs(r - reported["rhat"]))
        assert abs(r - reported["rhat"]) <= 0.002, (name, r, reported["rhat"])
    print(f"largest |mean difference| {worst_mean:.3g}, largest |R-hat difference| {worst_rhat:.3g}")
    # lp__ is a sampler statistic, the per-trial log-likelihood its own group
    assert "lp" in idata.sample_stats
    assert "log_lik" in idata.log_likelihood
    lp = idata.sample_stats["lp"].values
    ll = idata.log_likelihood["log_lik"].values[..., 0]
    diff = lp - ll
    assert abs(diff.max() - diff.min()) < 1e-6  # the constant log prior density
