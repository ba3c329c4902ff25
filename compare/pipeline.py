"""The whole comparison: both engines, each at its time step and half of it, over a sweep of
time steps: :func:`compare` and :class:`Comparison`."""

from __future__ import annotations

import sys
import time as _time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from simbridge.exceptions import InvalidArgumentError, ScenarioError

from .diff import QUANTITIES, Divergence, diff
from .run import Trajectory, run
from .scenario import Scenario, format_timestep, load_scenario, parse_timestep

__all__ = ["Comparison", "compare", "ProgressCallback"]

ProgressCallback = Callable[[str, int, int], None]
"""progress(what, steps_done_overall, steps_total_overall)."""


@dataclass
class Comparison:
    """Two engines on one scenario.

    ``runs[(slot, dt)]`` is engine ``slot`` (0 or 1) run at time step ``dt``; every ``dt`` of
    ``timesteps`` is run, and so is ``dt / 2`` for the engine's own time-step error.
    ``cross[dt]`` diffs the two engines at ``dt``; ``own[(slot, dt)]`` diffs an engine at ``dt``
    against itself at ``dt / 2``. ``timesteps[0]`` is the one the headline speaks of."""

    scenario: Scenario
    backends: tuple[str, str]
    profiles: tuple[str, str]
    timesteps: list[float]
    runs: dict[tuple[int, float], Trajectory]
    cross: dict[float, Divergence]
    own: dict[tuple[int, float], Divergence]
    command_line: list[str] = field(default_factory=list)
    wall_time: float = 0.0

    @property
    def timestep(self) -> float:
        return self.timesteps[0]

    @property
    def labels(self) -> tuple[str, str]:
        """Engine names for the report (``pybullet``, ``mujoco``; a backend compared with
        itself under another profile or the same one gets a suffix)."""
        a, b = self.backends
        if a != b:
            return a, b
        if self.profiles[0] != self.profiles[1]:
            return f"{a} ({self.profiles[0]})", f"{b} ({self.profiles[1]})"
        return a, f"{b} (2)"

    @property
    def headline_quantity(self) -> str:
        """The scenario's ``headline``, else ``base_distance`` for a free-moving subject and
        ``link_distance`` for a fixed base."""
        if self.scenario.headline:
            return self.scenario.headline
        fixed = self.scenario.robot(self.scenario.subject).fixed_base
        return "link_distance" if fixed else "base_distance"

    def summary(self) -> dict[str, Any]:
        """Every headline figure, JSON-ready (SI units: m, rad, s)."""
        q = self.headline_quantity
        dt = self.timestep
        cross = self.cross[dt]
        gap = cross.final[q]
        first = cross.first_to_diverge()
        own = {}
        for slot, label in enumerate(self.labels):
            d = self.own[(slot, dt)]
            err = d.final[q]
            own[label] = {
                "timestep": dt,
                "half_timestep": dt / 2,
                "final": err,
                "max": d.maximum[q],
                "gap_ratio": _ratio(gap, err),
                "gap_exceeds": bool(gap > err),
            }
        sweep = []
        for t in self.timesteps:
            row: dict[str, Any] = {
                "timestep": t,
                "gap_final": self.cross[t].final[q],
                "gap_max": self.cross[t].maximum[q],
                "engines": {},
            }
            for slot, label in enumerate(self.labels):
                tr = self.runs[(slot, t)]
                row["engines"][label] = {
                    "wall_per_sim_second": tr.wall_per_sim_second(),
                    "wall_time": tr.wall_time,
                    "own_error_final": self.own[(slot, t)].final[q],
                    "own_error_max": self.own[(slot, t)].maximum[q],
                }
            sweep.append(row)
        manifests = {
            label: self.runs[(slot, dt)].manifest for slot, label in enumerate(self.labels)
        }
        return {
            "scenario": self.scenario.name,
            "description": self.scenario.description,
            "scenario_file": str(self.scenario.source) if self.scenario.source else None,
            "subject": self.scenario.subject,
            "backends": list(self.backends),
            "labels": list(self.labels),
            "profiles": list(self.profiles),
            "timestep": dt,
            "timestep_text": format_timestep(dt),
            "duration": float(cross.time[-1]),
            "headline_quantity": q,
            "headline": {
                "quantity": q,
                "title": QUANTITIES[q].title,
                "unit": QUANTITIES[q].unit,
                "final": gap,
                "max": cross.maximum[q],
                "crossings": [
                    {"threshold": thr, "time": cross.first_crossing(q, thr)}
                    for thr in QUANTITIES[q].thresholds
                ],
                "first_to_diverge": (
                    None
                    if first is None
                    else {"quantity": first[0], "threshold": first[1], "time": first[2]}
                ),
                "own_error": own,
                "gap_exceeds_all_own_errors": all(v["gap_exceeds"] for v in own.values()),
            },
            "cross": cross.to_dict(),
            "own": {
                label: self.own[(slot, dt)].to_dict() for slot, label in enumerate(self.labels)
            },
            "sweep": sweep,
            "wall_time": self.wall_time,
            "manifest": {
                "simbridge_version": _version(),
                "command_line": self.command_line,
                "engines": manifests,
            },
        }


def _ratio(gap: float, err: float) -> float | None:
    """gap / err; None when the engine's own error is zero (JSON has no infinity)."""
    return gap / err if err > 0 else None


def _version() -> str:
    from simbridge import __version__

    return __version__


def compare(
    scenario: str | Path | Scenario,
    backends: Sequence[str] = ("pybullet", "mujoco"),
    *,
    profile: str | Sequence[str] | None = None,
    timesteps: Sequence[float | str] | None = None,
    duration: float | None = None,
    progress: ProgressCallback | None = None,
    command_line: Sequence[str] | None = None,
) -> Comparison:
    """Run ``scenario`` on two backends at every time step of ``timesteps`` and at half of each,
    and diff them.

    Args:
        scenario: a shipped scenario name, a TOML path or a :class:`Scenario`.
        backends: two registered backend names (the same one twice compares it with itself).
        profile: one profile name for both, or one per backend; default the scenario's.
        timesteps: time steps (s or ``"1/480"``), the first one being the headline's; default
            the scenario's. Every phase keeps its duration.
        duration: only the first ``duration`` seconds of the scenario.
        progress: ``progress(what, done, total)`` in steps over all runs.
        command_line: recorded in the manifest (default ``sys.argv``).

    Raises:
        ScenarioError, SimbridgeError: a bad scenario or time step, a backend that fails.
    """
    start = _time.perf_counter()
    sc = load_scenario(scenario)
    if len(backends) != 2:
        raise InvalidArgumentError("backends", f"expected two backend names, got {backends!r}")
    pair = (backends[0], backends[1])
    if profile is None:
        profiles = (sc.profile, sc.profile)
    elif isinstance(profile, str):
        profiles = (profile, profile)
    else:
        if len(profile) not in (1, 2):
            raise InvalidArgumentError("profile", f"expected one or two names, got {profile!r}")
        profiles = (profile[0], profile[-1])
    dts: list[float] = []
    for t in timesteps or [sc.timestep]:
        try:
            dt = parse_timestep(t)
        except ValueError as exc:
            raise ScenarioError(sc._where(), "timestep", str(exc)) from None
        if dt not in dts:
            dts.append(dt)
    scaled = {}
    for dt in dts:
        for d in (dt, dt / 2):
            s = sc.with_timestep(d)  # raises on a step that does not divide a phase
            scaled[d] = s.truncated(duration) if duration is not None else s
    todo = [(slot, d) for slot in (0, 1) for dt in dts for d in (dt, dt / 2)]
    todo = list(dict.fromkeys(todo))
    total = sum(scaled[d].steps for _, d in todo)
    done = 0
    runs: dict[tuple[int, float], Trajectory] = {}
    cache: dict[tuple[str, str, float], Trajectory] = {}
    for slot, d in todo:
        key = (pair[slot], profiles[slot], d)
        if key not in cache:
            what = f"{pair[slot]} @ {format_timestep(d)} s"
            base = done

            def tick(n: int, _total: int, _what: str = what, _base: int = base) -> None:
                if progress is not None:
                    progress(_what, _base + n, total)

            cache[key] = run(scaled[d], pair[slot], profile=profiles[slot], progress=tick)
        runs[(slot, d)] = cache[key]
        done += scaled[d].steps
    cross = {dt: diff(runs[(0, dt)], runs[(1, dt)]) for dt in dts}
    own = {
        (slot, dt): diff(runs[(slot, dt)], runs[(slot, dt / 2)]) for slot in (0, 1) for dt in dts
    }
    return Comparison(
        scenario=sc,
        backends=pair,
        profiles=profiles,
        timesteps=dts,
        runs=runs,
        cross=cross,
        own=own,
        command_line=list(sys.argv if command_line is None else command_line),
        wall_time=_time.perf_counter() - start,
    )
