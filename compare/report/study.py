"""A report folder's ``study.json``, and the report rebuilt from it and the cache alone.

:func:`write_study` records what :func:`~simbridge.compare.compare` was asked (the scenario's
canonical TOML and its file, the backends, profiles, time steps, ensemble, seed, tolerance,
resync interval), the key of every job, and the options :func:`~simbridge.compare.report` was
given; after ``--resolve``, :func:`record_resolution` adds the verdict at each time step
(``resolve``: :meth:`~simbridge.compare.study.Resolution.as_dict`), the report's resolve table.
:func:`~simbridge.compare.report.rebuild.rebuild` (``simbridge report DIR [--cache
DIR]``) makes the comparison again
from those jobs' cached results, running no engine, and writes the whole report again; a job
missing from the cache is a :class:`~simbridge.exceptions.CacheEntryMissingError` naming it.
"""

from __future__ import annotations

import json
import math
import os
from pathlib import Path
from typing import Any

from simbridge.exceptions import SimbridgeError

from ..pipeline import Comparison
from ..run.studyjobs import STUDY_FORMAT

__all__ = ["STUDY_FILE", "write_study", "read_study", "record_resolution", "resolution_of"]

STUDY_FILE = "study.json"


def write_study(comparison: Comparison, out: Path, options: dict[str, Any]) -> Path | None:
    """Write ``out/study.json`` (None: a comparison made by hand, with no study record)."""
    if comparison.study is None:
        return None
    record = dict(comparison.study)
    record.pop("resolve", None)  # a resolve study adds its own (record_resolution)
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


def record_resolution(out: str | os.PathLike[str], resolution: dict[str, Any]) -> None:
    """Add a resolve study's steps (``Resolution.as_dict()``) to ``out/study.json`` (written by
    the report of its last comparison), for :func:`resolution_of` when the report is rebuilt."""
    path = Path(out) / STUDY_FILE
    if not path.is_file():
        return
    record = json.loads(path.read_text(encoding="utf-8"))
    record["resolve"] = resolution
    text = json.dumps(record, indent=2, allow_nan=True, default=_plain)
    path.write_text(text + "\n", encoding="utf-8")


def _plain(obj: Any) -> Any:
    tolist = getattr(obj, "tolist", None)  # a numpy scalar or array
    if tolist is not None:
        return tolist()
    return str(obj)


def resolution_of(data: dict[str, Any], final: Comparison) -> Any:
    """The :class:`~simbridge.compare.study.Resolution` that ``study.json``'s ``resolve`` records,
    ``final`` its last comparison (the figures per step as recorded; their gap series, which the
    resolve table does not show, left empty)."""
    import numpy as np

    from ..analysis.verdict import Interval
    from ..study.points import PairFigures
    from ..study.resolve import Resolution, ResolveStep

    def interval(d: dict[str, Any]) -> Interval:
        value = d.get("value")
        return Interval(math.nan if value is None else float(value), d.get("low"), d.get("high"))

    def pair(d: dict[str, Any]) -> PairFigures:
        return PairFigures(
            labels=(d["labels"][0], d["labels"][1]),
            verdict=d["verdict"],
            reason=d["reason"],
            engines=list(d["engines"]),
            marginal=bool(d["marginal"]),
            quantity=d["quantity"],
            unit=d["unit"],
            tolerance=d["tolerance"],
            judged_time=d["judged_time"],
            judged_at=d["judged_at"],
            gap=interval(d["gap"]),
            gap_end=interval(d["gap_end"]),
            spreads=(interval(d["spreads"][0]), interval(d["spreads"][1])),
            own_errors=(d["own_errors"][0], d["own_errors"][1]),
            p_value=d["p_value"],
            gap_series=np.empty(0),
            time=np.empty(0),
        )

    try:
        steps = [
            ResolveStep(s["timestep"], [pair(p) for p in s["pairs"]], s["wall_time"])
            for s in data["steps"]
        ]
        return Resolution(steps=steps, limit=data["limit"], final=final, outcome=data["outcome"])
    except (KeyError, IndexError, TypeError, ValueError) as exc:
        raise SimbridgeError(
            f"{STUDY_FILE}: its resolve record is not one this version reads ({exc!r})"
        ) from None
