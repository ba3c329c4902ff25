"""simbridge.transforms: quaternion (x, y, z, w), roll-pitch-yaw and pose maths, checked
against PyBullet's own conversions (this test imports pybullet on purpose)."""

from __future__ import annotations

import numpy as np
import pybullet as p
import pytest

from simbridge import transforms as T


def _same_quat(a, b, tol=1e-9) -> bool:
    a, b = np.asarray(a), np.asarray(b)
    return bool(np.abs(a - b).max() < tol or np.abs(a + b).max() < tol)


def test_quaternion_helpers_agree_with_pybullet():
    rng = np.random.default_rng(1)
    for _ in range(20):
        rpy = rng.uniform(-3, 3, 3)
        q = T.quat_from_rpy(rpy)
        assert q == pytest.approx(p.getQuaternionFromEuler(rpy), abs=1e-12)
        assert T.quat_from_rpy(T.rpy_from_quat(q)) == pytest.approx(q, abs=1e-9) or _same_quat(
            T.quat_from_rpy(T.rpy_from_quat(q)), q, 1e-9
        )
        m = T.quat_to_matrix(q)
        assert m.ravel() == pytest.approx(p.getMatrixFromQuaternion(q), abs=1e-12)
        assert _same_quat(T.quat_from_matrix(m), q)
        v = rng.normal(size=3)
        assert T.quat_rotate(q, v) == pytest.approx(m @ v, abs=1e-12)
        q2 = T.quat_from_rpy(rng.uniform(-3, 3, 3))
        assert T.quat_to_matrix(T.quat_multiply(q, q2)) == pytest.approx(
            m @ T.quat_to_matrix(q2), abs=1e-12
        )
        pose = (tuple(rng.normal(size=3)), q)
        ident = T.transform_multiply(pose, T.transform_inverse(pose))
        assert ident[0] == pytest.approx((0, 0, 0), abs=1e-12)
        assert _same_quat(ident[1], T.IDENTITY_QUAT)
    assert T.wxyz_to_xyzw(T.xyzw_to_wxyz((1, 2, 3, 4))) == (1, 2, 3, 4)


def test_rpy_from_quat_agrees_with_pybullet_and_scalars_match_scenarios():
    rng = np.random.default_rng(2)
    for _ in range(20):
        q = T.quat_from_rpy(rng.uniform(-1.5, 1.5, 3))
        assert T.rpy_from_quat(q) == pytest.approx(p.getEulerFromQuaternion(q), abs=1e-12)
    # integers, as a scenario file may give them, are the same angles as floats
    assert T.quat_from_rpy([0, 0, 1]) == T.quat_from_rpy((0.0, 0.0, 1.0))
    assert T.xyzw_to_wxyz(T.IDENTITY_QUAT) == (1.0, 0.0, 0.0, 0.0)
