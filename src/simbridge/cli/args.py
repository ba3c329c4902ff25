"""The command line's argument types and its job options, shared by :mod:`simbridge.cli` and
:mod:`simbridge.cli.study`: each raises ``argparse.ArgumentTypeError`` (argparse's usage error)
naming what it expects."""

from __future__ import annotations

import argparse
import math
from collections.abc import Callable
from pathlib import Path
from typing import Any

__all__ = [
    "add_job_options",
    "duration",
    "job_options",
    "nonnegative_float",
    "nonnegative_int",
    "positive_int",
    "timestep",
]


def timestep(text: str) -> float:
    """``--timestep``'s argument type.

    Args:
        text: The argument as given (seconds: ``0.004``, or ``1/240``).

    Returns:
        The time step (s).

    Raises:
        argparse.ArgumentTypeError: not a time step (the scenario reader's message).
    """
    from simbridge.compare.scenario import parse_timestep

    try:
        return parse_timestep(text)
    except ValueError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None


def _integer(low: int) -> Callable[[str], int]:
    """An integer >= ``low``."""

    def parse(text: str) -> int:
        try:
            value = int(text)
        except ValueError:
            raise argparse.ArgumentTypeError(
                f"expected an integer >= {low}, got {text!r}"
            ) from None
        if value < low:
            raise argparse.ArgumentTypeError(f"expected an integer >= {low}, got {text!r}")
        return value

    return parse


def _number(expected: str, zero: bool) -> Callable[[str], float]:
    """A finite number > 0 (>= 0 where ``zero``); ``expected`` names it in the message of a
    text that is no number."""
    bound = ">= 0" if zero else "> 0"

    def parse(text: str) -> float:
        try:
            value = float(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"expected {expected}, got {text!r}") from None
        if not ((value >= 0 if zero else value > 0) and math.isfinite(value)):
            raise argparse.ArgumentTypeError(f"must be a finite number {bound}, got {text!r}")
        return value

    return parse


duration = _number("seconds", zero=False)
nonnegative_float = _number("a number >= 0", zero=True)
positive_int = _integer(1)
nonnegative_int = _integer(0)


def add_job_options(p: argparse.ArgumentParser) -> None:
    """Add where and how a study's runs (jobs) run, and their cache: ``--workers``,
    ``--scheduler``, ``--cache``, ``--no-cache``, ``--fresh``.

    Args:
        p: The command's parser.
    """
    p.add_argument(
        "--workers",
        type=nonnegative_int,
        metavar="N",
        help="processes running the study's runs on this machine (default: the CPU count; 0: "
        "all in this process)",
    )
    p.add_argument(
        "--scheduler",
        metavar="tcp://HOST:PORT",
        help="run the study's runs on this Dask cluster (needs simbridge[cluster])",
    )
    p.add_argument(
        "--cache",
        type=Path,
        metavar="DIR",
        help="keep every run's result here, by content, and reuse it (default: "
        "$XDG_CACHE_HOME/simbridge, else ~/.cache/simbridge)",
    )
    p.add_argument("--no-cache", action="store_true", help="neither read nor write the cache")
    p.add_argument(
        "--fresh", action="store_true", help="run everything again (the cache's entries replaced)"
    )


def job_options(args: argparse.Namespace) -> dict[str, Any]:
    """compare()'s job options from the options :func:`add_job_options` adds.

    Args:
        args: The parsed command line.

    Returns:
        ``workers``, ``scheduler``, ``cache`` and ``fresh`` by name, those not given left out.
    """
    out: dict[str, Any] = {}
    if getattr(args, "workers", None) is not None:
        out["workers"] = args.workers
    if getattr(args, "scheduler", None) is not None:
        out["scheduler"] = args.scheduler
    if getattr(args, "no_cache", False):
        out["cache"] = False
    elif getattr(args, "cache", None) is not None:
        out["cache"] = args.cache
    if getattr(args, "fresh", False):
        out["fresh"] = True
    return out
