"""Ensembles: each engine runs the scenario N times from spawn poses moved by a tiny seeded
random offset, in parallel processes: :func:`run_ensembles`, :class:`Ensemble`.

Member 0 of every ensemble is the nominal run (no offset); member k >= 1 moves every robot's
spawn pose by offset k: its position by ``eps_m`` metres in a random direction, its orientation
by ``eps_rad`` radians about a random axis (world frame). Every engine gets the same
directions; the sizes are the requested ones, raised for an engine whose state type cannot
represent them (:func:`engine_perturbation`: a float32 engine), so that member k of every
engine starts in the same direction from the spawn pose, and of engines of the same state type
exactly where member k of the other does.

Each worker process creates its own engines (nothing engine-made crosses a process boundary),
sends nothing to stdout or stderr (its file descriptors 1 and 2 go to ``os.devnull`` before any
engine is imported), and returns only what the judgement needs: the followed robot's
:func:`~simbridge.compare.diff.features` for the headline quantity at every kept instant, its
end point, and the scenario's outcomes measured on the run
(:func:`simbridge.compare.outcomes.evaluate`, in the worker). A phase's controller is named by
its reference in the scenario the worker receives, and made there afresh: no controller object
crosses a process boundary. Only the :class:`simbridge.Sim` interface is used.
"""

from __future__ import annotations

import logging
import math
import os
import time as _time
from collections.abc import Callable, Sequence
from concurrent.futures import Future, ProcessPoolExecutor
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from simbridge.exceptions import InvalidArgumentError, SimbridgeError
from simbridge.registry import state_dtype

from ..scenario import Scenario
from .offsets import (
    FLOAT_SPACINGS,
    directions,
    engine_perturbation,
    offsets,
    perturbed,
    scaled,
)
from .outcomes import OutcomeRecord
from .quantities import FEATURE_SOURCES, QUANTITIES, distance, features
from .recording import run
from .trajectory import BodyTrajectory, Trajectory

__all__ = [
    "DEFAULT_ENSEMBLE",
    "DEFAULT_PERTURB",
    "DEFAULT_SEED",
    "MAX_INSTANTS",
    "SPREAD_PERCENTILE",
    "Ensemble",
    "Member",
    "offsets",
    "directions",
    "engine_perturbation",
    "FLOAT_SPACINGS",
    "perturbed",
    "member_of",
    "run_ensembles",
    "pairwise_spread",
    "horizons",
]

DEFAULT_ENSEMBLE = 16
"""Runs per engine, the nominal one included (``--ensemble``). Measured on this project's 2-core
machine: ``simbridge compare r2d2`` in about 7 s with 16 (see docs/compare.md)."""
DEFAULT_PERTURB = 1e-9
"""Size of each spawn-pose offset: metres for the position, radians for the orientation."""
DEFAULT_SEED = 0
SPREAD_PERCENTILE = 90.0
"""An ensemble's spread at an instant: this percentile of the distances between its members,
every pair once."""
MAX_INSTANTS = 10_001
"""At most this many recorded instants are kept per member (every step up to 10 000 steps;
beyond, every k-th step and the last)."""


@dataclass
class Member:
    """One ensemble run, as the judgement needs it (small: no full trajectory)."""

    index: int
    features: np.ndarray  # (T, ...) the headline quantity's features at the kept instants
    end_point: np.ndarray  # (3,) m, world: base position (free base) or last link's CoM (fixed)
    wall_time: float  # s, the whole run in its worker
    outcomes: dict[str, OutcomeRecord] = field(default_factory=dict)
    """The scenario's outcomes on this run, by name
    (:func:`~simbridge.compare.run.outcomes.evaluate` records)."""
    log: list[tuple[str, int, str]] = field(default_factory=list)
    """A worker process's ``simbridge`` log records (logger name, level, message), for the
    parent to show: empty for a member run in the caller's process (its records went out as
    they came)."""

    # A member comes back from its worker process pickled: the outcome records travel in their
    # JSON form (OutcomeRecord.to_dict, from_dict), as in a saved trajectory.
    def __getstate__(self) -> dict[str, Any]:
        state = dict(self.__dict__)
        state["outcomes"] = {name: r.to_dict() for name, r in self.outcomes.items()}
        return state

    def __setstate__(self, state: dict[str, Any]) -> None:
        state = dict(state)
        state["outcomes"] = {
            name: OutcomeRecord.from_dict(r, file="<ensemble worker>", key=f"outcomes.{name}")
            for name, r in state["outcomes"].items()
        }
        self.__dict__.update(state)


@dataclass
class Ensemble:
    """One engine's runs: ``features[k]`` of member k (k = 0 is the nominal run).

    ``time`` (T,) s are the kept instants, ``rows`` their row numbers in the nominal
    trajectory."""

    label: str
    backend: str
    profile: str
    quantity: str
    time: np.ndarray  # (T,) s
    rows: np.ndarray  # (T,) int
    features: np.ndarray  # (N, T, ...)
    end_points: np.ndarray  # (N, 3) m
    offsets_m: np.ndarray  # (N, R, 3) m: position offset per member and robot
    offsets_rad: np.ndarray  # (N, R, 3) rad: rotation vector per member and robot
    perturbation: tuple[float, float] = (DEFAULT_PERTURB, DEFAULT_PERTURB)
    """The offsets' size (m, rad) this engine got (:func:`engine_perturbation`)."""
    state_dtype: str = "float64"
    """The floating-point type the engine keeps its state in (its backend's declaration)."""
    wall_time: float = 0.0  # s, summed over the members run in workers
    outcomes: list[dict[str, OutcomeRecord]] = field(default_factory=list)
    """Per member (member 0 first), the scenario's outcomes by name."""
    _spread: np.ndarray | None = field(default=None, repr=False)

    @property
    def size(self) -> int:
        return int(self.features.shape[0])

    @property
    def spread(self) -> np.ndarray:
        """(T,) the :data:`SPREAD_PERCENTILE` percentile of the distances between members at
        every kept instant (0 for a single member), in the quantity's unit."""
        if self._spread is None:
            self._spread = pairwise_spread(self.quantity, self.features)
        return self._spread

    def horizons(self) -> list[tuple[float, float | None]]:
        """``(threshold, first time the spread reaches it or None)`` for every threshold of
        the quantity (1 cm, 10 cm, 1 m for a distance): the predictability horizon."""
        return horizons(self.time, self.spread, QUANTITIES[self.quantity].thresholds)


def pairwise_spread(quantity: str, members: np.ndarray, percentile: float = SPREAD_PERCENTILE):
    """(T,) the ``percentile`` of :func:`~simbridge.compare.diff.distance` over every pair of
    ``members`` (N, T, ...) at each instant; zeros for N < 2."""
    n = members.shape[0]
    if n < 2:
        return np.zeros(members.shape[1])
    d = np.stack(
        [distance(quantity, members[i], members[j]) for i in range(n) for j in range(i + 1, n)]
    )
    return np.percentile(d, percentile, axis=0)


def horizons(
    time: np.ndarray, series: np.ndarray, thresholds: Sequence[float]
) -> list[tuple[float, float | None]]:
    """First instant where ``series`` reaches each threshold (None: never)."""
    out: list[tuple[float, float | None]] = []
    for thr in thresholds:
        hit = np.flatnonzero(series >= thr)
        out.append((float(thr), float(time[hit[0]]) if hit.size else None))
    return out


# ---------------------------------------------------------------- members


def kept_rows(steps: int) -> np.ndarray:
    """Row numbers kept of a run of ``steps`` steps: all of them up to :data:`MAX_INSTANTS`,
    else every k-th and the last."""
    rows = steps + 1
    stride = max(1, math.ceil((rows - 1) / (MAX_INSTANTS - 1)))
    kept = np.arange(0, rows, stride)
    if kept[-1] != rows - 1:
        kept = np.append(kept, rows - 1)
    return kept


def end_point(body: BodyTrajectory) -> np.ndarray:
    """(3,) m: where the followed robot ends: its base position, or for a fixed base its last
    link's centre of mass."""
    if body.fixed_base:
        return np.array(body.link_positions[-1, -1, :], dtype=np.float64)
    return np.array(body.base_position[-1], dtype=np.float64)


def member_of(tr: Trajectory, quantity: str, index: int = 0) -> Member:
    """The :class:`Member` record of a full trajectory (the nominal run)."""
    body = tr.body
    rows = kept_rows(tr.steps)
    src = getattr(body, FEATURE_SOURCES[quantity])[rows]
    return Member(index, features(quantity, src), end_point(body), tr.wall_total, tr.outcomes)


def _main_importable() -> bool:
    """Whether a spawned process can import this program's ``__main__`` (it always tries): no
    file (``python -c``, an interactive session) or a file that exists."""
    import sys

    path = getattr(sys.modules.get("__main__"), "__file__", None)
    return path is None or os.path.isfile(path)


def _quiet(parent: int) -> None:
    """Worker initialiser: file descriptors 1 and 2 to os.devnull, so that nothing an engine
    prints from C (or Python) reaches the parent's terminal; and a watch on the parent, so
    that a worker never outlives it."""
    import sys

    null = os.open(os.devnull, os.O_WRONLY)
    for fd in (1, 2):
        os.dup2(null, fd)
    os.close(null)
    sys.stdout = open(os.devnull, "w", encoding="utf-8")  # noqa: SIM115
    sys.stderr = sys.stdout
    _watch_parent(parent)


PARENT_POLL_S = 0.5


def _watch_parent(parent: int) -> None:
    """End this worker once its parent is gone. A parent stopped by SIGTERM or SIGKILL runs no
    clean-up, and its pool's workers would wait on their queue for ever, each holding its
    engines' memory (measured: two 100-125 MB workers left idle after `kill -TERM` of
    `simbridge compare`). The worker is then re-parented, so its parent's pid changes; a
    daemon thread looks every PARENT_POLL_S s and ends the process at once (its run's results
    have nobody to go to). ``parent``: the pid the parent passed (this worker's own start may
    outlast it: the first look is at once)."""
    import threading

    def watch() -> None:
        while True:
            if os.getppid() != parent:
                os._exit(3)
            _time.sleep(PARENT_POLL_S)

    threading.Thread(target=watch, name="simbridge-parent-watch", daemon=True).start()


class _Collect(logging.Handler):
    """A worker's ``simbridge`` log records, kept as (logger, level, message)."""

    def __init__(self, level: int) -> None:
        super().__init__(level)
        self.records: list[tuple[str, int, str]] = []

    def emit(self, record: logging.LogRecord) -> None:
        self.records.append((record.name, record.levelno, record.getMessage()))


def _member_job(
    scenario: Scenario,
    backend: str,
    profile: str,
    quantity: str,
    index: int,
    log_level: int | None = None,
) -> Member | str:
    """One ensemble member: the Member, or the failure as text (exceptions of this package
    need not pickle). ``log_level`` (in a worker process): the ``simbridge`` log records at
    that level or above go back to the parent in ``Member.log``, which shows them there."""
    log = logging.getLogger("simbridge")
    handler = None
    if log_level is not None:
        handler = _Collect(log_level)
        log.addHandler(handler)
        log.setLevel(log_level)
    try:
        tr = run(scenario, backend, profile=profile)
        member = member_of(tr, quantity, index)
        if handler is not None:
            member.log = handler.records
        return member
    except BaseException as exc:  # noqa: BLE001 - reported to the parent as text
        return f"{type(exc).__name__}: {exc}"
    finally:
        if handler is not None:
            log.removeHandler(handler)


def _show_worker_log(members: Sequence[Member], backend: str) -> None:
    """The workers' log records, each distinct one once, on its own logger (the caller's
    handlers decide what shows: ``--verbose`` shows them all), with how many members logged it
    (15 members loading one URDF would say the same thing 15 times)."""
    seen: dict[tuple[str, int, str], int] = {}
    for m in members:
        for key in dict.fromkeys(m.log):
            seen[key] = seen.get(key, 0) + 1
    for (name, level, message), count in seen.items():
        logging.getLogger(name).log(
            level, "%s [%d of %d %s ensemble members]", message, count, len(members), backend
        )


MemberProgress = Callable[[str, int], None]
"""progress(what, steps_done_so_far) as members finish."""


class EnsembleRunner:
    """Runs the perturbed members (k >= 1) of both engines' ensembles in worker processes while
    the caller does other work; :meth:`collect` waits for them.

    ``workers`` processes (default: the CPU count, at most the number of members); 0 runs every
    member here, in this process, when :meth:`collect` is called (engine output is then not
    silenced)."""

    def __init__(
        self,
        scenario: Scenario,
        engines: Sequence[tuple[str, str]],
        quantity: str,
        *,
        size: int,
        perturb: float | tuple[float, float] = DEFAULT_PERTURB,
        seed: int = DEFAULT_SEED,
        workers: int | None = None,
    ):
        size = _check_size(size)
        eps_m, eps_rad = _check_perturb(perturb)
        seed = _check_seed(seed)
        self.scenario = scenario
        self.engines = list(engines)
        self.quantity = quantity
        self.size = size
        self.eps = (eps_m, eps_rad)
        self.seed = seed
        units = directions(size, len(scenario.robots), seed)
        self.dpos, self.drot = scaled(units, eps_m, eps_rad)  # the requested sizes
        self.state_dtypes = [state_dtype(backend) for backend, _ in self.engines]
        self.engine_eps = [
            engine_perturbation(self.eps, dtype, scenario) for dtype in self.state_dtypes
        ]
        """Per engine, the perturbation it gets (m, rad): the requested one, raised for a
        float32 engine (:func:`engine_perturbation`)."""
        self.engine_offsets = [
            (self.dpos, self.drot) if eps == self.eps else scaled(units, *eps)
            for eps in self.engine_eps
        ]
        self.jobs = [(slot, k) for k in range(1, size) for slot in range(len(self.engines))]
        if workers is None:
            workers = os.cpu_count() or 1
        if isinstance(workers, bool) or not isinstance(workers, int) or workers < 0:
            raise InvalidArgumentError("workers", f"expected an integer >= 0, got {workers!r}")
        self.workers = min(workers, len(self.jobs))
        self.futures: dict[tuple[int, int], Future[Member | str]] = {}
        self.pool: ProcessPoolExecutor | None = None
        self.steps_done = 0
        self.start = _time.perf_counter()
        self.wall_time = 0.0

    @property
    def total_steps(self) -> int:
        return len(self.jobs) * self.scenario.steps

    def submit(self) -> None:
        """Start the workers (no-op with ``workers=0`` or no perturbed member). A main module
        that a spawned process cannot import (a script read from stdin) runs the members here
        instead."""
        if self.workers == 0 or not self.jobs:
            return
        if not _main_importable():
            self.workers = 0
            return
        import multiprocessing

        ctx = multiprocessing.get_context("spawn")
        self.pool = ProcessPoolExecutor(
            max_workers=self.workers, mp_context=ctx, initializer=_quiet, initargs=(os.getpid(),)
        )
        level = logging.getLogger("simbridge").getEffectiveLevel()  # what the caller shows
        for slot, k in self.jobs:
            backend, profile = self.engines[slot]
            dpos, drot = self.engine_offsets[slot]
            sc = perturbed(self.scenario, dpos[k], drot[k])
            self.futures[(slot, k)] = self.pool.submit(
                _member_job, sc, backend, profile, self.quantity, k, level
            )

    def cancel(self) -> None:
        if self.pool is not None:
            self.pool.shutdown(wait=True, cancel_futures=True)
            self.pool = None

    def collect(
        self, nominal: Sequence[Trajectory], labels: Sequence[str], progress: MemberProgress
    ) -> list[Ensemble]:
        """Wait for every member; one :class:`Ensemble` per engine, member 0 from ``nominal``.

        Raises:
            SimbridgeError: a member failed (its engine, member number and error), or the
                workers died (a script that runs compare() must guard its top level with
                ``if __name__ == "__main__":`` for worker processes to start).
        """
        from concurrent.futures import as_completed
        from concurrent.futures.process import BrokenProcessPool

        results: dict[tuple[int, int], Member] = {}
        try:
            if self.pool is None:
                for slot, k in self.jobs:
                    backend, profile = self.engines[slot]
                    dpos, drot = self.engine_offsets[slot]
                    sc = perturbed(self.scenario, dpos[k], drot[k])
                    results[(slot, k)] = self._check(
                        _member_job(sc, backend, profile, self.quantity, k), slot, k
                    )
                    self.steps_done += self.scenario.steps
                    progress(f"{backend} ensemble {k}/{self.size - 1}", self.steps_done)
            else:
                where = {f: key for key, f in self.futures.items()}
                for f in as_completed(where):
                    slot, k = where[f]
                    results[(slot, k)] = self._check(f.result(), slot, k)
                    self.steps_done += self.scenario.steps
                    progress(f"{self.engines[slot][0]} ensemble", self.steps_done)
        except BrokenProcessPool:
            raise SimbridgeError(
                "the ensemble's worker processes died before finishing (a script that calls "
                "simbridge.compare.compare() must guard its top level with "
                '`if __name__ == "__main__":` for worker processes to start; or pass '
                "ensemble=1)"
            ) from None
        finally:
            self.cancel()
        wall = _time.perf_counter() - self.start
        out = []
        for slot, ((backend, profile), tr) in enumerate(zip(self.engines, nominal, strict=True)):
            members = [member_of(tr, self.quantity, 0)] + [
                results[(slot, k)] for k in range(1, self.size)
            ]
            _show_worker_log(members[1:], backend)
            rows = kept_rows(tr.steps)
            out.append(
                Ensemble(
                    label=labels[slot],
                    backend=backend,
                    profile=profile,
                    quantity=self.quantity,
                    time=tr.time[rows],
                    rows=rows,
                    features=np.stack([m.features for m in members]),
                    end_points=np.stack([m.end_point for m in members]),
                    offsets_m=self.engine_offsets[slot][0],
                    offsets_rad=self.engine_offsets[slot][1],
                    perturbation=self.engine_eps[slot],
                    state_dtype=self.state_dtypes[slot],
                    wall_time=sum(m.wall_time for m in members[1:]),
                    outcomes=[m.outcomes for m in members],
                )
            )
        self.wall_time = wall
        return out

    def _check(self, result: Member | str, slot: int, k: int) -> Member:
        if isinstance(result, str):
            backend = self.engines[slot][0]
            raise SimbridgeError(f"ensemble member {k} on {backend} failed: {result}")
        return result


def _check_size(size: Any) -> int:
    if isinstance(size, bool) or not isinstance(size, (int, np.integer)) or size < 1:
        raise InvalidArgumentError(
            "ensemble", f"expected an integer >= 1 (runs per engine), got {size!r}"
        )
    return int(size)


def _check_perturb(perturb: Any) -> tuple[float, float]:
    pair = perturb if isinstance(perturb, (tuple, list)) else (perturb, perturb)
    ok = len(pair) == 2 and all(
        not isinstance(x, bool)
        and isinstance(x, (int, float, np.floating, np.integer))
        and math.isfinite(x)
        and x >= 0
        for x in pair
    )
    if not ok:
        raise InvalidArgumentError(
            "perturb",
            f"expected a finite number >= 0 (m and rad), or two (m, rad), got {perturb!r}",
        )
    return float(pair[0]), float(pair[1])


def _check_seed(seed: Any) -> int:
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or seed < 0:
        raise InvalidArgumentError("seed", f"expected an integer >= 0, got {seed!r}")
    return int(seed)


def run_ensembles(
    scenario: Scenario,
    engines: Sequence[tuple[str, str]],
    quantity: str,
    *,
    size: int = DEFAULT_ENSEMBLE,
    perturb: float | tuple[float, float] = DEFAULT_PERTURB,
    seed: int = DEFAULT_SEED,
    labels: Sequence[str] | None = None,
    workers: int | None = None,
) -> list[Ensemble]:
    """Run ``scenario`` ``size`` times on each ``(backend, profile)`` of ``engines`` (the
    nominal run and ``size - 1`` perturbed ones, see the module's docstring) and return one
    :class:`Ensemble` per engine.

    Raises:
        InvalidArgumentError: a bad size, perturbation, seed or worker count.
        SimbridgeError: a run failed.
    """
    runner = EnsembleRunner(
        scenario, engines, quantity, size=size, perturb=perturb, seed=seed, workers=workers
    )
    runner.submit()
    try:
        nominal = [run(scenario, b, profile=p) for b, p in engines]
    except BaseException:
        runner.cancel()
        raise
    names = list(labels) if labels is not None else [b for b, _ in engines]
    return runner.collect(nominal, names, lambda what, done: None)
