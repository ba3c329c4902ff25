"""Fixtures for every test: the result cache of compare() (``$XDG_CACHE_HOME/simbridge`` by
default) points into a temporary folder for the whole session, so that no test (nor a
command-line run a test starts, which inherits the environment) writes the user's own cache."""

from __future__ import annotations

import os
from collections.abc import Iterator

import pytest


@pytest.fixture(scope="session", autouse=True)
def _private_cache_home(tmp_path_factory: pytest.TempPathFactory) -> Iterator[None]:
    old = os.environ.get("XDG_CACHE_HOME")
    os.environ["XDG_CACHE_HOME"] = str(tmp_path_factory.mktemp("xdg-cache"))
    try:
        yield
    finally:
        if old is None:
            os.environ.pop("XDG_CACHE_HOME", None)
        else:
            os.environ["XDG_CACHE_HOME"] = old


# The longest test modules (seconds in a full run on 2 workers, 2026-11-26: the hostile corpus's
# three module setups 115-150 s each, the soak 146 s, the windows under Xvfb ~100 s, the
# same-results hashes ~150 s, the CLI's full r2d2 run 88 s) go first: under `--dist loadfile`
# the workers take modules in collection order, and one of these collected last (the soak was)
# ran alone at the end for minutes while the other worker idled.
FIRST = (
    "tests/test_soak.py",
    "tests/hostile/test_hostile_physx.py",
    "tests/hostile/test_hostile_mujoco.py",
    "tests/hostile/test_hostile.py",
    "tests/test_same_results.py",
    "tests/test_gui.py",
    "tests/test_cli.py",
    "tests/compare/test_report_html.py",
)


def pytest_collection_modifyitems(config: pytest.Config, items: list[pytest.Item]) -> None:
    def rank(item: pytest.Item) -> int:
        path = item.nodeid.split("::", 1)[0]
        for i, name in enumerate(FIRST):
            if path == name or path.endswith("/" + name):
                return i
        return len(FIRST)

    items.sort(key=rank)  # a stable sort: every other module keeps its place
