"""The whole comparison: two or more engines, each at its time step and half of it, over a sweep
of time steps, every pair of them judged: :func:`compare` and :class:`Comparison`."""

from __future__ import annotations

import math
import os
import sys
import time as _time
from collections.abc import Callable, Mapping, Sequence
from concurrent.futures import Executor
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from simbridge.engine_settings import require_engines
from simbridge.exceptions import InvalidArgumentError, ScenarioError, SimbridgeError

from .analysis.diff import Divergence, diff
from .analysis.judged import judged
from .analysis.verdict import Verdict
from .run.cache import Cache
from .run.ensemble import (
    DEFAULT_ENSEMBLE,
    DEFAULT_PERTURB,
    DEFAULT_SEED,
    Ensemble,
    EnsembleRunner,
    _main_importable,
)
from .run.resync import Resync, default_every
from .run.studyjobs import (
    JobCounts,
    JobFailed,
    Plan,
    ensembles_of,
    resync_of,
    run_jobs,
    study_record,
)
from .run.trajectory import Trajectory
from .scenario import Scenario, load_scenario, parse_timestep

__all__ = [
    "Comparison",
    "Pair",
    "EnsembleSettings",
    "compare",
    "installed_backends",
    "ProgressCallback",
]

ProgressCallback = Callable[[str, int, int], None]
"""progress(what, steps_done_overall, steps_total_overall)."""


@dataclass(frozen=True)
class EnsembleSettings:
    """How the ensembles of a comparison were run."""

    size: int  # runs per engine, the nominal one included
    perturb: tuple[float, float]  # largest perturbation of the spawn: position m, orientation rad
    seed: int
    workers: int  # worker processes (0: in this process)
    wall_time: float = 0.0  # s, every engine's ensemble


@dataclass
class Pair:
    """Two engines of a comparison, ``a`` before ``b`` (slots into :attr:`Comparison.labels`):
    ``cross[dt]`` diffs their runs at every time step, ``verdict`` judges their ensembles at the
    headline time step (None for a comparison made without one)."""

    a: int
    b: int
    cross: dict[float, Divergence]
    verdict: Verdict | None = None
    resync: Resync | None = None
    """The one-step error from each other's states and each engine's floor
    (:mod:`simbridge.compare.run.resync`); None with ``resync_every=0`` or when a job failed."""


@dataclass
class Comparison:
    """Two or more engines on one scenario, every pair judged.

    ``runs[(slot, dt)]`` is engine ``slot`` (0 to N-1, in ``backends`` order) run at time step
    ``dt``; every ``dt`` of ``timesteps`` is run, and so is ``dt / 2`` for the engine's own
    time-step error. ``own[(slot, dt)]`` diffs an engine at ``dt`` against itself at ``dt / 2``.
    ``timesteps[0]`` is the one the headline speaks of. ``ensembles`` holds each engine's runs
    from perturbed spawn poses at that time step. ``pairs`` holds every pair of engines (0, 1),
    (0, 2), ..., (1, 2), ...: its cross diff and verdict; ``cross`` and ``verdict`` are the
    first pair's (:mod:`simbridge.compare.analysis.verdict`)."""

    scenario: Scenario
    backends: tuple[str, ...]
    profiles: tuple[str, ...]
    timesteps: list[float]
    runs: dict[tuple[int, float], Trajectory]
    cross: dict[float, Divergence]
    own: dict[tuple[int, float], Divergence]
    command_line: list[str] = field(default_factory=list)
    wall_time: float = 0.0
    ensembles: list[Ensemble] = field(default_factory=list)
    verdict: Verdict | None = None
    resync: Resync | None = None
    """The one-step error from each other's states and each engine's floor, between the first
    pair's engines (:mod:`simbridge.compare.run.resync`); None with ``resync_every=0``. Every
    pair's is its :attr:`Pair.resync`."""
    ensemble_settings: EnsembleSettings | None = None
    """How the ensembles were run (None in a Comparison made by hand)."""
    pairs: list[Pair] = field(default_factory=list)
    """Every pair of engines, in order; the first is (0, 1), whose ``cross`` and ``verdict``
    these are."""
    left_out: dict[str, str] = field(default_factory=dict)
    """With the backends chosen by default (every installed one): each registered backend
    left out and why (:func:`installed_backends`); empty when the backends were named."""
    failed: list[JobFailed] = field(default_factory=list)
    """Jobs that killed their worker (a segfault, an abort, an out-of-memory kill): the study
    was judged without them (an ensemble on its other members)."""
    failed_members: dict[str, list[JobFailed]] = field(default_factory=dict)
    """Per engine label, its ensemble members among :attr:`failed`."""
    jobs: JobCounts | None = None
    """How many jobs the comparison had, how many came from the cache and how many ran."""
    study: dict[str, Any] | None = None
    """What :func:`compare` was asked and the key of every job, for ``study.json``
    (:mod:`simbridge.compare.report.study`: ``simbridge report DIR`` rebuilds from it)."""

    @property
    def timestep(self) -> float:
        return self.timesteps[0]

    @property
    def labels(self) -> tuple[str, ...]:
        """Engine names for the report (``pybullet``, ``mujoco``; when the profiles are not all
        the same each name carries its profile, ``pybullet (urdf)``; an engine named twice gets
        a suffix from its second time on, ``mujoco (2)``)."""
        return engine_labels(self.backends, self.profiles)

    @property
    def engine_pairs(self) -> list[tuple[int, int]]:
        """Every pair of engine slots, (0, 1) first."""
        return [(p.a, p.b) for p in self.pairs] or _pairs(len(self.backends))

    @property
    def headline_quantity(self) -> str:
        """The scenario's ``headline``, else ``base_distance`` for a free-moving subject and
        ``link_distance`` for a fixed base."""
        return _headline_quantity(self.scenario)


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


def _pairs(n: int) -> list[tuple[int, int]]:
    return [(i, j) for i in range(n) for j in range(i + 1, n)]


def compare(
    scenario: str | Path | Scenario,
    backends: Sequence[str] | None = None,
    *,
    profile: str | Sequence[str] | None = None,
    timesteps: Sequence[float | str] | None = None,
    duration: float | None = None,
    progress: ProgressCallback | None = None,
    command_line: Sequence[str] | None = None,
    ensemble: int = DEFAULT_ENSEMBLE,
    perturb: float | tuple[float, float] = DEFAULT_PERTURB,
    seed: int = DEFAULT_SEED,
    tolerance: float | None = None,
    workers: int | None = None,
    controller: Any = None,
    resync_every: int | None = None,
    resync_pairs: int | None = None,
    engine_settings: Mapping[str, Mapping[str, Any]] | None = None,
    cache: Cache | str | os.PathLike[str] | bool | None = None,
    fresh: bool = False,
    scheduler: str | None = None,
    executor: Executor | None = None,
    offline: bool = False,
) -> Comparison:
    """Run ``scenario`` on two or more backends at every time step of ``timesteps`` and at half
    of each, run each engine's ensemble at the first time step, diff and judge every pair.

    Args:
        scenario: a shipped scenario name, a TOML path or a :class:`Scenario`.
        backends: two or more registered backend names (the same one twice compares it with
            itself); every pair is judged, the first two make the headline. Default: every
            installed backend, in registration order (:func:`installed_backends`: ``pybullet
            mujoco`` and ``physx`` where SAPIEN is installed); the report names each registered
            one left out and why.
        profile: one profile name for all, or one per backend; default the scenario's.
        timesteps: time steps (s or ``"1/480"``), the first one being the headline's; default
            the scenario's. Every phase keeps its duration.
        duration: only the first ``duration`` seconds of the scenario.
        progress: ``progress(what, done, total)`` in steps over all runs.
        command_line: recorded in the manifest (default ``sys.argv``).
        ensemble: runs per engine at the headline time step, the nominal one included (1: none
            perturbed; chaos then cannot be told from an engine difference).
        perturb: size of each perturbed run's spawn-pose offset: one number for metres and
            radians alike, or ``(m, rad)``.
        seed: seeds the offsets, the bootstrap and the permutation test.
        tolerance: the gap below which the engines agree, in the headline quantity's unit
            (default its first threshold: 1 cm, 1°, 0.1 rad/s).
        workers: processes that run the jobs (every run: nominal, half-step, ensemble members,
            resync; default: the CPU count; 0: in this process). A script that calls this with
            workers must guard its top level with ``if __name__ == "__main__":`` (worker
            processes are spawned).
        controller: a controller driving every phase in place of the scenario's own (a class
            or function at a module's top level, a ``"file.py:Name"`` or
            ``"package.module:Name"`` reference, or a ``ControllerSpec``); see
            :meth:`Scenario.with_controller`.
        resync_every: every this many steps set each engine's state into the other engine
            and into a second Sim of its own, and step once (:mod:`~simbridge.compare.resync`);
            default about 150 points per run (:func:`~simbridge.compare.resync.default_every`);
            0: none. Every pair of engines gets its own (:attr:`Pair.resync`).
        resync_pairs: only the first this many pairs get a resync (in the order of
            :attr:`Comparison.pairs`); default every pair (``simbridge report DIR`` passes 1 for
            a study recorded when the first pair alone had one).
        engine_settings: engine settings per backend, ``{"mujoco": {"impratio": 10}}``
            (:mod:`simbridge.engine_settings`), on top of the scenario's ``[engines.*]``
            tables, key by key; every run of the study uses them (ensemble members included).
        cache: where job results are kept by content (:mod:`~simbridge.compare.run.cache`):
            None the default folder (``$XDG_CACHE_HOME/simbridge``, else
            ``~/.cache/simbridge``), a folder, a :class:`~simbridge.compare.run.cache.Cache`,
            or False for none. A job found there is not run again.
        fresh: run every job, even those in the cache (their results replace the entries).
        scheduler: ``"tcp://host:port"``: run the jobs on that Dask cluster.
        executor: run the jobs on this :class:`concurrent.futures.Executor` (not shut down).
        offline: run nothing: every job must be in the cache (``simbridge report DIR``).

    Raises:
        ScenarioError, SimbridgeError: a bad scenario or time step, a backend that fails.
        InvalidArgumentError: a bad ensemble size, perturbation, seed, worker count or
            ``resync_pairs``.
        EngineNotInStudyError: ``engine_settings`` for an engine not among ``backends``.
        CacheEntryMissingError: ``offline`` and a job is not in the cache.
    """
    start = _time.perf_counter()
    sc = load_scenario(scenario)
    if controller is not None:
        sc = sc.with_controller(controller)
    sc = sc.with_engine_settings(engine_settings)
    left_out: dict[str, str] = {}
    backends_named = backends is not None
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
    names = tuple(backends)
    require_engines("engine_settings", engine_settings, names)  # one not run changes nothing
    n = len(names)
    if profile is None:
        profiles = (sc.profile,) * n
    elif isinstance(profile, str):
        profiles = (profile,) * n
    else:
        if len(profile) not in (1, n):
            many = "two" if n == 2 else f"one per backend ({n})"
            raise InvalidArgumentError("profile", f"expected one or {many} names, got {profile!r}")
        profiles = tuple(profile) if len(profile) == n else (profile[0],) * n
    dts: list[float] = []
    for t in timesteps or [sc.timestep]:
        try:
            dt = parse_timestep(t)
        except ValueError as exc:
            raise ScenarioError(sc._where(), "timestep", str(exc)) from None
        if dt not in dts:
            dts.append(dt)
    scaled = {}
    for dt in sorted(dts, reverse=True):  # coarsest first: a half step covers the same time
        if dt not in scaled:  # (one that is a coarser step's half is that step's run)
            s = sc.with_timestep(dt)  # raises on a step that does not divide a phase
            scaled[dt] = s.truncated(duration) if duration is not None else s
        scaled[dt / 2] = scaled[dt].with_timestep(dt / 2)  # cut at dt, then halved
    todo = [(slot, d) for slot in range(n) for dt in dts for d in (dt, dt / 2)]
    todo = list(dict.fromkeys(todo))
    quantity = _headline_quantity(sc)
    if tolerance is not None and (
        isinstance(tolerance, bool)
        or not isinstance(tolerance, (int, float))
        or not (math.isfinite(tolerance) and tolerance > 0)
    ):
        raise InvalidArgumentError("tolerance", f"expected a finite number > 0, got {tolerance!r}")
    if resync_every is None:
        resync_every = default_every(scaled[dts[0]].steps)
    if isinstance(resync_every, bool) or not isinstance(resync_every, int) or resync_every < 0:
        raise InvalidArgumentError(
            "resync_every", f"expected a whole number of steps >= 0 (0: none), got {resync_every!r}"
        )
    runner = EnsembleRunner(  # checks the ensemble's arguments, draws its offsets
        scaled[dts[0]],
        list(zip(names, profiles, strict=True)),
        quantity,
        size=ensemble,
        perturb=perturb,
        seed=seed,
        workers=workers,
    )
    if executor is None and scheduler is None and workers != 0 and not _main_importable():
        workers = runner.workers = 0  # a script read from stdin: a spawned one cannot import it
    if not offline:  # a robot file or joint named wrong: FILE:LINE now, not after a run
        from .scenario.robot_check import check_robots

        check_robots(sc)
    labels = engine_labels(names, profiles)
    if resync_pairs is not None and (
        isinstance(resync_pairs, bool) or not isinstance(resync_pairs, int) or resync_pairs < 1
    ):
        raise InvalidArgumentError(
            "resync_pairs", f"expected a whole number of pairs >= 1, got {resync_pairs!r}"
        )
    plan = Plan(
        scaled, dts, todo, names, profiles, labels, quantity, runner, resync_every, resync_pairs
    )
    results, failed, counts = run_jobs(
        plan.jobs,
        cache=cache,
        fresh=fresh,
        offline=offline,
        workers=workers,
        scheduler=scheduler,
        executor=executor,
        progress=progress,
    )
    runs: dict[tuple[int, float], Trajectory] = {}
    for (slot, d), key in plan.nominal.items():
        result = results.get(key)
        if result is None:
            raise SimbridgeError(f"the run of {plan.by_key[key].label} failed: {failed[key].cause}")
        runs[(slot, d)] = result.value
    ensembles = ensembles_of(plan, results, runs)
    own = {(k, dt): diff(runs[(k, dt)], runs[(k, dt / 2)]) for k in range(n) for dt in dts}
    rows = ensembles[0].rows
    pairs = []
    for a, b in _pairs(n):
        verdict = judged(  # judge(), kept in the cache
            counts,
            ensembles[0].time,
            quantity,
            (labels[a], labels[b]),
            [ensembles[a].features, ensembles[b].features],
            [own[(k, dts[0])].series[quantity][rows] for k in (a, b)],
            tolerance=tolerance,
            seed=runner.seed,
        )
        cross = {dt: diff(runs[(a, dt)], runs[(b, dt)]) for dt in dts}
        resynced = None
        if (a, b) in plan.resync_pairs:
            steps = scaled[dts[0]].steps
            resynced = resync_of(plan, results, failed, runs, steps, tolerance, (a, b))
        pairs.append(Pair(a, b, cross, verdict, resynced))
    return Comparison(
        scenario=sc,
        backends=names,
        profiles=profiles,
        timesteps=dts,
        runs=runs,
        cross=pairs[0].cross,
        own=own,
        command_line=list(sys.argv if command_line is None else command_line),
        wall_time=_time.perf_counter() - start,
        ensembles=ensembles,
        verdict=pairs[0].verdict,
        resync=pairs[0].resync,
        ensemble_settings=EnsembleSettings(
            size=runner.size,
            perturb=runner.eps,
            seed=runner.seed,
            workers=runner.workers,
            wall_time=counts.wall_time,
        ),
        pairs=pairs,
        left_out=left_out,
        failed=[failed[k] for k in plan.keys if k in failed],
        failed_members=plan.failed_members(failed),
        jobs=counts,
        study=study_record(
            sc,
            plan,
            backends_named=not left_out and backends_named,
            duration=duration,
            tolerance=tolerance,
            command_line=list(sys.argv if command_line is None else command_line),
            left_out=left_out,
        ),
    )


def _headline_quantity(sc: Scenario) -> str:
    if sc.headline:
        return sc.headline
    return "link_distance" if sc.robot(sc.subject).fixed_base else "base_distance"
