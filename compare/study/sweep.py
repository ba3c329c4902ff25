"""``simbridge sweep SCENARIO --vary KEY=V1,V2,...``: one comparison per value of each setting,
the cross-engine gap and each engine's spread against the value: :func:`sweep`.

By default each setting is varied alone, the others at the scenario's (one point per value);
with ``grid=True`` every combination of the values is run. Each point is a
:func:`~simbridge.compare.compare` call with the changed profiles or time step
(:func:`~simbridge.compare.study.points.apply_setting`).
"""

from __future__ import annotations

import itertools
import time as _time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any

from simbridge.exceptions import InvalidArgumentError

from ..pipeline import compare
from ..run.asked import require_engines
from ..scenario import load_scenario
from .points import (
    PairFigures,
    Setting,
    all_pairs,
    apply_setting,
    check_vary,
    format_value,
    parse_vary,
)

__all__ = ["SweepPoint", "Sweep", "sweep"]


@dataclass
class SweepPoint:
    """One comparison of a sweep: the settings changed (key -> value), the profiles and time
    step it ran with, every pair's figures."""

    values: dict[str, Any]
    profiles: tuple[str, ...]
    timestep: float
    pairs: list[PairFigures]
    labels: tuple[str, ...]
    wall_time: float
    typed: dict[str, str] = field(default_factory=dict)
    """The values as they were written (``1/240``; :meth:`Setting.shown`), by key."""

    def shown(self, key: str) -> str:
        """The value of ``key`` as it was written, else as :func:`format_value` writes it."""
        return self.typed.get(key) or format_value(self.values[key], key)

    def as_dict(self) -> dict[str, Any]:
        return {
            "values": {k: _json_value(v) for k, v in self.values.items()},
            "typed": {k: self.shown(k) for k in self.values},
            "profiles": list(self.profiles),
            "timestep": self.timestep,
            "labels": list(self.labels),
            "wall_time": self.wall_time,
            "pairs": [p.as_dict() for p in self.pairs],
        }


def _json_value(v: Any) -> Any:
    return list(v) if isinstance(v, tuple) else v


@dataclass
class Sweep:
    """Every point of a sweep, in the order run."""

    scenario: str
    backends: tuple[str, ...]
    profiles: tuple[str, ...]  # before any change
    settings: list[Setting]
    grid: bool
    points: list[SweepPoint]
    ensemble: int
    duration: float | None
    wall_time: float

    def points_of(self, key: str) -> list[SweepPoint]:
        """The points where ``key`` was varied (all of them on a grid)."""
        return [p for p in self.points if key in p.values]

    def as_dict(self) -> dict[str, Any]:
        return {
            "scenario": self.scenario,
            "backends": list(self.backends),
            "profiles": list(self.profiles),
            "vary": {s.key: [_json_value(v) for v in s.values] for s in self.settings},
            "vary_typed": {s.key: [s.shown(v) for v in s.values] for s in self.settings},
            "grid": self.grid,
            "ensemble": self.ensemble,
            "duration": self.duration,
            "wall_time": self.wall_time,
            "points": [p.as_dict() for p in self.points],
        }


def sweep(
    scenario: Any,
    backends: Sequence[str] | None = None,
    vary: Sequence[str | Setting] = (),
    *,
    grid: bool = False,
    profile: str | Sequence[str] | None = None,
    timestep: float | str | None = None,
    on_point: Callable[[int, int, dict[str, Any]], None] | None = None,
    **compare_args: Any,
) -> Sweep:
    """One :func:`~simbridge.compare.compare` per value of each setting of ``vary``.

    Args:
        scenario: a shipped scenario name, a TOML path or a Scenario.
        backends: as :func:`~simbridge.compare.compare`'s (default: every installed one).
        vary: settings and their values, ``"lateral_friction=0.3,0.5,0.9"`` or
            :class:`~simbridge.compare.study.points.Setting` (:func:`parse_vary`).
        grid: every combination of the values (default: each setting alone).
        profile: the profile(s) the settings change (default the scenario's).
        timestep: the time step of the points that do not vary it (default the scenario's).
        on_point: ``on_point(index, total, values)`` before each point runs.
        compare_args: passed to every call (``ensemble``, ``duration``, ``seed``...).

    Raises:
        InvalidArgumentError: no setting, a setting given twice, a bad key or value, a
            ``KEY@N`` past the engines.
        EngineNotInStudyError: ``BACKEND.KEY`` (or ``engine_settings``) for a backend the
            sweep does not run.
    """
    start = _time.perf_counter()
    settings = [v if isinstance(v, Setting) else parse_vary(v) for v in vary]
    if not settings:
        raise InvalidArgumentError("vary", "expected at least one KEY=V1,V2,... to vary")
    keys = [s.key for s in settings]
    by_key = {s.key: s for s in settings}
    if len(set(keys)) != len(keys):
        raise InvalidArgumentError("vary", f"a setting is varied twice: {keys}")
    sc = load_scenario(scenario)
    if compare_args.get("controller") is not None:
        sc = sc.with_controller(compare_args.pop("controller"))
    if backends is None:
        from ..pipeline import installed_backends

        backends = installed_backends()[0]
    names = tuple(backends)
    check_vary(settings, names)  # a setting that changes nothing: said before any run
    require_engines("engine_settings", compare_args.get("engine_settings"), names)
    if profile is None:
        profiles = (sc.profile,) * len(names)
    elif isinstance(profile, str):
        profiles = (profile,) * len(names)
    else:
        profiles = tuple(profile) if len(profile) == len(names) else (profile[0],) * len(names)
    from ..scenario import parse_timestep

    dt0 = parse_timestep(timestep) if timestep is not None else sc.timestep
    if grid:
        combos = [
            dict(zip(keys, vals, strict=True))
            for vals in itertools.product(*(s.values for s in settings))
        ]
    else:
        combos = [{s.key: v} for s in settings for v in s.values]
    points = []
    for i, values in enumerate(combos):
        if on_point is not None:
            on_point(i, len(combos), values)
        profs, dt = profiles, dt0
        for key, value in values.items():
            profs, new_dt = apply_setting(names, profs, dt, key, value)
            dt = dt if new_dt is None else new_dt
        t0 = _time.perf_counter()
        c = compare(sc, names, profile=list(profs), timesteps=[dt], **compare_args)
        points.append(
            SweepPoint(
                values=values,
                profiles=tuple(profs),
                timestep=dt,
                pairs=all_pairs(c),
                labels=c.labels,
                wall_time=_time.perf_counter() - t0,
                typed={k: by_key[k].shown(v) for k, v in values.items()},
            )
        )
    ens = compare_args.get("ensemble")
    return Sweep(
        scenario=sc.name,
        backends=names,
        profiles=profiles,
        settings=settings,
        grid=grid,
        points=points,
        ensemble=int(ens) if ens is not None else _default_ensemble(),
        duration=compare_args.get("duration"),
        wall_time=_time.perf_counter() - start,
    )


def _default_ensemble() -> int:
    from ..run.ensemble import DEFAULT_ENSEMBLE

    return DEFAULT_ENSEMBLE
