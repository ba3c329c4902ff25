"""What every study shares: a setting and its values (``KEY=V1,V2``), a comparison point run
with some settings changed, and the figures a study keeps of it (:class:`PairFigures`).

A setting is one of

- ``timestep``: the time step every engine runs at (s, or ``1/480``);
- a profile entry (``lateral_friction``, ``solver_iterations`` ...: the fields of
  :class:`simbridge.Profile` but the time step and gravity, which are the scenario's), changed
  for every engine of the comparison;
- an engine setting ``BACKEND.KEY`` (``mujoco.impratio``), changed for that backend's slots.

A changed profile travels as a derived profile name (``pybullet+lateral_friction=0.9``:
:func:`simbridge.profiles.derived_profile`), so that every run of the comparison (the ensemble
members in their worker processes included) makes the same profile.
"""

from __future__ import annotations

import ast
import math
from collections.abc import Sequence
from dataclasses import dataclass, field, fields
from typing import Any

import numpy as np

from simbridge.exceptions import InvalidArgumentError, did_you_mean
from simbridge.profiles import SPEC_SEPARATOR, Profile, derived_profile

from ..analysis.verdict import Interval, Verdict
from ..pipeline import Comparison

__all__ = [
    "PROFILE_ENTRIES",
    "Setting",
    "parse_vary",
    "parse_value",
    "setting_kind",
    "split_slot",
    "apply_setting",
    "check_vary",
    "PairFigures",
    "pair_figures",
    "format_value",
]

PROFILE_ENTRIES = tuple(
    f.name for f in fields(Profile) if f.name not in ("name", "engines", "timestep", "gravity")
)
"""The profile entries a study may change."""


@dataclass(frozen=True)
class Setting:
    """A setting (``KEY``) and the values a study gives it; ``typed``: each value as it was
    written (``1/240``), what the terminal and the reports show (empty: none written)."""

    key: str
    values: tuple[Any, ...]
    typed: tuple[str, ...] = ()

    @property
    def kind(self) -> str:
        return setting_kind(self.key)

    def shown(self, value: Any) -> str:
        """``value`` as it was written, else as :func:`format_value` (a time step as
        ``1/240`` where it is one) writes it."""
        for v, text in zip(self.values, self.typed, strict=False):
            if type(v) is type(value) and v == value:
                return text
        return format_value(value, self.key)


def _registered() -> list[str]:
    from simbridge.registry import available_backends

    return list(available_backends())


def split_slot(key: str) -> tuple[str, int | None]:
    """``lateral_friction@2`` -> (``lateral_friction``, 1): the setting and the engine (1 for
    the first, here 0-based) it is changed on alone; None: every engine it applies to.

    Raises:
        InvalidArgumentError: a slot that is not a whole number >= 1.
    """
    name, at, slot = key.partition("@")
    if not at:
        return key, None
    if not slot.isdigit() or int(slot) < 1:
        raise InvalidArgumentError(
            "vary", f"{key!r}: expected KEY@N with N the engine's place, 1 for the first"
        )
    return name, int(slot) - 1


def setting_kind(key: str) -> str:
    """``timestep``, ``profile`` (a profile entry) or ``engine`` (``BACKEND.KEY``); a key may
    end in ``@N``: changed on the N-th engine alone (:func:`split_slot`).

    Raises:
        InvalidArgumentError: any other key (naming the valid ones).
    """
    key, slot = split_slot(key)
    if key == "timestep" and slot is not None:
        raise InvalidArgumentError("vary", "timestep@N: every engine runs at one time step")
    if key == "timestep":
        return "timestep"
    if key in PROFILE_ENTRIES:
        return "profile"
    backend, dot, name = key.partition(".")
    if dot and name and backend in _registered():
        return "engine"
    from simbridge.engine_settings import settings_for

    known = ["timestep", *PROFILE_ENTRIES]
    known += [f"{b}.{k}" for b in _registered() for k in settings_for(b)]
    raise InvalidArgumentError(
        "vary",
        f"unknown setting {key!r}{did_you_mean(key, known)}; valid: 'timestep', a profile entry "
        f"({', '.join(PROFILE_ENTRIES)}) or an engine setting BACKEND.KEY with BACKEND one of "
        f"{_registered()} (`simbridge settings [BACKEND]` lists the keys)",
    )


def parse_value(key: str, text: str) -> Any:
    """One value of ``key`` from its text: a time step (``1/480`` too) for ``timestep``, else a
    Python literal (``0.9``, ``True``, ``None``, ``(0.02, 1.0)``) or the text itself."""
    text = text.strip()
    if key == "timestep":
        from ..scenario import parse_timestep

        try:
            return parse_timestep(text)
        except ValueError as exc:
            raise InvalidArgumentError("vary", f"timestep: {exc}") from None
    return _literal(text)


def _split_values(text: str) -> list[str]:
    """Split at commas outside brackets: ``(0.02,1),(0.01,1)`` is two values."""
    out, depth, cur = [], 0, ""
    for ch in text:
        if ch in "([":
            depth += 1
        elif ch in ")]":
            depth -= 1
        if ch == "," and depth == 0:
            out.append(cur)
            cur = ""
        else:
            cur += ch
    out.append(cur)
    return [v for v in (x.strip() for x in out) if v]


def parse_vary(text: str) -> Setting:
    """``KEY=V1,V2,...`` as a :class:`Setting`, each value checked (a profile entry's by the
    profile, an engine setting's by the backend's settings when they exist).

    Raises:
        InvalidArgumentError: no ``=``, no value, an unknown key or a bad value.
    """
    key, eq, rest = text.partition("=")
    key = key.strip()
    if not eq or not key:
        raise InvalidArgumentError("vary", f"expected KEY=V1,V2,..., got {text!r}")
    kind = setting_kind(key)
    name = split_slot(key)[0]
    typed = tuple(_split_values(rest))
    values = tuple(parse_value(name, v) for v in typed)
    if not values:
        raise InvalidArgumentError("vary", f"{key}: no value given in {text!r}")
    if len(set(map(repr, values))) != len(values):
        raise InvalidArgumentError("vary", f"{key}: a value is given twice in {text!r}")
    for v in values:
        if kind == "profile" or kind == "engine":
            derived_profile("pybullet", {name: v})  # raises on a bad value
    return Setting(key, values, typed)


def check_vary(settings: Sequence[Setting | str], backends: Sequence[str]) -> None:
    """Each setting of a study over ``backends`` changes something: an engine setting's
    backend is one of them, a ``KEY@N``'s N within them (and its backend's, for an engine
    setting). Found before any run.

    Raises:
        EngineNotInStudyError: ``BACKEND.KEY`` for a backend not among ``backends``.
        InvalidArgumentError: ``KEY@N`` past the last engine, or naming another backend's.
    """
    from ..errors import EngineNotInStudyError

    for s in settings:
        key = s.key if isinstance(s, Setting) else s.partition("=")[0].strip()
        name, only = split_slot(key)
        backend = name.split(".", 1)[0] if setting_kind(key) == "engine" else None
        if backend is not None and backend not in backends:
            raise EngineNotInStudyError("vary", name, backend, backends)
        if only is not None and only >= len(backends):
            raise InvalidArgumentError(
                "vary",
                f"{key!r}: there are {len(backends)} engines ({', '.join(backends)}): N is 1 "
                f"to {len(backends)}",
            )
        if only is not None and backend is not None and backend != backends[only]:
            raise InvalidArgumentError(
                "vary",
                f"{key!r}: engine {only + 1} is {backends[only]!r}, not {backend!r}"
                f"{_where(name, backend, backends)}",
            )


def _where(name: str, backend: str, backends: Sequence[str]) -> str:
    """``"; 'physx' is engine 3 (physx.solver@3)"``: where ``backend`` is among the engines."""
    places = [n + 1 for n, b in enumerate(backends) if b == backend]
    if not places:
        return f"; {backend!r} is not among the engines ({', '.join(backends)})"
    at = " and ".join(str(n) for n in places)
    return f"; {backend!r} is engine {at} ({name}@{places[0]})"


def apply_setting(
    backends: Sequence[str],
    profiles: Sequence[str],
    timestep: float | None,
    key: str,
    value: Any,
) -> tuple[tuple[str, ...], float | None]:
    """The profiles (one per slot) and the time step of a comparison point with ``key`` set
    to ``value``: a profile entry on every slot, an engine setting on its backend's slots
    (``KEY@N``: on the N-th slot alone).

    Raises:
        InvalidArgumentError: ``KEY@N`` past the last slot, or naming another backend's slot.
    """
    kind = setting_kind(key)
    if kind == "timestep":
        return tuple(profiles), float(value)
    name, only = split_slot(key)
    if only is not None and only >= len(backends):
        raise InvalidArgumentError(
            "vary", f"{key!r}: there are {len(backends)} engines ({', '.join(backends)})"
        )
    if only is not None and kind == "engine" and name.split(".", 1)[0] != backends[only]:
        raise InvalidArgumentError(
            "vary",
            f"{key!r}: engine {only + 1} is {backends[only]!r}, not that setting's backend"
            f"{_where(name, name.split('.', 1)[0], backends)}",
        )
    out = []
    for slot, (backend, prof) in enumerate(zip(backends, profiles, strict=True)):
        if (only is not None and slot != only) or (
            kind == "engine" and name.split(".", 1)[0] != backend
        ):
            out.append(prof)
        else:
            out.append(_with_change(prof, name, value))
    return tuple(out), timestep


def _with_change(profile: str, key: str, value: Any) -> str:
    """``profile`` (a name, derived or not) with ``key`` set to ``value``, a change already
    there replaced."""
    base, *parts = profile.split(SPEC_SEPARATOR)
    changes: dict[str, Any] = {}
    for part in parts:
        k, _, v = part.partition("=")
        changes[k] = _literal(v)
    changes[key] = value
    return derived_profile(base, changes)


def _literal(text: str) -> Any:
    if text.lower() in ("true", "false"):  # as TOML and --set write a bool
        return text.lower() == "true"
    try:
        return ast.literal_eval(text)
    except (ValueError, SyntaxError):
        return text


def format_value(value: Any, key: str = "") -> str:
    """A setting's value as the tables show it where it was not written
    (:meth:`Setting.shown`): a time step (``key`` ``timestep``) as ``1/240`` where it is one."""
    if key == "timestep" and isinstance(value, float):
        from ..scenario import format_timestep

        return format_timestep(value)
    if isinstance(value, float):
        return f"{value:.6g}"
    if isinstance(value, (list, tuple)):
        return "(" + ", ".join(format_value(v) for v in value) + ")"
    return str(value)


@dataclass
class PairFigures:
    """What a study keeps of one pair of engines in one comparison: the verdict, the gap with
    its bootstrap interval at the judged instant, each engine's spread (interval too) and own
    time-step error there."""

    labels: tuple[str, str]
    verdict: str
    reason: str
    engines: list[str]
    marginal: bool
    quantity: str
    unit: str
    tolerance: float
    judged_time: float
    judged_at: str
    gap: Interval
    gap_end: Interval
    spreads: tuple[Interval, Interval]
    own_errors: tuple[float, float]
    p_value: float | None
    gap_series: np.ndarray = field(repr=False)
    time: np.ndarray = field(repr=False)

    def as_dict(self) -> dict[str, Any]:
        return {
            "labels": list(self.labels),
            "verdict": self.verdict,
            "reason": self.reason,
            "engines": self.engines,
            "marginal": self.marginal,
            "quantity": self.quantity,
            "unit": self.unit,
            "tolerance": self.tolerance,
            "judged_time": self.judged_time,
            "judged_at": self.judged_at,
            "gap": interval_dict(self.gap),
            "gap_end": interval_dict(self.gap_end),
            "spreads": [interval_dict(s) for s in self.spreads],
            "own_errors": list(self.own_errors),
            "p_value": self.p_value,
        }


def interval_dict(x: Interval) -> dict[str, Any]:
    return {"value": _finite(x.value), "low": _finite(x.low), "high": _finite(x.high)}


def _finite(x: float | None) -> float | None:
    return None if x is None or not math.isfinite(x) else float(x)


def pair_figures(v: Verdict) -> PairFigures:
    """:class:`PairFigures` of a pair's verdict."""
    return PairFigures(
        labels=v.labels,
        verdict=v.verdict,
        reason=v.reason,
        engines=list(v.engines),
        marginal=v.marginal,
        quantity=v.quantity,
        unit=v.unit,
        tolerance=v.tolerance,
        judged_time=v.judged_time,
        judged_at=v.judged_at,
        gap=v.gap,
        gap_end=v.gap_end,
        spreads=(v.per_engine[0].spread, v.per_engine[1].spread),
        own_errors=(v.per_engine[0].own_error, v.per_engine[1].own_error),
        p_value=None if v.test is None else v.test.p_value,
        gap_series=v.gap_series,
        time=v.time,
    )


def all_pairs(c: Comparison) -> list[PairFigures]:
    """:class:`PairFigures` of every judged pair of ``c``, the headline pair first."""
    return [pair_figures(p.verdict) for p in c.pairs if p.verdict is not None]
