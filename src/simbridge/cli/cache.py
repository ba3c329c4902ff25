"""``simbridge cache info`` and ``simbridge cache prune``: the size of the study cache
(:class:`simbridge.compare.run.cache.Cache`) and its least recently used entries removed."""

from __future__ import annotations

import argparse
import math
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

__all__ = ["add_commands", "fmt_size"]


def _days(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        value = math.nan
    if not (math.isfinite(value) and value >= 0):
        raise argparse.ArgumentTypeError(f"expected a number of days >= 0, got {text!r}")
    return value


def _size(text: str) -> int:
    from simbridge.compare.run.cache import parse_size
    from simbridge.exceptions import InvalidArgumentError

    try:
        return parse_size(text)
    except InvalidArgumentError as exc:
        raise argparse.ArgumentTypeError(str(exc).removeprefix("argument 'max_size': ")) from None


def add_commands(sub: Any, verbose: Callable[[argparse.ArgumentParser], None]) -> None:
    """Add ``simbridge cache`` and its commands ``info`` and ``prune`` (each parser's ``handler``
    set).

    Args:
        sub: The top-level parser's subparsers.
        verbose: Adds ``--verbose`` to a parser.
    """
    c = sub.add_parser(
        "cache",
        help="the study cache: its size, and its least recently used entries removed",
        description="The cache of the studies' runs (and what their reports derive from them: "
        "verdicts, figures, frames): `info` says how big it is, `prune` removes the least "
        "recently used entries (reading an entry marks it used).",
    )
    verbose(c)
    commands = c.add_subparsers(dest="cache_command", metavar="COMMAND", required=True)
    info = commands.add_parser(
        "info",
        help="the cache's folder, entries, size, oldest and newest use",
        description="The cache's folder, its entries (per kind), their size, and when the "
        "least and the most recently used one was last used.",
    )
    prune = commands.add_parser(
        "prune",
        help="remove the least recently used entries",
        description="Remove the entries last used more than --older-than DAYS ago, then the "
        "least recently used ones until the rest fits in --max-size SIZE (and any temporary "
        "file a killed write left behind). A study that needs a removed entry runs it again.",
    )
    for p in (info, prune):
        p.add_argument(
            "--cache",
            type=Path,
            metavar="DIR",
            help="the cache folder (default: $XDG_CACHE_HOME/simbridge, else ~/.cache/simbridge)",
        )
        verbose(p)
        p.set_defaults(handler=_info if p is info else _prune)
    prune.add_argument(
        "--older-than",
        type=_days,
        metavar="DAYS",
        help="remove the entries not used for DAYS days (fractions allowed: 0.5)",
    )
    prune.add_argument(
        "--max-size",
        type=_size,
        metavar="SIZE",
        help="then remove the least recently used entries until the rest takes at most SIZE "
        "(bytes, or 500K, 200M, 2G: units of 1024)",
    )
    prune.add_argument(
        "--dry-run", action="store_true", help="remove nothing: say what would be removed"
    )


def fmt_size(n: float) -> str:
    """A size in words: 512 B, 3.4 KiB, 61.8 MiB, 1.2 GiB.

    Args:
        n: Bytes.

    Returns:
        The size in the largest unit (up to GiB) under 1024 of it.
    """
    for unit in ("B", "KiB", "MiB", "GiB"):
        if n < 1024 or unit == "GiB":
            return f"{n:.0f} B" if unit == "B" else f"{n:.1f} {unit}"
        n /= 1024
    raise AssertionError("unreachable")


def _when(t: float | None, now: float) -> str:
    if t is None:
        return "-"
    stamp = time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime(t))
    return f"{stamp} ({max(0.0, now - t) / 86400:.1f} days ago)"


def _info(args: argparse.Namespace) -> int:
    from simbridge.compare.run.cache import Cache

    info = Cache(args.cache).info()
    now = time.time()
    kinds = ", ".join(f"{k} {n}" for k, n in sorted(info.kinds.items()))
    print(f"cache: {info.dir}" + ("" if info.dir.is_dir() else " (not made yet)"))
    print(f"entries: {info.entries}" + (f" ({kinds})" if kinds else ""))
    print(f"size: {fmt_size(info.size)}")
    print(f"oldest use: {_when(info.oldest, now)}")
    print(f"newest use: {_when(info.newest, now)}")
    return 0


def _prune(args: argparse.Namespace) -> int:
    from simbridge.cli.usage import Usage
    from simbridge.compare.run.cache import Cache

    if args.older_than is None and args.max_size is None:  # bad usage: exit 2
        raise Usage("give --older-than DAYS or --max-size SIZE (or both): what to remove")
    done = Cache(args.cache).prune(
        older_than=args.older_than, max_size=args.max_size, dry_run=args.dry_run
    )
    verb = "would remove" if done.dry_run else "removed"
    print(
        f"{verb} {len(done.removed)} entries ({fmt_size(done.freed)}) from {done.dir}; "
        f"{done.kept} left ({fmt_size(done.kept_size)})"
    )
    return 0
