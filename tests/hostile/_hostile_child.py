"""Runs hostile cases in this process, one after the other, and reports each on a pipe.

    python _hostile_child.py BACKEND FD < names.json

Reads a JSON list of case names on stdin and writes one JSON line per event to file
descriptor FD: ``{"ready": ...}`` once warmed up, ``{"start": name}`` before a case and
``{"result": {...}}`` after it. The parent (``_hostile_runner.py``) kills the process when a case
outlives its timeout and starts a new one for the cases left, so a crash or a hang costs one
case, not the batch.

Each case gets a folder of its own for the files it writes; ``TMPDIR`` (set by the parent) is a
folder of this child's alone, which must stay empty after every case. The file descriptors
and threads of the process must be as many after a case as before it.
"""

from __future__ import annotations

import gc
import json
import logging
import os
import shutil
import sys
import tempfile
import threading
import time
import traceback
from pathlib import Path
from typing import Any

sys.path.insert(0, str(Path(__file__).resolve().parent))

import _hostile_cases as h  # noqa: E402

import simbridge  # noqa: E402
from simbridge import exceptions as exc  # noqa: E402


def _fds() -> list[str]:
    out = []
    for fd in os.listdir("/proc/self/fd"):
        try:
            out.append(f"{fd}->{os.readlink(f'/proc/self/fd/{fd}')}")
        except OSError:
            pass  # the listing's own descriptor, closed by now
    return sorted(out)


def _warm_up(backend: str, work: Path) -> None:
    """Open once what an engine keeps for the life of the process (its import, plugins), so
    that a case's file-descriptor count compares like with like."""
    if backend == h.NEUTRAL:
        from simbridge.cli import build_parser
        from simbridge.compare.scenario import loads_scenario

        build_parser()
        loads_scenario(h.SCENARIO)
        return
    ctx = h.Ctx(backend, work)
    sim = ctx.sim()
    sim.load_urdf("plane.urdf")
    body = sim.load_urdf("r2d2.urdf")
    sim.load_urdf(h.mesh_robot(h.ROBOTS / "l_finger.stl"))
    sim.set_joint_velocity(body, [2, 3], 1.0, max_force=5)
    sim.step(2)
    h.nonfinite_reads(sim)
    sim.get_state()
    sim.close()
    with simbridge.Sim(backend) as again:  # a second engine instance in the process
        again.step()


def _exception(e: BaseException) -> dict[str, Any]:
    return {
        "type": type(e).__name__,
        "mro": [c.__name__ for c in type(e).__mro__],
        "simbridge": isinstance(e, exc.SimbridgeError),
        "message": str(e)[:2000],
        "traceback": "".join(traceback.format_exception(e))[-3000:],
    }


def _after_divergence(ctx: h.Ctx) -> dict[str, Any]:
    """After a SimulationDivergedError: the Sim that diverged refuses steps and every state
    read with the same error until reset(), then works again."""
    report: dict[str, Any] = {"refused": [], "answered": [], "recovered": None, "sims": 0}
    for sim in ctx.sims:
        if sim.closed:
            continue
        try:
            bodies = sim.bodies()
            sim.step()
        except exc.SimulationDivergedError:
            pass
        except Exception as e:  # noqa: BLE001 - reported
            report["answered"].append(f"step raised {type(e).__name__}: {e}")
            continue
        else:
            continue  # this Sim did not diverge (checked finite by the caller)
        report["sims"] += 1
        reads = {}
        for body in bodies:
            reads[f"base_state({body})"] = lambda b=body, s=sim: s.base_state(b)
            reads[f"joint_states({body})"] = lambda b=body, s=sim: s.joint_states(b)
            reads[f"link_state({body}, -1)"] = lambda b=body, s=sim: s.link_state(b, -1)
            reads[f"link_states({body})"] = lambda b=body, s=sim: s.link_states(b)
            if sim.num_joints(body):
                reads[f"link_state({body}, 0)"] = lambda b=body, s=sim: s.link_state(b, 0)
        reads["get_state()"] = lambda s=sim: s.get_state()
        for what, read in reads.items():
            try:
                value = read()
            except exc.SimulationDivergedError:
                report["refused"].append(what)
            except Exception as e:  # noqa: BLE001 - reported
                report["answered"].append(f"{what} raised {type(e).__name__}: {e}")
            else:
                report["answered"].append(f"{what} returned {str(value)[:200]}")
        try:
            sim.reset()  # (no step: the case may have set a time step that diverges again)
            body = sim.load_urdf("pendulum.urdf", fixed_base=True)
            report["recovered"] = not h.nonfinite_reads(sim) and sim.bodies() == [body]
        except Exception as e:  # noqa: BLE001 - reported
            report["recovered"] = f"{type(e).__name__}: {e}"
    return report


def run_case(case: h.Case, backend: str, work: Path, tmp: Path) -> dict[str, Any]:
    ctx = h.Ctx(backend, work)
    result: dict[str, Any] = {"name": case.name, "backend": backend}
    fds = _fds()
    threads = threading.active_count()
    t0 = time.perf_counter()
    try:
        value = case.run(ctx)
    except h.SilentNaN as e:
        result.update(outcome="nan", detail=str(e)[:2000])
    except h.CaseFailure as e:
        result.update(outcome="wrong", detail=str(e)[:2000])
    except exc.SimulationDivergedError as e:
        result.update(outcome="diverged", error=_exception(e), after=_after_divergence(ctx))
    except exc.SimbridgeError as e:
        result.update(outcome="error", error=_exception(e))
    except BaseException as e:  # noqa: BLE001 - a raw exception is what the corpus looks for
        result.update(outcome="raw", error=_exception(e))
    else:
        result.update(outcome="returned", value=repr(value)[:200])
    # every state of every Sim still open must be finite (or refused, after a divergence)
    silent: list[str] = []
    for sim in ctx.sims:
        if sim.closed:
            continue
        try:
            silent += h.nonfinite_reads(sim)
        except exc.SimulationDivergedError:
            if result["outcome"] != "diverged":
                silent.append("a read raised SimulationDivergedError after the case returned")
        except Exception as e:  # noqa: BLE001 - reported
            silent.append(f"a state read raised {type(e).__name__}: {e}")
    if silent:
        result["final_reads"] = silent[:8]
    close_errors = []
    for sim in ctx.sims:
        try:
            sim.close()
        except Exception as e:  # noqa: BLE001 - reported
            close_errors.append(f"{type(e).__name__}: {e}")
    if close_errors:
        result["close_errors"] = close_errors
    result["seconds"] = round(time.perf_counter() - t0, 4)
    del ctx
    gc.collect()
    leaks = []
    deadline = time.monotonic() + 5
    while threading.active_count() > threads and time.monotonic() < deadline:
        time.sleep(0.01)
    if threading.active_count() > threads:
        leaks.append(f"threads {threads} -> {threading.active_count()}")
    left = sorted(os.listdir(tmp))
    if left:
        leaks.append(f"temporary files left in TMPDIR: {left[:8]}")
        for name in left:
            path = tmp / name
            shutil.rmtree(path) if path.is_dir() else path.unlink()
    after = _fds()
    if after != fds:
        gone, new = sorted(set(fds) - set(after)), sorted(set(after) - set(fds))
        if new:  # a case may close what an engine opened lazily; only new ones leak
            leaks.append(f"file descriptors opened and not closed: {new[:8]}")
        del gone
    if leaks:
        result["leaks"] = leaks
    gc.freeze()  # what outlived the case's collection (caches, modules it imported): see main
    return result


def main() -> int:
    backend, fd = sys.argv[1], int(sys.argv[2])
    report = os.fdopen(fd, "w", buffering=1)
    names: list[str] = json.load(sys.stdin)
    tmp = Path(os.environ["TMPDIR"])
    tempfile.tempdir = str(tmp)
    base = Path(os.environ["HOSTILE_WORK"])
    logging.basicConfig(level=logging.WARNING, stream=sys.stderr)
    os.chdir(base)  # URDF text resolves relative meshes here; nothing is written
    _warm_up(backend, base / "warm-up")
    # what the imports and the warm-up made lives as long as the process: gc.freeze() keeps
    # it out of every later collection, and each case freezes what outlived its own
    # collection, so that a case's gc.collect() (run_case) walks only what that case made
    # (measured on 188 of MuJoCo's cases: 60 ms a collect, 11.3 of the batch's 14.6 s of
    # CPU, before)
    gc.collect()
    gc.freeze()
    report.write(json.dumps({"ready": os.getpid()}) + "\n")
    for k, name in enumerate(names):
        case = h.lookup(name)
        work = base / f"case-{k}"
        work.mkdir(parents=True, exist_ok=True)
        report.write(json.dumps({"start": name}) + "\n")
        result = run_case(case, backend, work, tmp)
        shutil.rmtree(work, ignore_errors=True)
        report.write(json.dumps({"result": result}) + "\n")
    report.close()
    return 0


if __name__ == "__main__":
    sys.exit(main())
