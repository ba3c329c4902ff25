"""README.md's code: every ```python block runs on its own (a fresh interpreter, nothing
defined before it; tests/_doc_blocks.py, shared with the site's pages) and the quick start
prints what the README says it prints. The sections the README once held live on the site
(docs/): tests/test_docs_site.py runs their blocks and checks their figures."""

from __future__ import annotations

import re
import sys
from pathlib import Path

import pytest
from _doc_blocks import blocks, run_python

README = Path(__file__).resolve().parents[1] / "README.md"

PYTHON = blocks(README, "python")


def test_the_readme_has_its_blocks():
    assert len(PYTHON) >= 1 and any("python3 -m venv" in b.code for b in blocks(README, "bash"))


@pytest.mark.parametrize("block", PYTHON, ids=[f"line{b.line}" for b in PYTHON])
def test_every_python_block_runs_on_its_own(block, tmp_path):
    run_python(block, tmp_path)


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
    block = next(b for b in PYTHON if 'r2d2 = sim.load_urdf("r2d2.urdf"' in b.code)
    assert 'simbridge.Sim("pybullet")' in block.code
    out = run_python(
        block, tmp_path, code=block.code.replace('Sim("pybullet")', f'Sim("{backend}")')
    )
    shown = re.search(rf'^Sim\("{backend}"\): +(\(.*\))$', README.read_text(encoding="utf-8"), re.M)
    assert shown is not None, f"the README shows no output for {backend}"
    assert out.strip() == shown.group(1)


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
