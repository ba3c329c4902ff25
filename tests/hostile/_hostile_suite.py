"""The hostile corpus's per-case tests, made for a group of backends: each backend group is its
own test module (``test_hostile_<group>.py``), so the two pytest workers (``--dist loadfile``)
share the corpus out instead of one worker running all of it (283 s in one module before)."""

from __future__ import annotations

from collections.abc import Iterable
from typing import Any

import _hostile_cases as h
import _hostile_runner as runner
import pytest


def params(group: Iterable[str]) -> list[Any]:
    """One pytest param per (backend, case) of the corpus whose backend is in ``group``."""
    group = set(group)
    out = []
    for case in h.CASES.values():
        for backend in case.backends:
            if backend not in group:
                continue
            reason = h.known(case.name, backend)
            marks = [pytest.mark.xfail(strict=True, reason=reason)] if reason else []
            out.append(pytest.param(backend, case.name, id=f"{backend}-{case.name}", marks=marks))
    return out


def run_wanted(request: pytest.FixtureRequest, tmp_path_factory: pytest.TempPathFactory) -> Any:
    """Run, in child processes, the cases of this module's ``test_case`` items selected in the
    session (a ``-k`` run starts only the children it needs)."""
    wanted = set()
    for item in request.session.items:
        spec = getattr(item, "callspec", None)
        if (
            getattr(item, "originalname", "") == "test_case"
            and item.module is request.module
            and spec is not None
        ):
            wanted.add((spec.params["backend"], spec.params["name"]))
    return runner.run(sorted(wanted), tmp_path_factory.mktemp("hostile"))


def check(reports: Any, backend: str, name: str) -> None:
    failure = runner.verdict(h.CASES[name], backend, reports.get((backend, name)))
    assert failure is None, failure


def left_behind(reports: Any) -> dict[Any, Any]:
    """What a child process left in its private TMPDIR when it ended (after every case in it
    had been checked)."""
    return {key: value for key, value in reports.items() if key[1].startswith("@")}
