"""compare/run/portable.py: lengths, dot products and arc cosines whose bits the processor does
not choose, and the guard that keeps the code making figures on them."""

from __future__ import annotations

import math
import re
from pathlib import Path

import numpy as np
import pytest

from simbridge.compare.run.portable import acos, dot, length, norm

COMPARE = Path(__file__).resolve().parents[3] / "compare"

# calls whose last bits depend on the processor (compare/run/portable.py says why): OpenBLAS's
# kernels and numpy's AVX-512 loops
DISPATCHED = re.compile(
    r"np\.linalg\.|np\.dot\(|np\.matmul\(|np\.einsum\(|np\.inner\(|np\.vdot\(|np\.tensordot\("
    r"|np\.arccos\(|np\.arcsin\(|np\.exp\(|np\.expm1\(|np\.log(2|10|1p)?\(|np\.power\("
    r"|np\.cbrt\(|np\.tanh\(|[\w\])] @ [\w(\[]"
)

# modules that draw pictures (pixels and the 3D replay's meshes), whose numbers no test holds
# bit for bit and no report states
PICTURES = {
    "report/plots.py",
    "report/replay.py",
    "report/replay_models.py",
    "report/frames.py",
}


def test_every_module_making_figures_avoids_the_dispatched_calls():
    found = []
    for path in sorted(COMPARE.rglob("*.py")):
        rel = path.relative_to(COMPARE).as_posix()
        if rel in PICTURES or rel == "run/portable.py":
            continue
        for n, line in enumerate(path.read_text(encoding="utf-8").splitlines(), 1):
            code = line.split("#", 1)[0]
            if DISPATCHED.search(code) and not code.lstrip().startswith(('"', "'")):
                found.append(f"compare/{rel}:{n}: {line.strip()}")
    assert found == [], "use compare/run/portable.py:\n" + "\n".join(found)


def test_the_guard_sees_each_kind_of_call():
    for code in (
        "d = np.linalg.norm(a - b)",
        "h = b.base_position @ up",
        "x = np.dot(q, t)",
        "t = np.arccos(c)",
        "y = np.exp(-x)",
        "z = np.log1p(x)",
        "w = np.power(x, 1.5)",
    ):
        assert DISPATCHED.search(code), code
    assert not DISPATCHED.search("a = np.sqrt(x * x + y * y)")
    assert not DISPATCHED.search('label = f"{backend} @ {dt} s"')


def test_dot_and_norm_add_in_index_order():
    rng = np.random.default_rng(5)
    a = rng.normal(size=(50, 7))
    b = rng.normal(size=(50, 7))
    expected = np.zeros(50)
    for k in range(7):  # the order the docstring promises, element by element
        expected = expected + a[:, k] * b[:, k]
    assert np.array_equal(dot(a, b), expected)
    assert np.array_equal(norm(a), np.sqrt(dot(a, a)))
    # the same figures as numpy's own, to rounding (its order may differ)
    np.testing.assert_allclose(dot(a, b), np.einsum("ij,ij->i", a, b), rtol=1e-12, atol=1e-14)
    np.testing.assert_allclose(norm(a), np.linalg.norm(a, axis=-1), rtol=1e-14)


def test_shapes_and_broadcasting():
    v = np.arange(24.0).reshape(2, 4, 3)
    assert norm(v).shape == (2, 4)
    assert norm(v, keepdims=True).shape == (2, 4, 1)
    assert dot(v, np.array([0.0, 0.0, 1.0])).shape == (2, 4)
    assert np.array_equal(dot(v, np.array([0.0, 0.0, 1.0])), v[..., 2])
    assert length([3.0, 4.0]) == 5.0 and isinstance(length([3.0, 4.0]), float)
    assert length(np.zeros(0)) == 0.0


def test_acos_is_the_c_librarys():
    x = np.linspace(-1.0, 1.0, 1001).reshape(7, 11, 13)
    got = acos(x)
    assert got.shape == x.shape
    assert all(g == math.acos(v) for g, v in zip(got.ravel(), x.ravel(), strict=True))
    with pytest.raises(ValueError):  # outside [-1, 1]: math's error, never a silent NaN
        acos(np.array([1.5]))
