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
