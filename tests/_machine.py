"""What decides the last bits of a result on this processor, for the tests that hold results
bit for bit (tests/test_same_results.py, tests/compare/pipeline/test_compare_same_results.py,
tests/test_readme.py) and the child processes that prove them under other kernels.

Three things on an x86-64 machine choose code by the processor, each from its feature flags
(never from its name):

- **OpenBLAS** picks a kernel (``OPENBLAS_CORETYPE`` overrides it: Haswell for AVX2,
  SkylakeX for AVX-512, Sandybridge for AVX); simbridge's figures call no BLAS
  (compare/run/portable.py), the Python step loop neither (backends/mujoco/solve.py);
- **numpy** dispatches some loops at run time to the best target the processor has
  (``numpy._core._multiarray_umath.__cpu_dispatch__``; ``NPY_DISABLE_CPU_FEATURES`` turns
  targets off): its AVX-512 ``arccos``, ``exp``, ``log`` and ``power`` differ in the last place
  from its other loops; the figures use none of them;
- **glibc's libm** (``math.acos``, ``sin``, ``atan2``, ``exp``...; numpy's float64 ``sin``,
  ``cos`` and ``arctan2``; the engines' own C) takes its FMA variants where the processor has
  FMA and AVX2 (glibc's ``ifunc-fma.h`` and ``ifunc-avx-fma4.h``), other code elsewhere.
  Measured (glibc 2.36; ``GLIBC_TUNABLES=glibc.cpu.hwcaps=-AVX2,-FMA`` takes the other
  variants on a machine that has both): ``acos``, ``atan2``, ``sin``, ``exp`` and ``log``
  of 200,000 arguments each differ in their last bits, and so do the same-results cases'
  figures (their report.md digits did not, in the three cases run). :func:`libm` is the key.

So the records hold on every x86-64 processor with FMA and AVX2 (x86-64-v3: Intel since
Haswell, 2013; AMD since Excavator, 2015) whatever its OpenBLAS kernel and numpy targets, and
are keyed on that, on the machine's architecture and on the libraries' versions.
"""

from __future__ import annotations

import platform
from functools import cache
from pathlib import Path

__all__ = ["cpu_flags", "numpy_targets", "libm", "kernel_variants"]


@cache
def cpu_flags() -> frozenset[str]:
    """The processor's feature flags (/proc/cpuinfo; empty where it cannot be read)."""
    try:
        for line in Path("/proc/cpuinfo").read_text(encoding="utf-8").splitlines():
            if line.startswith("flags"):
                return frozenset(line.split(":", 1)[1].split())
    except OSError:
        pass
    return frozenset()


def numpy_targets() -> list[str]:
    """numpy's run-time dispatch targets that this processor has, lowest first (e.g.
    ``X86_V3``, ``X86_V4``, ``AVX512_ICL``, ``AVX512_SPR``)."""
    from numpy._core._multiarray_umath import __cpu_dispatch__, __cpu_features__

    return [f for f in __cpu_dispatch__ if __cpu_features__.get(f)]


def libm() -> str:
    """Which variants glibc's libm takes here: ``"fma"`` on an x86-64 processor with FMA and
    AVX2, ``"no-fma"`` on one without, else the machine's architecture (another libm)."""
    if platform.machine() not in ("x86_64", "AMD64"):
        return platform.machine()
    return "fma" if {"fma", "avx2"} <= cpu_flags() else "no-fma"


def kernel_variants() -> list[tuple[str, dict[str, str]]]:
    """Child-process environments whose OpenBLAS kernel and numpy dispatch differ from this
    machine's defaults, each turning numpy's targets down a level with an OpenBLAS kernel of
    that level: where the processor has AVX-512 targets, those off and OpenBLAS's Haswell
    kernels (an AVX2 machine's choices); always every run-time target off and OpenBLAS's
    Sandybridge kernels (AVX). With the defaults (AVX-512 ones on an AVX-512 machine) they
    cover every level the processor has. Empty off x86-64."""
    if platform.machine() not in ("x86_64", "AMD64"):
        return []
    targets = numpy_targets()
    out = []
    above_v3 = [t for t in targets if t.startswith(("X86_V4", "AVX512"))]
    if above_v3:
        off = " ".join(above_v3)
        out.append(
            (
                f"OPENBLAS_CORETYPE=Haswell NPY_DISABLE_CPU_FEATURES='{off}'",
                {"OPENBLAS_CORETYPE": "Haswell", "NPY_DISABLE_CPU_FEATURES": off},
            )
        )
    off = " ".join(targets)
    env = {"OPENBLAS_CORETYPE": "Sandybridge"}
    if off:
        env["NPY_DISABLE_CPU_FEATURES"] = off
    out.append((f"OPENBLAS_CORETYPE=Sandybridge NPY_DISABLE_CPU_FEATURES='{off}'", env))
    return out
