"""The type stubs describe the module as built: mypy's stubtest compares every name,
signature and default in surae/_surae.pyi with the extension."""

import subprocess
import sys


def test_stubs_match_the_module():
    r = subprocess.run(
        [sys.executable, "-m", "mypy.stubtest", "surae"],
        capture_output=True,
        text=True,
    )
    assert r.returncode == 0, r.stdout + r.stderr
