"""An MJCF file as MuJoCo reads it (``Sim.load_mjcf(source, semantics="mujoco")``).

MuJoCo's own compiler (``mujoco.MjModel.from_xml_path``, or ``from_xml_string`` for text) reads
the file: ``<default>`` classes, ``<option>``, ``<compiler>``, ``<include>``, actuators, joint
damping, armature, friction loss, springs, limits, contact settings, keyframes, sites and
sensors are all MuJoCo's. This module is the one place outside the MuJoCo backend that imports
the engine (``tests/test_import_graph.py`` names it); the Sim imports it only for this reading.

How the compiled model maps onto simbridge's bodies (:func:`native_bodies`):

* Each top-level body of ``<worldbody>`` is one simbridge body, in MuJoCo's order. The
  worldbody's own geoms are the world (the ground): no body id.
* Its base (link -1): the top-level body itself when its first joint is ``free`` (a floating
  base) or when it has no joint (a fixed base); when it has other joints (half_cheetah's
  ``rootx``, ``rootz``, ``rooty``), the base is a massless root fixed where the body's frame
  is at ``qpos0``, and those joints are rows like any other.
* One joint-table row per MuJoCo joint below the base, in MuJoCo's joint order and with its
  names (an unnamed joint is ``joint<id>``): ``hinge`` is REVOLUTE, ``slide`` PRISMATIC,
  ``ball`` SPHERICAL. Row i moves link i, the MuJoCo body of that joint (an unnamed body is
  ``body<id>``); a body with several joints gives each a row, chained (the parent of its k-th
  joint is its (k-1)-th), and all of them read that one body's frame. A body without joints
  moves with its nearest ancestor and has no row of its own (its sites are readable).
* The 17 fields in simbridge's types: ``q_index``/``u_index`` are the joint's addresses in
  MuJoCo's ``qpos``/``qvel`` (``jnt_qposadr``, ``jnt_dofadr``), ``flags`` 0 (no default motor),
  ``damping`` and ``friction`` MuJoCo's ``dof_damping`` and ``dof_frictionloss``, the limits
  ``jnt_range`` where ``jnt_limited`` (else PyBullet's 0, -1), ``max_force`` the joint's
  ``actuatorfrcrange`` bound where limited (else 0), ``max_velocity`` 0; the axis and the
  parent frame in the inertial frames, at ``qpos0``.
"""

from __future__ import annotations

import os
import re
from dataclasses import dataclass
from typing import Any

import mujoco
import numpy as np

from simbridge.exceptions import MjcfCompileError
from simbridge.types import ActuatorInfo, JointInfo, JointType

__all__ = [
    "BAD_VALUE",
    "SEMANTICS",
    "NativeBody",
    "NativeMjcf",
    "actuator_table",
    "bad_coordinate",
    "compile_mjcf",
    "coordinate_name",
    "native_bodies",
]

SEMANTICS = ("pybullet", "mujoco")  # Sim.load_mjcf(semantics=...)

_TYPES = {
    int(mujoco.mjtJoint.mjJNT_HINGE): JointType.REVOLUTE,
    int(mujoco.mjtJoint.mjJNT_SLIDE): JointType.PRISMATIC,
    int(mujoco.mjtJoint.mjJNT_BALL): JointType.SPHERICAL,
}
_FREE = int(mujoco.mjtJoint.mjJNT_FREE)


@dataclass(frozen=True)
class NativeBody:
    """One simbridge body of the compiled model (see the module docstring).

    Attributes:
        name: The top-level MuJoCo body's name (``body<id>`` when unnamed).
        body_id: Its MuJoCo body id.
        free_joint: The MuJoCo id of its free joint, or -1 (a fixed base).
        massless_root: True when the base is a massless root (the body has non-free joints).
        link_bodies: (n,) the MuJoCo body id each row's link reads.
        joint_ids: (n,) the MuJoCo joint id of each row.
        table: The joint table, n rows.
    """

    name: str
    body_id: int
    free_joint: int
    massless_root: bool
    link_bodies: tuple[int, ...]
    joint_ids: tuple[int, ...]
    table: tuple[JointInfo, ...]


@dataclass(frozen=True, eq=False)
class NativeMjcf:
    """An MJCF file compiled by MuJoCo, and simbridge's view of it.

    Attributes:
        display_name: The file (or ``<MJCF text>``) for messages and the manifest.
        model: The compiled ``mujoco.MjModel`` (the backend that runs it takes it over).
        bodies: One :class:`NativeBody` per top-level body, in MuJoCo's order.
        actuators: MuJoCo's actuators, in its order.
        sensors: The sensors' names, in MuJoCo's order (``sensor<id>`` when unnamed).
        sites: The sites' names (``site<id>`` when unnamed).
        keyframes: The keyframes' names (``key<id>`` when unnamed).
    """

    display_name: str
    model: Any
    bodies: tuple[NativeBody, ...]
    actuators: tuple[ActuatorInfo, ...]
    sensors: tuple[str, ...]
    sites: tuple[str, ...]
    keyframes: tuple[str, ...]


def _names(m: Any, kind: Any, count: int, prefix: str) -> tuple[str, ...]:
    """Every object's name of one kind, ``<prefix><id>`` for an unnamed one."""
    return tuple(mujoco.mj_id2name(m, kind, i) or f"{prefix}{i}" for i in range(count))


# the compiler says "line 5"; its XML parser (TinyXML2) "Line number=4"
_LINE = re.compile(r"[Ll]ine(?: number=| )(\d+)")


def compile_mjcf(source: str | os.PathLike[str]) -> NativeMjcf:
    """Compile an MJCF file with MuJoCo's own compiler.

    Args:
        source: A path, a name on the search path (``"mjcf/ant.xml"`` in pybullet_data) or
            MJCF text (its ``<include>`` files and meshes resolve against the working folder).

    Returns:
        The compiled model and simbridge's tables of it.

    Raises:
        UrdfNotFoundError: The source is neither a file, a name on the search path nor text.
        MjcfCompileError: MuJoCo refuses the file: its own message, with the file and the
            line where MuJoCo gives one.
    """
    from simbridge.model.scene import resolve_scene_source

    src = resolve_scene_source(source, "mjcf")
    try:
        if src.path is not None:
            m = mujoco.MjModel.from_xml_path(str(src.path))
        else:
            m = mujoco.MjModel.from_xml_string(src.text)
    except ValueError as exc:
        detail = " ".join(str(exc).split())
        found = _LINE.search(str(exc))
        raise MjcfCompileError(
            src.display_name, detail, int(found.group(1)) if found else None
        ) from None
    return NativeMjcf(
        src.display_name,
        m,
        native_bodies(m),
        actuator_table(m),
        _names(m, mujoco.mjtObj.mjOBJ_SENSOR, m.nsensor, "sensor"),
        _names(m, mujoco.mjtObj.mjOBJ_SITE, m.nsite, "site"),
        _names(m, mujoco.mjtObj.mjOBJ_KEY, m.nkey, "key"),
    )


def _conj(q: np.ndarray) -> np.ndarray:
    out = np.empty(4)
    mujoco.mju_negQuat(out, q)
    return out


def _mul(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    out = np.empty(4)
    mujoco.mju_mulQuat(out, a, b)
    return out


def _rotate(q: np.ndarray, v: np.ndarray) -> np.ndarray:
    out = np.empty(3)
    mujoco.mju_rotVecQuat(out, v, q)
    return out


def _xyzw(q: np.ndarray) -> tuple[float, float, float, float]:
    return (float(q[1]), float(q[2]), float(q[3]), float(q[0]))


def native_bodies(m: Any) -> tuple[NativeBody, ...]:
    """simbridge's bodies of a compiled model (the mapping in the module docstring).

    Args:
        m: A compiled ``mujoco.MjModel``.

    Returns:
        One :class:`NativeBody` per top-level body, in MuJoCo's order.
    """
    d = mujoco.MjData(m)
    mujoco.mj_kinematics(m, d)  # frames at qpos0
    com_quat = np.empty((m.nbody, 4))
    for b in range(m.nbody):
        mujoco.mju_mat2Quat(com_quat[b], d.ximat[b])
    body_names = _names(m, mujoco.mjtObj.mjOBJ_BODY, m.nbody, "body")
    joint_names = _names(m, mujoco.mjtObj.mjOBJ_JOINT, m.njnt, "joint")
    out = []
    for top in range(1, m.nbody):
        if m.body_parentid[top] != 0:
            continue
        first = int(m.body_jntadr[top])
        free = first if first >= 0 and m.jnt_type[first] == _FREE else -1
        massless = first >= 0 and free < 0
        # the base's frame (the parent frame of the rows that hang from it)
        if massless:
            base_pos, base_quat = d.xpos[top].copy(), d.xquat[top].copy()
        else:
            base_pos, base_quat = d.xipos[top].copy(), com_quat[top]
        subtree = [b for b in range(top, m.nbody) if m.body_rootid[b] == top]
        last_row: dict[int, int] = {}  # MuJoCo body -> its last row
        rows: list[JointInfo] = []
        links: list[int] = []
        joints: list[int] = []
        for b in subtree:
            parent_row = -1
            a = int(m.body_parentid[b]) if b != top else 0
            while a != 0 and a not in last_row:
                a = int(m.body_parentid[a])
            if a != 0:
                parent_row = last_row[a]
            for j in range(int(m.body_jntadr[b]), int(m.body_jntadr[b] + m.body_jntnum[b])):
                if j == free:
                    continue
                if parent_row < 0:
                    p_pos, p_quat = base_pos, base_quat
                else:
                    pb = links[parent_row]
                    p_pos, p_quat = d.xipos[pb], com_quat[pb]
                rows.append(
                    _row(
                        m,
                        d,
                        j,
                        len(rows),
                        parent_row,
                        p_pos,
                        p_quat,
                        com_quat,
                        joint_names[j],
                        body_names[b],
                    )
                )
                links.append(b)
                joints.append(j)
                parent_row = len(rows) - 1
                last_row[b] = parent_row
        out.append(
            NativeBody(
                body_names[top], top, free, massless, tuple(links), tuple(joints), tuple(rows)
            )
        )
    return tuple(out)


def _row(
    m: Any,
    d: Any,
    j: int,
    index: int,
    parent: int,
    p_pos: np.ndarray,
    p_quat: np.ndarray,
    com_quat: np.ndarray,
    name: str,
    link: str,
) -> JointInfo:
    """One joint-table row of MuJoCo joint ``j`` (frames at qpos0)."""
    b = int(m.jnt_bodyid[j])
    kind = _TYPES[int(m.jnt_type[j])]
    dof = int(m.jnt_dofadr[j])
    limited = bool(m.jnt_limited[j])
    lower, upper = (float(m.jnt_range[j][0]), float(m.jnt_range[j][1])) if limited else (0.0, -1.0)
    if kind == JointType.SPHERICAL:
        axis = (0.0, 0.0, 0.0)
    else:  # jnt_axis is in the body frame; the row's axis in its inertial frame
        a = _rotate(_conj(m.body_iquat[b]), m.jnt_axis[j])
        axis = (float(a[0]), float(a[1]), float(a[2]))
    rel = _rotate(_conj(p_quat), d.xanchor[j] - p_pos)
    orn = _mul(_conj(p_quat), com_quat[b])
    max_force = float(m.jnt_actfrcrange[j][1]) if m.jnt_actfrclimited[j] else 0.0
    return JointInfo(
        index,
        name,
        kind,
        int(m.jnt_qposadr[j]),
        dof,
        0,
        float(m.dof_damping[dof]),
        float(m.dof_frictionloss[dof]),
        lower,
        upper,
        max_force,
        0.0,
        link,
        axis,
        (float(rel[0]), float(rel[1]), float(rel[2])),
        _xyzw(orn),
        parent,
    )


def _enum(kind: Any, prefix: str) -> dict[int, str]:
    """A MuJoCo enum's values -> their names in lower case, the prefix dropped."""
    return {int(v): k[len(prefix) :].lower() for k, v in kind.__members__.items()}


_TRN = _enum(mujoco.mjtTrn, "mjTRN_")
_DYN = _enum(mujoco.mjtDyn, "mjDYN_")
_GAIN = _enum(mujoco.mjtGain, "mjGAIN_")
_BIAS = _enum(mujoco.mjtBias, "mjBIAS_")
_TARGET = {
    "joint": mujoco.mjtObj.mjOBJ_JOINT,
    "jointinparent": mujoco.mjtObj.mjOBJ_JOINT,
    "tendon": mujoco.mjtObj.mjOBJ_TENDON,
    "site": mujoco.mjtObj.mjOBJ_SITE,
    "slidercrank": mujoco.mjtObj.mjOBJ_SITE,
    "body": mujoco.mjtObj.mjOBJ_BODY,
}


def actuator_table(m: Any) -> tuple[ActuatorInfo, ...]:
    """MuJoCo's actuators as simbridge reports them.

    Args:
        m: A compiled ``mujoco.MjModel``.

    Returns:
        One :class:`~simbridge.types.ActuatorInfo` per actuator, in MuJoCo's order.
    """
    names = _names(m, mujoco.mjtObj.mjOBJ_ACTUATOR, m.nu, "actuator")
    out = []
    for i in range(m.nu):
        trn = _TRN[int(m.actuator_trntype[i])]
        target = int(m.actuator_trnid[i][0])
        kind = _TARGET.get(trn)
        target_name = (mujoco.mj_id2name(m, kind, target) or "") if kind is not None else ""
        ctrl = tuple(map(float, m.actuator_ctrlrange[i])) if m.actuator_ctrllimited[i] else None
        force = tuple(map(float, m.actuator_forcerange[i])) if m.actuator_forcelimited[i] else None
        out.append(
            ActuatorInfo(
                i,
                names[i],
                trn,
                target_name,
                tuple(float(g) for g in m.actuator_gear[i]),  # type: ignore[arg-type]
                ctrl,  # type: ignore[arg-type]
                force,  # type: ignore[arg-type]
                _DYN[int(m.actuator_dyntype[i])],
                _GAIN[int(m.actuator_gaintype[i])],
                tuple(float(g) for g in m.actuator_gainprm[i][:3]),  # type: ignore[arg-type]
                _BIAS[int(m.actuator_biastype[i])],
                tuple(float(g) for g in m.actuator_biasprm[i][:3]),  # type: ignore[arg-type]
            )
        )
    return tuple(out)


# MuJoCo's "bad" value (``mju_isBad``: not finite, or beyond ``mjMAXVAL`` in magnitude), after
# which its own mj_step warns (mjWARN_BADQPOS, mjWARN_BADQVEL) and resets the data
BAD_VALUE = float(mujoco.mjMAXVAL)


def coordinate_name(m: Any, vector: str, index: int) -> str:
    """One of MuJoCo's generalized coordinates, named by its joint and body.

    Args:
        m: The compiled ``mujoco.MjModel``.
        vector: ``"qpos"``, or ``"qvel"`` (``qacc`` and forces share its addresses).
        index: The coordinate's address in that vector.

    Returns:
        ``"qvel[7] (joint 'hip_1' of body 'front_left_leg')"``.
    """
    if vector == "qpos":
        joint = int(np.searchsorted(m.jnt_qposadr, index, side="right")) - 1
    else:
        joint = int(m.dof_jntid[index])
    jname = mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_JOINT, joint) or f"joint{joint}"
    body = int(m.jnt_bodyid[joint])
    bname = mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_BODY, body) or f"body{body}"
    return f"{vector}[{index}] (joint {jname!r} of body {bname!r})"


def bad_coordinate(m: Any, qpos: np.ndarray, qvel: np.ndarray) -> str | None:
    """The first of ``qpos``, ``qvel`` that MuJoCo would call bad (not finite, or beyond
    :data:`BAD_VALUE` = ``mjMAXVAL``, 1e10, in magnitude: MuJoCo's own ``mj_step`` resets the
    data then), named, with its value, and how many others are bad.

    Args:
        m: The compiled ``mujoco.MjModel``.
        qpos: (nq,) generalized positions, MuJoCo's conventions.
        qvel: (nv,) generalized velocities.

    Returns:
        ``"qvel[7] (joint 'hip_1' of body 'front_left_leg') = nan (and 3 more values)"``, or
        None when every value is good.
    """
    if (np.abs(qpos) <= BAD_VALUE).all() and (np.abs(qvel) <= BAD_VALUE).all():
        return None  # NaN compares False
    found = []
    for vector, values in (("qpos", qpos), ("qvel", qvel)):
        bad = np.flatnonzero(~(np.abs(values) <= BAD_VALUE))  # NaN compares False
        found += [(vector, int(i), float(values[i])) for i in bad]
    if not found:
        return None
    vector, i, value = found[0]
    more = f" (and {len(found) - 1} more values)" if len(found) > 1 else ""
    return f"{coordinate_name(m, vector, i)} = {value:.6g}{more}"
