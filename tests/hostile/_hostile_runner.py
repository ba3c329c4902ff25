"""Runs the hostile corpus in child processes and classifies what each case did.

Cases are grouped into batches, one child process per batch: one per backend and category for
the cases that cannot take the process down, one per case for those that may crash or hang
(``Case.isolate``). A child reports each case as it starts and ends (``_hostile_child.py``);
the runner kills a child whose case outlives its timeout (a *hang*) or notes the case that was
running when a child died (a *crash*), and starts a new child for the rest of the batch. Two
children run at a time (the machine's two cores).

:func:`verdict` turns a case's report into None (as expected) or the reason it is not.
"""

from __future__ import annotations

import json
import os
import re
import select
import signal
import subprocess
import sys
import time
from collections.abc import Iterable
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import _hostile_cases as h

CHILD = Path(__file__).resolve().parent / "_hostile_child.py"
STARTUP_S = 90.0  # a child's import and warm-up, on a loaded 2-core machine
WORKERS = 2


@dataclass
class Batch:
    backend: str
    names: list[str]
    label: str


def plan(wanted: Iterable[tuple[str, str]]) -> list[Batch]:
    """Batches for the (backend, case name) pairs wanted: isolated cases first, longest
    timeout first (a hang then overlaps the other batches), then one per backend and
    category."""
    isolated: list[Batch] = []
    grouped: dict[tuple[str, str], list[str]] = {}
    for backend, name in wanted:
        case = h.lookup(name)
        if case.isolate:
            isolated.append(Batch(backend, [name], f"{backend}-{name}"))
        else:
            grouped.setdefault((backend, case.category), []).append(name)
    isolated.sort(key=lambda b: -h.lookup(b.names[0]).timeout)
    batches = [Batch(b, names, f"{b}-{cat}") for (b, cat), names in grouped.items()]
    batches.sort(key=lambda b: -len(b.names))
    return isolated + batches


def _tail(path: Path, n: int = 3000) -> str:
    try:
        return path.read_text(errors="replace")[-n:]
    except OSError:
        return ""


def run_batch(batch: Batch, base: Path) -> dict[tuple[str, str], dict[str, Any]]:
    """Run one batch in as many children as crashes and hangs make necessary."""
    results: dict[tuple[str, str], dict[str, Any]] = {}
    remaining = list(batch.names)
    attempt = 0
    while remaining:
        attempt += 1
        folder = base / f"{batch.label}-{attempt}"
        tmp, work = folder / "tmp", folder / "work"
        tmp.mkdir(parents=True)
        work.mkdir()
        env = dict(os.environ, TMPDIR=str(tmp), HOSTILE_WORK=str(work), PYTHONFAULTHANDLER="1")
        read_fd, write_fd = os.pipe()
        err_log = folder / "stderr.log"
        with open(folder / "stdout.log", "wb") as out, open(err_log, "wb") as err:
            proc = subprocess.Popen(
                [sys.executable, str(CHILD), batch.backend, str(write_fd)],
                stdin=subprocess.PIPE,
                stdout=out,
                stderr=err,
                env=env,
                pass_fds=(write_fd,),
                start_new_session=True,
            )
        os.close(write_fd)
        assert proc.stdin is not None
        proc.stdin.write(json.dumps(remaining).encode())
        proc.stdin.close()
        current: str | None = None
        started_any = False
        deadline = time.monotonic() + STARTUP_S
        buffer = b""
        outcome: dict[str, Any] | None = None  # a hang or crash that ends this child
        with os.fdopen(read_fd, "rb", buffering=0) as pipe:
            while True:
                wait = deadline - time.monotonic()
                ready = select.select([pipe], [], [], max(wait, 0))[0] if wait > 0 else []
                if not ready:
                    outcome = {"outcome": "hang", "detail": f"no answer within {_limit(current)} s"}
                    os.killpg(proc.pid, signal.SIGKILL)
                    proc.wait()
                    break
                chunk = pipe.read(65536)
                if not chunk:  # the child ended
                    code = proc.wait()
                    if current is not None or (remaining and code != 0):
                        why = f"killed by signal {-code}" if code < 0 else f"exit status {code}"
                        outcome = {"outcome": "crash", "detail": why, "stderr": _tail(err_log)}
                    break
                buffer += chunk
                *lines, buffer = buffer.split(b"\n")
                for line in lines:
                    event = json.loads(line)
                    if "start" in event:
                        current = event["start"]
                        started_any = True
                        deadline = time.monotonic() + h.lookup(current).timeout
                    elif "result" in event:
                        result = event["result"]
                        results[(batch.backend, result["name"])] = result
                        remaining.remove(result["name"])
                        current = None
                        deadline = time.monotonic() + 30.0  # the next case's start
                    elif "ready" in event:
                        deadline = time.monotonic() + 30.0
        if outcome is not None:
            victims = [current] if current is not None else ([] if started_any else remaining)
            if not victims:  # died between cases: the next one is blamed, once
                victims = remaining[:1]
            left = sorted(p.name for p in tmp.iterdir())
            if left:  # the dead child's: blamed on the case it died in
                outcome["leaks"] = [f"temporary files left in TMPDIR: {left[:8]}"]
            for name in list(victims):
                results[(batch.backend, name)] = {
                    "name": name, "backend": batch.backend, **outcome}  # fmt: skip
                remaining.remove(name)
        else:
            left = sorted(p.name for p in tmp.iterdir())
            if left:  # left by the child as it ended, after every case had been checked
                results[(batch.backend, f"@child-{batch.label}-{attempt}")] = {"leaks": left}
    return results


def _limit(name: str | None) -> float:
    return h.lookup(name).timeout if name else STARTUP_S


def run(wanted: Iterable[tuple[str, str]], base: Path) -> dict[tuple[str, str], dict[str, Any]]:
    """Every wanted (backend, case name) pair, its report; ``base``: a folder for the
    children's files. Keys starting with '@' report what a child left when it ended."""
    batches = plan(wanted)
    results: dict[tuple[str, str], dict[str, Any]] = {}
    with ThreadPoolExecutor(max_workers=WORKERS) as pool:
        for part in pool.map(lambda b: run_batch(b, base), batches):
            results.update(part)
    return results


def _matches(error: dict[str, Any], expect: h.Expect) -> bool:
    return any(
        cls.__name__ in error["mro"] and re.search(pattern, error["message"])
        for cls, pattern in expect.errors
    )


def verdict(case: h.Case, backend: str, result: dict[str, Any] | None) -> str | None:
    """None when ``result`` is what ``case`` expects on ``backend``, else why not."""
    if result is None:
        return "no report (the runner lost this case)"
    expect = case.expected(backend)
    problems = []
    outcome = result.get("outcome")
    error = result.get("error")
    if outcome in ("hang", "crash"):
        problems.append(f"a {outcome}: {result.get('detail')} {result.get('stderr', '')[-1500:]}")
    elif outcome == "raw":
        problems.append(f"a raw exception: {error['traceback']}")
    elif outcome == "nan":
        problems.append(f"a silent NaN: {result['detail']}")
    elif outcome == "wrong":
        problems.append(f"wrong: {result['detail']}")
    elif outcome == "returned":
        if expect.accept is None:
            problems.append(f"returned {result.get('value')} where it must raise")
    elif outcome == "error":
        if not _matches(error, expect):
            problems.append(f"raised {error['type']}: {error['message'][:600]}")
    elif outcome == "diverged":
        after = result["after"]
        if not expect.diverge and not _matches(error, expect):
            problems.append(f"diverged: {error['message']}")
        elif not after["sims"]:
            problems.append("SimulationDivergedError, but no Sim refuses a step afterwards")
        elif after["answered"] or after["recovered"] is not True:
            problems.append(
                "after SimulationDivergedError, reads that did not refuse: "
                f"{after['answered'][:4]}; reset() and a new load: {after['recovered']}"
            )
    else:
        problems.append(f"unknown outcome {outcome!r}")
    if result.get("final_reads"):
        problems.append(f"state reads after the case: {result['final_reads'][:4]}")
    if result.get("close_errors"):
        problems.append(f"close() failed: {result['close_errors']}")
    if result.get("leaks"):
        problems.append(f"leaks: {result['leaks']}")
    if not problems:
        return None
    return f"{case.name} on {backend}: expected {expect.describe()}; got " + "; ".join(problems)
