"""What a report derives from a comparison at some cost (the PNG figures, the key frames and
``replay.gif``, the 3D replay), kept in the study's cache: :func:`memo_files`, :func:`memo`.

Such an entry is keyed (:func:`report_key`) by the study's record (the scenario's canonical
TOML, :func:`~simbridge.compare.compare`'s arguments, the engines left out, every job's key)
together with the sha256 of every job's cache entry, and by
:func:`~simbridge.compare.run.cache.code_digest` (simbridge's code and the drawing libraries'
versions). A comparison is a function of its jobs' results and its arguments, so the same key
means the same pictures; a job run again (``--fresh``, an engine upgraded) writes a new entry
and so a new key. A comparison with no study record, no cache, or a job that failed (no entry)
is drawn every time."""

from __future__ import annotations

import logging
from collections.abc import Callable
from pathlib import Path
from typing import Any, TypeVar

from ..run.cache import Cache, derived_key

__all__ = ["report_key", "memo", "memo_files"]

log = logging.getLogger("simbridge.compare.cache")

T = TypeVar("T")


def report_key(c: Any, kind: str, *parts: Any) -> str | None:
    """The key of ``c``'s derived entry of ``kind`` (``parts``: what else it depends on), or
    None where ``c`` has none (see the module)."""
    jobs, study = getattr(c, "jobs", None), getattr(c, "study", None)
    if jobs is None or jobs.cache is None or study is None:
        return None
    keys = [j["key"] for j in study["jobs"]]
    digests = [jobs.digests.get(k) for k in keys]
    if any(d is None for d in digests):
        return None
    return derived_key(
        kind,
        study["scenario"]["toml"],
        study["arguments"],
        sorted(dict(getattr(c, "left_out", {})).items()),
        keys,
        digests,
        list(c.labels),
        list(parts),
    )


def _store(c: Any) -> Cache:
    return Cache(c.jobs.cache)


def memo(c: Any, kind: str, parts: tuple[Any, ...], make: Callable[[], T]) -> T:
    """``make()``, or what it gave for the same key before."""
    key = report_key(c, kind, *parts)
    if key is None:
        return make()
    store = _store(c)
    if not c.jobs.fresh:
        got = store.get(key, kind)
        if isinstance(got, dict) and "value" in got:
            return got["value"]
    value = make()
    _put(store, key, kind, {"value": value})
    return value


def memo_files(
    c: Any,
    kind: str,
    parts: tuple[Any, ...],
    out: Path,
    make: Callable[[], tuple[T, list[str]]],
) -> T:
    """``make()``'s value, ``make`` writing files into ``out`` and naming them (relative to
    ``out``); or, for the same key as before, that value and those files written again."""
    key = report_key(c, kind, *parts)
    if key is None:
        return make()[0]
    store = _store(c)
    if not c.jobs.fresh:
        got = store.get(key, kind)
        if isinstance(got, dict) and isinstance(got.get("files"), dict):
            for name, data in got["files"].items():
                path = out / name
                path.parent.mkdir(parents=True, exist_ok=True)
                path.write_bytes(data)
            return got["value"]
    value, names = make()
    files = {name: (out / name).read_bytes() for name in names}
    _put(store, key, kind, {"value": value, "files": files})
    return value


def _put(store: Cache, key: str, kind: str, entry: dict[str, Any]) -> None:
    try:
        store.put(key, entry, kind)
    except OSError as exc:
        log.warning("cannot write the cache entry of the report's %s: %s", kind, exc)
