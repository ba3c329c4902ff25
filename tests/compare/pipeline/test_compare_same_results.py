"""Every shipped scenario gives the summary and report it gave when they were recorded, bit for
bit, on every machine that can give them.

tests/compare/data/baseline/<case>/ holds ``summary.json`` (gzipped) and ``report.md`` as
:func:`simbridge.compare.compare` and :func:`~simbridge.compare.report` wrote them for each case
of :data:`CASES` (short runs with small ensembles, so that the whole pipeline runs in seconds:
the runs, the ensembles, the one-step resync, the verdict, events, parts, outcomes and every
section of the report). The test reruns each case and compares every figure of
``summary.json`` and every line of ``report.md`` exactly, after masking what legitimately
changes from one run or machine to the next: wall times, the simbridge and engine versions,
absolute paths, the command line and the worker count.

Exactly, with no tolerance: the trajectories are the same bits on every x86-64 processor with
FMA and AVX2 (tests/test_same_results.py), and so are the figures computed from them, which
call no BLAS and none of numpy's processor-dispatched loops (compare/run/portable.py says
which and why). As no figure can move, no printed digit can flip at a rounding boundary
either. :func:`test_the_same_figures_whatever_the_kernels` proves it on the processor at hand,
in child processes under other OpenBLAS kernels and numpy dispatch levels
(tests/_machine.py). The record is keyed on what decides its bits (:func:`_environment`: the
architecture, which libm variants the processor gets, and the versions of Python, numpy,
scipy and the engines); elsewhere the tests skip, saying which differs.

To record them again (a change of results that is deliberate, committed on its own with the
reason)::

    .venv/bin/python tests/compare/pipeline/test_compare_same_results.py
"""

from __future__ import annotations

import gzip
import json
import math
import os
import platform
import re
import shutil
import subprocess
import sys
from pathlib import Path
from typing import Any

import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[2]))
from _machine import kernel_variants, libm  # noqa: E402

DATA = Path(__file__).resolve().parents[1] / "data" / "baseline"
ROOT = Path(__file__).resolve().parents[3]

# name -> (scenario, options of compare()); each a few seconds on one core
CASES: dict[str, tuple[str, dict[str, Any]]] = {
    "ant-gait": ("ant-gait", {"duration": 1.0, "ensemble": 3}),
    "double-pendulum": ("double-pendulum", {"duration": 2.0, "ensemble": 3}),
    "kuka-reach": ("kuka-reach", {"ensemble": 3}),
    "laikago-stand": ("laikago-stand", {"ensemble": 3}),
    "pendulum": ("pendulum", {"duration": 2.0, "ensemble": 3, "timesteps": ["1/240", "1/480"]}),
    "r2d2-gentle": ("r2d2-gentle", {"duration": 1.5, "ensemble": 3}),
    "r2d2-goto": ("r2d2-goto", {"duration": 2.0, "ensemble": 3}),
    "r2d2": ("r2d2", {"duration": 1.5, "ensemble": 3, "plots": True}),
    "spinning-wheel": ("spinning-wheel", {"duration": 1.0, "ensemble": 1}),
}

# summary.json keys whose values change from run to run or machine to machine
MASKED_KEYS = {
    "wall_time",
    "wall_per_sim_second",
    "workers",
    "command_line",
    "simbridge_version",
    "engine_version",
    "engine_build",
    "python",
    "platform",
    "numpy",
    "scenario_file",
    "text",  # headline.text: report.md's opening lines, compared there
}


def _environment() -> dict[str, str]:
    """What the recorded bits depend on (tests/_machine.py): not the processor's name, its
    OpenBLAS kernel nor numpy's dispatch targets, which the figures are proven free of."""
    import mujoco
    import numpy
    import pybullet
    import scipy

    return {
        "machine": platform.machine(),
        "libm": libm(),
        "python": platform.python_version(),
        "numpy": numpy.__version__,
        "scipy": scipy.__version__,
        "mujoco": mujoco.__version__,
        "pybullet": str(pybullet.getAPIVersion()),
    }


def _unlike_the_record() -> str | None:
    """Why this machine cannot give the recorded bits (None: it can)."""
    recorded = json.loads((DATA / "recorded.json").read_text("utf-8"))
    here = _environment()
    differ = {k: (recorded.get(k), v) for k, v in here.items() if recorded.get(k) != v}
    if not differ:
        return None
    return f"recorded with other bits' deciders, {differ} (recorded, here)"


def _produce(
    case: str, out: Path, cache: Path | bool | None = None, workers: int | None = None
) -> Path:
    from simbridge.compare import compare, report

    scenario, options = CASES[case]
    options = dict(options)
    plots = options.pop("plots", False)
    result = compare(
        scenario,
        ["pybullet", "mujoco"],
        command_line=["simbridge"],
        cache=cache,
        workers=workers,
        **options,
    )
    report(result, out, plots=plots, trajectories=False, replay=False)  # figures, not pictures
    return out


def _mask(value: Any, paths: list[str]) -> Any:
    if isinstance(value, dict):
        return {k: ("<masked>" if k in MASKED_KEYS else _mask(v, paths)) for k, v in value.items()}
    if isinstance(value, list):
        return [_mask(v, paths) for v in value]
    if isinstance(value, str):
        for p in paths:
            value = value.replace(p, "<path>")
        return value
    return value


_WALL = re.compile(r"\b\d+(\.\d+)? ms\b")


def _mask_report(text: str, paths: list[str]) -> str:
    for p in paths:
        text = text.replace(p, "<path>")
    text = _WALL.sub("<ms>", text)  # wall time per simulated second
    text = re.sub(r"^simbridge \S+\.$", "simbridge <version>.", text, flags=re.M)
    lines = []
    for line in text.splitlines():
        if line.startswith("| ") and line.count("|") >= 8 and "<ms>" in line:
            cells = line.split("|")
            cells[2] = " <version> "  # the Setup table's engine version
            line = "|".join(cells)
        lines.append(line)
    return "\n".join(lines)


def _paths(out: Path) -> list[str]:
    return sorted({str(out), str(ROOT), str(Path.home())}, key=len, reverse=True)


def _masked(
    case: str, tmp: Path, cache: Path | bool | None = False, workers: int | None = None
) -> tuple[Any, str]:
    """``case``'s summary.json and report.md as recorded: masked, the report's text ending
    in a newline (``cache=False``: every job runs, none comes from ~/.cache/simbridge)."""
    out = _produce(case, tmp / case, cache, workers)
    paths = _paths(out)
    summary = _mask(json.loads((out / "summary.json").read_text("utf-8")), paths)
    text = _mask_report((out / "report.md").read_text("utf-8"), paths) + "\n"
    return summary, text


def _record(cases: list[str]) -> None:
    """Record the named cases (all when none are named: ``python
    tests/compare/pipeline/test_compare_same_results.py [CASE ...]``)."""
    import shutil
    import tempfile

    DATA.mkdir(parents=True, exist_ok=True)
    (DATA / "recorded.json").write_text(
        json.dumps(_environment(), indent=2) + "\n", encoding="utf-8"
    )
    for case in cases or CASES:
        with tempfile.TemporaryDirectory() as tmp:
            summary, text = _masked(case, Path(tmp))
        folder = DATA / case
        if folder.exists():
            shutil.rmtree(folder)
        folder.mkdir()
        with gzip.open(folder / "summary.json.gz", "wt", encoding="utf-8") as f:
            f.write(json.dumps(summary, indent=0, allow_nan=True) + "\n")
        (folder / "report.md").write_text(text, encoding="utf-8")
        print(case, file=sys.stderr)


def _produce_all(dest: Path, jobs: Path | None = None) -> None:
    """Every case's masked summary.json and report.md into ``dest`` (``CASE.json``,
    ``CASE.md``), its jobs run in this process (or read from the cache folder ``jobs``, which
    holds only the jobs' results: every verdict, figure and report line is computed here), and
    the numpy targets this process has in ``targets.json``: what a child of
    :func:`test_the_same_figures_whatever_the_kernels` does (``python
    tests/compare/pipeline/test_compare_same_results.py --produce DIR [--jobs CACHE]``)."""
    import tempfile

    from _machine import numpy_targets

    dest.mkdir(parents=True, exist_ok=True)
    (dest / "targets.json").write_text(json.dumps(numpy_targets()), encoding="utf-8")
    for case in CASES:
        with tempfile.TemporaryDirectory() as tmp:
            summary, text = _masked(case, Path(tmp), jobs if jobs else False, workers=0)
        (dest / f"{case}.json").write_text(json.dumps(summary, allow_nan=True), "utf-8")
        (dest / f"{case}.md").write_text(text, encoding="utf-8")


def _recorded(case: str) -> tuple[Any, str]:
    with gzip.open(DATA / case / "summary.json.gz", "rt", encoding="utf-8") as f:
        summary = json.load(f)
    return summary, (DATA / case / "report.md").read_text("utf-8")


def _diff(expected: Any, got: Any, where: str = "") -> list[str]:
    """Where two JSON values differ (exactly: floats too; NaN equals NaN)."""
    if isinstance(expected, dict) and isinstance(got, dict):
        out = [f"{where}/{k}: missing" for k in expected if k not in got]
        out += [f"{where}/{k}: not recorded" for k in got if k not in expected]
        for k in expected:
            if k in got:
                out += _diff(expected[k], got[k], f"{where}/{k}")
        return out
    if isinstance(expected, list) and isinstance(got, list):
        if len(expected) != len(got):
            return [f"{where}: {len(got)} items, recorded {len(expected)}"]
        pairs = enumerate(zip(expected, got, strict=True))
        return [d for k, (e, g) in pairs for d in _diff(e, g, f"{where}[{k}]")]
    nan = isinstance(expected, float) and math.isnan(expected)
    same = (math.isnan(got) if isinstance(got, float) else False) if nan else expected == got
    if same and type(expected) is type(got):
        return []
    return [f"{where}: {got!r}, recorded {expected!r}"]


@pytest.fixture(scope="module")
def module_cache(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The cache of this module's studies: test_same_summary_and_report_as_recorded runs each
    case's jobs into it, and test_a_warm_cache_gives_the_recorded_figures (after it) starts
    from those jobs instead of running the same case's engines again."""
    return tmp_path_factory.mktemp("same-results-cache")


@pytest.mark.slow
@pytest.mark.parametrize("case", list(CASES))
def test_same_summary_and_report_as_recorded(case, tmp_path, module_cache):
    why = _unlike_the_record()
    if why is not None:
        pytest.skip(why)
    summary, text = _masked(case, tmp_path, module_cache)
    expected, report_md = _recorded(case)
    differences = _diff(expected, summary)
    assert not differences, "summary.json differs:\n" + "\n".join(differences[:40])
    assert text == report_md


@pytest.mark.usefixtures("_no_home_cache_writes")
@pytest.mark.parametrize("case", ["pendulum", "r2d2-goto"])
def test_a_warm_cache_gives_the_recorded_figures(case, tmp_path, module_cache):
    """The recorded cases from a warm cache: nothing runs, and summary.json and report.md are
    the recorded ones. The cache is the module's: where the case's own test ran before, its
    jobs are there already and the first compare() runs none either."""
    from simbridge.compare import compare, report

    why = _unlike_the_record()
    if why is not None:
        pytest.skip(why)
    scenario, options = CASES[case]
    options = {k: v for k, v in options.items() if k != "plots"}
    backends = ["pybullet", "mujoco"]
    compare(scenario, backends, command_line=["simbridge"], cache=module_cache, **options)
    warm = compare(scenario, backends, command_line=["simbridge"], cache=module_cache, **options)
    assert warm.jobs is not None and warm.jobs.ran == 0 and warm.jobs.cached == warm.jobs.total
    out = tmp_path / case
    report(warm, out, plots=False, trajectories=False, replay=False)
    paths = _paths(out)
    summary = _mask(json.loads((out / "summary.json").read_text("utf-8")), paths)
    with gzip.open(DATA / case / "summary.json.gz", "rt", encoding="utf-8") as f:
        expected = json.load(f)
    assert not _diff(expected, summary)
    text = _mask_report((out / "report.md").read_text("utf-8"), paths) + "\n"
    assert text == (DATA / case / "report.md").read_text("utf-8")


@pytest.mark.slow
def test_the_same_figures_whatever_the_kernels(tmp_path, module_cache):
    """Every case, in one child process per kernel choice (tests/_machine.py: numpy's
    run-time targets turned down a level at a time, each with an OpenBLAS kernel of that
    level), gives the recorded summary.json and report.md bit for bit, as the parent's
    defaults do (test_same_summary_and_report_as_recorded): on an AVX-512 machine its AVX-512
    paths are the defaults', its AVX2 and AVX paths the children's. The children run their
    jobs in their own process (workers=0), side by side, and say which numpy targets they had
    and which OpenBLAS kernel loaded (``OPENBLAS_VERBOSE=2``), so a variable that did not
    take fails the test rather than proving nothing.

    The children start from the engines' runs of this module's cases (a copy of the module
    cache's ``jobs`` folder and nothing derived from it: no verdict, figure or report text),
    where those ran first, as they do in the module's order: what a kernel could move here is
    the figures computed from the runs, and every one of them is computed again in each child.
    The runs themselves are proven kernel-free by tests/test_same_results.py (the Python step
    loop under the same variants, the compiled loop and PyBullet calling no BLAS). A child
    given no jobs runs them too, as before (``-k`` this test alone): about 26 s of CPU a child
    then, measured 2026-11-29 against 5 s from the jobs (the same nine cases, figures and
    reports alike).

    Measured before compare/run/portable.py (an AVX-512 machine, the figures recorded on an
    AVX2 one): 61 figures of 9 cases moved in this test's AVX2 child, laikago-stand's report
    by 30 lines; after it none, in either child. About 26 s of CPU a child."""
    why = _unlike_the_record()
    if why is not None:
        pytest.skip(why)
    variants = kernel_variants()
    if not variants:
        pytest.skip("the kernel variants are x86-64's")
    children = []
    for k, (name, extra) in enumerate(variants):
        env = dict(os.environ, OPENBLAS_VERBOSE="2", **extra)
        if "NPY_DISABLE_CPU_FEATURES" not in extra:
            env.pop("NPY_DISABLE_CPU_FEATURES", None)
        dest = tmp_path / f"variant{k}"
        cmd = [sys.executable, str(Path(__file__).resolve()), "--produce", str(dest)]
        if (module_cache / "jobs").is_dir():  # the runs alone, copied: nothing derived
            shutil.copytree(module_cache / "jobs", tmp_path / f"cache{k}" / "jobs")
            cmd += ["--jobs", str(tmp_path / f"cache{k}")]
        proc = subprocess.Popen(
            cmd, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True
        )
        children.append((name, extra, dest, proc))
    failures = []
    for name, extra, dest, proc in children:
        _, err = proc.communicate(timeout=900)
        if proc.returncode != 0:
            failures.append(f"{name}: exit {proc.returncode}: {err[-2000:]}")
            continue
        core = re.search(r"^Core: (\S+)", err, re.M)
        if core is None or core.group(1) != extra["OPENBLAS_CORETYPE"]:
            failures.append(f"{name}: OpenBLAS loaded {core and core.group(1)!r}")
        off = set(extra.get("NPY_DISABLE_CPU_FEATURES", "").split())
        left = off & set(json.loads((dest / "targets.json").read_text("utf-8")))
        if left:
            failures.append(f"{name}: numpy still dispatched to {sorted(left)}")
        for case in CASES:
            expected, report_md = _recorded(case)
            got = json.loads((dest / f"{case}.json").read_text("utf-8"))
            moved = _diff(expected, got)
            if moved:
                failures.append(f"{name}: {case}: {len(moved)} figures moved: {moved[:3]}")
            if (dest / f"{case}.md").read_text("utf-8") != report_md:
                failures.append(f"{name}: {case}: report.md differs")
    assert failures == [], "\n".join(failures)


if __name__ == "__main__":
    if sys.argv[1:2] == ["--produce"]:
        jobs = Path(sys.argv[4]) if sys.argv[3:4] == ["--jobs"] else None
        _produce_all(Path(sys.argv[2]), jobs)
    else:
        _record(sys.argv[1:])
