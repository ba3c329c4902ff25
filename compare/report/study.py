"""A report folder's ``study.json``, and the report rebuilt from it and the cache alone.

:func:`write_study` records what :func:`~simbridge.compare.compare` was asked (the scenario's
canonical TOML and its file, the backends, profiles, time steps, ensemble, seed, tolerance,
resync interval), the key of every job, and the options :func:`~simbridge.compare.report` was
given. :func:`rebuild` (``simbridge report DIR [--cache DIR]``) makes the comparison again
from those jobs' cached results, running no engine, and writes the whole report again; a job
missing from the cache is a :class:`~simbridge.exceptions.CacheEntryMissingError` naming it.
"""

from __future__ import annotations

import json
import os
from pathlib import Path
from typing import Any

from simbridge.exceptions import SimbridgeError

from ..pipeline import Comparison, compare
from ..run.cache import Cache
from ..run.studyjobs import STUDY_FORMAT, scenario_of

__all__ = ["STUDY_FILE", "write_study", "read_study", "rebuild"]

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


def rebuild(
    folder: str | os.PathLike[str],
    *,
    cache: Cache | str | os.PathLike[str] | None = None,
    **options: Any,
) -> Path:
    """Write the report of the study recorded in ``folder`` again, from the cache alone (no
    engine runs); ``options`` replace the report options it recorded. Returns ``report.md``.

    Raises:
        CacheEntryMissingError: a job of the study is not in the cache.
        SimbridgeError: ``study.json`` unreadable, or the jobs its arguments make now are not
            the ones it recorded (a file it names changed, another simbridge version).
    """
    from . import report

    folder = Path(folder)
    record = read_study(folder)
    args = record["arguments"]
    comparison = compare(
        scenario_of(record),
        args["backends"],
        profile=args["profile"],
        timesteps=args["timesteps"],
        duration=args["duration"],
        ensemble=args["ensemble"],
        perturb=tuple(args["perturb"]),
        seed=args["seed"],
        tolerance=args["tolerance"],
        resync_every=args["resync_every"],
        workers=args["workers"],
        command_line=record["command_line"],
        cache=cache,
        offline=True,
    )
    assert comparison.study is not None
    now = [j["key"] for j in comparison.study["jobs"]]
    then = [j["key"] for j in record["jobs"]]
    if now != then:
        changed = sum(1 for a, b in zip(now, then, strict=False) if a != b)
        raise SimbridgeError(
            f"{folder / STUDY_FILE}: the study's arguments now make other jobs than it recorded "
            f"({changed} of {len(then)} differ): a file it names changed since, or another "
            "simbridge version; run the study again (simbridge compare)"
        )
    comparison.left_out = dict(record.get("left_out", {}))
    comparison.wall_time = float(record.get("wall_time", comparison.wall_time))
    if not args.get("backends_named", True):
        comparison.study["arguments"]["backends_named"] = False
    kwargs = dict(record.get("report", {}))
    kwargs.update(options)
    return report(comparison, folder, **kwargs)
