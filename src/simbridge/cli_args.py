"""The command line's argument types and its job options, shared by :mod:`simbridge.cli` and
:mod:`simbridge.cli_study`: each raises ``argparse.ArgumentTypeError`` (argparse's usage error)
naming what it expects."""

from __future__ import annotations

import argparse
import math
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
    from simbridge.compare.scenario import parse_timestep

    try:
        return parse_timestep(text)
    except ValueError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None


def duration(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected seconds, got {text!r}") from None
    if not (value > 0 and math.isfinite(value)):
        raise argparse.ArgumentTypeError(f"must be a finite number > 0, got {text!r}")
    return value


def positive_int(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected an integer >= 1, got {text!r}") from None
    if value < 1:
        raise argparse.ArgumentTypeError(f"expected an integer >= 1, got {text!r}")
    return value


def nonnegative_float(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number >= 0, got {text!r}") from None
    if not (value >= 0 and math.isfinite(value)):
        raise argparse.ArgumentTypeError(f"must be a finite number >= 0, got {text!r}")
    return value


def nonnegative_int(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected an integer >= 0, got {text!r}") from None
    if value < 0:
        raise argparse.ArgumentTypeError(f"expected an integer >= 0, got {text!r}")
    return value


def add_job_options(p: argparse.ArgumentParser) -> None:
    """Where and how a study's runs (jobs) run, and their cache."""
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
    """compare()'s job options from the options above, those not given left out."""
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
