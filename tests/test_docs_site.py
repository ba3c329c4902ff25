"""The documentation site (mkdocs.yml, docs/): it builds with ``mkdocs build --strict`` (a broken
link, a missing anchor, an API reference to a name that does not exist or a docstring griffe
cannot read fails it, as any warning does), every Python block on it runs on its own
(tests/_doc_blocks.py says how a block is marked), the README's links into it land, and what
the pages say is held to the code where it can drift (the scenario one writes is valid, the
PhysX section's rest offset is the setting's default).

Needs the extra ``docs`` (in ``test``): without MkDocs the build test is skipped, saying so,
and fails in CI (tests/_engines.py's rule).
"""

from __future__ import annotations

import importlib.util
import os
import re
import subprocess
import sys
from pathlib import Path

import pytest
from _doc_blocks import blocks, run_python
from _engines import require

ROOT = Path(__file__).resolve().parents[1]
DOCS = ROOT / "docs"
PAGES = sorted(DOCS.rglob("*.md"))


def _python_blocks() -> list:
    """Every Python block of the site, a pytest param marked slow where the page says so."""
    found = []
    for page in PAGES:
        for block in blocks(page, "python"):
            marks = [pytest.mark.slow] if "slow" in block.marks else []
            found.append(
                pytest.param(block, marks=marks, id=f"{block.file.relative_to(DOCS)}:{block.line}")
            )
    return found


PYTHON = _python_blocks()


def test_the_site_has_its_pages_and_blocks():
    names = {p.name for p in PAGES}
    assert {"index.md", "getting-started.md", "sim.md", "engines.md", "comparing.md"} <= names
    assert len(PYTHON) >= 10


def test_the_site_builds_strict(tmp_path):
    require(
        None
        if importlib.util.find_spec("mkdocs") and importlib.util.find_spec("mkdocstrings")
        else "MkDocs is not installed: pip install -e '.[docs]'"
    )
    done = subprocess.run(
        [sys.executable, "-m", "mkdocs", "build", "--strict", "-d", str(tmp_path / "site")],
        cwd=ROOT,
        capture_output=True,
        text=True,
        timeout=600,
        env=dict(os.environ, NO_MKDOCS_2_WARNING="1"),
    )
    out = done.stdout + done.stderr
    warnings = [line for line in out.splitlines() if re.match(r"(WARNING|ERROR)\b", line)]
    assert done.returncode == 0 and not warnings, out[-4000:]
    api = (tmp_path / "site" / "api" / "sim" / "index.html").read_text(encoding="utf-8")
    # the reference is rendered from the docstrings, their Google sections read as sections
    # (Sim's methods: 27 Returns, 42 Raises when this was written)
    assert api.count('doc-section-title">Raises:') >= 20, "Sim's Raises sections not rendered"
    assert "load_urdf" in api and "UrdfNotFoundError" in api


@pytest.mark.parametrize("block", PYTHON)
def test_every_python_block_runs_on_its_own(block, tmp_path):
    run_python(block, tmp_path)


def _slug(heading: str) -> str:
    """The anchor MkDocs gives a heading (Python-Markdown's toc slugify)."""
    from markdown.extensions.toc import slugify

    return slugify(re.sub(r"[`*]", "", heading), "-")


def test_the_readmes_links_into_the_site_land():
    """Every link from the README to a page of the site (``docs/x.md#anchor``) names a page
    that exists and a heading on it (MkDocs checks the site's own links when it builds)."""
    text = (ROOT / "README.md").read_text(encoding="utf-8")
    links = re.findall(r"\]\((docs/[\w/.-]+\.md)(?:#([\w-]+))?\)", text)
    for target, anchor in links:
        assert (ROOT / target).is_file(), f"README links to {target}, which does not exist"
        if anchor:
            headings = re.findall(r"^#+ (.+)$", (ROOT / target).read_text(encoding="utf-8"), re.M)
            assert anchor in {_slug(h) for h in headings}, f"{target} has no heading #{anchor}"


def test_the_scenario_to_write_is_valid():
    from simbridge.compare.scenario import loads_scenario

    (block,) = [
        b for b in blocks(DOCS / "comparing.md", "toml") if 'name = "my-pendulum"' in b.code
    ]
    scenario = loads_scenario(block.code, file="docs/comparing.md")
    assert scenario.name == "my-pendulum"
    assert [p.name for p in scenario.phases] == ["push", "swing"]


def test_the_physx_section_gives_the_rest_offset_and_both_install_lines():
    from simbridge.engine_settings import settings_for

    text = (DOCS / "engines.md").read_text(encoding="utf-8")
    section = text[text.index("## The PhysX backend") :] + "\n## "
    section = " ".join(section[: section.index("\n## ")].split())
    per_shape = settings_for("physx")["rest_offset"].default  # m
    assert f"rest offset 0 ({per_shape * 1000:g} mm per shape instead" in section
    assert f"two shapes rest {2 * per_shape * 1000:g} mm apart" in section
    assert "(1 mm between two shapes" not in section
    assert "`pip install 'simbridge[physx]'` (from a clone: `pip install -e '.[physx]'`" in section
