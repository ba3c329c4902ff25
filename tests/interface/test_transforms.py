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


def test_quat_from_matrix_bullet_gives_bullets_sign():
    """Bullet's ``getRotation`` (what the joint table's field 15 goes through) against PyBullet's
    own: ``p.invertTransform`` turns a quaternion into a matrix, transposes it and calls it.
    Random turns and the half turns and three-quarter turns whose sign a w >= 0 rule gets wrong
    (bravo7's joint1: (0, 0, 0, -1) in PyBullet's table)."""
    rng = np.random.default_rng(3)
    turns = [tuple(q / np.linalg.norm(q)) for q in rng.normal(size=(40, 4))]
    for axis in np.eye(3):
        # (not a turn of 120 degrees: trace 0, its sign is round-off, and these helpers of
        # PyBullet's round in float32 where the joint table's Bullet computes in double)
        for angle in (np.pi / 2, np.pi, 1.5 * np.pi, -np.pi, -np.pi / 2):
            turns.append((*(np.sin(angle / 2) * axis), np.cos(angle / 2)))
    for q in turns:
        want = p.invertTransform((0, 0, 0), q)[1]
        m = T.matrix_from_quat_bullet(q)
        assert np.array(m) == pytest.approx(T.quat_to_matrix(q), abs=1e-15)
        got = T.quat_from_matrix_bullet(np.array(m).T)
        # PyBullet's transform helpers compute in float32 (3e-8 apart, measured): 1e-6, far
        # below the 2 between a quaternion's component and its negation
        assert got == pytest.approx(want, abs=1e-6), q


def test_rpy_from_quat_agrees_with_pybullet_and_scalars_match_scenarios():
    rng = np.random.default_rng(2)
    for _ in range(20):
        q = T.quat_from_rpy(rng.uniform(-1.5, 1.5, 3))
        assert T.rpy_from_quat(q) == pytest.approx(p.getEulerFromQuaternion(q), abs=1e-12)
    # integers, as a scenario file may give them, are the same angles as floats
    assert T.quat_from_rpy([0, 0, 1]) == T.quat_from_rpy((0.0, 0.0, 1.0))
    assert T.xyzw_to_wxyz(T.IDENTITY_QUAT) == (1.0, 0.0, 0.0, 0.0)
