"""A report written again from its folder's ``study.json`` and the cache alone
(``simbridge report DIR``): :func:`rebuild`."""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any

from simbridge.exceptions import SimbridgeError

from ..errors import CacheEntryMissingError
from ..pipeline import compare
from ..run.cache import Cache
from ..run.studyjobs import scenario_of
from . import report
from .inputs import inputs_changed, study_inputs
from .study import STUDY_FILE, add_resolution, read_study

__all__ = ["rebuild", "study_inputs", "inputs_changed"]


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
    folder = Path(folder)
    record = read_study(folder)
    try:
        comparison = _compare(record, cache)
    except CacheEntryMissingError as exc:  # the jobs are new ones: say what made them new
        what = _changed(record)
        if not what:
            raise
        raise SimbridgeError(
            f"{folder / STUDY_FILE}: {exc.missing} of {exc.total} jobs of the study are not "
            f"the ones it ran, and not in the cache: since it ran, {'; '.join(what)}; run the "
            "study again (simbridge compare)"
        ) from exc
    assert comparison.study is not None
    now = [j["key"] for j in comparison.study["jobs"]]
    then = [j["key"] for j in record["jobs"]]
    if now != then:
        changed = sum(1 for a, b in zip(now, then, strict=False) if a != b)
        what = _changed(record)
        why = (
            f"since: {'; '.join(what)}"
            if what
            else "a file it names changed since, or simbridge's code that makes a run or an "
            "engine's version did"
        )
        raise SimbridgeError(
            f"{folder / STUDY_FILE}: the study's arguments now make other jobs than it recorded "
            f"({changed} of {len(then)} differ): {why}; run the study again "
            "(simbridge compare)"
        )
    return _write(folder, record, comparison, options)


def _changed(record: dict[str, Any]) -> list[str]:
    """What changed since the study of ``record`` ran (:func:`inputs_changed`; [] for a
    ``study.json`` that records no ``inputs``)."""
    recorded = record.get("inputs")
    return inputs_changed(recorded, study_inputs(record)) if recorded else []


def _compare(record: dict[str, Any], cache: Any) -> Any:
    """The study of ``record`` made again from the cache alone."""
    args = record["arguments"]
    n = len(args["backends"])
    resynced = sum(1 for j in record["jobs"] if j.get("kind") == "resync") // 2
    return compare(
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
        # a study recorded when the first pair alone had a resync: that pair's, as recorded
        resync_pairs=resynced if 0 < resynced < n * (n - 1) // 2 else None,
        workers=args["workers"],
        command_line=record["command_line"],
        cache=cache,
        offline=True,
    )


def _write(folder: Path, record: dict[str, Any], comparison: Any, options: dict[str, Any]) -> Path:
    """The report of ``comparison`` (made again) written in ``folder`` as ``record`` says."""
    args = record["arguments"]
    comparison.left_out = dict(record.get("left_out", {}))
    comparison.study["left_out"] = dict(comparison.left_out)  # kept for the next rebuild too
    comparison.wall_time = float(record.get("wall_time", comparison.wall_time))
    if not args.get("backends_named", True):
        comparison.study["arguments"]["backends_named"] = False
    kwargs = dict(record.get("report", {}))
    kwargs.update(options)
    path = report(comparison, folder, **kwargs)
    resolved = record.get("resolve")
    if resolved is not None:  # `compare --resolve`: the verdict at each step, as recorded
        try:
            summary, lines = dict(resolved["summary"]), [str(x) for x in resolved["markdown"]]
        except (KeyError, TypeError, ValueError) as exc:
            raise SimbridgeError(
                f"{folder / STUDY_FILE}: its resolve record is not one this version reads ({exc!r})"
            ) from None
        add_resolution(folder, summary, lines)
    return path
