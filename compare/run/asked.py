"""What :func:`~simbridge.compare.pipeline.compare` is asked, read and checked, and its jobs
planned: :func:`plan_study` and :class:`Study`, the study's first stage (the arguments are
checked in one order, so a study with several wrong says the first)."""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from simbridge.exceptions import InvalidArgumentError

from ..errors import EngineNotInStudyError, ScenarioError
from ..scenario import Scenario, load_scenario, parse_timestep
from .ensemble import EnsembleRunner, _main_importable
from .resync import default_every
from .studyjobs import Plan

__all__ = [
    "Study",
    "plan_study",
    "engine_labels",
    "installed_backends",
    "headline_quantity",
    "require_engines",
]


def engine_labels(backends: Sequence[str], profiles: Sequence[str]) -> tuple[str, ...]:
    """:attr:`Comparison.labels` of ``backends`` run under ``profiles``."""
    if len(set(profiles)) > 1:
        names = [f"{b} ({p})" for b, p in zip(backends, profiles, strict=True)]
    else:
        names = list(backends)
    out: list[str] = []
    for name in names:
        seen = names[: len(out)].count(name)
        out.append(name if seen == 0 else f"{name} ({seen + 1})")
    return tuple(out)


def installed_backends() -> tuple[list[str], dict[str, str]]:
    """Every registered backend that loads here, in registration order, and each other
    registered one with why it does not (:func:`simbridge.registry.unavailable_reason`: its
    engine or module is not installed): what :func:`compare` runs when no backend is named."""
    from simbridge.registry import available_backends, unavailable_reason

    names: list[str] = []
    left_out: dict[str, str] = {}
    for name in available_backends():
        reason = unavailable_reason(name)
        if reason is None:
            names.append(name)
        else:
            left_out[name] = reason
    return names, left_out


@dataclass(frozen=True)
class Study:
    """What a comparison was asked, read and checked: every job it needs (:class:`Plan`)."""

    scenario: Scenario  # with the controller and the engine settings in force
    names: tuple[str, ...]  # the backends, in slot order
    profiles: tuple[str, ...]
    dts: list[float]  # the time steps asked, the headline's first
    scaled: dict[float, Scenario]  # the scenario at every time step run (each dt and dt / 2)
    runner: EnsembleRunner
    plan: Plan
    left_out: dict[str, str]  # backends left out of a default choice, and why
    workers: int | None  # 0 where a spawned worker could not import the caller's script
    named: bool  # the backends were named (not every installed one)
    duration: float | None  # s: only the scenario's first seconds
    tolerance: float | None  # checked: None or a finite number > 0

    @property
    def slots(self) -> range:
        return range(len(self.names))


def plan_study(
    scenario: str | Path | Scenario,
    backends: Sequence[str] | None,
    *,
    profile: str | Sequence[str] | None,
    timesteps: Sequence[float | str] | None,
    duration: float | None,
    ensemble: int,
    perturb: float | tuple[float, float],
    seed: int,
    tolerance: float | None,
    workers: int | None,
    controller: Any,
    resync_every: int | None,
    resync_pairs: int | None,
    engine_settings: Mapping[str, Mapping[str, Any]] | None,
    parallel: bool,
    offline: bool,
) -> Study:
    """Read the scenario and check every argument of :func:`compare` (in this order: a study
    with several wrong says the first), then plan its jobs.

    Args:
        parallel: the jobs go to an executor or a scheduler (not this process's own workers).
        Others: as :func:`compare`'s.

    Returns:
        The study read and checked, its jobs planned.

    Raises:
        ScenarioError, SimbridgeError, InvalidArgumentError, EngineNotInStudyError: as
        :func:`compare`.
    """
    sc = load_scenario(scenario)
    if controller is not None:
        sc = sc.with_controller(controller)
    sc = sc.with_engine_settings(engine_settings)
    names, left_out = _backends(backends)
    require_engines("engine_settings", engine_settings, names)  # one not run changes nothing
    profiles = _profiles(profile, sc.profile, len(names))
    dts = _timesteps(sc, timesteps)
    scaled = _scaled(sc, dts, duration)
    todo = [(slot, d) for slot in range(len(names)) for dt in dts for d in (dt, dt / 2)]
    quantity = headline_quantity(sc)
    _check_tolerance(tolerance)
    every = _resync_every(resync_every, scaled[dts[0]].steps)
    runner = EnsembleRunner(  # checks the ensemble's arguments, draws its offsets
        scaled[dts[0]],
        list(zip(names, profiles, strict=True)),
        quantity,
        size=ensemble,
        perturb=perturb,
        seed=seed,
        workers=workers,
    )
    if not parallel and workers != 0 and not _main_importable():
        workers = runner.workers = 0  # a script read from stdin: a spawned one cannot import it
    if not offline:  # a robot file or joint named wrong: FILE:LINE now, not after a run
        from ..scenario.robot_check import check_robots

        check_robots(sc)
    labels = engine_labels(names, profiles)
    _check_resync_pairs(resync_pairs)
    plan = Plan(
        scaled,
        dts,
        list(dict.fromkeys(todo)),
        names,
        profiles,
        labels,
        quantity,
        runner,
        every,
        resync_pairs,
    )
    named = backends is not None
    return Study(
        sc,
        names,
        profiles,
        dts,
        scaled,
        runner,
        plan,
        left_out,
        workers,
        named,
        duration,
        tolerance,
    )


def _backends(backends: Sequence[str] | None) -> tuple[tuple[str, ...], dict[str, str]]:
    """The backends to compare: ``backends``, else every installed one.

    Returns:
        The names, and each registered backend left out of a default choice with why.

    Raises:
        InvalidArgumentError: fewer than two backends (named, or installed here).
    """
    left_out: dict[str, str] = {}
    if backends is None:
        backends, left_out = installed_backends()
        if len(backends) < 2:
            why = "; ".join(f"{b}: {r}" for b, r in left_out.items()) or "none registered"
            raise InvalidArgumentError(
                "backends",
                f"two or more installed backends are needed, installed here: {backends} "
                f"(left out: {why})",
            )
    if isinstance(backends, str) or len(backends) < 2:
        raise InvalidArgumentError(
            "backends", f"expected two or more backend names, got {backends!r}"
        )
    return tuple(backends), left_out


def _profiles(profile: str | Sequence[str] | None, default: str, n: int) -> tuple[str, ...]:
    """One profile per backend: ``profile`` for all, one each, else the scenario's ``default``.

    Raises:
        InvalidArgumentError: neither one name nor ``n``.
    """
    if profile is None:
        return (default,) * n
    if isinstance(profile, str):
        return (profile,) * n
    if len(profile) not in (1, n):
        many = "two" if n == 2 else f"one per backend ({n})"
        raise InvalidArgumentError("profile", f"expected one or {many} names, got {profile!r}")
    return tuple(profile) if len(profile) == n else (profile[0],) * n


def _timesteps(sc: Scenario, timesteps: Sequence[float | str] | None) -> list[float]:
    """The time steps asked (s; each once, in order), else the scenario's.

    Raises:
        ScenarioError: a time step that does not parse.
    """
    dts: list[float] = []
    for t in timesteps or [sc.timestep]:
        try:
            dt = parse_timestep(t)
        except ValueError as exc:
            raise ScenarioError(sc._where(), "timestep", str(exc)) from None
        if dt not in dts:
            dts.append(dt)
    return dts


def _scaled(sc: Scenario, dts: Sequence[float], duration: float | None) -> dict[float, Scenario]:
    """``sc`` at every time step of ``dts`` and at half of each, cut to ``duration`` (s).

    Raises:
        ScenarioError: a time step that does not divide a phase.
    """
    scaled = {}
    for dt in sorted(dts, reverse=True):  # coarsest first: a half step covers the same time
        if dt not in scaled:  # (one that is a coarser step's half is that step's run)
            s = sc.with_timestep(dt)  # raises on a step that does not divide a phase
            scaled[dt] = s.truncated(duration) if duration is not None else s
        scaled[dt / 2] = scaled[dt].with_timestep(dt / 2)  # cut at dt, then halved
    return scaled


def _check_tolerance(tolerance: float | None) -> None:
    """Raises InvalidArgumentError unless ``tolerance`` is None or a finite number > 0."""
    if tolerance is not None and (
        isinstance(tolerance, bool)
        or not isinstance(tolerance, (int, float))
        or not (math.isfinite(tolerance) and tolerance > 0)
    ):
        raise InvalidArgumentError("tolerance", f"expected a finite number > 0, got {tolerance!r}")


def _resync_every(resync_every: int | None, steps: int) -> int:
    """Steps between resync points: ``resync_every``, else about 150 over ``steps``.

    Raises:
        InvalidArgumentError: not a whole number >= 0.
    """
    if resync_every is None:
        resync_every = default_every(steps)
    if isinstance(resync_every, bool) or not isinstance(resync_every, int) or resync_every < 0:
        raise InvalidArgumentError(
            "resync_every", f"expected a whole number of steps >= 0 (0: none), got {resync_every!r}"
        )
    return resync_every


def _check_resync_pairs(resync_pairs: int | None) -> None:
    """Raises InvalidArgumentError unless ``resync_pairs`` is None or a whole number >= 1."""
    if resync_pairs is not None and (
        isinstance(resync_pairs, bool) or not isinstance(resync_pairs, int) or resync_pairs < 1
    ):
        raise InvalidArgumentError(
            "resync_pairs", f"expected a whole number of pairs >= 1, got {resync_pairs!r}"
        )


def headline_quantity(sc: Scenario) -> str:
    if sc.headline:
        return sc.headline
    return "link_distance" if sc.robot(sc.subject).fixed_base else "base_distance"


def require_engines(
    argument: str, settings: Mapping[str, Mapping[str, Any]] | None, engines: Sequence[str]
) -> None:
    """Every backend ``settings`` sets something for is one of ``engines`` (the study's).

    Args:
        argument: the argument the settings came in (``"engine_settings"``, ``"set"``).
        settings: ``{backend: {key: value}}``, or None for none.
        engines: the backends the study runs.

    Raises:
        EngineNotInStudyError: a setting for another engine, naming it and ``engines``.
    """
    for backend, values in (settings or {}).items():
        if backend not in engines and values:
            key = next(iter(values))
            raise EngineNotInStudyError(argument, f"{backend}.{key}", backend, engines)
