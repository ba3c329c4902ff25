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


def test_ci_runs_exactly_the_readmes_test_command() -> None:
    """.ci/run is the README's test command, character for character (its workers and
    distribution included: a suite that passes in CI passes for a reader who copies it)."""

    def command(text: str) -> list[str]:
        return [
            line.strip()
            for line in text.splitlines()
            if line.strip().startswith("python3 -m venv") and "[test]" in line
        ]

    readme = command((ROOT / "README.md").read_text(encoding="utf-8"))
    ci = command((ROOT / ".ci" / "run").read_text(encoding="utf-8"))
    assert len(readme) == 1 and "pytest" in readme[0], readme
    assert ci == readme
