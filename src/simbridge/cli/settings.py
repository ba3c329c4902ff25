"""The command line's engine settings: ``simbridge settings [BACKEND]`` and ``--set``."""

from __future__ import annotations

import argparse
import json
from collections.abc import Sequence
from dataclasses import fields
from typing import Any

from simbridge.engine_settings import merge, parse_assignment, settings_for, validate

__all__ = ["add_settings_parser", "add_set_option", "settings_from_args", "settings_command"]


def add_set_option(parser: argparse.ArgumentParser) -> None:
    """Add ``--set BACKEND.KEY=VALUE``, repeatable, each checked as it is parsed.

    Args:
        parser: The command's parser.
    """
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
    value); :func:`settings_from_args` reads it. argparse puts ``argument --set:`` before the
    message: the message does not say it again. A profile entry or a key without its backend
    is answered with the form that sets it."""
    from simbridge.exceptions import InvalidArgumentError, InvalidEngineSettingError, SimbridgeError

    name, _, raw = text.partition("=")
    first, dot, rest = name.strip().partition(".")
    key, value = (rest if dot else first).strip(), raw.strip()
    try:
        backend, key, parsed = parse_assignment(text)
    except InvalidArgumentError as exc:
        said = str(exc).removeprefix(f"argument {exc.argument!r}: ")
        hint = _elsewhere(key, value) or (_owners_hint(key, value) if not dot else "")
        raise argparse.ArgumentTypeError(said + (f": {hint}" if hint else "")) from None
    try:
        validate(backend, {key: parsed})
    except InvalidEngineSettingError as exc:
        hint = _elsewhere(key, value) if exc.key == key else ""
        if hint:  # no setting of the engine's, but set another way
            raise argparse.ArgumentTypeError(f"{backend}.{key}: {hint}") from None
        raise argparse.ArgumentTypeError(str(exc)) from None
    except SimbridgeError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None
    return text


def _elsewhere(key: str, value: str) -> str:
    """Where ``key`` is set when it is no engine setting: a profile entry for every engine
    with ``--profile NAME+KEY=VALUE``, the time step with ``--timestep``, gravity in the
    scenario. Empty for any other key."""
    from simbridge.profiles import PROFILES, Profile

    shown = value or "VALUE"
    if key in ("timestep", "gravity"):
        how = f"--timestep {shown}" if key == "timestep" else "the scenario's gravity = [x, y, z]"
        return f"{key} is the scenario's, not an engine setting: set it with {how}"
    entries = [f.name for f in fields(Profile) if f.name not in ("name", "engines")]
    if key in entries:
        return (
            f"{key} is a profile entry (one value for every engine), not an engine setting: "
            f"set it with --profile PROFILE+{key}={shown}, the profile (the scenario's by "
            f"default; one of {', '.join(PROFILES)}) with the entry changed, e.g. --profile "
            f"pybullet+{key}={shown}"
        )
    return ""


def _owners_hint(key: str, value: str) -> str:
    """For ``--set KEY=VALUE`` without a backend: the ``--set BACKEND.KEY=VALUE`` of each
    engine that has ``KEY``, or else the key most like it; empty where none is near."""
    import difflib

    from simbridge.engine_settings import owners
    from simbridge.registry import available_backends

    found, typed = owners(key), key
    if not found:
        every = list(dict.fromkeys(k for b in available_backends() for k in _settings_of(b)))
        near = difflib.get_close_matches(key, every, n=1)
        if not near:
            return ""
        key = near[0]
        found = owners(key)
    forms = " or ".join(f"--set {b}.{key}={value or 'VALUE'}" for b in found)
    whose = f"a setting of {' and '.join(found)}{' alone' if len(found) == 1 else ''}"
    if key != typed:
        return f"no engine has a setting {typed}; did you mean {key}, {whose}: {forms}"
    return f"{key} is {whose}: {forms}"


def _settings_of(backend: str) -> list[str]:
    try:
        return list(settings_for(backend))
    except Exception:  # noqa: BLE001 - only a hint: a broken registration is reported elsewhere
        return []


def settings_from_args(assignments: Sequence[str] | None) -> dict[str, dict[str, Any]] | None:
    """``--set``'s assignments as settings per backend, each checked.

    Args:
        assignments: The assignments as given, or None.

    Returns:
        ``{backend: {key: value}}``, later assignments on top; None when there are none.

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
    """Add ``simbridge settings [BACKEND] [--json]``.

    Args:
        sub: The top-level parser's subparsers.
        backends: The registered backends (the choices of BACKEND).

    Returns:
        The command's parser.
    """
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
    """Print each backend's engine settings: key, default, accepted values, unit, meaning and
    counterpart (or JSON with ``--json``).

    Args:
        args: The parsed command line (``backend``, ``json``).
        backends: Every registered backend, listed when ``args.backend`` is not given.

    Returns:
        The exit status, 0.
    """
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
