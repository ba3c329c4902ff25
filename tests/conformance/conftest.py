"""The conformance suite's fixtures: every registered backend, both profiles, shared robots.

Every test that takes the ``backend`` fixture runs once per name in
:func:`simbridge.available_backends` (built-in and entry-point backends alike), so a new backend
needs no new test code. A backend whose module or class is not there at all (not yet written,
or its engine not installed) fails if it is one this project ships (pybullet, mujoco, physx) and is
skipped with the reason if it is a third-party one, unless
``SIMBRIDGE_REQUIRE_ALL_BACKENDS=1`` (CI) turns that into a failure; a backend that is there but
breaks on import always fails.
"""

from __future__ import annotations

import os
import tempfile
from collections.abc import Callable, Iterator
from pathlib import Path

import pytest

import simbridge
from simbridge.registry import unavailable_reason

BACKENDS = simbridge.available_backends()
PROFILES = ["pybullet", "urdf"]
# The backends this project ships must always run: only a third-party backend may be skipped.
SHIPPED_BACKENDS = ("pybullet", "mujoco", "physx")

ROBOTS_DIR = Path(__file__).resolve().parents[2] / "robots"


def pytest_configure(config: pytest.Config) -> None:
    config.addinivalue_line(
        "markers",
        "exhaustive: every URDF of pybullet_data (about 1100 files); runs by default, "
        'deselect with -m "not exhaustive" for a quick pass',
    )
    config.addinivalue_line(
        "markers",
        "known_bug(name): a backend listed under _gaps.KNOWN_BUGS[name] fails this test's "
        "assertions (reported xfail; strict: a pass there fails)",
    )


@pytest.hookimpl(hookwrapper=True)
def pytest_runtest_makereport(item: pytest.Item, call: pytest.CallInfo[None]):  # type: ignore[no-untyped-def]
    """A test marked known_bug(name) on a backend that declares that bug: an assertion failure
    is reported as xfail with the declared cause, a pass as a failure (the bug is gone: take it
    out of _gaps.KNOWN_BUGS); any other error stays an error."""
    outcome = yield
    marker = item.get_closest_marker("known_bug")
    if marker is None or call.when != "call":
        return
    from _gaps import known_bug

    params = getattr(item, "callspec", None)
    why = known_bug(params.params.get("backend") if params else None, marker.args[0])
    if why is None:
        return
    report = outcome.get_result()
    if report.failed and call.excinfo is not None and call.excinfo.errisinstance(AssertionError):
        report.outcome = "skipped"
        report.wasxfail = f"known bug {marker.args[0]!r}: {why}"
    elif report.passed:
        report.outcome = "failed"
        report.longrepr = (
            f"known bug {marker.args[0]!r} no longer shows on this backend: take it out of "
            "tests/conformance/_gaps.py KNOWN_BUGS"
        )


@pytest.fixture(params=BACKENDS)
def backend(request: pytest.FixtureRequest) -> str:
    name: str = request.param
    reason = unavailable_reason(name)
    if reason is not None:
        if name in SHIPPED_BACKENDS or os.environ.get("SIMBRIDGE_REQUIRE_ALL_BACKENDS") == "1":
            pytest.fail(f"backend {name!r} is registered but unavailable: {reason}")
        pytest.skip(f"backend {name!r} unavailable here: {reason}")
    return name


@pytest.fixture(params=PROFILES)
def profile(request: pytest.FixtureRequest) -> str:
    return request.param  # type: ignore[no-any-return]


@pytest.fixture
def make_sim(backend: str) -> Iterator[Callable[..., simbridge.Sim]]:
    """A factory of Sims on the current backend; every Sim is closed after the test."""
    sims: list[simbridge.Sim] = []

    def make(**kwargs: object) -> simbridge.Sim:
        sim = simbridge.Sim(backend, **kwargs)  # type: ignore[arg-type]
        sims.append(sim)
        return sim

    yield make
    for sim in sims:
        sim.close()


@pytest.fixture
def private_tmp(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    """A private temporary directory that every ``tempfile`` call of this process uses, so a test
    can check that a backend left nothing behind (the shared /tmp sees other processes' files)."""
    folder = tmp_path / "tmp"
    folder.mkdir()
    monkeypatch.setenv("TMPDIR", str(folder))
    monkeypatch.setattr(tempfile, "tempdir", str(folder))
    return folder
