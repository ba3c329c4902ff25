"""Expectations computed from yourdfpy's reading of a URDF plus PyBullet's documented rules,
independently of simbridge's own parser and of any backend.

PyBullet's rules used here (ENGINES.md; bullet3 ``URDF2Bullet.cpp``,
``PhysicsServerCommandProcessor.cpp``), each checked against raw PyBullet on every file of
pybullet_data that both PyBullet and yourdfpy read (``test_reference_rules.py``):

* order: links depth-first, pre-order from the root, children in the order their joints appear in
  the file; joint i moves link i; the root is link -1;
* types: revolute and continuous -> 0, prismatic -> 1, fixed -> 4;
* limits, every joint type alike (fixed joints too): no range gives lower 0, upper -1; a
  ``lower``/``upper`` attribute overrides its half; effort and velocity default to 0;
* ``q_index``/``u_index``: 7 and 6 base coordinates always come first, whether the base is
  free, of mass 0 (cartpole.urdf) or fixed (``useFixedBase``; measured on PyBullet 3.2.7);
  fixed joints -1;
* ``flags``: 1 (JOINT_HAS_MOTORIZED_POWER) for revolute and prismatic joints, 0 for fixed ones;
* the axis is expressed in the child's inertial (centre-of-mass) frame and not normalised;
  fixed joints report (0, 0, 0);
* the parent frame *position* is the joint origin expressed in the parent's inertial frame,
  ``Rp^T (p_joint - p_parent_com)``; the parent frame *orientation* is not the joint frame's
  orientation there but Bullet's ``m_zeroRotParentToThis``: the rotation taking vectors from the
  parent's inertial frame into the child's inertial frame at q = 0, ``Rc^T Rj^T Rp`` (Rp, Rc the
  inertial rotations in their link frames, Rj the joint origin's rotation). Measured on every
  pybullet_data URDF PyBullet loads (r2d2's legs: ``Rp^T Rj`` would be wrong by a half turn);
* a link without ``<inertial>`` has mass 1 (0 when it is named "world") and an identity
  inertial frame;
* with the file's inertia (``URDF_USE_INERTIA_FROM_FILE``) a tensor is diagonalised and the
  inertial frame turned onto its principal axes; a tensor whose principal moments break the
  triangle inequality is replaced by zeros ("Bad inertia tensor properties").

``yourdfpy`` costs about 1 s to import (it imports trimesh): it is imported on first use and each
file is read once per session.
"""

from __future__ import annotations

import functools
import logging
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

TYPE_NUMBER = {"revolute": 0, "continuous": 0, "prismatic": 1, "spherical": 2, "fixed": 4}


@functools.cache
def load(path: str, scene: bool = False) -> Any:
    """yourdfpy's URDF object for ``path`` (meshes not loaded), cached per file."""
    import yourdfpy

    logging.getLogger("yourdfpy").setLevel(logging.ERROR)
    return yourdfpy.URDF.load(
        path,
        load_meshes=False,
        build_scene_graph=scene,
        build_collision_scene_graph=False,
        load_collision_meshes=False,
    )


# ---------------------------------------------------------------- rotations


def quat_to_matrix(q: Any) -> np.ndarray:
    """(x, y, z, w) -> 3x3 rotation matrix (normalises first)."""
    x, y, z, w = np.asarray(q, dtype=float) / np.linalg.norm(q)
    return np.array(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
            [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
            [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
        ]
    )


def pose_matrix(position: Any, orientation_xyzw: Any) -> np.ndarray:
    t = np.eye(4)
    t[:3, :3] = quat_to_matrix(orientation_xyzw)
    t[:3, 3] = position
    return t


def inverse(t: np.ndarray) -> np.ndarray:
    out = np.eye(4)
    out[:3, :3] = t[:3, :3].T
    out[:3, 3] = -t[:3, :3].T @ t[:3, 3]
    return out


def axis_angle(axis: Any, angle: float) -> np.ndarray:
    a = np.asarray(axis, dtype=float)
    a = a / np.linalg.norm(a)
    k = np.array([[0, -a[2], a[1]], [a[2], 0, -a[0]], [-a[1], a[0], 0]])
    return np.eye(3) + np.sin(angle) * k + (1 - np.cos(angle)) * (k @ k)


# ---------------------------------------------------------------- the URDF, PyBullet's way


def _origin(elem: Any) -> np.ndarray:
    origin = getattr(elem, "origin", None)
    return np.eye(4) if origin is None else np.asarray(origin, dtype=float)


def root_link(robot: Any) -> str:
    children = {j.child for j in robot.joints}
    roots = [link.name for link in robot.links if link.name not in children]
    assert len(roots) == 1, f"yourdfpy sees {len(roots)} roots: {roots}"
    return roots[0]


def pybullet_order(robot: Any) -> list[Any]:
    """yourdfpy joints in PyBullet's order (depth-first pre-order, children in file order)."""
    by_parent: dict[str, list[Any]] = {}
    for joint in robot.joints:
        by_parent.setdefault(joint.parent, []).append(joint)
    out: list[Any] = []

    def visit(link: str) -> None:
        for joint in by_parent.get(link, []):
            out.append(joint)
            visit(joint.child)

    visit(root_link(robot))
    return out


def link_by_name(robot: Any) -> dict[str, Any]:
    return {link.name: link for link in robot.links}


def inertial_frame(link: Any) -> np.ndarray:
    """The link's inertial frame in its link frame, as written (identity without <inertial>)."""
    return _origin(link.inertial) if link.inertial is not None else np.eye(4)


def link_mass(link: Any) -> float:
    """PyBullet's mass: the file's; without <inertial> 1 kg, except a link named "world", which
    PyBullet makes static (mass 0; cube_no_rotation.urdf, pendulum5.urdf, xarm/*.urdf)."""
    if link.inertial is None:
        return 0.0 if link.name == "world" else 1.0
    return float(link.inertial.mass)


def principal_moments(link: Any) -> np.ndarray:
    if link.inertial is None or link.inertial.inertia is None:
        return np.ones(3)
    return np.linalg.eigvalsh(np.asarray(link.inertial.inertia, dtype=float))


def inertia_is_physical(link: Any) -> bool | None:
    """True/False when the principal moments clearly do/do not satisfy the triangle
    inequality (and are >= 0); None within 1e-9 relative of the boundary (a thin rod)."""
    a, b, c = principal_moments(link)  # ascending
    scale = max(abs(c), 1e-300)
    margin = (a + b - c) / scale
    if a < -1e-9 * scale or margin < -1e-9:
        return False
    return True if margin > 1e-9 and a > 0 else None


def inertia_is_diagonal(link: Any) -> bool:
    if link.inertial is None or link.inertial.inertia is None:
        return True
    m = np.asarray(link.inertial.inertia, dtype=float)
    return bool(np.all(m[~np.eye(3, dtype=bool)] == 0.0))


@dataclass(frozen=True)
class Row:
    """The expected getJointInfo row; rotations as matrices so quaternion signs do not matter.

    ``parent_frame`` and ``axis_in_child_link`` are in the *link* frames: the test moves them into
    the inertial frames it expects (see :func:`expected_inertial_rotation`)."""

    index: int
    name: str
    type: int
    q_index: int
    u_index: int
    flags: int
    damping: float
    friction: float
    lower: float
    upper: float
    max_force: float
    max_velocity: float
    link_name: str
    parent_index: int
    parent_link: str
    joint_origin: np.ndarray  # 4x4, joint frame in the parent's link frame
    axis: np.ndarray  # as written, in the child's link frame; zeros for fixed joints


def joint_table(robot: Any, fixed_base: bool) -> list[Row]:
    joints = pybullet_order(robot)
    index_of_link = {root_link(robot): -1} | {j.child: i for i, j in enumerate(joints)}
    del fixed_base  # the layout does not depend on it (PyBullet 3.2.7)
    q, u = 7, 6
    rows = []
    for i, j in enumerate(joints):
        jtype = TYPE_NUMBER[j.type]
        movable = jtype != 4
        lim = j.limit
        lower = 0.0 if lim is None or lim.lower is None else float(lim.lower)
        upper = -1.0 if lim is None or lim.upper is None else float(lim.upper)
        effort = 0.0 if lim is None or lim.effort is None else float(lim.effort)
        velocity = 0.0 if lim is None or lim.velocity is None else float(lim.velocity)
        dyn = j.dynamics
        damping = 0.0 if dyn is None or dyn.damping is None else float(dyn.damping)
        friction = 0.0 if dyn is None or dyn.friction is None else float(dyn.friction)
        axis = np.zeros(3)
        if movable and jtype != 2:  # PyBullet reports no axis for a spherical joint (measured)
            axis = np.array([1.0, 0.0, 0.0]) if j.axis is None else np.asarray(j.axis, float)
        rows.append(
            Row(
                index=i,
                name=j.name,
                type=jtype,
                q_index=q if movable else -1,
                u_index=u if movable else -1,
                flags=1 if movable and jtype != 2 else 0,  # a spherical joint's motor: 0
                damping=damping,
                friction=friction,
                lower=lower,
                upper=upper,
                max_force=effort,
                max_velocity=velocity,
                link_name=j.child,
                parent_index=index_of_link[j.parent],
                parent_link=j.parent,
                joint_origin=_origin(j),
                axis=axis,
            )
        )
        if movable:  # a spherical joint: a quaternion and an angular velocity
            q += 4 if jtype == 2 else 1
            u += 3 if jtype == 2 else 1
    return rows


def link_names_in_order(robot: Any) -> list[str]:
    """Link names by PyBullet index: [root (-1), link 0, link 1, ...]."""
    return [root_link(robot)] + [j.child for j in pybullet_order(robot)]


def has_mimic(robot: Any) -> bool:
    return any(j.mimic is not None for j in robot.joints)


def with_mimic(robot: Any, positions: dict[str, float]) -> dict[str, float]:
    """Complete ``positions`` with URDF ``<mimic>`` joints (q = multiplier * q_master + offset).

    PyBullet ignores ``<mimic>``: a test sets mimic joints explicitly to these values so that the
    engine and yourdfpy describe the same configuration."""
    out = dict(positions)
    for joint in robot.joints:
        if joint.mimic is not None:
            m = joint.mimic
            multiplier = 1.0 if m.multiplier is None else float(m.multiplier)
            offset = 0.0 if m.offset is None else float(m.offset)
            out[joint.name] = multiplier * out.get(m.joint, 0.0) + offset
    return out


def forward_kinematics(
    path: str, base: np.ndarray, positions: dict[str, float]
) -> dict[str, np.ndarray]:
    """World pose (4x4) of every link frame from yourdfpy's scene graph. ``base`` places the
    root's link frame; ``positions`` gives the joints yourdfpy actuates (mimic joints follow)."""
    urdf = load(path, scene=True)
    urdf.update_cfg({n: float(positions.get(n, 0.0)) for n in urdf.actuated_joint_names})
    root = root_link(urdf.robot)
    return {
        name: base @ np.asarray(urdf.get_transform(frame_to=name, frame_from=root), dtype=float)
        for name in link_names_in_order(urdf.robot)
    }


def robot_path(name: str) -> str:
    return str(Path(__file__).resolve().parents[2] / "robots" / name)
