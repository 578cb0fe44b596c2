"""Shared fixtures: the repository, the `surae` command line to compare against, and a way to
run it."""

import csv
import json
import os
import subprocess
from pathlib import Path

import numpy as np
import pytest

REPO = Path(__file__).resolve().parents[2]


@pytest.fixture(scope="session")
def repo() -> Path:
    return REPO


@pytest.fixture(scope="session")
def surae_bin() -> Path:
    """The command-line binary: $SURAE_BIN, else the workspace's release build (built here
    when it is missing, so the comparison never silently runs against nothing)."""
    env = os.environ.get("SURAE_BIN")
    if env:
        path = Path(env)
        assert path.is_file(), f"SURAE_BIN={env} is not a file"
        return path
    target = Path(os.environ.get("CARGO_TARGET_DIR", REPO / "target"))
    path = target / "release" / "surae"
    if not path.is_file():
        subprocess.run(
            ["cargo", "build", "--release", "-p", "cli", "--bin", "surae"],
            cwd=REPO,
            check=True,
        )
    assert path.is_file(), f"{path} was not built"
    return path


@pytest.fixture
def cli(surae_bin):
    """Runs `surae ARGS` and returns the completed process (never raises on failure)."""

    def run(*args):
        return subprocess.run(
            [str(surae_bin), *map(str, args)],
            capture_output=True,
            text=True,
            cwd=REPO,
        )

    return run


def read_csv_columns(path):
    """A CSV with a header line as a dict of float arrays."""
    with open(path, newline="") as f:
        rows = [r for r in csv.reader(f) if r and not r[0].startswith("#")]
    header, body = rows[0], rows[1:]
    return {
        name: np.array([float(r[i]) for r in body]) for i, name in enumerate(header)
    }


def read_json(path):
    with open(path) as f:
        return json.load(f)


def without(doc, *keys):
    """A copy of a JSON object without some top-level keys."""
    return {k: v for k, v in doc.items() if k not in keys}
