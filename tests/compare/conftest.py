"""Fixtures of the comparison tests: every registered backend, and pairs of them.

PyBullet and MuJoCo fail where they cannot load; another backend whose engine or module is missing
(PhysX without the physx extra) is skipped with the reason, except in CI (``CI=true``) or with
``SIMBRIDGE_REQUIRE_ALL_BACKENDS=1``, where it fails; a backend that is there but breaks on
import fails (tests/_engines.py: the suite's one rule).
"""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path

import pytest
from _engines import require_backend as require

import simbridge

BACKENDS = simbridge.available_backends()
OTHERS = [b for b in BACKENDS if b != "pybullet"]


@pytest.fixture(params=BACKENDS)
def backend(request: pytest.FixtureRequest) -> str:
    """Each registered backend in turn."""
    return require(request.param)


@pytest.fixture(params=OTHERS)
def other(request: pytest.FixtureRequest) -> str:
    """Each registered backend but PyBullet, the reference engine of the comparisons."""
    require("pybullet")
    return require(request.param)


@pytest.fixture
def _no_home_cache_writes() -> Iterator[None]:
    """Nothing of the test lands in the user's own cache (~/.cache/simbridge)."""
    home = Path.home() / ".cache" / "simbridge"
    before = sorted(home.rglob("*")) if home.exists() else None
    yield
    after = sorted(home.rglob("*")) if home.exists() else None
    assert after == before, "a test wrote the user's cache"
