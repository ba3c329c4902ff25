"""Every run of a study as a pure job: :class:`Job`, :func:`run_job` and :class:`JobResult`.

A comparison is a set of runs: each engine's nominal run at every time step and at half of it,
the perturbed members of each engine's ensemble, and the one-step resync from each engine's
states. Each is a :class:`Job`, a frozen, picklable record of everything its result depends
on:

* the scenario as run (scaled to the time step, cut to the duration, a member's spawn pose
  moved), as canonical TOML text (:func:`~simbridge.compare.scenario.dumps_scenario`);
* the content hash (sha256) of every file the scenario names: robot files (URDF, MJCF) and
  the Python files of its controllers and outcome functions (the job carries the hashes; the
  files are read where the scenario names them);
* the engine, the profile (its :meth:`~simbridge.Profile.as_dict`, so per-engine settings
  count), the time step, the ensemble seed and member number, the kind of run, and the
  simbridge version;
* :func:`run_code_digest`: simbridge's code that makes a run (not its report), so that an
  edited backend or another checkout sharing the cache never reuses another code's results;
* :func:`engine_versions`: the versions of numpy and of the job's own engine library (and the
  target engine's, for a resync job), as its backend's registration declares them
  (``register(..., engine_dists=)``), so that an engine upgrade makes other keys, but
  installing or upgrading another engine does not.

:attr:`Job.key` is the sha256 of those, so a result can be cached by it
(:mod:`simbridge.compare.run.cache`): the same key means the same inputs. What the key does not
see: files a robot file names in turn (meshes) and a ``package.module`` controller's own
imports (``--fresh`` runs them again).

:func:`run_job` runs a job in whatever process it is given to and returns a :class:`JobResult`:
a nominal or half-step run's whole :class:`~simbridge.compare.run.trajectory.Trajectory`, an
ensemble member's :class:`~simbridge.compare.run.ensemble.Member`, or a resync direction's
:class:`~simbridge.compare.run.resync.Direction`; with the ``simbridge`` log records the run
produced, for the caller to show.
"""

from __future__ import annotations

import functools
import hashlib
import importlib.util
import json
import logging
import os
import pickle
import time as _time
from dataclasses import dataclass, field
from functools import cached_property
from pathlib import Path
from typing import Any

from simbridge._version import __version__
from simbridge.exceptions import InvalidArgumentError

from ..scenario import Scenario, dumps_scenario, format_timestep, loads_scenario

__all__ = [
    "KINDS",
    "Job",
    "JobResult",
    "run_job",
    "file_hashes",
    "profile_dict",
    "engine_versions",
    "run_code_digest",
]

KINDS = ("nominal", "half-step", "member", "resync")
"""What a job runs: a nominal run at one of the study's time steps, the run at half a time
step (the engine's own time-step error), a perturbed ensemble member, or a resync point set
(one engine's run with its states set into the other engine and into itself, one step each)."""

FORMAT = "simbridge.compare.Job/1"


# the parts of simbridge a run does not depend on: what is written or judged about it
_NOT_RUN_CODE = ("compare/report/", "compare/analysis/", "compare/study/", "simbridge/cli")
NOT_INSTALLED = "-"
"""The version :func:`engine_versions` gives a distribution that is not installed."""


@functools.cache
def dist_version(dist: str) -> str:
    """The installed version of distribution ``dist`` (:data:`NOT_INSTALLED`: none); read from
    its metadata, importing nothing."""
    import importlib.metadata

    try:
        return importlib.metadata.version(dist)
    except importlib.metadata.PackageNotFoundError:
        return NOT_INSTALLED


def engine_versions(*backends: str) -> dict[str, str]:
    """``{distribution: version}`` of what the runs of ``backends`` depend on besides simbridge:
    numpy and each backend's engine distributions (:func:`simbridge.registry.engine_dists`); a
    backend unknown here counts numpy alone (its run fails and says why)."""
    from simbridge.exceptions import UnknownBackendError
    from simbridge.registry import engine_dists

    dists: list[str] = ["numpy"]
    for name in backends:
        try:
            dists += engine_dists(name)
        except UnknownBackendError:
            pass
    return {d: dist_version(d) for d in dict.fromkeys(dists)}


@functools.lru_cache(maxsize=1)
def run_code_digest() -> str:
    """sha256 of the code a run's result depends on: simbridge's own Python files (the core, the
    backends, compare's scenarios and runs; not its report, analysis, study or CLI code). In
    every job's key, so that a result made by other code (an edited backend, another checkout
    sharing the cache) is never taken for this code's; the engines' versions are the job's own
    (:func:`engine_versions`)."""
    import simbridge

    roots = [Path(simbridge.__file__).resolve().parent, Path(__file__).resolve().parents[1]]
    spec = importlib.util.find_spec("simbridge.backends")
    if spec is not None and spec.submodule_search_locations:
        roots += [Path(p).resolve() for p in spec.submodule_search_locations]
    files: dict[str, Path] = {}
    for root in dict.fromkeys(roots):
        for f in root.rglob("*.py"):
            name = f"{root.name}/{f.relative_to(root).as_posix()}"
            if not any(part in f"/{name}" for part in _NOT_RUN_CODE):
                files[name] = f
    h = hashlib.sha256()
    for name in sorted(files):
        h.update(name.encode() + b"\0" + files[name].read_bytes() + b"\0")
    return h.hexdigest()


def profile_dict(profile: Any) -> dict[str, Any]:
    """The profile's entries (a name or a :class:`~simbridge.Profile`), as its key sees them."""
    from simbridge.profiles import get_profile

    return get_profile(profile).as_dict()


def _sha256_file(path: Path) -> str:
    h = hashlib.sha256()
    with path.open("rb") as f:
        for block in iter(lambda: f.read(1 << 20), b""):
            h.update(block)
    return h.hexdigest()


def _code_file(ref: str, folder: Path | None) -> Path | None:
    """The Python file of a ``file.py:Name`` or ``package.module:Name`` reference (None: not
    found, the run will say why)."""
    target = ref.rsplit(":", 1)[0]
    if target.endswith(".py"):
        path = Path(target)
        if not path.is_absolute():
            path = (folder or Path.cwd()) / path
        return path if path.is_file() else None
    try:
        spec = importlib.util.find_spec(target)
    except (ImportError, ValueError):
        return None
    if spec is None or not spec.origin or not os.path.isfile(spec.origin):
        return None
    return Path(spec.origin)


def file_hashes(sc: Scenario) -> tuple[tuple[str, str], ...]:
    """``(reference, sha256)`` of every file ``sc`` names: each robot's file as
    ``Sim.load_urdf`` / ``load_mjcf`` would read it, each controller's and outcome function's
    Python file; a reference that names no file here gets ``""`` (its run fails and says so)."""
    from simbridge.model.urdf_source import resolve_source

    out: dict[str, str] = {}
    for r in sc.robots:
        ref = f"{r.kind}:{r.urdf}"
        source = sc.resolve_urdf(r)
        try:
            path = Path(source)
            if path.is_file():
                out[ref] = _sha256_file(path)
            else:
                text = resolve_source(source).text
                out[ref] = hashlib.sha256(text.encode("utf-8")).hexdigest()
        except Exception:  # noqa: BLE001 - the run names the missing file
            out[ref] = ""
    refs = [p.controller.ref for p in sc.phases if p.controller is not None]
    refs += [o.function for o in sc.outcomes if getattr(o, "function", "")]
    for ref in refs:
        code = _code_file(ref, sc.folder)
        out[f"code:{ref}"] = _sha256_file(code) if code is not None else ""
    return tuple(sorted(out.items()))


@dataclass(frozen=True)
class Job:
    """One run of a study (module docstring); :attr:`key` is its content hash."""

    kind: str
    scenario: str
    """The scenario as run, canonical TOML (:func:`dumps_scenario`)."""
    files: tuple[tuple[str, str], ...]
    """``(reference, sha256)`` of every file the scenario names (:func:`file_hashes`)."""
    backend: str
    profile: Any
    """A profile name or a :class:`~simbridge.Profile` (its entries are hashed)."""
    timestep: float
    seed: int = 0
    member: int = 0
    quantity: str = ""
    """The headline quantity: what a member's features and a resync's errors measure."""
    target: tuple[str, Any] | None = None
    """A resync job: ``(backend, profile)`` of the engine the states are set into."""
    labels: tuple[str, str] = ("", "")
    """A resync job: the names of the source and target engines in its results."""
    every: int = 0
    """A resync job: a resync point every this many steps."""
    cut_at: float | None = None
    """Where :meth:`Scenario.truncated` cut the scenario (its outcomes say so)."""
    version: str = __version__
    poses: tuple[tuple[str, tuple[float, ...], tuple[float, ...]], ...] = ()
    """Every robot's ``(name, position, orientation)`` as run (an ensemble member's offsets; an
    MJCF robot's displacement, which its TOML text does not carry)."""
    spec: Scenario | None = field(default=None, compare=False, repr=False)
    """The scenario object that runs (not in the key: :attr:`scenario`, :attr:`poses` and
    :attr:`files` are what it is)."""

    def __post_init__(self) -> None:
        if self.kind not in KINDS:
            raise InvalidArgumentError(
                "kind", f"expected one of {', '.join(KINDS)}, got {self.kind!r}"
            )

    @classmethod
    def of(
        cls,
        kind: str,
        sc: Scenario,
        backend: str,
        profile: Any,
        files: tuple[tuple[str, str], ...] | None = None,
        **kw: Any,
    ) -> Job:
        """The job running ``sc`` (as it is: scaled, cut, perturbed) on ``backend``;
        ``files``: :func:`file_hashes` of ``sc`` when the caller has them (the jobs of one
        study share them)."""
        return cls(
            kind=kind,
            scenario=dumps_scenario(sc),
            files=file_hashes(sc) if files is None else files,
            backend=backend,
            profile=profile,
            timestep=float(sc.timestep),
            cut_at=sc.cut_at,
            poses=tuple(
                (r.name, tuple(map(float, r.position)), tuple(map(float, r.orientation)))
                for r in sc.robots
            ),
            spec=sc,
            **kw,
        )

    def identity(self) -> dict[str, Any]:
        """Everything the result depends on, as JSON-able data (what :attr:`key` hashes)."""
        return {
            "format": FORMAT,
            "kind": self.kind,
            "scenario": self.scenario,
            "files": [list(f) for f in self.files],
            "backend": self.backend,
            "profile": profile_dict(self.profile),
            "timestep": self.timestep,
            "seed": self.seed,
            "member": self.member,
            "quantity": self.quantity,
            "target": None
            if self.target is None
            else [self.target[0], profile_dict(self.target[1])],
            "labels": list(self.labels),
            "every": self.every,
            "cut_at": self.cut_at,
            "poses": [[n, list(p), list(o)] for n, p, o in self.poses],
            "version": self.version,
        }

    @property
    def engines(self) -> tuple[str, ...]:
        """The backends the job runs: its own and, for a resync job, its target's."""
        return (self.backend,) if self.target is None else (self.backend, self.target[0])

    def identity_with_code(self) -> dict[str, Any]:
        """:meth:`identity`, :func:`run_code_digest` and the :func:`engine_versions` of its
        engines (what :attr:`key` hashes)."""
        return {
            **self.identity(),
            "code": run_code_digest(),
            "engine_versions": engine_versions(*self.engines),
        }

    @cached_property
    def key(self) -> str:
        """sha256 (hex) of :meth:`identity`: equal for jobs whose results are equal."""
        text = json.dumps(self.identity_with_code(), sort_keys=True, default=str, allow_nan=True)
        return hashlib.sha256(text.encode("utf-8")).hexdigest()

    @property
    def label(self) -> str:
        """A short name for progress and failures: ``mujoco ensemble member 3``."""
        dt = format_timestep(self.timestep)
        if self.kind == "member":
            return f"{self.backend} ensemble member {self.member} @ {dt} s"
        if self.kind == "resync":
            other = self.target[0] if self.target else "?"
            return f"one step from {self.backend}'s states into {other} @ {dt} s"
        return f"{self.backend} @ {dt} s"

    @property
    def steps(self) -> int:
        """Steps the job takes (a resync job's source run; its targets step at its points)."""
        return self.load_scenario().steps

    def load_scenario(self) -> Scenario:
        """The scenario as run."""
        if self.spec is None:
            return loads_scenario(self.scenario, file="<job>")
        return self.spec


@dataclass
class JobResult:
    """What a job gives back: ``value`` (a Trajectory, a Member, or a resync ``(Direction,
    scale)``), the ``simbridge`` log records of the run (logger, level, message), its wall
    time (s), the process it ran in and the CPU time (s, user + system) the run took there."""

    kind: str
    value: Any
    log: list[tuple[str, int, str]] = field(default_factory=list)
    wall_time: float = 0.0
    pid: int = 0
    cpu_time: float = 0.0


class _Collect(logging.Handler):
    def __init__(self) -> None:
        super().__init__(logging.DEBUG)
        self.records: list[tuple[str, int, str]] = []

    def emit(self, record: logging.LogRecord) -> None:
        self.records.append((record.name, record.levelno, record.getMessage()))


def run_job(job: Job) -> JobResult:
    """Run ``job`` here and return its result (a pure function of the job: the same job gives
    the same figures). An exception of the run propagates, made picklable if it was not (a
    job may run in another process)."""
    import multiprocessing

    from .ensemble import member_of
    from .recording import run

    start, cpu = _time.perf_counter(), _time.process_time()
    log = logging.getLogger("simbridge")
    level = log.level
    handler = _Collect()
    if multiprocessing.parent_process() is not None:  # a worker: every record goes back
        log.setLevel(logging.DEBUG)
    log.addHandler(handler)
    try:
        sc = job.load_scenario()
        value: Any
        if job.kind == "member":
            tr = run(sc, job.backend, profile=job.profile)
            value = member_of(tr, job.quantity, job.member)
        elif job.kind == "resync":
            value = _resync(job, sc)
        else:
            value = run(sc, job.backend, profile=job.profile)
    except BaseException as exc:
        _portable(exc)
        raise
    finally:
        log.removeHandler(handler)
        log.setLevel(level)
    return JobResult(
        job.kind,
        value,
        handler.records,
        _time.perf_counter() - start,
        os.getpid(),
        _time.process_time() - cpu,
    )


def run_job_registered(specs: tuple[Any, ...], job: Job) -> JobResult:
    """:func:`run_job` in a worker process, after registering each backend of ``specs``
    (:class:`simbridge.registry.BackendSpec`) it does not know: a backend registered at run
    time in the study's process (``simbridge.register`` in a script or a test) is unknown to a
    spawned worker, which sees only the entry points."""
    from simbridge import registry

    known = set(registry.available_backends())
    for spec in specs:
        if spec.name not in known:
            registry.register(
                spec.name,
                spec.entry_point,
                requires=spec.requires,
                pip_name=spec.pip_name,
                settings=spec.settings,
                state_dtype=spec.state_dtype,
                engine_dists=spec.engine_dists,
            )
    return run_job(job)


def _resync(job: Job, sc: Scenario) -> tuple[Any, float]:
    """A resync job: the Direction from ``job.backend``'s states into ``job.target`` (its
    worst points found) and the largest magnitude of the quantity's source on that run (the
    precision floor's scale)."""
    import numpy as np

    from .quantities import FEATURE_SOURCES
    from .resync import _direction, _worst

    assert job.target is not None
    source = (job.backend, job.profile, job.labels[0])
    target = (job.target[0], job.target[1], job.labels[1])
    d, tr = _direction(sc, source, target, job.every, job.quantity, None)
    d.worst = _worst(d, tr)
    src = FEATURE_SOURCES[job.quantity]
    scale = float(np.max(np.abs(getattr(tr.body, src)), initial=0.0))
    return d, scale


def _rebuild(
    cls: type[BaseException], args: tuple[Any, ...], state: dict[str, Any]
) -> BaseException:
    exc = cls.__new__(cls)
    exc.args = args
    exc.__dict__.update(state)
    return exc


def _portable(exc: BaseException) -> None:
    """Make ``exc`` pickle back to its own type and message (an exception whose ``__init__``
    takes other arguments than its message does not, by default)."""
    try:
        back = pickle.loads(pickle.dumps(exc))
        if type(back) is type(exc) and str(back) == str(exc):
            return
    except Exception:  # noqa: BLE001 - made portable below
        pass
    state = {k: v for k, v in exc.__dict__.items() if k != "__reduce_ex__"}
    try:
        pickle.dumps(state)
    except Exception:  # noqa: BLE001
        state = {}
    reduced = (_rebuild, (type(exc), exc.args, state))
    exc.__reduce_ex__ = lambda _protocol: reduced  # type: ignore[method-assign]
