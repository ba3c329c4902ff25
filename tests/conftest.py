"""Fixtures for every test: the result cache of compare() (``$XDG_CACHE_HOME/simbridge`` by
default) points into a temporary folder for the whole session, so that no test (nor a
command-line run a test starts, which inherits the environment) writes the user's own cache.

And the order of the suite under ``pytest -n 2 --dist loadfile`` (README): pytest-xdist hands
out whole modules, those with the most tests first, so a long module of one test (the soak,
about 155 s) came last and ran alone while the other worker stood idle. The modules in
:data:`SCHEDULED_FIRST` are handed out before all others, longest first; the rest keep xdist's
order."""

from __future__ import annotations

import os
import sys
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

SCHEDULED_FIRST = (
    "tests/test_soak.py",
    "tests/test_same_results.py",
    "tests/compare/pipeline/test_compare_same_results.py",
    "tests/test_conformance_neutrality.py",
    "tests/test_gui.py",
    "tests/test_gui_mujoco.py",
    "tests/hostile/test_hostile.py",
    "tests/hostile/test_hostile_mujoco.py",
    "tests/hostile/test_hostile_physx.py",
    "tests/test_docs_site.py",
    "tests/test_bench.py",
    "tests/conformance/test_pybullet_data.py",
    "tests/test_packaging.py",
)
"""Modules (paths from the repository root) that take a minute or more as a whole, longest
first (``pytest -m slow -n 1 --durations=60``, 2026-11-29, the machine shared: the soak's six
rows 510 s, same-results 400 s, the report figures' same-results 250 s, the neutrality run
144 s, each window file 130-170 s, each hostile corpus 90-110 s; the site's blocks, the bench
smoke runs, pybullet_data's files and the wheel about a minute each): handed out first under
``--dist loadfile``, longest first, so that neither worker is left with a long module at the
end while the other stands idle (xdist hands out the modules with the most tests first, which
put these modules of few tests last)."""


@pytest.hookimpl(optionalhook=True)  # a pytest-xdist hook: without xdist it is never called
def pytest_xdist_make_scheduler(config: pytest.Config, log: Any) -> Any:
    """Under ``--dist loadfile``, xdist's own scheduler with :data:`SCHEDULED_FIRST` moved to
    the front of its queue (xdist keeps its queue of modules in an ordered dict and hands out
    its first entry); any other ``--dist`` keeps xdist's scheduler."""
    if config.getvalue("dist") != "loadfile":
        return None
    from xdist.scheduler import LoadFileScheduling

    class LongModulesFirst(LoadFileScheduling):
        def _assign_work_unit(self, node: Any) -> None:
            queue = getattr(self, "workqueue", None)
            if queue is not None and hasattr(queue, "move_to_end"):
                for module in reversed(SCHEDULED_FIRST):
                    if module in queue:
                        queue.move_to_end(module, last=False)
            super()._assign_work_unit(node)

    return LongModulesFirst(config, log)


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


def pytest_configure(config: pytest.Config) -> None:
    """Ctrl-C raises KeyboardInterrupt in every test process. A shell without job control
    starts a command put in the background (``cmd &``) with SIGINT ignored, which Python then
    keeps (it installs its own handler only where SIGINT was left at its default), and every
    process started from it inherits: the tests that stop a step, a pool or a command with
    Ctrl-C then waited for ever (a clean-clone run started as ``(bash .ci/run &)`` hung in
    test_world's and test_executors' Ctrl-C tests). The xdist workers and the commands the
    tests start inherit the handler set here (an exec resets a handled signal to its
    default). And the ``needs_backend`` mark (:func:`pytest_runtest_setup`); and the checkout
    compiled where Python writes no bytecode (:func:`_compile_the_checkout`)."""
    import signal

    if signal.getsignal(signal.SIGINT) is signal.SIG_IGN:
        signal.signal(signal.SIGINT, signal.default_int_handler)
    config.addinivalue_line(
        "markers",
        "needs_backend(name): the test needs backend name's engine: where it is missing the "
        "test is skipped with what to install, or fails in CI (tests/_engines.py)",
    )
    _compile_the_checkout(config)


COMPILED = ("src/simbridge", "backends", "compare", "bench", "tests")
"""The folders (from the repository root) whose modules :func:`_compile_the_checkout` compiles."""


def _compile_the_checkout(config: pytest.Config) -> None:
    """Where Python writes no bytecode (``PYTHONDONTWRITEBYTECODE``, as on the project's 2-core
    machines), every process the suite starts (a command, a documentation block, a pool's
    spawned worker, a window or hostile child) compiled simbridge's modules from their source
    again: 0.15 s of CPU for a child that makes a MuJoCo Sim, more for one that runs a
    comparison. They are compiled once here, before the tests (into the ``__pycache__``
    folders git ignores, as Python's own imports write them where bytecode is written; a file
    already compiled is left alone, about 1 s of CPU the first time), and every process reads
    them: tests/cli/test_cli.py with compare/run/test_compare_ensemble.py 80.8 -> 69.8 s of CPU
    with their children. Once per run: in the main process, not again in each xdist worker."""
    if not sys.flags.dont_write_bytecode or hasattr(config, "workerinput"):
        return
    import compileall

    root = Path(__file__).resolve().parents[1]
    for folder in COMPILED:
        compileall.compile_dir(root / folder, quiet=2, workers=1)


def pytest_collection_finish(session: pytest.Session) -> None:
    """What collection made (the modules imported, the engines among them, the 4,000 test
    items and their parameters: all alive to the end of the session) moved out of the
    collector's reach (``gc.freeze``), so that each of the automatic full collections during
    the tests walks only what the tests made since, not the same collection-time objects again.
    Measured with the whole suite collected and test_joint_table's 511 tests run (``pytest
    tests -k "test_joint_table and not test_joint_table_and"``): 6.4 -> 4.2 s of the process's
    CPU in the collector. Nothing
    a test checks changes: what is frozen was never garbage, and the tests' own objects are
    collected as before."""
    import gc

    gc.collect()
    gc.freeze()


def pytest_runtest_setup(item: pytest.Item) -> None:
    """A test marked ``needs_backend(name)``: skipped or failed, by tests/_engines.py's one
    rule, where that backend's engine is missing."""
    from _engines import require_backend

    for mark in item.iter_markers("needs_backend"):
        require_backend(*mark.args)
