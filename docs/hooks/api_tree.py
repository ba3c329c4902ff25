"""A MkDocs hook: the package tree as it is installed, for mkdocstrings to read, and the
docstrings' Sphinx roles made links.

The installed package ``simbridge`` is put together from four folders (pyproject.toml's
``package-dir``: ``src/simbridge``, ``backends``, ``compare``, ``robots``); mkdocstrings reads
source files and finds ``simbridge.compare`` only inside ``src/simbridge``. This hook builds a
temporary ``simbridge/`` of symbolic links to those folders when the build starts and points
the Python handler at it, so ``::: simbridge.compare.pipeline.compare`` resolves. The folders
come from pyproject.toml itself: a new mapped folder needs no change here.

The docstrings name other objects with Sphinx roles (``:func:`~simbridge.compare.compare```),
which Markdown shows as the literal ``:func:`` before the name. :func:`on_page_content` turns
each into a cross-reference that mkdocs-autorefs resolves to the object's place in the API
reference (a name the reference does not render stays code, with no warning); ``~`` shows the
last part of the name, as Sphinx does.
"""

from __future__ import annotations

import atexit
import re
import shutil
import tempfile
import tomllib
from pathlib import Path
from typing import Any

from mkdocs.plugins import event_priority

ROOT = Path(__file__).resolve().parents[2]


def _package_dirs() -> dict[str, Path]:
    """Dotted package name -> its folder, from pyproject.toml's ``[tool.setuptools]
    package-dir``."""
    pyproject = tomllib.loads((ROOT / "pyproject.toml").read_text(encoding="utf-8"))
    mapped = pyproject["tool"]["setuptools"]["package-dir"]
    return {name: ROOT / folder for name, folder in mapped.items() if name}


def build_tree(into: Path) -> Path:
    """Link every mapped folder into ``into`` at its dotted name's place; returns ``into``.

    Raises:
        FileNotFoundError: a folder named in pyproject.toml does not exist.
    """
    dirs = _package_dirs()
    for name in sorted(dirs, key=lambda n: n.count(".")):  # parents before their children
        target = into.joinpath(*name.split("."))
        if target.is_symlink() or target.exists():
            continue  # inside a linked parent already, at the same folder
        target.parent.mkdir(parents=True, exist_ok=True)
        if not dirs[name].is_dir():
            raise FileNotFoundError(f"pyproject.toml maps {name!r} to {dirs[name]}: no such folder")
        target.mkdir()
        for entry in dirs[name].iterdir():
            if entry.name != "__pycache__":
                (target / entry.name).symlink_to(entry)
    return into


@event_priority(100)  # before mkdocstrings' own on_config, which makes the handler
def on_config(config: Any) -> Any:
    """Point mkdocstrings' Python handler at a fresh tree (removed when the build ends)."""
    tree = Path(tempfile.mkdtemp(prefix="simbridge-api-"))
    atexit.register(shutil.rmtree, tree, ignore_errors=True)
    handlers = config["plugins"]["mkdocstrings"].config["handlers"]
    handlers.setdefault("python", {})["paths"] = [str(build_tree(tree))]
    return config


_ROLE = re.compile(r":(?:func|class|meth|mod|data|attr|exc|obj):<code>(~?)([\w.]+)</code>")


def _role_link(match: re.Match[str]) -> str:
    """One role's HTML: an optional autorefs cross-reference, or code for a relative name."""
    tilde, target = match.groups()
    shown = target.rsplit(".", 1)[-1] if tilde else target.lstrip(".")
    if target.startswith("."):
        return f"<code>{shown}</code>"
    return f'<autoref identifier="{target}" optional><code>{shown}</code></autoref>'


def on_page_content(html: str, **_: Any) -> str:
    """Each ``:role:`name``` of a rendered docstring made a cross-reference (see above).

    Args:
        html: the page's HTML.
        **_: MkDocs' other arguments (page, config, files), unused.

    Returns:
        The HTML with the roles replaced.
    """
    return _ROLE.sub(_role_link, html)
