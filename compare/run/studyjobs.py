"""A comparison's runs as jobs (:mod:`.jobs`): which jobs it has (:class:`Plan`), running those
the cache does not hold (:func:`run_jobs`), and putting their results back together as the
comparison needs them (:func:`ensembles_of`, :func:`resync_of`, :func:`study_record`).

Results come back the same wherever a job ran (here, a worker process, a Dask worker) and
whether it ran now or was read from the cache: a cached study gives the same figures."""

from __future__ import annotations

import functools
import logging
import os
import time as _time
from collections.abc import Callable, Sequence
from concurrent.futures import Executor
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from simbridge._version import __version__

from ..errors import CacheEntryMissingError
from ..scenario import Scenario, dumps_scenario
from .cache import Cache, resolve
from .ensemble import (
    Ensemble,
    EnsembleRunner,
    _main_importable,
    _show_worker_log,
    kept_rows,
    member_of,
    perturbed,
)
from .executors import JobFailed, run_all
from .jobs import Job, JobResult, file_hashes, run_job_registered
from .quantities import QUANTITIES
from .resync import FLOOR_RELATIVE, Resync
from .trajectory import Trajectory

__all__ = [
    "JobCounts",
    "JobFailed",
    "Plan",
    "run_jobs",
    "ensembles_of",
    "resync_of",
    "study_record",
    "STUDY_FORMAT",
]

log = logging.getLogger("simbridge.compare.jobs")

STUDY_FORMAT = "simbridge.compare.study/1"


@dataclass
class JobCounts:
    """A comparison's jobs: how many in all, read from the cache, run, failed; ``wall_time``
    (s) of running them (0 when all came from the cache)."""

    total: int
    cached: int
    ran: int
    failed: int
    wall_time: float = 0.0
    cache: str | None = None  # the cache folder (None: no cache)
    # per job key, the sha256 of its cache entry's bytes (jobs read or stored; none without a
    # cache): what the report's derived entries (figures, frames) are keyed by
    digests: dict[str, str] = field(default_factory=dict)
    fresh: bool = False  # --fresh: derived entries are made again too


class Plan:
    """Every job of a comparison (each once: two runs with the same inputs are one job).

    ``nominal[(slot, dt)]``, ``members[(slot, k)]`` and ``resync_pairs[(a, b)]`` (a's states
    into b, b's into a) hold the keys of the jobs whose results fill :attr:`Comparison.runs`,
    the ensembles and each pair's resync; ``resync`` is the first pair's. Every pair of engines
    gets its resync (the first ``resync_pairs`` pairs where given: a study recorded when only
    the first pair had one), the first pair's jobs first, as with two engines.
    """

    def __init__(
        self,
        scaled: dict[float, Scenario],
        dts: Sequence[float],
        todo: Sequence[tuple[int, float]],
        names: Sequence[str],
        profiles: Sequence[Any],
        labels: Sequence[str],
        quantity: str,
        runner: EnsembleRunner,
        every: int,
        resync_pairs: int | None = None,
    ):
        self.dts = list(dts)
        self.names, self.profiles, self.labels = list(names), list(profiles), list(labels)
        self.quantity = quantity
        self.runner = runner
        self.every = every
        self.by_key: dict[str, Job] = {}
        self.nominal: dict[tuple[int, float], str] = {}
        self.members: dict[tuple[int, int], str] = {}
        self.resync: list[str] = []
        head = scaled[self.dts[0]]
        hashes = {d: file_hashes(s) for d, s in scaled.items()}  # once per study, not per job
        files = hashes[self.dts[0]]  # the members' and resync's (only their poses differ)
        for slot, d in todo:
            kind = "nominal" if d in self.dts else "half-step"
            job = Job.of(kind, scaled[d], names[slot], profiles[slot], hashes[d])
            self.nominal[(slot, d)] = self._add(job)
        self.resync_pairs: dict[tuple[int, int], list[str]] = {}
        if every:
            every_pair = [(a, b) for a in range(len(names)) for b in range(a + 1, len(names))]
            for a, b in every_pair if resync_pairs is None else every_pair[:resync_pairs]:
                keys = self.resync_pairs[(a, b)] = []
                for i, j in ((a, b), (b, a)):
                    job = Job.of(
                        "resync",
                        head,
                        names[i],
                        profiles[i],
                        files,
                        target=(names[j], profiles[j]),
                        labels=(labels[i], labels[j]),
                        every=every,
                        quantity=quantity,
                    )
                    keys.append(self._add(job))
            self.resync = self.resync_pairs.get((0, 1), [])
        for slot, k in runner.jobs:
            dpos, drot = runner.engine_offsets[slot]
            job = Job.of(
                "member",
                perturbed(head, dpos[k], drot[k]),
                names[slot],
                profiles[slot],
                files,
                seed=runner.seed,
                member=k,
                quantity=quantity,
            )
            self.members[(slot, k)] = self._add(job)

    def failed_members(self, failed: dict[str, JobFailed]) -> dict[str, list[JobFailed]]:
        """Per engine label, its failed ensemble members (engines with none left out)."""
        out: dict[str, list[JobFailed]] = {}
        for (slot, _), key in self.members.items():
            if key in failed:
                out.setdefault(self.labels[slot], []).append(failed[key])
        return out

    def _add(self, job: Job) -> str:
        self.by_key.setdefault(job.key, job)
        return job.key

    @property
    def jobs(self) -> list[Job]:
        return list(self.by_key.values())

    @property
    def keys(self) -> list[str]:
        return list(self.by_key)


_COST = {"resync": 3.0}  # a resync job steps its source and, at each point, two more Sims


def run_jobs(
    jobs: Sequence[Job],
    *,
    cache: Cache | str | os.PathLike[str] | bool | None = None,
    fresh: bool = False,
    offline: bool = False,
    workers: int | None = None,
    scheduler: str | None = None,
    executor: Executor | None = None,
    progress: Callable[[str, int, int], None] | None = None,
) -> tuple[dict[str, JobResult], dict[str, JobFailed], JobCounts]:
    """Each job's result by key: from the cache unless ``fresh``, else run (and then stored);
    the jobs that killed their worker by key; the counts.

    ``progress(what, steps_done, steps_total)``: as jobs finish (cached ones count as done);
    None: the executor's own progress over jobs (a bar on a terminal).

    Raises:
        CacheEntryMissingError: ``offline`` and a job is not in the cache.
    """
    store = resolve(cache)
    results = _from_cache(store, jobs) if store is not None and not fresh else {}
    missing = [j for j in jobs if j.key not in results]
    counts = JobCounts(
        total=len(jobs),
        cached=len(results),
        ran=0,
        failed=0,
        cache=str(store.dir) if store is not None else None,
        fresh=fresh,
    )
    if offline and missing:
        raise CacheEntryMissingError(
            str(store.dir) if store is not None else "(no cache)",
            missing[0].label,
            missing[0].key,
            len(missing),
            len(jobs),
        )
    done = _Done(jobs, results, progress)
    failed: dict[str, JobFailed] = {}
    if missing:
        if executor is None and scheduler is None:
            if workers is None and len(missing) == 1:
                workers = 0  # one job: no process to start
            elif workers != 0 and not _main_importable():
                workers = 0  # a script read from stdin: a spawned process cannot import it
        _run_missing(
            missing,
            results,
            failed,
            counts,
            store,
            done,
            workers=workers,
            scheduler=scheduler,
            executor=executor,
        )
    elif progress is not None:
        progress("every run from the cache", done.steps, done.total)
    if store is not None:
        counts.digests = {j.key: store.digests[j.key] for j in jobs if j.key in store.digests}
    log.info(
        "%d jobs: %d from the cache (%s), %d run, %d failed",
        counts.total,
        counts.cached,
        counts.cache or "none",
        counts.ran,
        counts.failed,
    )
    _replay_logs(jobs, results)
    return results, failed, counts


def _from_cache(store: Cache, jobs: Sequence[Job]) -> dict[str, JobResult]:
    """The results of ``jobs`` that ``store`` holds (of the same kind), by key."""
    results: dict[str, JobResult] = {}
    for job in jobs:
        got = store.get(job.key)
        if isinstance(got, JobResult) and got.kind == job.kind:
            results[job.key] = got
    return results


class _Done:
    """The steps of a study's jobs done so far (the cached ones from the start), told to
    ``progress(what, steps_done, steps_total)`` as each job finishes."""

    def __init__(
        self,
        jobs: Sequence[Job],
        results: dict[str, JobResult],
        progress: Callable[[str, int, int], None] | None,
    ):
        self.job_steps = {j.key: j.steps for j in jobs}
        self.total = sum(self.job_steps.values())
        self.steps = sum(self.job_steps[k] for k in results)
        self.progress = progress

    def finished(self, job: Job) -> None:
        self.steps += self.job_steps[job.key]
        if self.progress is not None:
            self.progress(job.label, self.steps, self.total)


def _run_missing(
    missing: list[Job],
    results: dict[str, JobResult],
    failed: dict[str, JobFailed],
    counts: JobCounts,
    store: Cache | None,
    done: _Done,
    *,
    workers: int | None,
    scheduler: str | None,
    executor: Executor | None,
) -> None:
    """Run the jobs not in the cache, costliest first, into ``results`` (and ``store``) or
    ``failed``; ``counts`` counts them and the wall time."""
    missing.sort(key=lambda j: -_COST.get(j.kind, 1.0) * done.job_steps[j.key])
    start = _time.perf_counter()

    def on_result(index: int, result: Any) -> None:
        job = missing[index]
        results[job.key] = result
        counts.ran += 1
        if store is not None:
            try:
                store.put(job.key, result)
            except OSError as exc:
                log.warning("cannot write the cache entry of %s: %s", job.label, exc)
        done.finished(job)

    from simbridge.registry import available_backends, backend_spec

    specs = tuple(backend_spec(name) for name in available_backends())
    out = run_all(
        functools.partial(run_job_registered, specs),
        missing,
        labels=[j.label for j in missing],
        workers=workers,
        scheduler=scheduler,
        executor=executor,
        progress=None if done.progress is None else _silent,
        on_result=on_result,
    )
    for job, result in zip(missing, out, strict=True):
        if isinstance(result, JobFailed):  # not cached: the next study runs it again
            failed[job.key] = result
            counts.failed += 1
            done.finished(job)
    counts.wall_time = _time.perf_counter() - start


def _replay_logs(jobs: Sequence[Job], results: dict[str, JobResult]) -> None:
    """Log what the runs in other processes logged, each message once, under its job's label
    (a member's logs are its nominal run's)."""
    here = os.getpid()
    for job in jobs:  # what the runs logged, each once, where no handler has seen it yet
        r = results.get(job.key)
        if r is not None and job.kind != "member" and r.pid != here:
            for name, level, message in dict.fromkeys(r.log):
                logging.getLogger(name).log(level, "%s [%s]", message, job.label)


def _silent(done: int, total: int, label: str) -> None:
    pass


def ensembles_of(
    plan: Plan, results: dict[str, JobResult], runs: dict[tuple[int, float], Trajectory]
) -> list[Ensemble]:
    """One :class:`Ensemble` per engine: member 0 from its nominal run, the others from their
    jobs (a failed member left out, with its offsets)."""
    runner, quantity = plan.runner, plan.quantity
    here = os.getpid()
    out = []
    for slot, backend in enumerate(plan.names):
        tr = runs[(slot, plan.dts[0])]
        members = [member_of(tr, quantity, 0)]
        kept = [0]
        for k in range(1, runner.size):
            r = results.get(plan.members[(slot, k)])
            if r is None:
                continue
            member = r.value
            member.log = list(r.log) if r.pid != here else []
            members.append(member)
            kept.append(k)
        _show_worker_log(members[1:], backend)
        rows = kept_rows(tr.steps)
        dm, dr = runner.engine_offsets[slot]
        if len(kept) < runner.size:
            dm, dr = dm[kept], dr[kept]
        out.append(
            Ensemble(
                label=plan.labels[slot],
                backend=backend,
                profile=plan.profiles[slot],
                quantity=quantity,
                time=tr.time[rows],
                rows=rows,
                features=np.stack([m.features for m in members]),
                end_points=np.stack([m.end_point for m in members]),
                offsets_m=dm,
                offsets_rad=dr,
                perturbation=runner.engine_eps[slot],
                state_dtype=runner.state_dtypes[slot],
                wall_time=sum(m.wall_time for m in members[1:]),
                outcomes=[m.outcomes for m in members],
            )
        )
    return out


def resync_of(
    plan: Plan,
    results: dict[str, JobResult],
    failed: dict[str, JobFailed],
    runs: dict[tuple[int, float], Trajectory],
    steps: int,
    tolerance: float | None,
    pair: tuple[int, int] = (0, 1),
) -> Resync | None:
    """The :class:`Resync` of the engines of ``pair`` (slots, the first two by default) from
    its two jobs (None, with a warning, when one failed or the plan has none for it)."""
    a, b = pair
    directions, scales, wall = [], [1.0], 0.0
    keys = plan.resync_pairs.get(pair, [])
    for key in keys:
        r = results.get(key)
        if r is None:
            log.warning(
                "%s failed (%s): the report has no one-step resync for %s and %s",
                plan.by_key[key].label,
                failed[key].cause if key in failed else "no result",
                plan.labels[a],
                plan.labels[b],
            )
            return None
        d, scale = r.value
        directions.append(d)
        scales.append(scale)
        wall += r.wall_time
    if not directions:
        return None
    q = plan.quantity
    return Resync(
        every=plan.every,
        quantity=q,
        labels=(plan.labels[a], plan.labels[b]),
        directions=directions,
        precision_floor=FLOOR_RELATIVE * max(scales),
        significant=(tolerance or QUANTITIES[q].thresholds[0]) / max(1, steps),
        trajectories=[runs[(a, plan.dts[0])], runs[(b, plan.dts[0])]],
        wall_time=wall,
    )


def _jsonable_profile(p: Any) -> Any:
    if isinstance(p, str):
        return p
    from .jobs import profile_dict

    return profile_dict(p)


def study_record(
    sc: Scenario,
    plan: Plan,
    *,
    backends_named: bool,
    duration: float | None,
    tolerance: float | None,
    command_line: list[str],
    left_out: dict[str, str],
) -> dict[str, Any]:
    """What ``study.json`` records: the scenario, compare()'s arguments as resolved, every
    job's key (:mod:`simbridge.compare.report.study`)."""
    runner = plan.runner
    return {
        "format": STUDY_FORMAT,
        "simbridge_version": __version__,
        "scenario": {
            "name": sc.name,
            "file": str(sc.source) if sc.source is not None else None,
            "toml": dumps_scenario(sc),
        },
        "arguments": {
            "backends": list(plan.names),
            "backends_named": backends_named,
            "profile": [_jsonable_profile(p) for p in plan.profiles],
            "timesteps": list(plan.dts),
            "duration": duration,
            "ensemble": runner.size,
            "perturb": list(runner.eps),
            "seed": runner.seed,
            "tolerance": tolerance,
            "resync_every": plan.every,
            "workers": runner.workers,
        },
        "left_out": dict(left_out),
        "command_line": list(command_line),
        "jobs": [{"key": j.key, "kind": j.kind, "label": j.label} for j in plan.jobs],
    }


def scenario_of(record: dict[str, Any]) -> Scenario:
    """The scenario a ``study.json`` records (its file for relative references)."""
    from ..scenario import loads_scenario

    file = record["scenario"].get("file")
    source = Path(file) if file else None
    return loads_scenario(record["scenario"]["toml"], file=file or "study.json", source=source)
