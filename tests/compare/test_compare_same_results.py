"""Every shipped scenario gives the summary and report it gave when they were recorded.

tests/compare/data/baseline/<case>/ holds ``summary.json`` (gzipped) and ``report.md`` as
:func:`simbridge.compare.compare` and :func:`~simbridge.compare.report` wrote them for each case
of :data:`CASES` (short runs with small ensembles, so that the whole pipeline runs in seconds:
the runs, the ensembles, the one-step resync, the verdict, events, parts, outcomes and every
section of the report). The test reruns each case and compares every figure of
``summary.json`` and every line of ``report.md`` exactly, after masking what legitimately
changes from one run or machine to the next: wall times, the simbridge and engine versions,
absolute paths, the command line and the worker count.

The engines' trajectories depend on the processor's floating-point kernels, so an exact
comparison holds on the machine and engine versions that recorded them (``recorded.json``); on
another the test is skipped with the reason. To record them again (a change of results that is
deliberate, committed on its own with the reason)::

    .venv/bin/python tests/compare/test_compare_same_results.py
"""

from __future__ import annotations

import gzip
import json
import math
import platform
import re
import sys
from pathlib import Path
from typing import Any

import pytest

DATA = Path(__file__).resolve().parent / "data" / "baseline"
ROOT = Path(__file__).resolve().parents[2]

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
    import mujoco
    import numpy
    import pybullet

    return {
        "machine": platform.machine(),
        "processor": _cpu_model(),
        "python": platform.python_version(),
        "numpy": numpy.__version__,
        "mujoco": mujoco.__version__,
        "pybullet": str(pybullet.getAPIVersion()),
    }


def _cpu_model() -> str:
    try:
        text = Path("/proc/cpuinfo").read_text(encoding="utf-8")
    except OSError:
        return platform.processor()
    found = re.search(r"^model name\s*:\s*(.+)$", text, re.M)
    return found.group(1).strip() if found else platform.processor()


def _produce(case: str, out: Path, cache: Path | None = None) -> Path:
    from simbridge.compare import compare, report

    scenario, options = CASES[case]
    options = dict(options)
    plots = options.pop("plots", False)
    result = compare(
        scenario, ["pybullet", "mujoco"], command_line=["simbridge"], cache=cache, **options
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


def _record(cases: list[str]) -> None:
    """Record the named cases (all when none are named: ``python
    tests/compare/test_compare_same_results.py [CASE ...]``)."""
    import shutil
    import tempfile

    DATA.mkdir(parents=True, exist_ok=True)
    (DATA / "recorded.json").write_text(
        json.dumps(_environment(), indent=2) + "\n", encoding="utf-8"
    )
    for case in cases or CASES:
        with tempfile.TemporaryDirectory() as tmp:
            out = _produce(case, Path(tmp) / case)
            paths = _paths(out)
            summary = _mask(json.loads((out / "summary.json").read_text("utf-8")), paths)
            text = _mask_report((out / "report.md").read_text("utf-8"), paths)
        folder = DATA / case
        if folder.exists():
            shutil.rmtree(folder)
        folder.mkdir()
        with gzip.open(folder / "summary.json.gz", "wt", encoding="utf-8") as f:
            f.write(json.dumps(summary, indent=0, allow_nan=True) + "\n")
        (folder / "report.md").write_text(text + "\n", encoding="utf-8")
        print(case, file=sys.stderr)


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
    recorded = json.loads((DATA / "recorded.json").read_text("utf-8"))
    here = _environment()
    if here != recorded:
        pytest.skip(f"recorded on {recorded}, this is {here}: engine results may differ")
    out = _produce(case, tmp_path / case, module_cache)
    paths = _paths(out)
    summary = _mask(json.loads((out / "summary.json").read_text("utf-8")), paths)
    with gzip.open(DATA / case / "summary.json.gz", "rt", encoding="utf-8") as f:
        expected = json.load(f)
    differences = _diff(expected, summary)
    assert not differences, "summary.json differs:\n" + "\n".join(differences[:40])
    text = _mask_report((out / "report.md").read_text("utf-8"), paths) + "\n"
    assert text == (DATA / case / "report.md").read_text("utf-8")


@pytest.mark.usefixtures("_no_home_cache_writes")
@pytest.mark.parametrize("case", ["pendulum", "r2d2-goto"])
def test_a_warm_cache_gives_the_recorded_figures(case, tmp_path, module_cache):
    """The recorded cases from a warm cache: nothing runs, and summary.json and report.md are
    the recorded ones. The cache is the module's: where the case's own test ran before, its
    jobs are there already and the first compare() runs none either."""
    from simbridge.compare import compare, report

    if _environment() != json.loads((DATA / "recorded.json").read_text("utf-8")):
        pytest.skip("the recorded figures are from another machine or engine version")
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


if __name__ == "__main__":
    _record(sys.argv[1:])
