"""The hostile corpus on PhysX (``test_hostile.py`` says how it runs)."""

from __future__ import annotations

import sys
from pathlib import Path
from typing import Any

import pytest

sys.path.insert(0, str(Path(__file__).resolve().parent))

import _hostile_suite as suite  # noqa: E402

GROUP = ("physx",)
# _hostile_cases.BACKENDS leaves PhysX out where its engine is missing (no case then): the module
# is skipped, or fails in CI (tests/_engines.py)
pytestmark = [pytest.mark.needs_backend("physx"), pytest.mark.slow]


@pytest.fixture(scope="module")
def reports(request: pytest.FixtureRequest, tmp_path_factory: pytest.TempPathFactory) -> Any:
    return suite.run_wanted(request, tmp_path_factory)


@pytest.mark.parametrize(("backend", "name"), suite.params(GROUP))
def test_case(reports: Any, backend: str, name: str) -> None:
    suite.check(reports, backend, name)


def test_children_left_nothing(reports: Any) -> None:
    assert suite.left_behind(reports) == {}
