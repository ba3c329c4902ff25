"""Fixtures of the comparison tests: every registered backend, and pairs of them.

A shipped backend (pybullet, mujoco) that cannot load fails; a third-party backend whose engine
or module is missing is skipped with the reason, unless ``SIMBRIDGE_REQUIRE_ALL_BACKENDS=1``
turns that into a failure; a backend that is there but breaks on import fails.
"""

from __future__ import annotations

import os
from collections.abc import Iterator
from pathlib import Path

import pytest

import simbridge
from simbridge.registry import unavailable_reason

BACKENDS = simbridge.available_backends()
OTHERS = [b for b in BACKENDS if b != "pybullet"]
SHIPPED_BACKENDS = ("pybullet", "mujoco")  # never skipped: only a third-party backend may be


def require(name: str) -> str:
    reason = unavailable_reason(name)
    if reason is not None:
        if name in SHIPPED_BACKENDS or os.environ.get("SIMBRIDGE_REQUIRE_ALL_BACKENDS") == "1":
            pytest.fail(f"backend {name!r} is registered but unavailable: {reason}")
        pytest.skip(f"backend {name!r} unavailable here: {reason}")
    return name


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
