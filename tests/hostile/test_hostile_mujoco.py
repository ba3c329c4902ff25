"""The hostile corpus on MuJoCo (``test_hostile.py`` says how it runs)."""

from __future__ import annotations

import sys
from pathlib import Path
from typing import Any

import pytest

sys.path.insert(0, str(Path(__file__).resolve().parent))

import _hostile_suite as suite  # noqa: E402

pytestmark = pytest.mark.slow  # among the slowest files: left out of the quick tier

GROUP = ("mujoco",)


@pytest.fixture(scope="module")
def reports(request: pytest.FixtureRequest, tmp_path_factory: pytest.TempPathFactory) -> Any:
    return suite.run_wanted(request, tmp_path_factory)


@pytest.mark.parametrize(("backend", "name"), suite.params(GROUP))
def test_case(reports: Any, backend: str, name: str) -> None:
    suite.check(reports, backend, name)


def test_children_left_nothing(reports: Any) -> None:
    assert suite.left_behind(reports) == {}
