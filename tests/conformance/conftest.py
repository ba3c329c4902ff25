"""The conformance suite's fixtures: every registered backend, both profiles, shared robots.

Every test that takes the ``backend`` fixture runs once per name in
:func:`simbridge.available_backends` (built-in and entry-point backends alike), so a new backend
needs no new test code. A backend whose module or class is not there at all (not yet written,
or its engine not installed) fails if it is one this project ships (pybullet, mujoco, physx) and is
skipped with the reason if it is a third-party one, except in CI (``CI=true``) or with
``SIMBRIDGE_REQUIRE_ALL_BACKENDS=1``, where it fails; a backend that is there but breaks on
import always fails (tests/_engines.py: the suite's one rule).
"""

from __future__ import annotations

import tempfile
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import pytest

import simbridge

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
        "`within` measures by no more than the sizes recorded there (reported xfail; strict: "
        "a pass there fails, and so does a measure over its recorded size)",
    )


class Within:
    """The ``within`` fixture: ``within(what, measured, rule)`` asserts that a test's measure
    ``measured`` is at most its rule ``rule``. In a test marked ``known_bug(name)`` on a backend
    that declares that bug (_gaps.KNOWN_BUGS), a measure over its rule must be at most the size
    the bug records for ``what`` (a larger one, or one the bug records no size for, fails at
    once); it is noted, and the test goes on, so the asserts after it still run. The test is
    then reported xfail with the measures that showed the bug (pytest_runtest_makereport
    below)."""

    def __init__(self, name: str | None, bug: Any) -> None:
        self.name, self.bug = name, bug
        self.shown: list[tuple[str, float, float]] = []  # (what, measured, recorded size)
        self.met: list[str] = []  # measures within their rule

    def __call__(self, what: str, measured: float, rule: float) -> None:
        measured = float(measured)
        if measured <= rule:
            self.met.append(what)
            return
        if self.bug is None:
            raise AssertionError(f"{what}: {measured:.3g} > {rule:.3g}")
        size = self.bug.sizes.get(what)
        if size is None:
            raise AssertionError(
                f"{what}: {measured:.3g} > {rule:.3g}, and known bug {self.name!r} records no "
                "size for it (tests/conformance/_gaps.py KNOWN_BUGS): a departure it does not "
                "describe"
            )
        if not measured <= size:
            raise AssertionError(
                f"{what}: {measured:.3g} > {rule:.3g}, and beyond the {size:.3g} known bug "
                f"{self.name!r} records (tests/conformance/_gaps.py KNOWN_BUGS): worse than "
                "measured"
            )
        self.shown.append((what, measured, size))


@pytest.fixture
def within(request: pytest.FixtureRequest, backend: str) -> Within:
    marker = request.node.get_closest_marker("known_bug")
    if marker is None:
        return Within(None, None)
    from _gaps import known_bug

    return Within(marker.args[0], known_bug(backend, marker.args[0]))


@pytest.hookimpl(hookwrapper=True)
def pytest_runtest_makereport(item: pytest.Item, call: pytest.CallInfo[None]):  # type: ignore[no-untyped-def]
    """A test marked known_bug(name) on a backend that declares that bug: reported xfail where
    it passed with at least one measure over its rule (and within the bug's recorded size: the
    ``within`` fixture), naming them; a failure stays a failure (a measure beyond its recorded
    size among them); a pass with every measure within its rule fails (the bug is gone: take it
    out of _gaps.KNOWN_BUGS), and so does a pass where a measure the bug records a size for met
    its rule (take that size out)."""
    outcome = yield
    marker = item.get_closest_marker("known_bug")
    if marker is None or call.when != "call":
        return
    from _gaps import known_bug

    params = getattr(item, "callspec", None)
    bug = known_bug(params.params.get("backend") if params else None, marker.args[0])
    if bug is None:
        return
    report = outcome.get_result()
    if not report.passed:
        return
    checked = getattr(item, "funcargs", {}).get("within")
    stale = [what for what in checked.met if what in bug.sizes] if checked else []
    if checked is None:
        why = "it takes no `within` fixture: the bug's measures must go through it"
    elif not checked.shown:
        why = "it no longer shows: take it out of tests/conformance/_gaps.py KNOWN_BUGS"
    elif stale:
        why = f"{stale} met their rule: take their sizes out of tests/conformance/_gaps.py"
    else:
        shown = ", ".join(f"{w} {m:.3g} (<= {s:.3g})" for w, m, s in checked.shown)
        report.outcome = "skipped"
        report.wasxfail = f"known bug {marker.args[0]!r}: {bug.why}; measured {shown}"
        return
    report.outcome = "failed"
    report.longrepr = f"known bug {marker.args[0]!r} on this backend: {why}"


@pytest.fixture(params=BACKENDS)
def backend(request: pytest.FixtureRequest) -> str:
    from _engines import require_backend  # tests/_engines.py: the suite's one rule

    return require_backend(request.param, always=request.param in SHIPPED_BACKENDS)


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
