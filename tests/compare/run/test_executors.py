"""run_all (compare/run/executors.py) on real processes and a real Dask cluster: the same
results here, on the local pool and on a Dask LocalCluster; a job that segfaults or aborts its
worker is a JobFailed naming the signal while the others complete; a worker killed mid-study
has its job rerun; Ctrl-C stops a study cleanly after delivering what finished.

The job functions are this module's top-level functions: spawned workers import this module
(spawn passes the parent's sys.path), Dask pickles them by reference."""

from __future__ import annotations

import ctypes
import os
import signal
import subprocess
import sys
import textwrap
import threading
import time
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import pytest

from simbridge.compare.errors import ExtraNotInstalledError, JobError
from simbridge.compare.run.executors import JobFailed, describe_exit, run_all, shutdown_pool
from simbridge.exceptions import InvalidArgumentError, UrdfNotFoundError

# ---------------------------------------------------------------- job functions


def _square(x: int) -> tuple[int, int]:
    return x * x, os.getpid()


def _faulty(x: str) -> str:
    if x == "segv":
        ctypes.string_at(0)  # reads address 0: SIGSEGV
    if x == "abort":
        os.abort()
    if x == "oom":  # what the kernel's out-of-memory killer sends
        os.kill(os.getpid(), signal.SIGKILL)
    if x == "raise":
        raise ValueError("a bug in the job")
    if x == "missing":  # a simbridge error whose __init__ takes more than its message
        raise UrdfNotFoundError("robots/typo.urdf", ["/a", "/b"])
    if x == "unpicklable":
        raise _Unpicklable("a", "b")
    return x.upper()


class _Unpicklable(Exception):
    """An error whose class cannot be rebuilt from its pickle (``__init__`` takes two)."""

    def __init__(self, a: str, b: str) -> None:
        super().__init__(f"{a} and {b}")


def _killer(args: tuple[str, int, str]) -> str:
    """Job ``("kill", _, dir)`` waits for job ``("victim", _, dir)`` to say its pid, then kills
    that worker with SIGKILL (once: a marker file); a victim says its pid and, the first time,
    waits to be killed (it slept 1 s: a killer not scheduled within that second on loaded
    cores found it done). The waits end after 120 s, a stop for a broken run, not a timing."""
    role, _, where = args
    d = Path(where)
    if role == "victim":
        with open(d / "victim-runs", "a") as f:
            first = f.tell() == 0
            f.write(f"{os.getpid()}\n")
        deadline = time.monotonic() + 120
        while first and time.monotonic() < deadline:
            time.sleep(0.05)  # SIGKILL ends this
        return "victim done"
    if role == "kill" and not (d / "killed").exists():
        deadline = time.monotonic() + 120
        while time.monotonic() < deadline:
            runs = (d / "victim-runs").read_text().split() if (d / "victim-runs").exists() else []
            if runs:
                (d / "killed").write_text(runs[0])
                os.kill(int(runs[0]), signal.SIGKILL)
                return "killed"
            time.sleep(0.02)
    return role


def _end_point(args: tuple[str, str, float]) -> tuple[float, ...]:
    """A real simbridge run: the scenario on the backend for ``duration`` s; where the robot
    ends (its base, or a fixed base's last link)."""
    from simbridge.compare.run.ensemble import end_point
    from simbridge.compare.run.recording import run

    scenario, backend, duration = args
    return tuple(float(v) for v in end_point(run(scenario, backend, duration=duration).body))


# ---------------------------------------------------------------- here and the local pool


def test_pool_gives_the_serial_results_in_order_with_callbacks() -> None:
    items = list(range(7))
    here = run_all(_square, items, workers=0)
    assert [r[0] for r in here] == [x * x for x in items]
    assert {r[1] for r in here} == {os.getpid()}
    seen: list[int] = []
    ticks: list[tuple[int, int, str]] = []
    pooled = run_all(
        _square,
        items,
        workers=2,
        labels=[f"sq{x}" for x in items],
        on_result=lambda i, r: seen.append(i),
        progress=lambda done, total, label: ticks.append((done, total, label)),
    )
    assert [r[0] for r in pooled] == [x * x for x in items]
    assert os.getpid() not in {r[1] for r in pooled}  # in workers
    assert sorted(seen) == items
    assert [t[0] for t in ticks] == list(range(1, 8)) and {t[1] for t in ticks} == {7}
    assert sorted(t[2] for t in ticks) == sorted(f"sq{x}" for x in items)


def test_an_exception_in_a_job_propagates() -> None:
    with pytest.raises(ValueError, match="a bug in the job"):
        run_all(_faulty, ["a", "raise", "b"], workers=1)
    with pytest.raises(ValueError, match="a bug in the job"):
        run_all(_faulty, ["a", "raise", "b"], workers=0)


def test_an_error_from_a_worker_reaches_the_caller_as_it_is_or_as_a_job_error() -> None:
    """Every simbridge error pickles, so a worker's reaches the caller with its class and
    attributes (a UrdfNotFoundError did not unpickle: the pool took the job for a dead worker
    and the study failed with 'SIGTERM'); an error of a class that does not pickle comes back
    as a JobError naming its class and carrying the worker's traceback."""
    with pytest.raises(UrdfNotFoundError, match="typo.urdf") as info:
        run_all(_faulty, ["a", "missing"], workers=1, labels=["ok", "bad robot"])
    assert info.value.source == "robots/typo.urdf"
    with pytest.raises(JobError, match=r"job 'odd' raised .*_Unpicklable: a and b") as raised:
        run_all(_faulty, ["unpicklable"], workers=1, labels=["odd"])
    assert "Traceback" in raised.value.traceback and "_faulty" in raised.value.traceback


def test_a_job_that_kills_its_worker_is_job_failed_and_the_others_complete() -> None:
    items = ["a", "segv", "b", "c"]
    # one worker (each restart spawns fresh ones: the fewer, the faster on a busy machine)
    out = run_all(_faulty, items, workers=1, labels=[f"job-{x}" for x in items])
    assert out[0] == "A" and out[2] == "B" and out[3] == "C"
    assert out[1] == JobFailed("job-segv", "SIGSEGV", 2)  # its worker died twice
    assert "SIGSEGV" in str(out[1]) and "2 times" in str(out[1])
    out = run_all(_faulty, ["abort", "a", "oom"], workers=1, max_attempts=1)
    assert out[:2] == [JobFailed("job 0", "SIGABRT", 1), "A"]
    assert out[2] == JobFailed("job 2", "SIGKILL (killed: out of memory?)", 1)


def test_a_worker_killed_mid_study_has_its_job_rerun(tmp_path: Path) -> None:
    items = [("kill", 0, str(tmp_path)), ("victim", 1, str(tmp_path)), ("other", 2, "")]
    out = run_all(_killer, items, workers=2)
    assert out[1] == "victim done"  # rerun after its worker was killed
    assert out[2] == "other"
    runs = (tmp_path / "victim-runs").read_text().split()
    assert len(runs) == 2 and runs[0] != runs[1]  # a second worker ran it
    assert (tmp_path / "killed").read_text() == runs[0]


def test_the_pool_is_kept_warm_for_the_next_call_and_survives_an_idle_worker_killed() -> None:
    shutdown_pool()
    first = {r[1] for r in run_all(_square, [1, 2, 3, 4], workers=2)}
    second = {r[1] for r in run_all(_square, [5, 6, 7, 8], workers=2)}
    assert second <= first  # the same, already started, processes
    for pid in first:  # an idle worker dies between calls: the next call starts a new pool
        os.kill(pid, signal.SIGKILL)
    time.sleep(0.2)
    third = run_all(_square, [2, 3], workers=2)
    assert [r[0] for r in third] == [4, 9] and not {r[1] for r in third} & first
    shutdown_pool()
    for pid in {r[1] for r in third}:
        assert not _alive(pid), f"worker {pid} outlived shutdown_pool"


def test_describe_exit() -> None:
    assert describe_exit(-signal.SIGSEGV) == "SIGSEGV"
    assert describe_exit(-signal.SIGKILL).startswith("SIGKILL (killed: out of memory")
    assert describe_exit(3) == "exit code 3"


def test_bad_arguments_name_the_argument() -> None:
    with pytest.raises(InvalidArgumentError, match="workers"):
        run_all(_square, [1], workers=-1)
    with pytest.raises(InvalidArgumentError, match="labels"):
        run_all(_square, [1, 2], labels=["one"])
    with pytest.raises(InvalidArgumentError, match="scheduler"):
        run_all(_square, [1], scheduler="tcp://127.0.0.1:1", executor=ThreadPoolExecutor(1))
    with pytest.raises(InvalidArgumentError, match="max_attempts"):
        run_all(_square, [1], max_attempts=0)
    assert run_all(_square, [], workers=2) == []


def test_any_executor() -> None:
    with ThreadPoolExecutor(2) as pool:
        out = run_all(_square, [3, 4], executor=pool)
        assert [r[0] for r in out] == [9, 16]
        assert pool.submit(_square, 2).result()[0] == 4  # not shut down by run_all


def test_a_scheduler_without_dask_says_which_extra(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setitem(sys.modules, "distributed", None)  # import distributed: ImportError
    with pytest.raises(ExtraNotInstalledError, match=r"pip install 'simbridge\[cluster\]'"):
        run_all(_square, [1], scheduler="tcp://127.0.0.1:8786")


_INTERRUPTED = """
import multiprocessing, os, sys, time

def slow(item):
    # jobs 0 and 1 return at once; the others wait for the test's release, which comes after
    # its Ctrl-C: none can finish first, on any machine (120 s only bounds a hang)
    x, release = item
    deadline = time.monotonic() + 120
    while x >= 2 and not os.path.exists(release) and time.monotonic() < deadline:
        time.sleep(0.02)
    return x, os.getpid()

if __name__ == "__main__":
    from simbridge.compare.run.executors import run_all
    got = []
    def on_result(i, r):
        got.append(r)
        print("result", i, r[1], flush=True)
    where = {"scheduler": sys.argv[2]} if len(sys.argv) > 2 else {"workers": 2}
    try:
        run_all(slow, [(x, sys.argv[1]) for x in range(12)], on_result=on_result, **where)
        print("finished", flush=True)
    except KeyboardInterrupt:
        # a worker being ended may take a moment to go (seen in 2 of 4 runs at load 5): none
        # may be left within 5 s
        deadline = time.monotonic() + 5
        while multiprocessing.active_children() and time.monotonic() < deadline:
            time.sleep(0.05)
        print("interrupted", len(got), len(multiprocessing.active_children()), flush=True)
        sys.exit(130)
"""


def test_ctrl_c_stops_cleanly_after_delivering_finished_jobs(tmp_path: Path) -> None:
    results = _interrupt(tmp_path)
    for pid in {int(ln.split()[2]) for ln in results}:
        deadline = time.monotonic() + 5
        while _alive(pid) and time.monotonic() < deadline:
            time.sleep(0.05)
        assert not _alive(pid), f"worker {pid} outlived the study"


def _interrupt(tmp_path: Path, *args: str) -> list[str]:
    """Run _INTERRUPTED with ``args``, Ctrl-C it after its first result: its result lines. Its
    jobs past the first two wait until the Ctrl-C has been handled (the file ``release``)."""
    script = tmp_path / "study.py"
    script.write_text(textwrap.dedent(_INTERRUPTED))
    release = tmp_path / "release"
    proc = subprocess.Popen(
        [sys.executable, str(script), str(release), *args],
        stdout=subprocess.PIPE,
        text=True,
        start_new_session=True,  # its own process group, as a terminal's foreground job
    )
    assert proc.stdout is not None
    try:
        lines = [proc.stdout.readline()]
        assert lines[0].startswith("result"), lines
        os.killpg(proc.pid, signal.SIGINT)  # Ctrl-C reaches the whole group, workers included
        t0 = time.monotonic()
        rest, _ = proc.communicate(timeout=30)
        assert time.monotonic() - t0 < 10  # measured: under a second
    finally:
        release.touch()  # a job still running on a Dask cluster ends now
        if proc.poll() is None:
            proc.kill()
    lines += rest.splitlines()
    assert proc.returncode == 130, lines
    results = [ln for ln in lines if ln.startswith("result")]
    last = lines[-1].split()
    assert last[0] == "interrupted"
    # every result printed was delivered; the Ctrl-C may land inside on_result itself, between
    # its append and its print (seen once in a full-suite run): one more delivered than printed
    assert len(results) <= int(last[1]) <= len(results) + 1 and 1 <= len(results) < 12
    assert last[2] == "0"  # no worker process left
    return results


def _alive(pid: int) -> bool:
    try:
        with open(f"/proc/{pid}/stat") as f:
            return f.read().split(") ")[1][0] != "Z"
    except (FileNotFoundError, ProcessLookupError):
        return False


# ---------------------------------------------------------------- a real Dask cluster


@pytest.fixture(scope="module")
def cluster():
    distributed = pytest.importorskip("distributed")
    import logging

    import dask

    # a task is given up after killing 2 workers (default 4): a worker killed once has its
    # task rerun, and the test's segfault costs 2 worker restarts, not 4
    with dask.config.set({"distributed.scheduler.allowed-failures": 1}):
        lc = distributed.LocalCluster(
            n_workers=2,
            threads_per_worker=1,
            processes=True,
            host="127.0.0.1",
            dashboard_address=":0",  # any free port, none taken from another cluster
            silence_logs=logging.CRITICAL,
        )
    try:
        yield lc
    finally:
        lc.close()


def test_dask_gives_the_local_pools_results_for_real_runs(cluster) -> None:
    items = [("r2d2", b, 0.25) for b in ("pybullet", "mujoco")] + [("pendulum", "mujoco", 0.25)]
    labels = [f"{s} on {b}" for s, b, _ in items]
    pooled = run_all(_end_point, items, workers=1, labels=labels)
    on_dask = run_all(_end_point, items, scheduler=cluster.scheduler_address, labels=labels)
    assert on_dask == pooled  # the same numbers to the last bit
    assert len(set(pooled)) == len(items)  # three different runs


def test_dask_reruns_a_killed_workers_job_and_gives_up_a_segfaulting_one(
    cluster, tmp_path: Path
) -> None:
    items = [("kill", 0, str(tmp_path)), ("victim", 1, str(tmp_path)), ("other", 2, "")]
    out = run_all(_killer, items, scheduler=cluster.scheduler_address)
    assert out == ["killed", "victim done", "other"]
    assert len((tmp_path / "victim-runs").read_text().split()) == 2
    from distributed import Client

    with Client(cluster.scheduler_address) as client:
        client.wait_for_workers(2, timeout=60)  # the nanny restarted the killed one
        out = run_all(_faulty, ["a", "segv", "b"], executor=client.get_executor(pure=False))
    assert out[0] == "A" and out[2] == "B"
    assert isinstance(out[1], JobFailed)
    assert out[1].cause.startswith("KilledWorker") and out[1].attempts == 2


def test_the_default_progress_is_a_bar_on_a_terminal_and_silent_elsewhere(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    import io

    class Terminal(io.StringIO):
        def isatty(self) -> bool:
            return True

    for stream, shown in ((io.StringIO(), False), (Terminal(), True)):
        monkeypatch.setattr(sys, "stderr", stream)
        assert [r[0] for r in run_all(_square, [1, 2, 3], workers=0, labels="abc")] == [1, 4, 9]
        text = stream.getvalue()
        assert ("/3 [" in text and "job/s" in text) is shown and (text == "") is not shown


def test_ctrl_c_on_dask_cancels_the_clusters_pending_tasks(cluster, tmp_path: Path) -> None:
    from distributed import Client

    _interrupt(tmp_path, cluster.scheduler_address)
    with Client(cluster.scheduler_address) as client:
        deadline = time.monotonic() + 10  # a task running when cancelled ends first

        def left() -> int:
            return client.run_on_scheduler(lambda dask_scheduler: len(dask_scheduler.tasks))

        while left() and time.monotonic() < deadline:
            time.sleep(0.1)
        assert left() == 0


@pytest.mark.skipif(
    threading.current_thread() is not threading.main_thread(),
    reason="signals reach the main thread",
)
def test_ctrl_c_while_waiting_on_many_jobs_leaves_no_future_locked(monkeypatch) -> None:
    """A Ctrl-C (or SIGTERM) that lands inside ``concurrent.futures.wait`` while it takes the
    futures' locks one by one left some taken: the pool's result thread then blocked on them and
    the pool's shutdown never returned (a killed `simbridge compare` of 400 runs hung). The
    signal is now held and raised between waits. With waits that return at once (the loop
    spends its time taking the 400 locks), raised from the handler it left locks taken in about
    8 of 30 tries; held, in none."""
    import random
    import threading as th
    from concurrent.futures import Future

    from simbridge.compare.run import held_signals

    monkeypatch.setattr(held_signals, "WAIT_POLL_S", 0)
    rng = random.Random(0)

    def taken(fs: set[Future[None]], out: list[bool]) -> None:
        free = [f._condition.acquire(blocking=False) for f in fs]
        for f, ok in zip(fs, free, strict=True):
            if ok:
                f._condition.release()
        out.append(not all(free))

    locked = 0
    previous = signal.signal(signal.SIGINT, signal.default_int_handler)
    try:
        for _ in range(30):
            futures: set[Future[None]] = {Future() for _ in range(400)}
            deadline = time.monotonic() + 30  # a Ctrl-C lost fails the test, not hangs it
            # the timer starts inside pytest.raises: on a loaded machine this thread can be
            # held up past the timer's 10-50 ms before it reaches the block, and a Ctrl-C
            # landing before pytest.raises would stop the whole test run
            with pytest.raises(KeyboardInterrupt):
                th.Timer(rng.uniform(0.01, 0.05), os.kill, (os.getpid(), signal.SIGINT)).start()
                with held_signals.HeldSignals() as held:
                    while time.monotonic() < deadline:
                        held_signals.wait_first(futures, held)
            out: list[bool] = []
            # from another thread: the main thread would re-enter its own RLocks
            probe = th.Thread(target=taken, args=(futures, out))
            probe.start()
            probe.join()
            locked += out[0]
        assert signal.getsignal(signal.SIGINT) is signal.default_int_handler
    finally:
        signal.signal(signal.SIGINT, previous)
    assert locked == 0, f"{locked} of 30 Ctrl-Cs left futures locked"


@pytest.mark.skipif(
    threading.current_thread() is not threading.main_thread(),
    reason="signals reach the main thread",
)
def test_a_held_ctrl_c_is_never_lost() -> None:
    """A Ctrl-C after the last wait is raised when the block ends; a holding handler left
    installed past its block (a signal landing inside the block's start) raises as Python's
    own would."""
    from simbridge.compare.run import held_signals

    previous = signal.signal(signal.SIGINT, signal.default_int_handler)
    try:
        with pytest.raises(KeyboardInterrupt), held_signals.HeldSignals():
            os.kill(os.getpid(), signal.SIGINT)
            time.sleep(0.05)  # the handler runs here: held, not raised
        assert signal.getsignal(signal.SIGINT) is signal.default_int_handler

        held = held_signals.HeldSignals()
        held.__enter__()
        leaked = signal.getsignal(signal.SIGINT)
        held.active = False  # as if __exit__ never ran
        with pytest.raises(KeyboardInterrupt):
            leaked(signal.SIGINT, None)
    finally:
        signal.signal(signal.SIGINT, previous)
