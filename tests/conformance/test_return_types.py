"""Every read of the Sim returns the Python types its annotations (``simbridge.types``) and
PyBullet's backend give: plain ``float``/``int``/``str`` in every tuple (never a numpy scalar,
whose repr is ``np.float64(0.0)``), the declared enums, and numpy arrays only where a field is
declared one, of the dtype PyBullet's backend gives.

Each read runs on r2d2 (on the ground, driving: its contacts), KUKA's arm and the spherical
pendulum (``joint_states_multi_dof`` and the spherical part of a state), after some steps.
"""

from __future__ import annotations

import re
import types
import typing
from enum import Enum
from typing import Any

import numpy as np

import simbridge
from simbridge.types import JointType, MotorMode


def _leaves(value: Any, hint: Any, where: str) -> list[tuple[str, str]]:
    """(place, type) of every leaf of ``value`` read as ``hint`` says, and an ``"ERROR ..."``
    entry where a leaf is not of the declared type."""
    origin = typing.get_origin(hint)
    if isinstance(hint, type) and issubclass(hint, tuple) and hasattr(hint, "_fields"):
        if type(value) is not hint:
            return [(where, f"ERROR {type(value).__name__}, not {hint.__name__}")]
        hints = typing.get_type_hints(hint)
        out: list[tuple[str, str]] = []
        for name in hint._fields:
            out += _leaves(getattr(value, name), hints[name], f"{where}.{name}")
        return out
    if origin is tuple:
        args = typing.get_args(hint)
        if type(value) is not tuple:
            return [(where, f"ERROR {type(value).__name__}, not tuple")]
        if len(args) == 2 and args[1] is Ellipsis:
            args = (args[0],) * len(value)
        if len(args) != len(value):
            return [(where, f"ERROR {len(value)} items, not {len(args)}")]
        out = []
        for i, (v, h) in enumerate(zip(value, args, strict=True)):
            out += _leaves(v, h, f"{where}[{i}]")
        return out
    if origin in (list, typing.Union, types.UnionType):
        raise AssertionError(f"{where}: no rule for {hint}")
    if hint is np.ndarray:
        if type(value) is not np.ndarray:
            return [(where, f"ERROR {type(value).__name__}, not numpy.ndarray")]
        return [(where, f"ndarray {value.dtype}")]
    if hint is Any:
        return []
    if isinstance(hint, type) and (issubclass(hint, Enum) or hint in (float, int, str, bool)):
        if type(value) is not hint:  # exactly: np.float64 is a float subclass, bool an int one
            return [(where, f"ERROR {type(value).__module__}.{type(value).__name__}, not {hint}")]
        return [(where, hint.__name__)]
    raise AssertionError(f"{where}: no rule for {hint}")


def _reads(backend: str) -> dict[str, str]:
    """Every read of the Sim on the three robots: place -> leaf type (or an ERROR)."""
    sim = simbridge.Sim(backend=backend)
    try:
        sim.load_urdf("plane.urdf")
        r2d2 = sim.load_urdf("r2d2.urdf", base_position=(0.0, 0.0, 0.475))
        kuka = sim.load_urdf("kuka_iiwa/model.urdf", base_position=(2.0, 0.0, 0.0), fixed_base=True)
        ball = sim.load_urdf("spherical_pendulum.urdf", base_position=(-2.0, 0.0, 1.0))
        wheels = [j.index for j in sim.joints(r2d2) if j.type == JointType.REVOLUTE]
        sim.set_joint_velocity(r2d2, wheels, 5.0, max_force=10.0)
        sim.set_joint_position(kuka, [1, 3], [0.5, -0.5], max_force=100.0)
        sim.reset_joint_state_multi_dof(ball, 0, (0.2, 0.0, 0.0, 0.98), (0.0, 1.0, 0.0))
        sim.step(60)
        found: list[tuple[str, str]] = []
        found += _leaves(sim.time, float, "time")
        found += _leaves(sim.timestep, float, "timestep")
        found += _leaves(sim.gravity, tuple[float, float, float], "gravity")
        found += _leaves(tuple(sim.bodies()), tuple[int, ...], "bodies")
        for name, body in (("r2d2", r2d2), ("kuka", kuka), ("ball", ball)):
            found += _leaves(sim.body_name(body), str, f"{name}.body_name")
            found += _leaves(sim.num_joints(body), int, f"{name}.num_joints")
            rows = sim.joints(body)
            assert type(rows) is list
            for row in rows:
                found += _leaves(row, simbridge.JointInfo, f"{name}.joints[{row.index}]")
                found += _leaves(
                    sim.joint_info(body, row.name), simbridge.JointInfo, f"{name}.joint_info"
                )
                found += _leaves(sim.joint_index(body, row.name), int, f"{name}.joint_index")
                found += _leaves(sim.link_index(body, row.link_name), int, f"{name}.link_index")
            for link in range(-1, sim.num_joints(body)):
                found += _leaves(
                    sim.dynamics_info(body, link), simbridge.DynamicsInfo, f"{name}.dyn[{link}]"
                )
            for link in range(sim.num_joints(body)):
                found += _leaves(
                    sim.link_state(body, link), simbridge.LinkState, f"{name}.link_state[{link}]"
                )
            found += _leaves(sim.link_states(body), simbridge.LinkStates, f"{name}.link_states")
            found += _leaves(sim.base_state(body), simbridge.BaseState, f"{name}.base_state")
            found += _leaves(sim.joint_states(body), simbridge.JointStates, f"{name}.joint_states")
            multi = sim.joint_states_multi_dof(body)
            found += _leaves(
                multi, tuple[simbridge.JointStateMultiDof, ...], f"{name}.joint_states_multi_dof"
            )
        contacts = sim.contact_points(r2d2)
        assert contacts, "r2d2 on the ground has contacts"
        found += _leaves(contacts, tuple[simbridge.ContactPoint, ...], "contact_points")
        state = sim.get_state()
        found += _leaves(state.time, float, "state.time")
        found += _leaves(state.timestep, float, "state.timestep")
        found += _leaves(state.bodies, tuple[simbridge.BodyState, ...], "state.bodies")
        assert state.bodies[-1].spherical, "the pendulum's state holds its spherical joint"
        # the engines find different numbers of contacts: one entry per field of all of them,
        # an error kept over a good one
        table: dict[str, str] = {}
        for place, kind in found:
            place = re.sub(r"^contact_points\[\d+\]", "contact_points[*]", place)
            if not table.get(place, "").startswith("ERROR"):
                table[place] = kind
        return table
    finally:
        sim.close()


_PYBULLET: dict[str, str] = {}


def _pybullet_reads() -> dict[str, str]:
    if not _PYBULLET:
        _PYBULLET.update(_reads("pybullet"))
    return _PYBULLET


def test_every_read_returns_the_declared_types(backend: str) -> None:
    found = _reads(backend)
    wrong = {k: v for k, v in found.items() if v.startswith("ERROR")}
    assert not wrong, f"{backend}: {len(wrong)} fields of the wrong type: {wrong}"


def test_every_read_returns_pybullets_types(backend: str) -> None:
    # the arrays' dtypes too (a motor mode int8 in one backend and int64 in another pickles
    # and compares differently), and the same set of fields (the same tables)
    found = _reads(backend)
    reference = _pybullet_reads()
    assert found.keys() == reference.keys()
    differ = {k: (reference[k], found[k]) for k in reference if found[k] != reference[k]}
    assert not differ, f"{backend} against pybullet (pybullet's, {backend}'s): {differ}"


def test_the_check_catches_a_numpy_leaves() -> None:
    # the checker itself: a numpy scalar in a quaternion, an int for a float, a list for a tuple
    row = (0.0, 0.0, np.float64(0.0), 1.0)
    assert _leaves(row, tuple[float, float, float, float], "q")[2][1].startswith("ERROR")
    assert _leaves(1, float, "x")[0][1].startswith("ERROR")
    assert _leaves([0.0, 0.0, 0.0], tuple[float, float, float], "v")[0][1].startswith("ERROR")
    assert _leaves(MotorMode.NONE, int, "m")[0][1].startswith("ERROR")
