"""Moving code leaves results alone: every shipped scenario's trajectories, on both backends
and on both MuJoCo step loops, hash to what they did before the MuJoCo backend became the
``backends/mujoco/`` package (tests/data/trajectory_hashes.json, written by
tests/_trajectory_hashes.py). A deliberate change of behaviour records them again, in its own
commit, saying why.

The hashes are the same on every x86-64 processor with FMA and AVX2, whatever its OpenBLAS
kernel and numpy's SIMD targets: PyBullet and the compiled step loop are plain C arithmetic,
whose calls to libm (``sin``, ``cos``, ``atan2``...) take glibc's FMA variants on such a
processor (on one without, 16 of the 20 compiled-loop and PyBullet hashes and 2 of PhysX's
differ, measured with ``GLIBC_TUNABLES=glibc.cpu.hwcaps=-AVX2,-FMA``: tests/_machine.py), and
the Python step loop does the compiled loop's arithmetic in the same order without BLAS or
LAPACK (backends/mujoco/solve.py, damping.py), so it gives the compiled loop's bits.
:func:`test_the_same_bits_whatever_the_kernels` proves it in child processes under other
OpenBLAS kernels and with numpy's SIMD dispatch turned off (the Python loop there, the
only path a kernel could move: its docstring says why); before, the Python loop's
``np.linalg.solve`` and ``@`` moved 7 of its 10 hashes on an AVX-512 machine (SkylakeX
kernels) and 7 here under ``OPENBLAS_CORETYPE=Sandybridge``.
"""

from __future__ import annotations

import json
import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).parent))
from _machine import kernel_variants, libm  # noqa: E402
from _trajectory_hashes import (  # noqa: E402
    all_extras,
    all_hashes,
    engine_versions,
    physx_hashes,
    physx_version,
)

RECORD = json.loads((Path(__file__).parent / "data" / "trajectory_hashes.json").read_text())
SCRIPT = Path(__file__).parent / "_trajectory_hashes.py"
MUJOCO = {k: v for k, v in RECORD["compiled"].items() if k.endswith("/mujoco")}

pytestmark = pytest.mark.skipif(
    engine_versions() != RECORD["engines"] or libm() != RECORD["libm"],
    reason=f"hashes were recorded on {RECORD['engines']} with libm's {RECORD['libm']!r} "
    f"variants, this is {engine_versions()} with {libm()!r}: other engine builds, and libm's "
    "other variants, give other bits",
)
pytestmark = [pytestmark, pytest.mark.slow]  # child processes under other kernels: minutes


def _mismatches(expected: dict[str, str], got: dict[str, str]) -> list[str]:
    return [k for k in expected if got.get(k) != expected[k]]


def test_compiled_loop_and_pybullet_bit_identical() -> None:
    got = {**all_hashes(), **all_extras()}
    assert sorted(got) == sorted(RECORD["compiled"]), "the shipped scenarios changed"
    assert _mismatches(RECORD["compiled"], got) == []


def test_python_step_loop_gives_the_compiled_loops_bits() -> None:
    out = subprocess.run(
        [sys.executable, str(SCRIPT), "--mujoco-only"],
        env=dict(os.environ, SIMBRIDGE_MUJOCO_STEP="python"),
        check=True,
        capture_output=True,
        text=True,
    ).stdout
    got = json.loads(out)
    assert sorted(got) == sorted(MUJOCO)
    assert _mismatches(MUJOCO, got) == []


def test_the_same_bits_whatever_the_kernels() -> None:
    """The Python step loop, every MuJoCo scenario and the KUKA script, in one child process
    per kernel choice (run side by side): every hash is the record's. The children set the
    variables before numpy loads, the only time OpenBLAS and numpy read them. The choices are
    tests/_machine.py's :func:`kernel_variants`, as the report figures' proof takes them: each
    child turns numpy's run-time targets down a level with an OpenBLAS kernel of that level
    (on an AVX2 processor one child, every target off with Sandybridge's AVX kernels; on an
    AVX-512 one a second, AVX-512 off with Haswell's), so with the parent's defaults every
    level the processor has is covered. Each child says which OpenBLAS kernel it loaded
    (``OPENBLAS_VERBOSE=2``), so a variable that did not take fails the test rather than
    proving nothing.

    Only the Python loop runs under the variants, as it is the only path whose bits a kernel
    could move; the other two are checked under this machine's own kernels by
    :func:`test_compiled_loop_and_pybullet_bit_identical`:

    - the compiled loop runs the Python loop's code but the step (the same backend, the same
      load, reads and recording, ``loop.py`` vs ``_mjkernel.c`` only), and its states are the
      Python loop's bit for bit (the record holds both to the same hashes), so a kernel that
      moved anything outside its C step would move the Python loop's hash in the same child;
      the C step itself calls no numpy and no BLAS;
    - PyBullet steps in its own C (it does not load numpy's OpenBLAS); its backend
      (``backends/pybullet_*.py``), the recorder (``compare/run/recording.py``) and the
      scenarios' controllers call no BLAS or LAPACK (no ``@``, ``dot``, ``linalg``, ``einsum``)
      and no numpy transcendental (``math`` does the trigonometry); the only numpy linear
      algebra it reaches is the core's at load (``urdf.py``'s principal inertias,
      ``load_options.py``), which runs in ``Sim`` before the backend sees the file, on the
      file alone: the same numbers for both engines, hashed here through the Python loop,
      which loads every scenario's files too.

    Measured on the 2-core development machine (AMD EPYC, AVX2), the Python loop is about 34 s
    of CPU a child. Until 2026-11-29 this test ran three children here, one variable changed in
    each (OpenBLAS's Haswell kernels, which are this processor's default and so proved nothing
    new; Sandybridge's; numpy's targets off): 102 s of CPU. A child that changes both the
    kernel and the dispatch at once moves the hash if either would (two last-bit changes do not
    cancel across thousands of steps), as the figures' proof has argued since it was written.
    """
    variants = kernel_variants()
    if not variants:
        pytest.skip("the kernel variants are x86-64's")
    children = []
    for name, extra in variants:
        env = dict(os.environ, OPENBLAS_VERBOSE="2", **extra)
        env["SIMBRIDGE_MUJOCO_STEP"] = "python"
        if "NPY_DISABLE_CPU_FEATURES" not in extra:
            env.pop("NPY_DISABLE_CPU_FEATURES", None)
        proc = subprocess.Popen(
            [sys.executable, str(SCRIPT), "--mujoco-only"],
            env=env,
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
        )
        children.append((name, extra, proc))
    failures = []
    for name, extra, proc in children:
        out, err = proc.communicate(timeout=900)
        if proc.returncode != 0:
            failures.append(f"{name}: exit {proc.returncode}: {err[-2000:]}")
            continue
        core = re.search(r"^Core: (\S+)", err, re.M)
        if core is None or core.group(1) != extra["OPENBLAS_CORETYPE"]:
            failures.append(f"{name}: OpenBLAS loaded {core and core.group(1)!r}")
        got = json.loads(out)
        if sorted(got) != sorted(MUJOCO):
            failures.append(f"{name}: scenarios {sorted(got)}, recorded {sorted(MUJOCO)}")
        python = _mismatches(MUJOCO, got)
        if python:
            failures.append(f"{name}: Python loop {python}")
    assert failures == [], "\n".join(failures)


PHYSX = RECORD.get("physx", {})


@pytest.mark.skipif(
    physx_version() is None or physx_version() != PHYSX.get("sapien"),
    reason=f"PhysX's hashes were recorded on SAPIEN {PHYSX.get('sapien')}, here "
    f"{physx_version() or 'the physx extra is not installed'}",
)
def test_physx_bit_identical() -> None:
    """Every shipped scenario and the KUKA script on PhysX (CPU PhysX 5 through SAPIEN) give the
    recorded bits. Measured before recording: the same hashes in two fresh processes, under
    OPENBLAS_CORETYPE=Sandybridge and with numpy's run-time SIMD targets turned off (PhysX's
    CPU solver is SAPIEN's compiled code; the backend's own numpy arithmetic on float32 arrays
    does not go through BLAS), so they are not keyed by processor. Measured: 61 s of CPU
    (137 s wall on the loaded shared 2-core machine)."""
    got = physx_hashes()
    assert sorted(got) == sorted(PHYSX["hashes"]), "the shipped scenarios changed"
    assert _mismatches(PHYSX["hashes"], got) == []
