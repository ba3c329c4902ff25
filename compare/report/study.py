"""A report folder's ``study.json``, and the report rebuilt from it and the cache alone.

:func:`write_study` records what :func:`~simbridge.compare.compare` was asked (the scenario's
canonical TOML and its file, the backends, profiles, time steps, ensemble, seed, tolerance,
resync interval), the key of every job, and the options :func:`~simbridge.compare.report` was
given. :func:`~simbridge.compare.report.rebuild.rebuild` (``simbridge report DIR [--cache
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

__all__ = ["STUDY_FILE", "write_study", "read_study"]

STUDY_FILE = "study.json"


def write_study(comparison: Comparison, out: Path, options: dict[str, Any]) -> Path | None:
    """Write ``out/study.json`` (None: a comparison made by hand, with no study record)."""
    if comparison.study is None:
        return None
    record = dict(comparison.study)
    record["wall_time"] = comparison.wall_time
    record["report"] = dict(options)
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
            "`simbridge compare` (or was written before reports recorded their study)"
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
