"""Every key ``summary.json`` writes is documented in docs/compare.md, and every key documented
there is written.

docs/compare.md's section "``summary.json``: every key" lists them two names deep: a top-level
key, then the keys under it, through the maps keyed by data (``<engine>``: an engine label,
``<outcome>``: an outcome's name, ``<quantity>``: a quantity, ``<kind>``: an event kind,
``<threshold>``: a threshold) and lists (``[]``: every item), which do not count as a name. The
written keys are those of the summaries recorded for every shipped scenario
(tests/compare/data/baseline/, written by the same :func:`simbridge.compare.summary`; the
same-results test keeps them current), so this test runs no engine.
"""

from __future__ import annotations

import gzip
import json
import re
from pathlib import Path
from typing import Any

from simbridge.compare import QUANTITIES
from simbridge.compare.run.events import KINDS

HERE = Path(__file__).resolve().parents[1]
DOC = HERE.parents[1] / "docs" / "compare.md"
BASELINE = HERE / "data" / "baseline"
HEADING = "### `summary.json`: every key"
DEPTH = 2


def _placeholder(keys: set[str], summary: dict[str, Any]) -> str | None:
    """The name of a map keyed by data, or None for a map of fixed keys."""
    outcomes = {d["name"] for d in (summary.get("outcomes") or {}).get("declared", [])}
    if not keys:
        return None
    for name, pool in (
        ("<engine>", set(summary["labels"])),
        ("<outcome>", outcomes),
        ("<quantity>", set(QUANTITIES)),
        ("<kind>", set(KINDS)),
    ):
        if keys <= pool:
            return name
    if all(re.fullmatch(r"[-+0-9.e]+", k) for k in keys):
        return "<threshold>"
    return None


def written(summary: dict[str, Any]) -> set[str]:
    """Every key path of ``summary`` up to :data:`DEPTH` names deep."""
    out: set[str] = set()

    def walk(value: Any, path: str, depth: int) -> None:
        if isinstance(value, dict):
            ph = _placeholder(set(value), summary)
            for key, item in value.items():
                name = ph or key
                sub = f"{path}.{name}" if path else name
                deeper = depth if ph else depth + 1
                if deeper <= DEPTH:
                    out.add(sub)
                    walk(item, sub, deeper)
        elif isinstance(value, list):
            for item in value:
                walk(item, path + "[]", depth)

    walk(summary, "", 0)
    return out


def documented() -> set[str]:
    """The key paths listed in docs/compare.md's section: ``parent: key, key`` lines, or a
    bare top-level key."""
    text = DOC.read_text(encoding="utf-8")
    section = text.split(HEADING, 1)[1].split("```text", 1)[1].split("```", 1)[0]
    out: set[str] = set()
    for line in section.strip().splitlines():
        line = line.partition("#")[0]  # a key written only in some cases carries a comment
        parent, colon, children = line.partition(":")
        parent = parent.strip()
        out.add(parent)
        if colon:
            out.update(f"{parent}.{c.strip()}" for c in children.split(",") if c.strip())
    for path in list(out):  # every parent path is a key in its own right
        parts = path.split(".")
        out.update(".".join(parts[:k]) for k in range(1, len(parts)))
    return out


def conditional() -> set[str]:
    """The keys docs/compare.md's list marks as written only in some cases (``key  # only
    when ...``): not in every recorded summary, tested where they are written
    (tests/compare/pipeline/test_compare_every_engine.py)."""
    text = DOC.read_text(encoding="utf-8")
    section = text.split(HEADING, 1)[1].split("```text", 1)[1].split("```", 1)[0]
    return {
        line.partition("#")[0].partition(":")[0].strip()
        for line in section.strip().splitlines()
        if "#" in line
    }


def _recorded() -> list[dict[str, Any]]:
    out = []
    for path in sorted(BASELINE.glob("*/summary.json.gz")):
        with gzip.open(path, "rt", encoding="utf-8") as f:
            out.append(json.load(f))
    return out


def _normal(paths: set[str]) -> set[str]:
    """``sweep[].engines`` and ``sweep`` alike: a list's path without its brackets too."""
    return {p.replace("[]", "") for p in paths}


def test_every_written_key_is_documented_and_every_documented_key_written():
    summaries = _recorded()
    assert len(summaries) >= 9
    keys: set[str] = set()
    for s in summaries:
        keys |= written(s)
    doc = documented()
    assert _normal(keys) - _normal(doc) == set(), "written, not documented in " + HEADING
    only = _normal(conditional())  # pairs[].resync too
    assert _normal(doc) - _normal(keys) - only == set(), "documented, never written"
    assert conditional() <= doc and not only & _normal(keys), "a conditional key in every summary"


def test_the_key_walk_names_maps_keyed_by_data():
    s = {
        "labels": ["a", "b"],
        "own": {"a": {"final": 1.0, "deep": {"x": 1}}, "b": {"final": 2.0, "deep": {}}},
        "sweep": [{"timestep": 0.1, "engines": {"a": {"wall": 1}}}],
        "cross": {"crossings": {"base_distance": {"0.01": None}}},
    }
    assert written(s) == {
        "labels",
        "own",
        "own.<engine>",
        "own.<engine>.final",
        "own.<engine>.deep",
        "sweep",
        "sweep[].timestep",
        "sweep[].engines",
        "sweep[].engines.<engine>",
        "cross",
        "cross.crossings",
        "cross.crossings.<quantity>",
        "cross.crossings.<quantity>.<threshold>",
    }
