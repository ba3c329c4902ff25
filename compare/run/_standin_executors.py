"""A minimal run_all with the signature of compare/run/executors.py (temporary: replaced by it
once merged). workers=0 runs here; otherwise a local spawn process pool, or ``executor``."""

from __future__ import annotations

import os
from collections.abc import Callable, Sequence
from concurrent.futures import Executor, ProcessPoolExecutor, as_completed
from concurrent.futures.process import BrokenProcessPool
from dataclasses import dataclass
from typing import Any


@dataclass(frozen=True)
class JobFailed:
    label: str
    cause: str
    attempts: int = 1


def run_all(
    fn: Callable[[Any], Any],
    items: Sequence[Any],
    *,
    labels: Sequence[str] | None = None,
    workers: int | None = None,
    scheduler: str | None = None,
    executor: Executor | None = None,
    progress: Callable[[int, int, str], None] | None = None,
    on_result: Callable[[int, Any], None] | None = None,
) -> list[Any]:
    items = list(items)
    names = list(labels) if labels is not None else [str(i) for i in range(len(items))]
    out: list[Any] = [None] * len(items)
    done = 0

    def finish(i: int, value: Any) -> None:
        nonlocal done
        out[i] = value
        done += 1
        if on_result is not None:
            on_result(i, value)
        if progress is not None:
            progress(done, len(items), names[i])

    if scheduler is not None:
        raise NotImplementedError("scheduler= needs compare/run/executors.py")
    if executor is None and (workers == 0 or not items):
        for i, item in enumerate(items):
            finish(i, fn(item))
        return out
    own = executor is None
    if executor is None:
        import multiprocessing

        from .ensemble import _quiet

        n = min(workers or os.cpu_count() or 1, len(items))
        executor = ProcessPoolExecutor(
            max_workers=n,
            mp_context=multiprocessing.get_context("spawn"),
            initializer=_quiet,
            initargs=(os.getpid(),),
        )
    try:
        futures = {executor.submit(fn, item): i for i, item in enumerate(items)}
        for f in as_completed(futures):
            i = futures[f]
            try:
                value = f.result()
            except BrokenProcessPool as exc:
                value = JobFailed(names[i], f"worker died: {exc}")
            finish(i, value)
    except BaseException:
        for f in futures:
            f.cancel()
        raise
    finally:
        if own:
            executor.shutdown(wait=True, cancel_futures=True)
    return out
