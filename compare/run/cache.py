"""Job results cached by content: :class:`Cache`.

An entry is a job's :class:`~simbridge.compare.run.jobs.JobResult` under its
:attr:`~simbridge.compare.run.jobs.Job.key` (a sha256 of everything the result depends on), in
``<dir>/jobs/<first two hex digits>/<key>.pkl``. The default folder is
``$XDG_CACHE_HOME/simbridge``, else ``~/.cache/simbridge`` (:func:`default_dir`).

Entries are written whole or not at all: into a temporary file beside the entry, then renamed
over it (a rename within a folder is atomic), the temporary file removed on any error. An entry
that does not read back (cut short, overwritten, from another format) is a miss: the caller
recomputes it and a warning on the ``simbridge.compare.cache`` logger names it.

Entries are Python pickles: a cache folder is trusted as the user's own files are (do not point
``--cache`` at a folder others can write to).
"""

from __future__ import annotations

import logging
import os
import pickle
import tempfile
from pathlib import Path
from typing import Any

from simbridge.exceptions import InvalidArgumentError

__all__ = ["Cache", "default_dir", "resolve"]

log = logging.getLogger("simbridge.compare.cache")

FORMAT = "simbridge.compare.cache/1"


def default_dir() -> Path:
    """``$XDG_CACHE_HOME/simbridge``, else ``~/.cache/simbridge``."""
    xdg = os.environ.get("XDG_CACHE_HOME")
    base = Path(xdg) if xdg and Path(xdg).is_absolute() else Path.home() / ".cache"
    return base / "simbridge"


class Cache:
    """Job results by key in folder ``dir`` (made on the first :meth:`put`)."""

    def __init__(self, dir: str | os.PathLike[str] | None = None):
        self.dir = Path(dir).expanduser() if dir is not None else default_dir()
        self.hits = 0
        self.misses = 0
        self.writes = 0

    def __repr__(self) -> str:
        return f"Cache({str(self.dir)!r})"

    def path(self, key: str) -> Path:
        """Where the entry of ``key`` lives."""
        if not (len(key) >= 8 and all(c in "0123456789abcdef" for c in key)):
            raise InvalidArgumentError("key", f"expected a hex digest, got {key!r}")
        return self.dir / "jobs" / key[:2] / f"{key}.pkl"

    def __contains__(self, key: str) -> bool:
        return self.path(key).is_file()

    def get(self, key: str) -> Any | None:
        """The result stored under ``key``, or None (missing, or unreadable: then removed, with
        a warning)."""
        path = self.path(key)
        try:
            with path.open("rb") as f:
                data = f.read()
        except FileNotFoundError:
            self.misses += 1
            return None
        try:
            entry = pickle.loads(data)
            if not (isinstance(entry, dict) and entry.get("format") == FORMAT):
                raise ValueError("not a simbridge cache entry")
            if entry.get("key") != key:
                raise ValueError(f"it holds key {entry.get('key')!r}")
            value = entry["result"]
        except Exception as exc:  # noqa: BLE001 - any unreadable entry is recomputed
            log.warning(
                "cache entry %s is unreadable (%s: %s): recomputing it",
                path,
                type(exc).__name__,
                exc,
            )
            try:
                path.unlink()
            except OSError:
                pass
            self.misses += 1
            return None
        self.hits += 1
        return value

    def put(self, key: str, result: Any) -> Path:
        """Store ``result`` under ``key`` atomically; returns the entry's path."""
        path = self.path(key)
        path.parent.mkdir(parents=True, exist_ok=True)
        data = pickle.dumps(
            {"format": FORMAT, "key": key, "result": result}, protocol=pickle.HIGHEST_PROTOCOL
        )
        fd, tmp = tempfile.mkstemp(prefix=f".{key[:16]}.", suffix=".tmp", dir=path.parent)
        try:
            with os.fdopen(fd, "wb") as f:
                f.write(data)
            os.replace(tmp, path)
        except BaseException:
            try:
                os.unlink(tmp)
            except OSError:
                pass
            raise
        self.writes += 1
        return path


def resolve(cache: Cache | str | os.PathLike[str] | bool | None) -> Cache | None:
    """compare()'s ``cache`` argument: None the default folder, a path that folder, a
    :class:`Cache` itself, False none (every job runs, nothing is stored)."""
    if cache is None or cache is True:
        return Cache()
    if cache is False:
        return None
    if isinstance(cache, Cache):
        return cache
    if isinstance(cache, (str, os.PathLike)):
        return Cache(cache)
    raise InvalidArgumentError(
        "cache", f"expected a folder, a Cache, None (the default folder) or False, got {cache!r}"
    )
