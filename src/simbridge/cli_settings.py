"""The command line's engine settings: ``simbridge settings [BACKEND]`` and ``--set``."""

from __future__ import annotations

import argparse
import json
from collections.abc import Sequence
from typing import Any

from .engine_settings import merge, parse_assignment, settings_for, validate

__all__ = ["add_settings_parser", "add_set_option", "settings_from_args", "settings_command"]


def add_set_option(parser: argparse.ArgumentParser) -> None:
    """``--set BACKEND.KEY=VALUE``, repeatable."""
    parser.add_argument(
        "--set",
        action="append",
        default=None,
        metavar="BACKEND.KEY=VALUE",
        dest="engine_settings",
        type=_assignment,
        help="an engine setting for every run of that engine, on top of the scenario's "
        "[engines.*] tables; repeatable (--set mujoco.impratio=10 --set "
        "'mujoco.solref=[0.01, 1]'); `simbridge settings` lists them",
    )


def _assignment(text: str) -> str:
    """``--set``'s argument, checked as it is parsed (bad usage, exit 2, on a bad key or
    value); :func:`settings_from_args` reads it."""
    from .exceptions import SimbridgeError

    try:
        backend, key, value = parse_assignment(text)
        validate(backend, {key: value})
    except SimbridgeError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None
    return text


def settings_from_args(assignments: Sequence[str] | None) -> dict[str, dict[str, Any]] | None:
    """``--set``'s assignments as ``{backend: {key: value}}``, each checked (None: none).

    Raises:
        InvalidArgumentError, UnknownBackendError, InvalidProfileError: a bad assignment.
    """
    if not assignments:
        return None
    layers = []
    for text in assignments:
        backend, key, value = parse_assignment(text)
        layers.append({backend: validate(backend, {key: value})})
    return merge(*layers)


def add_settings_parser(sub: Any, backends: Sequence[str]) -> argparse.ArgumentParser:
    s: argparse.ArgumentParser = sub.add_parser(
        "settings",
        help="list each engine's own settings (set them with --set or [engines.NAME])",
        description="Each backend's engine settings: key, default, accepted values, unit, "
        "meaning and the counterpart in another engine (->). Set them in a scenario's "
        "[engines.NAME] table, with `compare --set NAME.KEY=VALUE`, or in Python with "
        "Profile.with_engine / Sim(engine_settings=).",
    )
    s.add_argument("backend", nargs="?", choices=list(backends), metavar="BACKEND")
    s.add_argument("--json", action="store_true", help="JSON on stdout, for machines")
    return s


def settings_command(args: argparse.Namespace, backends: Sequence[str]) -> int:
    names = [args.backend] if args.backend else list(backends)
    if args.json:
        data = {b: [s.as_dict() for s in settings_for(b).values()] for b in names}
        print(json.dumps(data, indent=1))
        return 0
    for i, b in enumerate(names):
        if i:
            print()
        known = settings_for(b)
        print(f"[engines.{b}]" + ("" if known else "  (no settings declared)"))
        width = max((len(k) for k in known), default=0)
        for key, s in known.items():
            unit = f" {s.unit}" if s.unit else ""
            toward = f"  (-> {s.toward})" if s.toward else ""
            print(f"  {key:<{width}}  default {s.default_text()}{unit}; {s.range_text()}")
            print(f"  {'':<{width}}  {s.meaning}{toward}")
    return 0
