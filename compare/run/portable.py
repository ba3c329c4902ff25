"""Arithmetic whose result bits are the same on every processor, for the figures a comparison
reports: lengths, dot products and the arc cosine.

numpy hands some operations to code the processor chooses at run time, whose last bits differ
from one processor to the next:

- ``@``, ``np.dot``, ``np.linalg.norm`` of a vector and the rest of ``np.linalg`` call
  OpenBLAS, whose kernel (Haswell, SkylakeX, Zen, Sandybridge...) is picked from the processor
  and sums in its own order;
- ``np.arccos``, ``np.exp``, ``np.log`` and ``np.power`` take AVX-512 loops where the processor
  has AVX-512 (numpy's run-time dispatch), whose results differ from the other loops' in the
  last place.

Measured (tests/compare/pipeline/test_compare_same_results.py's cases, an AVX-512 machine against
itself with ``OPENBLAS_CORETYPE=Haswell`` and ``NPY_DISABLE_CPU_FEATURES`` naming its AVX-512
targets): the ensembles' spawn offsets moved by one spacing (``np.linalg.norm`` of a rotation
vector), laikago-stand's PyBullet spread went from 1.25 cm to 1.55 cm through it, and r2d2's
tilt and spreads moved in their last digits.

The functions here do the same work with operations every IEEE 754 processor rounds alike:
numpy's element-wise ``+``, ``-``, ``*``, ``/`` and ``sqrt`` (correctly rounded, whatever the
SIMD width; numpy fuses no multiply-add), added in index order, and ``math.acos`` (the C
library's, the same on every x86-64 processor with FMA, which its variant is chosen by).
tests/compare/pipeline/test_compare_same_results.py proves the figures under other OpenBLAS kernels
and with numpy's run-time dispatch turned down; tests/compare/run/test_portable.py keeps the
modules that make figures off the processor-dependent calls.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np

__all__ = ["norm", "dot", "acos", "length"]


def dot(a: Any, b: Any) -> np.ndarray:
    """The dot product over the last axis of ``a`` and ``b`` (broadcast), the products added
    in index order: shape the broadcast shape less its last axis."""
    a, b = np.broadcast_arrays(np.asarray(a, dtype=np.float64), np.asarray(b, dtype=np.float64))
    out = np.zeros(a.shape[:-1])
    for k in range(a.shape[-1]):
        out = out + a[..., k] * b[..., k]
    return out


def norm(v: Any, *, keepdims: bool = False) -> np.ndarray:
    """The Euclidean length over the last axis of ``v``: the square root of the squares
    added in index order (shape ``v``'s less its last axis, kept as 1 with ``keepdims``)."""
    v = np.asarray(v, dtype=np.float64)
    out = np.sqrt(dot(v, v))
    return out[..., None] if keepdims else out


def length(v: Sequence[float] | np.ndarray) -> float:
    """The Euclidean length of one vector, as a float (:func:`norm`)."""
    return float(norm(v))


def acos(x: Any) -> np.ndarray:
    """The arc cosine (rad) of every element of ``x`` (each within [-1, 1]), by
    ``math.acos``: shape ``x``'s."""
    x = np.asarray(x, dtype=np.float64)
    flat = x.ravel().tolist()
    return np.fromiter(map(math.acos, flat), dtype=np.float64, count=len(flat)).reshape(x.shape)
