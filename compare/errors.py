"""Every error simbridge.compare raises, beside the core's (:mod:`simbridge.exceptions`).

Each is a subclass of :class:`simbridge.SimbridgeError` and of the matching built-in, builds its
message from the context it was given, and pickles (a study's jobs run in other processes and
their errors must reach the caller as themselves). The core never imports this module; the
names stay importable from :mod:`simbridge.exceptions` for one release, with a
``DeprecationWarning``.
"""

from __future__ import annotations

from collections.abc import Sequence

from simbridge.exceptions import InvalidArgumentError, SimbridgeError

__all__ = [
    "ScenarioError",
    "TrajectoryFileError",
    "CacheEntryMissingError",
    "JobError",
    "EngineNotInStudyError",
    "ExtraNotInstalledError",
]


class ScenarioError(SimbridgeError, ValueError):
    """A comparison scenario file is missing, malformed, or says something invalid.

    ``file`` names the file (or ``<scenario>``), ``key`` the dotted key path
    (``phases[1].commands[0].mode``), ``line`` the 1-based line in the file where it was found
    (``None`` when it cannot be located)."""

    def __init__(self, file: str, key: str | None, detail: str, line: int | None = None):
        self.file = file
        self.key = key
        self.line = line
        where = file if line is None else f"{file}:{line}"
        what = f"key {key!r}: " if key else ""
        super().__init__(f"{where}: {what}{detail}")


class TrajectoryFileError(SimbridgeError, ValueError):
    """A saved comparison trajectory (``Trajectory.load``) holds something malformed.

    ``file`` names the file, ``key`` the dotted key path inside its header
    (``outcomes.goal.closest``)."""

    def __init__(self, file: str, key: str, detail: str):
        self.file = file
        self.key = key
        super().__init__(f"{file}: key {key!r}: {detail}")


class CacheEntryMissingError(SimbridgeError, LookupError):
    """A study rebuilt from the cache alone (``simbridge report DIR``) needs a job's result that
    the cache does not hold: ``cache`` the folder, ``job`` and ``key`` the first such job,
    ``missing`` of ``total`` jobs absent."""

    def __init__(self, cache: str, job: str, key: str, missing: int, total: int):
        self.cache = cache
        self.job = job
        self.key = key
        self.missing = missing
        self.total = total
        super().__init__(
            f"{missing} of {total} jobs of the study are not in the cache {cache}: the first is "
            f"{job} (key {key[:16]}); name the cache the study used (--cache DIR), or run the "
            "study again (simbridge compare): a changed robot, controller or scenario file, or "
            "another simbridge version, makes new jobs"
        )


class JobError(SimbridgeError, RuntimeError):
    """A job run in another process raised an error that cannot be sent back as it is (its
    class does not pickle): its class, message and the worker's traceback, as text."""

    def __init__(self, job: str, error: BaseException, traceback: str):
        self.job = job
        self.error_type = f"{type(error).__module__}.{type(error).__qualname__}"
        self.traceback = traceback
        super().__init__(
            f"job {job!r} raised {self.error_type}: {error} (the error could not be sent back "
            f"from the worker process as it is; the worker's traceback:\n{traceback})"
        )


class EngineNotInStudyError(InvalidArgumentError):
    """An engine setting (``--set``, ``engine_settings=``, a ``--vary BACKEND.KEY``) for an
    engine the study does not run: it would change nothing. A scenario's own ``[engines.*]``
    tables are not this: a scenario is written for every engine."""

    def __init__(self, argument: str, setting: str, backend: str, engines: Sequence[str]):
        self.setting = setting
        self.backend = backend
        self.engines = list(engines)
        InvalidArgumentError.__init__(
            self,
            argument,
            f"{setting} is a setting of {backend!r}, which this study does not run (its "
            f"engines: {', '.join(map(repr, dict.fromkeys(engines)))}): it would change "
            f"nothing; add {backend} to the backends or leave the setting out",
        )


class ExtraNotInstalledError(SimbridgeError, ImportError):
    """A feature needs a package of one of simbridge's extras that is not installed."""

    def __init__(self, feature: str, module: str, pip_name: str, cause: BaseException):
        self.feature = feature
        self.module = module
        super().__init__(
            f"{feature} needs the Python package {module!r}, which is not importable "
            f"({cause}); install it with: pip install '{pip_name}'"
        )
