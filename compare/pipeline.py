"""The whole comparison: two or more engines, each at its time step and half of it, over a sweep
of time steps, every pair of them judged: :func:`compare` and :class:`Comparison`."""

from __future__ import annotations

import os
import sys
import time as _time
from collections.abc import Callable, Mapping, Sequence
from concurrent.futures import Executor
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from simbridge.exceptions import SimbridgeError

from .analysis.diff import Divergence, diff
from .analysis.judged import judged
from .analysis.verdict import Verdict
from .run.asked import (
    Study,
    engine_labels,
    headline_quantity,
    installed_backends,
    plan_study,
)
from .run.cache import Cache
from .run.ensemble import (
    DEFAULT_ENSEMBLE,
    DEFAULT_PERTURB,
    DEFAULT_SEED,
    Ensemble,
)
from .run.jobs import JobResult
from .run.resync import Resync
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
from .scenario import Scenario

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
        return headline_quantity(self.scenario)


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
    study = plan_study(
        scenario,
        backends,
        profile=profile,
        timesteps=timesteps,
        duration=duration,
        ensemble=ensemble,
        perturb=perturb,
        seed=seed,
        tolerance=tolerance,
        workers=workers,
        controller=controller,
        resync_every=resync_every,
        resync_pairs=resync_pairs,
        engine_settings=engine_settings,
        parallel=executor is not None or scheduler is not None,
        offline=offline,
    )
    results, failed, counts = run_jobs(
        study.plan.jobs,
        cache=cache,
        fresh=fresh,
        offline=offline,
        workers=study.workers,
        scheduler=scheduler,
        executor=executor,
        progress=progress,
    )
    runs = _nominal_runs(study.plan, results, failed)
    ensembles = ensembles_of(study.plan, results, runs)
    own = {(k, dt): diff(runs[(k, dt)], runs[(k, dt / 2)]) for k in study.slots for dt in study.dts}
    pairs = _judge_pairs(study, results, failed, runs, own, ensembles, counts)
    line = list(sys.argv if command_line is None else command_line)
    return _comparison(study, runs, own, ensembles, pairs, failed, counts, line, start)


def _nominal_runs(
    plan: Plan, results: dict[str, JobResult], failed: dict[str, JobFailed]
) -> dict[tuple[int, float], Trajectory]:
    """Every engine's run at every time step, by ``(slot, dt)``.

    Raises:
        SimbridgeError: one of them failed (the study cannot be judged without it).
    """
    runs: dict[tuple[int, float], Trajectory] = {}
    for (slot, d), key in plan.nominal.items():
        result = results.get(key)
        if result is None:
            raise SimbridgeError(f"the run of {plan.by_key[key].label} failed: {failed[key].cause}")
        runs[(slot, d)] = result.value
    return runs


def _judge_pairs(
    study: Study,
    results: dict[str, JobResult],
    failed: dict[str, JobFailed],
    runs: dict[tuple[int, float], Trajectory],
    own: Mapping[tuple[int, float], Divergence],
    ensembles: Sequence[Ensemble],
    counts: JobCounts,
) -> list[Pair]:
    """Every pair of engines diffed at every time step, judged on their ensembles at the
    headline one, and resynced where the plan has it."""
    plan, dts = study.plan, study.dts
    rows = ensembles[0].rows
    pairs = []
    for a, b in _pairs(len(study.names)):
        verdict = judged(  # judge(), kept in the cache
            counts,
            ensembles[0].time,
            plan.quantity,
            (plan.labels[a], plan.labels[b]),
            [ensembles[a].features, ensembles[b].features],
            [own[(k, dts[0])].series[plan.quantity][rows] for k in (a, b)],
            tolerance=study.tolerance,
            seed=study.runner.seed,
        )
        cross = {dt: diff(runs[(a, dt)], runs[(b, dt)]) for dt in dts}
        resynced = None
        if (a, b) in plan.resync_pairs:
            steps = study.scaled[dts[0]].steps
            resynced = resync_of(plan, results, failed, runs, steps, study.tolerance, (a, b))
        pairs.append(Pair(a, b, cross, verdict, resynced))
    return pairs


def _comparison(
    study: Study,
    runs: dict[tuple[int, float], Trajectory],
    own: dict[tuple[int, float], Divergence],
    ensembles: list[Ensemble],
    pairs: list[Pair],
    failed: dict[str, JobFailed],
    counts: JobCounts,
    command_line: list[str],
    start: float,
) -> Comparison:
    """The :class:`Comparison` of a study run and judged, begun at ``start``
    (``time.perf_counter()``), with its record for ``study.json``."""
    runner = study.runner
    return Comparison(
        scenario=study.scenario,
        backends=study.names,
        profiles=study.profiles,
        timesteps=study.dts,
        runs=runs,
        cross=pairs[0].cross,
        own=own,
        command_line=command_line,
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
        left_out=study.left_out,
        failed=[failed[k] for k in study.plan.keys if k in failed],
        failed_members=study.plan.failed_members(failed),
        jobs=counts,
        wall_time=_time.perf_counter() - start,
        study=study_record(
            study.scenario,
            study.plan,
            backends_named=not study.left_out and study.named,
            duration=study.duration,
            tolerance=study.tolerance,
            command_line=list(command_line),
            left_out=study.left_out,
        ),
    )
