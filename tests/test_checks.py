"""The project's static checks, run as part of the test suite (so CI, which runs exactly the
README's test command, runs them too): ruff's lint and format check over the whole tree, and
mypy over every package (src/simbridge, backends, compare: ``files`` in pyproject.toml).

Each runs in a child process with this interpreter's own ruff and mypy (the ``test`` extra), from
the repository root, so that pyproject.toml's settings apply. mypy keeps its cache in
.mypy_cache: about 8 s the first time, under 1 s after.
"""

from __future__ import annotations

import importlib.util
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]

CHECKS = {
    "ruff check": ("ruff", ["check", "."]),
    "ruff format": ("ruff", ["format", "--check", "."]),
    "mypy": ("mypy", []),
}


@pytest.mark.parametrize("name", list(CHECKS))
def test_static_check_passes(name: str) -> None:
    tool, args = CHECKS[name]
    assert importlib.util.find_spec(tool) is not None, (
        f"{tool} is not installed in {sys.executable}'s environment: "
        "pip install -e '.[test]' (see the README's test command)"
    )
    out = subprocess.run(
        [sys.executable, "-m", tool, *args],
        cwd=ROOT,
        capture_output=True,
        text=True,
        timeout=300,
    )
    if out.returncode != 0:
        pytest.fail(
            f"`{tool} {' '.join(args)}` failed (exit {out.returncode}) in {ROOT}:\n"
            f"{out.stdout}{out.stderr}",
            pytrace=False,
        )
