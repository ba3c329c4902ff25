"""Fixtures of the comparison tests: every registered backend, and pairs of them.

A backend whose module is not in this checkout (not written yet, or its engine not installed)
is skipped with the reason, unless ``SIMBRIDGE_REQUIRE_ALL_BACKENDS=1`` turns that into a
failure; a backend that is there but breaks on import fails.
"""

from __future__ import annotations

import os

import pytest

import simbridge
from simbridge.exceptions import BackendError, BackendNotInstalledError
from simbridge.registry import load_backend

BACKENDS = simbridge.available_backends()
OTHERS = [b for b in BACKENDS if b != "pybullet"]


def unavailable(name: str) -> str | None:
    """Why backend ``name`` cannot run here, or None when it can."""
    try:
        load_backend(name)
    except BackendNotInstalledError as exc:
        return str(exc)
    except BackendError as exc:
        cause = exc.__cause__
        if isinstance(cause, ModuleNotFoundError) and (cause.name or "").startswith(
            "simbridge.backends."
        ):
            return f"backend module {cause.name!r} does not exist in this checkout"
        raise
    return None


def require(name: str) -> str:
    reason = unavailable(name)
    if reason is not None:
        if os.environ.get("SIMBRIDGE_REQUIRE_ALL_BACKENDS") == "1":
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
