"""README.md's code: every ```python block runs on its own (a fresh interpreter, nothing
defined before it), the quick start prints what the README says it prints, and the scenario of
"Write your own scenario" is a valid scenario file."""

from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

import pytest

from simbridge.compare.scenario import loads_scenario

README = Path(__file__).resolve().parents[1] / "README.md"


def _blocks(language: str) -> list[tuple[int, str]]:
    """(line, code) of every fenced block of ``language`` in the README."""
    text = README.read_text(encoding="utf-8")
    found = []
    for m in re.finditer(rf"^```{language}\n(.*?)^```$", text, re.S | re.M):
        found.append((text.count("\n", 0, m.start()) + 1, m.group(1)))
    return found


def _run(code: str, tmp_path: Path) -> str:
    done = subprocess.run(
        [sys.executable, "-c", code],
        cwd=tmp_path,
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert done.returncode == 0, done.stderr[-3000:]
    return done.stdout


PYTHON = _blocks("python")


def test_the_readme_has_its_blocks():
    assert len(PYTHON) >= 4 and len(_blocks("toml")) >= 1


@pytest.mark.parametrize("line, code", PYTHON, ids=[f"line{n}" for n, _ in PYTHON])
def test_every_python_block_runs_on_its_own(line, code, tmp_path):
    _run(code, tmp_path)


def _recorded_here() -> str | None:
    """Why this machine may not give the README's digits (None: its architecture, libm variant
    and engine versions are those they were recorded with,
    tests/compare/data/baseline/recorded.json; tests/_machine.py says why these decide)."""
    import json
    import platform

    import mujoco
    import pybullet

    sys.path.insert(0, str(Path(__file__).resolve().parent))
    from _machine import libm

    data = Path(__file__).resolve().parent / "compare" / "data" / "baseline" / "recorded.json"
    recorded = json.loads(data.read_text(encoding="utf-8"))
    here = {
        "machine": platform.machine(),
        "libm": libm(),
        "mujoco": mujoco.__version__,
        "pybullet": str(pybullet.getAPIVersion()),
    }
    differ = {k: (recorded.get(k), v) for k, v in here.items() if recorded.get(k) != v}
    return None if not differ else f"recorded with {differ} (recorded, here)"


@pytest.mark.parametrize("backend", ["pybullet", "mujoco"])
def test_the_quick_start_prints_what_the_readme_shows(backend, tmp_path):
    # the engines' trajectories are the same bits wherever libm takes the same variants and
    # the engine versions are the same (tests/_machine.py): the README's digits are held
    # exactly there; PhysX's float32 state is not held
    why = _recorded_here()
    if why is not None:
        pytest.skip(f"the README's quick-start digits were {why}")
    code = next(c for _, c in PYTHON if 'r2d2 = sim.load_urdf("r2d2.urdf"' in c)
    assert 'simbridge.Sim("pybullet")' in code
    out = _run(code.replace('Sim("pybullet")', f'Sim("{backend}")'), tmp_path)
    shown = re.search(rf'^Sim\("{backend}"\): +(\(.*\))$', README.read_text(encoding="utf-8"), re.M)
    assert shown is not None, f"the README shows no output for {backend}"
    assert out.strip() == shown.group(1)


def test_the_scenario_to_write_is_valid():
    (_, text), *_ = [(n, t) for n, t in _blocks("toml") if 'name = "my-pendulum"' in t]
    scenario = loads_scenario(text, file="README.md")
    assert scenario.name == "my-pendulum"
    assert [p.name for p in scenario.phases] == ["push", "swing"]


def test_the_physx_section_gives_the_rest_offset_and_both_install_lines():
    from simbridge.engine_settings import settings_for

    text = README.read_text(encoding="utf-8")
    section = text[text.index("## The PhysX backend") :]
    section = " ".join(section[: section.index("\n## ")].split())
    per_shape = settings_for("physx")["rest_offset"].default  # m
    assert f"rest offset 0 ({per_shape * 1000:g} mm per shape instead" in section
    assert f"two shapes rest {2 * per_shape * 1000:g} mm apart" in section
    assert "(1 mm between two shapes" not in section
    assert "`pip install 'simbridge[physx]'` (from a clone: `pip install -e '.[physx]'`" in section


def _extras_of(line: str) -> list[str]:
    """The extras a README command installs: ``pip install -q -e '.[a,b]'`` -> [a, b]."""
    m = re.search(r"pip install -q -e '\.\[([a-z,]+)\]'", line)
    assert m is not None, line
    return m.group(1).split(",")


def test_command_1_installs_and_compares_every_engine():
    """README command 1, the main job: one line that makes the venv, installs simbridge with
    the extras that every engine shipped with simbridge needs beyond the core dependencies
    (PhysX's SAPIEN is the ``physx`` extra) and the replay's (``report``), then compares r2d2
    on every installed engine (compare's default)."""
    import tomllib

    from simbridge import registry

    text = README.read_text(encoding="utf-8")
    setup = text[text.index("## Set-up: two commands") :]
    lines = [x for x in setup.splitlines() if x.startswith("python3 -m venv .venv")]
    line = next(x for x in lines if "simbridge compare" in x)
    assert line.endswith("&& .venv/bin/simbridge compare r2d2"), line
    extras = _extras_of(line)
    meta = tomllib.loads((README.parent / "pyproject.toml").read_text(encoding="utf-8"))
    project = meta["project"]

    def names(reqs: list[str]) -> set[str]:
        return {re.split(r"[<>=!~\[; ]", r, maxsplit=1)[0].lower() for r in reqs}

    installed = names(project["dependencies"])
    for extra in extras:
        installed |= names(project["optional-dependencies"][extra])
    shipped = [
        n
        for n in registry.available_backends()
        if registry.backend_spec(n).entry_point.startswith("simbridge.backends.")
    ]
    assert {"pybullet", "mujoco", "physx"} <= set(shipped)
    for name in shipped:
        dists = registry.engine_dists(name)
        assert set(dists) - {"numpy"} <= installed, (name, dists, extras)
    assert "viser" in installed  # report.html's 3D replay
