"""Running jobs: :func:`run_all` runs one picklable top-level function over a list of items, in
this process, on a local process pool, on a Dask cluster or on any
:class:`concurrent.futures.Executor`, and gives the results back in the items' order.

It knows nothing of what a job computes. What it adds to an executor:

- **A job that kills its worker** (a segfault, an abort, an out-of-memory kill) breaks a
  :class:`~concurrent.futures.ProcessPoolExecutor` for every job it holds. The local pool
  then starts afresh and resubmits every job not finished; each worker reports which job it
  is running, so the job that was running in the dead worker is known and its worker's exit
  status is its cause (``SIGSEGV``, ``SIGABRT``, ``SIGKILL``: an out-of-memory kill, or
  ``exit code N``). A job whose worker died ``max_attempts`` times (2 by default) comes back as
  :class:`JobFailed`; the others run to the end. On a Dask cluster the scheduler reschedules a
  lost worker's tasks itself, and a task that killed ``allowed-failures + 1`` workers (the
  scheduler's setting, 3 by default) ends as Dask's ``KilledWorker``: a :class:`JobFailed`.
- **Ctrl-C** (``KeyboardInterrupt`` in the caller) cancels the jobs not started, stops the
  pool's workers (none is left behind), calls ``on_result`` for every job that finished, and
  raises ``KeyboardInterrupt`` again. The local pool's workers ignore SIGINT (the terminal
  sends it to the whole process group): the caller decides. SIGTERM (``kill``, ``timeout``)
  does the same while the local pool runs (:mod:`simbridge.terminate`): the pool is stopped,
  its semaphores released, before ``Terminated`` (a ``KeyboardInterrupt``) is raised.
- **Warm workers**: the local pool is kept after a call that ran to the end, its workers
  started and their imports done (simbridge, the engines: about half a second of each
  worker's start), and the next call with the same ``workers`` reuses it: a sweep or an
  ``explain`` makes one call per point. :func:`shutdown_pool` ends it (the interpreter's exit
  does too).
- **Progress** over jobs: a tqdm bar with the ETA on stderr when stderr is a terminal, silent
  otherwise; or a callable ``progress(done, total, label)``.

A Python exception raised by the function is raised here (the jobs not finished are
cancelled): a bug in a job is not a fault of the machine.
"""

from __future__ import annotations

import contextlib
import os
import signal
import sys
import threading
import time
from collections.abc import Callable, Sequence
from concurrent.futures import Executor, Future
from dataclasses import dataclass
from typing import Any

from simbridge.exceptions import InvalidArgumentError, SimbridgeError
from simbridge.terminate import sigterm_raises

from ..errors import ExtraNotInstalledError, JobError
from .held_signals import HeldSignals, wait_first

__all__ = [
    "JobFailed",
    "run_all",
    "shutdown_pool",
    "describe_exit",
    "DEFAULT_ATTEMPTS",
    "Progress",
    "OnResult",
]

DEFAULT_ATTEMPTS = 2
"""A job is given up (:class:`JobFailed`) once its worker died this many times while running
it on the local pool."""

BLAMELESS_BREAKS = 3
"""The local pool broke this many times in a row with no job running in the dead worker: its
workers cannot start (see the error raised)."""

Progress = Callable[[int, int, str], None]
"""progress(jobs_done, jobs_total, label_of_the_last_finished_job)."""
OnResult = Callable[[int, Any], None]
"""on_result(index, result), in the caller's process, as each job returns."""


@dataclass(frozen=True)
class JobFailed:
    """A job given up: its worker died while running it, ``attempts`` times.

    ``cause``: the worker's exit status in words (``"SIGSEGV"``, ``"SIGABRT"``, ``"SIGKILL
    (killed: out of memory?)"``, ``"exit code 3"``) or, on a Dask cluster, the scheduler's
    ``KilledWorker`` message."""

    label: str
    cause: str
    attempts: int

    def __str__(self) -> str:
        times = "once" if self.attempts == 1 else f"{self.attempts} times"
        return f"job {self.label!r} failed: its worker died {times} ({self.cause})"


def run_all(
    fn: Callable[[Any], Any],
    items: Sequence[Any],
    *,
    labels: Sequence[str] | None = None,
    workers: int | None = None,
    scheduler: str | None = None,
    executor: Executor | None = None,
    progress: Progress | None = None,
    on_result: OnResult | None = None,
    max_attempts: int = DEFAULT_ATTEMPTS,
) -> list[Any]:
    """``[fn(item) for item in items]``, run in parallel; a job that killed its worker is a
    :class:`JobFailed` in its place.

    Args:
        fn: a picklable top-level function of one argument.
        items: its arguments, picklable.
        labels: one short name per item (progress, :class:`JobFailed`); default ``"job i"``.
        workers: 0 runs every job here, serially; N > 0 a local pool of N processes (spawned,
            kept for the next call: :func:`shutdown_pool`); default the CPU count. Never more
            processes than jobs.
        scheduler: ``"tcp://HOST:PORT"``: a Dask scheduler (the extra ``simbridge[cluster]``).
        executor: any :class:`concurrent.futures.Executor` (``client.get_executor()`` of a
            Dask client, a thread pool...), used as given and not shut down here.
        progress: ``progress(done, total, label)`` as jobs finish; default a tqdm bar on
            stderr when stderr is a terminal, nothing otherwise.
        on_result: ``on_result(index, result)`` in this process as each job returns (not for
            a :class:`JobFailed`).
        max_attempts: on the local pool, a job is given up once its worker died this many
            times while running it.

    Raises:
        InvalidArgumentError: a bad ``workers``, ``labels``, ``scheduler`` or
            ``max_attempts``, or both ``scheduler`` and ``executor``.
        ExtraNotInstalledError: ``scheduler`` without ``dask.distributed``.
        SimbridgeError: the local pool's workers cannot start (a script must guard its top
            level with ``if __name__ == "__main__":``), or the scheduler cannot be reached.
        KeyboardInterrupt: Ctrl-C, after ``on_result`` of every finished job.
        Exception: whatever ``fn`` raised.
    """
    items = list(items)
    n = len(items)
    names = _check_labels(labels, n)
    if isinstance(max_attempts, bool) or not isinstance(max_attempts, int) or max_attempts < 1:
        raise InvalidArgumentError(
            "max_attempts", f"expected an integer >= 1, got {max_attempts!r}"
        )
    if workers is not None and (
        isinstance(workers, bool) or not isinstance(workers, int) or workers < 0
    ):
        raise InvalidArgumentError("workers", f"expected an integer >= 0 or None, got {workers!r}")
    if scheduler is not None and executor is not None:
        raise InvalidArgumentError("scheduler", "give a scheduler address or an executor, not both")
    if workers is not None and (scheduler is not None or executor is not None):
        raise InvalidArgumentError(
            "workers",
            "sets the local pool's size; a Dask cluster or an executor has its own workers "
            "(give workers=None with scheduler= or executor=)",
        )
    if scheduler is not None and (
        not isinstance(scheduler, str) or "://" not in scheduler and ":" not in scheduler
    ):
        raise InvalidArgumentError(
            "scheduler", f"expected a Dask scheduler address 'tcp://HOST:PORT', got {scheduler!r}"
        )
    tracker = _Tracker(names, progress, on_result)
    try:
        if n == 0:
            return []
        if executor is not None:
            _run_executor(fn, items, executor, tracker)
        elif scheduler is not None:
            _run_dask(fn, items, scheduler, tracker)
        else:
            count = (os.cpu_count() or 1) if workers is None else workers
            if count == 0 or not _main_importable():
                _run_here(fn, items, tracker)
            else:
                with sigterm_raises():  # SIGTERM stops the pool as Ctrl-C does
                    _run_pool(fn, items, count, max_attempts, tracker)
    finally:
        tracker.close()
    return [tracker.results[i] for i in range(n)]


# ---------------------------------------------------------------- bookkeeping


def _check_labels(labels: Sequence[str] | None, n: int) -> list[str]:
    if labels is None:
        return [f"job {i}" for i in range(n)]
    names = [str(x) for x in labels]
    if len(names) != n:
        raise InvalidArgumentError("labels", f"expected one label per item ({n}), got {len(names)}")
    return names


class _Tracker:
    """Results by index, ``on_result`` and the progress as jobs finish."""

    def __init__(self, labels: list[str], progress: Progress | None, on_result: OnResult | None):
        self.labels = labels
        self.results: dict[int, Any] = {}
        self.on_result = on_result
        self.bar: Any = None
        if progress is None:
            from tqdm import tqdm

            # disable=None: silent when stderr is not a terminal; the ETA counts from here
            self.bar = tqdm(
                total=len(labels), unit="job", file=sys.stderr, disable=None, leave=False
            )
            progress = self._bar
        self.progress = progress

    def _bar(self, done: int, total: int, label: str) -> None:
        self.bar.set_postfix_str(label, refresh=False)
        self.bar.update(done - self.bar.n)

    def finish(self, index: int, result: Any) -> None:
        if index in self.results:
            return
        self.results[index] = result
        if self.on_result is not None and not isinstance(result, JobFailed):
            self.on_result(index, result)
        self.progress(len(self.results), len(self.labels), self.labels[index])

    def close(self) -> None:
        if self.bar is not None:
            self.bar.close()
            self.bar = None


def _run_here(fn: Callable[[Any], Any], items: list[Any], tracker: _Tracker) -> None:
    for i, item in enumerate(items):
        tracker.finish(i, fn(item))


# ---------------------------------------------------------------- any executor


def _killed_worker(exc: BaseException) -> bool:
    return type(exc).__name__ == "KilledWorker"


def _run_executor(
    fn: Callable[[Any], Any], items: list[Any], executor: Executor, tracker: _Tracker
) -> None:
    with HeldSignals() as held:
        _run_executor_held(fn, items, executor, tracker, held)


def _run_executor_held(
    fn: Callable[[Any], Any],
    items: list[Any],
    executor: Executor,
    tracker: _Tracker,
    held: HeldSignals,
) -> None:
    futures: dict[Future[Any], int] = {executor.submit(fn, item): i for i, item in enumerate(items)}
    pending = set(futures)
    try:
        while pending:
            done, pending = wait_first(pending, held)
            for f in done:
                i = futures[f]
                if f.cancelled():
                    continue
                exc = f.exception()
                if exc is None:
                    tracker.finish(i, f.result())
                elif _killed_worker(exc):
                    tracker.finish(i, _killed(tracker.labels[i], exc))
                else:
                    raise exc
    except BaseException:
        for f in pending:
            f.cancel()
        _deliver_done(futures, tracker)
        raise


def _killed(label: str, exc: BaseException) -> JobFailed:
    """Dask's KilledWorker: the task killed ``allowed_failures + 1`` workers."""
    return JobFailed(label, f"KilledWorker: {exc}", getattr(exc, "allowed_failures", 0) + 1)


def _deliver_done(futures: dict[Future[Any], int], tracker: _Tracker) -> None:
    """``on_result`` of the jobs that finished and were not yet delivered."""
    for f, i in futures.items():
        if f.done() and not f.cancelled() and f.exception() is None:
            tracker.finish(i, f.result())


def _run_dask(fn: Callable[[Any], Any], items: list[Any], address: str, tracker: _Tracker) -> None:
    try:
        from distributed import Client
    except ImportError as exc:
        raise ExtraNotInstalledError(
            "a Dask scheduler (scheduler=)", "distributed", "simbridge[cluster]", exc
        ) from exc
    try:
        client = Client(address, timeout="10s")
    except OSError as exc:
        raise SimbridgeError(f"cannot reach the Dask scheduler at {address!r}: {exc}") from exc
    try:
        _run_client(client, fn, items, tracker)
    finally:
        client.close()


def _run_client(client: Any, fn: Callable[[Any], Any], items: list[Any], tracker: _Tracker) -> None:
    """The jobs as the client's own futures (not through ``client.get_executor()``, whose
    futures log a traceback each when cancelled)."""
    from distributed import as_completed

    futures = [client.submit(fn, item, pure=False) for item in items]
    where = {f.key: i for i, f in enumerate(futures)}
    try:
        for f in as_completed(futures):
            i = where[f.key]
            if f.status == "finished":
                tracker.finish(i, f.result())
                continue
            exc = f.exception()
            if _killed_worker(exc):
                tracker.finish(i, _killed(tracker.labels[i], exc))
            else:
                raise exc
    except BaseException:
        client.cancel([f for f in futures if not f.done()])
        for i, f in enumerate(futures):
            if f.status == "finished":
                tracker.finish(i, f.result())
        raise


# ---------------------------------------------------------------- the local pool


def _main_importable() -> bool:
    """Whether a spawned process can import this program's ``__main__`` (it always tries): no
    file (``python -c``, an interactive session) or a file that exists. Else (a script read
    from stdin) the jobs run in this process."""
    path = getattr(sys.modules.get("__main__"), "__file__", None)
    return path is None or os.path.isfile(path)


_STARTED: Any = None
"""In a pool worker: the queue on which it says which job it starts (index, pid)."""


PARENT_POLL_S = 0.5


def _worker_init(parent: int, started: Any) -> None:
    """A pool worker's start: SIGINT ignored (the caller handles Ctrl-C); file descriptors 1
    and 2 to os.devnull, so that nothing an engine prints from C reaches the caller's terminal;
    and a watch on the parent: a parent killed without clean-up (SIGKILL) leaves no worker
    behind, each holding its engines' memory (the worker is re-parented, its parent's pid
    changes, and a daemon thread that looks every PARENT_POLL_S s ends it)."""
    import threading

    global _STARTED
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    null = os.open(os.devnull, os.O_WRONLY)
    for fd in (1, 2):
        os.dup2(null, fd)
    os.close(null)
    sys.stdout = sys.stderr = open(os.devnull, "w", encoding="utf-8")  # noqa: SIM115
    _STARTED = started

    def watch() -> None:
        while os.getppid() == parent:
            time.sleep(PARENT_POLL_S)
        os._exit(3)

    threading.Thread(target=watch, name="simbridge-parent-watch", daemon=True).start()


def _call(fn: Callable[[Any], Any], item: Any, index: int, label: str) -> Any:
    _STARTED.put((index, os.getpid()))  # SimpleQueue: written before fn runs, no feeder thread
    try:
        return fn(item)
    except Exception as exc:
        raise _sendable(exc, label) from None


def _sendable(exc: Exception, label: str) -> Exception:
    """``exc`` if it comes back through pickle as itself, else a :class:`JobError` carrying its
    class, message and traceback as text (an error that does not unpickle in the parent breaks
    the pool's result thread: the job would look like a dead worker)."""
    import pickle
    import traceback

    try:
        back = pickle.loads(pickle.dumps(exc))
        if type(back) is type(exc) and str(back) == str(exc):
            return exc
    except Exception:  # noqa: S110 - any failure to round-trip means: send text instead
        pass
    return JobError(label, exc, "".join(traceback.format_exception(exc)))


def describe_exit(code: int | None) -> str:
    """A worker's exit status in words: ``"SIGSEGV"``, ``"SIGKILL (killed: out of memory?)"``,
    ``"exit code 3"``."""
    if code is None:
        return "unknown exit status"
    if code < 0:
        try:
            name = signal.Signals(-code).name
        except ValueError:
            name = f"signal {-code}"
        if -code == signal.SIGKILL:
            name += " (killed: out of memory?)"
        return name
    return f"exit code {code}"


def _stop(pool: Any) -> None:
    """Shut ``pool`` down now: cancel what has not started, end the running workers, reap
    every worker."""
    processes = dict(getattr(pool, "_processes", None) or {})
    pool.shutdown(wait=False, cancel_futures=True)
    for p in processes.values():
        if p.is_alive():
            p.terminate()
    for p in processes.values():
        p.join(5)
        if p.is_alive():
            p.kill()
            p.join()
    with contextlib.suppress(Exception):
        pool.shutdown(wait=True)


class _WarmPool:
    """The local pool kept between :func:`run_all` calls of this process: its workers have
    started and imported what the jobs import (simbridge, the engines), so the next call's jobs
    start at once (a study's sweep or ``explain`` makes one call per point). One per process
    (a forked child does not use its parent's) and per worker count; a call that finds it in
    use by another thread gets a pool of its own. A pool that broke or was stopped (Ctrl-C, a
    job's exception) is not kept. Its idle workers hold their engines' memory until
    :func:`shutdown_pool` or the interpreter's exit."""

    lock = threading.Lock()
    pool: Any = None
    started: Any = None
    workers = 0
    pid = 0


def shutdown_pool() -> None:
    """End the local pool's idle workers kept by :func:`run_all` (they are ended at exit)."""
    with _WarmPool.lock:
        _drop_warm()


def _drop_warm() -> None:
    pool, started = _WarmPool.pool, _WarmPool.started
    _WarmPool.pool = _WarmPool.started = None
    if pool is not None and _WarmPool.pid == os.getpid():
        pool.shutdown(wait=True)
        started.close()


def _new_pool(ctx: Any, workers: int) -> tuple[Any, Any]:
    from concurrent.futures import ProcessPoolExecutor

    started_q = ctx.SimpleQueue()
    pool = ProcessPoolExecutor(
        max_workers=workers,
        mp_context=ctx,
        initializer=_worker_init,
        initargs=(os.getpid(), started_q),
    )
    return pool, started_q


def _take_pool(ctx: Any, workers: int) -> tuple[Any, Any, bool]:
    """``(pool, its started-queue, warm)``: the kept pool of ``workers`` processes when it is
    free and whole (``warm``: give it back with :func:`_keep`), else a new one of the caller's
    own (shut down by the caller) when the kept one is in use."""
    if not _WarmPool.lock.acquire(blocking=False):
        return (*_new_pool(ctx, workers), False)
    if _WarmPool.pid != os.getpid():  # a forked child: its parent's pool is not its own
        _WarmPool.pool = _WarmPool.started = None
    pool = _WarmPool.pool
    if pool is not None and (_WarmPool.workers != workers or getattr(pool, "_broken", False)):
        _drop_warm()
        pool = None
    if pool is None:
        _WarmPool.pool, _WarmPool.started = _new_pool(ctx, workers)
        _WarmPool.workers, _WarmPool.pid = workers, os.getpid()
    started = _WarmPool.started
    while not started.empty():  # what a previous call's jobs said
        started.get()
    return _WarmPool.pool, started, True


def _release(pool: Any, started: Any, warm: bool, keep: bool) -> None:
    """After a call: the kept pool stays for the next call when ``keep`` (its jobs ran to the
    end); any other pool is shut down (the kept one dropped)."""
    try:
        if warm and keep:
            return
        if warm and _WarmPool.pool is pool:
            _WarmPool.pool = _WarmPool.started = None
        with contextlib.suppress(Exception):
            pool.shutdown(wait=True)
        started.close()
    finally:
        if warm:
            _WarmPool.lock.release()


def _run_pool(
    fn: Callable[[Any], Any],
    items: list[Any],
    workers: int,
    max_attempts: int,
    tracker: _Tracker,
) -> None:
    with HeldSignals() as held:
        _run_pool_held(fn, items, workers, max_attempts, tracker, held)


def _run_pool_held(
    fn: Callable[[Any], Any],
    items: list[Any],
    workers: int,
    max_attempts: int,
    tracker: _Tracker,
    held: HeldSignals,
) -> None:
    import multiprocessing
    from concurrent.futures.process import BrokenProcessPool

    ctx = multiprocessing.get_context("spawn")
    attempts = [0] * len(items)
    todo = list(range(len(items)))
    blameless = 0
    while todo:
        pool, started_q, warm = _take_pool(ctx, workers)
        futures: dict[Future[Any], int] = {}
        broken = False
        try:
            for i in todo:
                futures[pool.submit(_call, fn, items[i], i, tracker.labels[i])] = i
            pending = set(futures)
            while pending and not broken:
                done, pending = wait_first(pending, held)
                for f in done:
                    exc = f.exception()
                    if exc is None:
                        tracker.finish(futures[f], f.result())
                        held.check()
                    elif isinstance(exc, BrokenProcessPool):
                        broken = True
                    else:
                        raise exc
        except BrokenProcessPool:  # a kept pool whose idle worker died: submit refused
            broken = True
        except BaseException:
            _stop(pool)
            _deliver_done(futures, tracker)
            _release(pool, started_q, warm, keep=False)
            raise
        if not broken:
            _release(pool, started_q, warm, keep=True)
            break
        # A worker died: every job the pool held failed with BrokenProcessPool; the pool
        # ended its other workers (SIGTERM). Which job ran in the dead one?
        processes = dict(getattr(pool, "_processes", None) or {})
        pool.shutdown(wait=True)
        _deliver_done(futures, tracker)
        started: dict[int, int] = {}
        while not started_q.empty():
            index, pid = started_q.get()
            started[index] = pid
        _release(pool, started_q, warm, keep=False)
        codes = {pid: p.exitcode for pid, p in processes.items()}
        unfinished = [i for i in todo if i not in tracker.results]
        running = {i: codes.get(started[i]) for i in unfinished if i in started}
        dead = {i: c for i, c in running.items() if c not in (None, 0, -signal.SIGTERM)}
        if not dead:  # killed by SIGTERM from outside: indistinguishable from the pool's own
            dead = {i: c for i, c in running.items() if c not in (None, 0)}
        if dead:
            blameless = 0
        else:
            blameless += 1
            if blameless >= BLAMELESS_BREAKS:
                exits = sorted({describe_exit(c) for c in codes.values()})
                raise SimbridgeError(
                    f"the local pool's worker processes died before running any job "
                    f"{BLAMELESS_BREAKS} times (exits: {', '.join(exits)}); a script that "
                    f'runs jobs must guard its top level with `if __name__ == "__main__":` '
                    f"for worker processes to start; or pass workers=0"
                )
        for i, code in dead.items():
            attempts[i] += 1
            if attempts[i] >= max_attempts:
                tracker.finish(i, JobFailed(tracker.labels[i], describe_exit(code), attempts[i]))
        todo = [i for i in unfinished if i not in tracker.results]
