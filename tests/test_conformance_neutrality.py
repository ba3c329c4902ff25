"""The conformance suite is backend-neutral: a backend it has never heard of runs it.

A backend registered under a new name through the ``simbridge.backends`` entry-point group
(``mujoco-alias``: a subclass of the MuJoCo backend with only its name changed, exposed by a
throwaway ``.dist-info`` on ``PYTHONPATH`` in a child process, as an installed package would)
runs the suite with no KeyError and no failure from a test that branches on a backend's name:
where backends differ, a test asks the backend's declared facts or the known-gaps table
(tests/conformance/_gaps.py, which a subclass of a listed backend inherits), never the name.

Cost, measured on this project's 2-core machine shared with other work (wall time of
``PYTHONPATH=<alias> pytest tests/conformance -k mujoco-alias``): the whole suite on the alias,
612 tests, 174 s; ``-m "not exhaustive"`` (every test module, pybullet_data's random URDFs left
out), 602 tests, 98 s; that with one profile, 537 tests, 112 s (the machine was busier: the
profile is not where the time goes, the file sweeps are). So the test runs the first case of
each test function of ``-m "not exhaustive"``: 147 cases in the 18 modules that take the
backend, 70 s in all (collection included). Every test's code runs on the alias once (a
branch that only some cases reach, such as one file of a sweep, is left to the static check
below); every module that takes the ``backend`` fixture is checked to have run (from the JUnit
report). Marked ``slow``.

A static check beside it: no file under tests/conformance compares a backend's name to a
literal backend name, indexes a table by the backend, or keys a dict by a backend's name
(_gaps.py, where the known gaps are declared, aside).
"""

from __future__ import annotations

import ast
import os
import subprocess
import sys
import xml.etree.ElementTree as ET
from collections.abc import Iterator
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
SUITE = ROOT / "tests" / "conformance"
ALIAS = "mujoco-alias"

# The names a conformance test could branch on: the shipped backends, the one being written,
# and the alias. Profiles share the name "pybullet": a comparison with a profile is not flagged.
BACKEND_NAMES = {"pybullet", "mujoco", "physx", ALIAS}
PROFILE_NAMES = {"pybullet", "urdf"}
DECLARED_IN = {"_gaps.py"}  # where the known gaps are keyed by backend, by design

ALIAS_MODULE = f'''from simbridge.backends.mujoco import MujocoBackend


class AliasBackend(MujocoBackend):
    """The MuJoCo backend under a name no test has ever seen."""

    name = "{ALIAS}"
'''


def _install_alias(folder: Path) -> None:
    """A module and the ``.dist-info`` an installed package would have: importlib.metadata
    finds its entry point on sys.path, as pip's install would leave it."""
    (folder / "simbridge_alias_backend.py").write_text(ALIAS_MODULE, encoding="utf-8")
    info = folder / "simbridge_alias-0.0.dist-info"
    info.mkdir()
    (info / "METADATA").write_text(
        "Metadata-Version: 2.1\nName: simbridge-alias\nVersion: 0.0\n", encoding="utf-8"
    )
    (info / "entry_points.txt").write_text(
        f"[simbridge.backends]\n{ALIAS} = simbridge_alias_backend:AliasBackend\n",
        encoding="utf-8",
    )


def _env(folder: Path) -> dict[str, str]:
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join(filter(None, [str(folder), env.get("PYTHONPATH")]))
    env["SIMBRIDGE_REQUIRE_ALL_BACKENDS"] = "1"  # an alias that fails to load fails, not skips
    return env


def _modules_taking_the_backend() -> set[str]:
    """The suite's test modules with a test that takes the backend (``backend`` or
    ``make_sim``): those the alias must run."""
    found = set()
    for path in sorted(SUITE.glob("test_*.py")):
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, ast.FunctionDef) and node.name.startswith("test_"):
                if {"backend", "make_sim"} & {a.arg for a in node.args.args}:
                    found.add(path.stem)
                    break
    return found


def test_the_alias_is_registered_through_the_entry_point_group(tmp_path):
    _install_alias(tmp_path)
    code = (
        "import simbridge\n"
        f"assert {ALIAS!r} in simbridge.available_backends()\n"
        f"with simbridge.Sim({ALIAS!r}) as sim:\n"
        "    body = sim.load_urdf('r2d2.urdf')\n"
        "    sim.step()\n"
        "    print(sim.backend, type(sim.manifest()['backend']).__name__)\n"
    )
    child = subprocess.run(
        [sys.executable, "-c", code],
        capture_output=True,
        text=True,
        env=_env(tmp_path),
        cwd=ROOT,
        timeout=120,
    )
    assert child.returncode == 0, child.stderr
    assert child.stdout.split() == [ALIAS, "str"]


def _pytest(folder: Path, *args: str, timeout: float) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-m", "pytest", "-p", "no:cacheprovider", *args],
        capture_output=True,
        text=True,
        env=_env(folder),
        cwd=ROOT,
        timeout=timeout,
    )


def _one_case_per_test(collected: str) -> list[str]:
    """The first collected case of each test function (``path::name[params]`` lines): a name
    branch or a table keyed by name fails in every case of a test alike, so one case each runs
    every test's code at a fraction of the sweep's cost."""
    first: dict[str, str] = {}
    for line in collected.splitlines():
        if "::" in line and f"[{ALIAS}" in line:
            first.setdefault(line.partition("[")[0], line.strip())
    return list(first.values())


@pytest.mark.slow
def test_a_backend_under_a_new_name_runs_the_conformance_suite(tmp_path):
    _install_alias(tmp_path)
    listed = _pytest(
        tmp_path,
        "--collect-only",
        "-q",
        str(SUITE),
        "-k",
        ALIAS,
        "-m",
        "not exhaustive",
        timeout=300,
    )
    assert listed.returncode == 0, listed.stdout[-4000:] + listed.stderr[-2000:]
    cases = _one_case_per_test(listed.stdout)
    report = tmp_path / "report.xml"
    child = _pytest(tmp_path, "-q", f"--junitxml={report}", *cases, timeout=900)
    assert child.returncode == 0, child.stdout[-6000:] + child.stderr[-2000:]
    ran: dict[str, int] = {}
    for case in ET.parse(report).getroot().iter("testcase"):
        assert f"[{ALIAS}" in case.get("name", ""), case.get("name")  # the alias's own runs
        outcome = {c.tag for c in case}
        assert not {"failure", "error", "skipped"} & outcome, (case.get("name"), outcome)
        module = case.get("classname", "").rpartition(".")[2]
        ran[module] = ran.get(module, 0) + 1
    assert sum(ran.values()) == len(cases)
    missing = _modules_taking_the_backend() - set(ran)
    assert not missing, f"modules the alias did not run: {sorted(missing)}"


def test_one_case_per_test_keeps_the_first_of_each():
    collected = (
        f"tests/conformance/test_a.py::test_x[{ALIAS}-pybullet]\n"
        f"tests/conformance/test_a.py::test_x[{ALIAS}-urdf]\n"
        "tests/conformance/test_a.py::test_x[mujoco-urdf]\n"
        f"tests/conformance/test_a.py::test_y[{ALIAS}]\n"
        "\n602 tests collected in 3.1s\n"
    )
    assert _one_case_per_test(collected) == [
        f"tests/conformance/test_a.py::test_x[{ALIAS}-pybullet]",
        f"tests/conformance/test_a.py::test_y[{ALIAS}]",
    ]


# ---------------------------------------------------------------- no name branch, read statically


def _names_a_backend(node: ast.AST) -> bool:
    """A literal backend name, or a tuple/list/set of them."""
    if isinstance(node, ast.Constant):
        return isinstance(node.value, str) and node.value in BACKEND_NAMES
    if isinstance(node, (ast.Tuple, ast.List, ast.Set)):
        return any(_names_a_backend(e) for e in node.elts)
    return False


def _is_the_backend(node: ast.AST) -> bool:
    """An expression that is a backend's name: a variable named ``backend`` (or ``*backend*``),
    an attribute ``.backend`` (``sim.backend``, ``state.backend``), or ``x["backend"]``
    (``sim.manifest()["backend"]``)."""
    if isinstance(node, ast.Name):
        return "backend" in node.id.lower()
    if isinstance(node, ast.Attribute):
        return node.attr == "backend"
    if isinstance(node, ast.Subscript):
        return isinstance(node.slice, ast.Constant) and node.slice.value == "backend"
    return False


def _name_branches(tree: ast.Module) -> Iterator[tuple[int, str]]:
    """(line, code) of each place a test could branch on, or index by, a backend's name."""
    for node in ast.walk(tree):
        if isinstance(node, ast.Compare):
            operands = [node.left, *node.comparators]
            if any(map(_is_the_backend, operands)) and any(map(_names_a_backend, operands)):
                yield node.lineno, ast.unparse(node)
        elif isinstance(node, ast.Subscript) and _is_the_backend(node.slice):
            yield node.lineno, ast.unparse(node)  # TABLE[backend]: a KeyError for a new one
        elif (
            isinstance(node, ast.Call)
            and isinstance(node.func, ast.Attribute)
            and node.func.attr == "get"
            and node.args
            and _is_the_backend(node.args[0])
        ):
            yield node.lineno, ast.unparse(node)  # TABLE.get(backend): silently nothing
        elif isinstance(node, ast.Dict):
            keys = [k for k in node.keys if isinstance(k, ast.Constant)]
            if any(k.value in BACKEND_NAMES - PROFILE_NAMES for k in keys):
                yield node.lineno, ast.unparse(node)[:80]


def test_no_conformance_test_branches_on_a_backend_name():
    found = [
        f"  {path.relative_to(ROOT)}:{line}: {code}"
        for path in sorted(SUITE.glob("*.py"))
        if path.name not in DECLARED_IN
        for line, code in _name_branches(ast.parse(path.read_text(encoding="utf-8")))
    ]
    assert not found, (
        "the conformance suite asks a backend's declared facts or the known gaps "
        "(tests/conformance/_gaps.py, README.md there), never its name:\n" + "\n".join(found)
    )


def test_the_name_check_sees_each_way_of_writing_a_branch():
    code = ast.parse(
        "if backend == 'mujoco': pass\n"
        "x = sim.backend != 'pybullet'\n"
        "n = 3000 if sim.manifest()['backend'] == 'pybullet' else 40000\n"
        "other = 'mujoco' if backend == 'pybullet' else 'pybullet'\n"
        "ok = backend in ('pybullet', 'mujoco')\n"
        "limit = DEEPEST[backend]\n"
        "entry = REFUSED.get(sim.backend, {})\n"
        "FLOOR = {'mujoco': 1e-10, 'pybullet': 0.5}\n"
        # none of these is a name branch
        "if profile == 'pybullet': pass\n"
        "brake = sim.profile.joint_brake == 'pybullet'\n"
        "size = gap(backend, 'link_state_float32')\n"
        "p = {'pybullet': 1, 'urdf': 2}\n"
    )
    assert sorted(line for line, _ in _name_branches(code)) == [1, 2, 3, 4, 5, 6, 7, 8]
