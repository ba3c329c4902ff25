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

Reading an entry touches it (its access and modification times set to now), so the times say
when an entry was last used whatever the file system's ``atime`` policy: :meth:`Cache.prune`
removes the least recently used entries first (``simbridge cache prune``), and
:meth:`Cache.info` says how many there are and their size (``simbridge cache info``). Every
file under ``<dir>/<kind>/<two hex digits>/`` is an entry (``jobs/`` holds the jobs' results;
other kinds hold what a report derives from them, each under a key of everything it depends on).
"""

from __future__ import annotations

import functools
import hashlib
import json
import logging
import math
import os
import pickle
import tempfile
import time as _time
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from simbridge.exceptions import InvalidArgumentError

__all__ = [
    "Cache",
    "CacheEntry",
    "CacheInfo",
    "Pruned",
    "KINDS",
    "default_dir",
    "resolve",
    "parse_size",
    "code_digest",
    "derived_key",
]

log = logging.getLogger("simbridge.compare.cache")

FORMAT = "simbridge.compare.cache/1"

STALE_TEMPORARY = 3600.0
"""s: a temporary file older than this is the remains of a write cut short (a killed process);
:meth:`Cache.prune` removes it."""

KINDS = ("verdicts", "figures", "frames", "replays", "trajectories")
"""The entries derived from the jobs' results (besides ``jobs``): the verdicts (their bootstrap
and permutation test), the report's PNG figures, its key frames and animation, its 3D replay,
its trajectory files (``.npz``, ``.csv``).
Each is kept under :func:`derived_key` of everything it depends on."""

_SIZE_UNITS = {"": 1, "B": 1, "K": 1024, "M": 1024**2, "G": 1024**3, "T": 1024**4}


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
        self.digests: dict[str, str] = {}  # key: sha256 of its entry's bytes, as read or written

    def __repr__(self) -> str:
        return f"Cache({str(self.dir)!r})"

    def path(self, key: str, kind: str = "jobs") -> Path:
        """Where the entry of ``key`` lives (``kind``: ``jobs``, the jobs' results, or one of
        :data:`KINDS`, what is derived from them)."""
        if not (len(key) >= 8 and all(c in "0123456789abcdef" for c in key)):
            raise InvalidArgumentError("key", f"expected a hex digest, got {key!r}")
        if kind != "jobs" and kind not in KINDS:
            raise InvalidArgumentError("kind", f"expected one of {['jobs', *KINDS]}, got {kind!r}")
        return self.dir / kind / key[:2] / f"{key}.pkl"

    def __contains__(self, key: str) -> bool:
        return self.path(key).is_file()

    def get(self, key: str, kind: str = "jobs") -> Any | None:
        """The result stored under ``key``, or None (missing, or unreadable: then removed, with
        a warning). A hit is touched (its last use is now) and the sha256 of its bytes kept in
        :attr:`digests`."""
        path = self.path(key, kind)
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
        self.digests[key] = hashlib.sha256(data).hexdigest()
        touch(path)
        return value

    def put(self, key: str, result: Any, kind: str = "jobs") -> Path:
        """Store ``result`` under ``key`` atomically; returns the entry's path."""
        path = self.path(key, kind)
        path.parent.mkdir(parents=True, exist_ok=True)
        data = pickle.dumps(
            {"format": FORMAT, "key": key, "result": result}, protocol=pickle.HIGHEST_PROTOCOL
        )
        self.digests[key] = hashlib.sha256(data).hexdigest()
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

    # ------------------------------------------------------------ size and pruning

    def entries(self) -> list[CacheEntry]:
        """Every entry (jobs' results and the other kinds), least recently used first."""
        out = [e for e in self._files() if not e.temporary]
        out.sort(key=lambda e: (e.last_used, str(e.path)))
        return out

    def _files(self) -> Iterator[CacheEntry]:
        if not self.dir.is_dir():
            return
        for kind in sorted(self.dir.iterdir()):
            if not kind.is_dir():
                continue
            for shard in kind.iterdir():
                if not shard.is_dir():
                    continue
                for f in shard.iterdir():
                    try:
                        st = f.stat()
                    except OSError:  # removed meanwhile
                        continue
                    if not f.is_file():
                        continue
                    yield CacheEntry(
                        path=f,
                        kind=kind.name,
                        size=st.st_size,
                        last_used=max(st.st_atime, st.st_mtime),
                        temporary=f.name.startswith(".") and f.name.endswith(".tmp"),
                    )

    def info(self) -> CacheInfo:
        """How many entries the folder holds, their size in bytes, the oldest and newest use."""
        entries = self.entries()
        kinds: dict[str, int] = {}
        for e in entries:
            kinds[e.kind] = kinds.get(e.kind, 0) + 1
        return CacheInfo(
            dir=self.dir,
            entries=len(entries),
            size=sum(e.size for e in entries),
            oldest=entries[0].last_used if entries else None,
            newest=entries[-1].last_used if entries else None,
            kinds=kinds,
        )

    def prune(
        self,
        *,
        older_than: float | None = None,
        max_size: int | None = None,
        dry_run: bool = False,
        now: float | None = None,
    ) -> Pruned:
        """Remove the entries last used more than ``older_than`` days ago, then, while the
        entries left take more than ``max_size`` bytes, the least recently used ones; and the
        temporary files of writes cut short (older than :data:`STALE_TEMPORARY`). ``dry_run``:
        remove nothing, say what would go. ``now``: the time to measure ages from (default: the
        clock).

        Raises:
            InvalidArgumentError: ``older_than`` not a number of days >= 0, ``max_size`` not a
                whole number of bytes >= 0, or neither given.
        """
        if older_than is None and max_size is None:
            raise InvalidArgumentError(
                "older_than", "give older_than (days) or max_size (bytes), or both"
            )
        if older_than is not None and (
            isinstance(older_than, bool)
            or not isinstance(older_than, (int, float))
            or not (math.isfinite(older_than) and older_than >= 0)
        ):
            raise InvalidArgumentError(
                "older_than", f"expected a finite number of days >= 0, got {older_than!r}"
            )
        if max_size is not None and (
            isinstance(max_size, bool) or not isinstance(max_size, int) or max_size < 0
        ):
            raise InvalidArgumentError(
                "max_size", f"expected a whole number of bytes >= 0, got {max_size!r}"
            )
        now = _time.time() if now is None else now
        files = list(self._files())
        entries = sorted((e for e in files if not e.temporary), key=lambda e: e.last_used)
        gone: list[CacheEntry] = [
            e for e in files if e.temporary and now - e.last_used > STALE_TEMPORARY
        ]
        kept = entries
        if older_than is not None:
            cut = now - older_than * 86400.0
            gone += [e for e in entries if e.last_used < cut]
            kept = [e for e in entries if e.last_used >= cut]
        if max_size is not None:
            size = sum(e.size for e in kept)
            i = 0
            while size > max_size and i < len(kept):
                size -= kept[i].size
                gone.append(kept[i])
                i += 1
            kept = kept[i:]
        result = Pruned(
            dir=self.dir,
            removed=[e.path for e in gone],
            freed=sum(e.size for e in gone),
            kept=len(kept),
            kept_size=sum(e.size for e in kept),
            dry_run=dry_run,
        )
        if dry_run:
            return result
        for e in gone:
            try:
                e.path.unlink()
            except FileNotFoundError:
                pass
        for shard in {e.path.parent for e in gone}:
            try:
                shard.rmdir()  # only when empty
            except OSError:
                pass
        log.info("pruned %d entries (%d bytes) from %s", len(gone), result.freed, self.dir)
        return result


@dataclass(frozen=True)
class CacheEntry:
    """A file of the cache: its ``kind`` (the folder under the cache's, ``jobs`` ...), size in
    bytes and last use (s since the epoch: the later of its access and modification times)."""

    path: Path
    kind: str
    size: int
    last_used: float
    temporary: bool = False


@dataclass(frozen=True)
class CacheInfo:
    """:meth:`Cache.info`: the folder, its entries' count and size (bytes), the oldest and the
    newest last use (s since the epoch; None when empty), entries per kind."""

    dir: Path
    entries: int
    size: int
    oldest: float | None
    newest: float | None
    kinds: dict[str, int] = field(default_factory=dict)


@dataclass(frozen=True)
class Pruned:
    """:meth:`Cache.prune`: the files removed (or, with ``dry_run``, to be removed), the bytes
    freed, the entries left and their size."""

    dir: Path
    removed: list[Path]
    freed: int
    kept: int
    kept_size: int
    dry_run: bool


def touch(path: Path) -> None:
    """Mark the cache file ``path`` used now (a read-only cache is left as it is)."""
    try:
        os.utime(path)
    except OSError:
        pass


def parse_size(text: str) -> int:
    """Bytes from ``500M``, ``2G``, ``1.5GB``, ``100k``, ``4096`` (units of 1024).

    Raises:
        InvalidArgumentError: not a size.
    """
    t = str(text).strip().upper().removesuffix("IB").removesuffix("B")
    num, unit = t, ""
    if t and t[-1] in _SIZE_UNITS and t[-1] != "B":
        num, unit = t[:-1], t[-1]
    try:
        value = float(num)
    except ValueError:
        value = math.nan
    if not (math.isfinite(value) and value >= 0):
        raise InvalidArgumentError(
            "max_size",
            f"expected a size >= 0 such as 4096, 100K, 500M, 2G or 1T (units of 1024 bytes), "
            f"got {text!r}",
        )
    return int(value * _SIZE_UNITS[unit])


@functools.lru_cache(maxsize=1)
def code_digest() -> str:
    """sha256 of simbridge's own Python files (the core, the backends, compare) and the versions
    of the libraries a derived entry depends on: a derived entry made by other code is another
    one."""
    import importlib.metadata
    import importlib.util

    import simbridge

    roots = {Path(simbridge.__file__).resolve().parent, Path(__file__).resolve().parents[1]}
    spec = importlib.util.find_spec("simbridge.backends")
    if spec is not None and spec.submodule_search_locations:
        roots.update(Path(p).resolve() for p in spec.submodule_search_locations)
    h = hashlib.sha256()
    files = sorted({f for root in roots for f in root.rglob("*.py")})
    for f in files:
        h.update(f.name.encode() + b"\0" + f.read_bytes() + b"\0")
    for lib in ("numpy", "scipy", "matplotlib", "pillow", "pybullet", "viser"):
        try:
            version = importlib.metadata.version(lib)
        except importlib.metadata.PackageNotFoundError:
            version = "-"
        h.update(f"{lib}={version}\0".encode())
    return h.hexdigest()


def derived_key(kind: str, *parts: Any) -> str:
    """The key of a derived entry of ``kind``: sha256 of ``parts`` (JSON; numpy arrays by
    dtype, shape and bytes), the cache's format and :func:`code_digest`."""
    import numpy as np

    h = hashlib.sha256()
    h.update(f"{FORMAT}\0{kind}\0{code_digest()}\0".encode())

    def default(obj: Any) -> Any:
        if isinstance(obj, np.ndarray):
            a = np.ascontiguousarray(obj)
            h.update(f"{a.dtype.str}{a.shape}".encode() + a.tobytes())
            return f"array:{a.dtype.str}{a.shape}"
        if isinstance(obj, (np.integer, np.floating, np.bool_)):
            return obj.item()
        if isinstance(obj, Path):
            return str(obj)
        raise TypeError(f"no key for {type(obj).__name__}")

    h.update(json.dumps(parts, default=default, sort_keys=True, allow_nan=True).encode())
    return h.hexdigest()


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
