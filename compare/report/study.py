"""A report folder's ``study.json``, and the report rebuilt from it and the cache alone.

:func:`write_study` records what :func:`~simbridge.compare.compare` was asked (the scenario's
canonical TOML and its file, the backends, profiles, time steps, ensemble, seed, tolerance,
resync interval), the key of every job, and the options :func:`~simbridge.compare.report` was
given; after ``--resolve``, :func:`add_resolution` adds the verdict at each time step
(``resolve``: the report's resolve table and summary.json's ``resolve``).
:func:`~simbridge.compare.report.rebuild.rebuild` (``simbridge report DIR [--cache
DIR]``) makes the comparison again
from those jobs' cached results, running no engine, and writes the whole report again; a job
missing from the cache is a :class:`~simbridge.exceptions.CacheEntryMissingError` naming it.
"""

from __future__ import annotations

import json
import os
from pathlib import Path
from typing import Any

from simbridge.exceptions import SimbridgeError

from ..pipeline import Comparison
from ..run.studyjobs import STUDY_FORMAT

__all__ = ["STUDY_FILE", "write_study", "read_study", "add_resolution"]

STUDY_FILE = "study.json"


def write_study(comparison: Comparison, out: Path, options: dict[str, Any]) -> Path | None:
    """Write ``out/study.json`` (None: a comparison made by hand, with no study record)."""
    if comparison.study is None:
        return None
    record = dict(comparison.study)
    record.pop("resolve", None)  # a resolve study adds its own (add_resolution)
    record["wall_time"] = comparison.wall_time
    record["report"] = dict(options)
    if "inputs" not in record:  # what the jobs' keys hold besides the arguments
        from .inputs import study_inputs

        record["inputs"] = study_inputs(record)
    path = out / STUDY_FILE
    path.write_text(json.dumps(record, indent=2, allow_nan=True) + "\n", encoding="utf-8")
    return path


def read_study(folder: str | os.PathLike[str]) -> dict[str, Any]:
    """The ``study.json`` of report folder ``folder``.

    Raises:
        FileNotFoundError: no ``study.json`` there.
        SimbridgeError: one this version cannot read.
    """
    path = Path(folder) / STUDY_FILE
    if not path.is_file():
        raise FileNotFoundError(
            f"{path} not found: {str(folder)!r} is not a report folder written by "
            "`simbridge compare` (or was written before reports recorded their study; a sweep's "
            "or an explain's folder is written again by running it: its runs come from the cache)"
        )
    try:
        record = json.loads(path.read_text(encoding="utf-8"))
    except ValueError as exc:
        raise SimbridgeError(f"{path}: not JSON ({exc})") from None
    if not isinstance(record, dict) or record.get("format") != STUDY_FORMAT:
        raise SimbridgeError(
            f"{path}: expected format {STUDY_FORMAT!r}, got {record.get('format')!r}"
        )
    return record


def add_resolution(
    out: str | os.PathLike[str], resolution: dict[str, Any], lines: list[str]
) -> None:
    """Add a resolve study to the report in ``out``: its table (``lines``) to report.md, its
    steps (``Resolution.as_dict()``) to summary.json under ``resolve``, and both to
    study.json, from which :func:`~simbridge.compare.report.rebuild.rebuild` adds them again
    (the table is the study's: its verdicts and wall times at each step, not made again)."""
    out = Path(out)
    md = out / "report.md"
    text = md.read_text(encoding="utf-8") if md.exists() else ""
    md.write_text(text.rstrip("\n") + "\n" + "\n".join(lines) + "\n", "utf-8")
    sj = out / "summary.json"
    data = json.loads(sj.read_text(encoding="utf-8")) if sj.exists() else {}
    data["resolve"] = resolution
    sj.write_text(json.dumps(data, indent=2, default=_plain) + "\n", encoding="utf-8")
    path = out / STUDY_FILE
    if path.is_file():
        record = json.loads(path.read_text(encoding="utf-8"))
        record["resolve"] = {"summary": resolution, "markdown": list(lines)}
        text = json.dumps(record, indent=2, allow_nan=True, default=_plain)
        path.write_text(text + "\n", encoding="utf-8")


def _plain(obj: Any) -> Any:
    tolist = getattr(obj, "tolist", None)  # a numpy scalar or array
    if tolist is not None:
        return tolist()
    return str(obj)
