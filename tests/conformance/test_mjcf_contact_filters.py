"""MuJoCo's contact filter under its reading of MJCF (``load_mjcf(path, semantics="mujoco")``) on
every engine that declares that reading: a parent and its child never touch (``filterparent``),
unless one of them is welded to the world; the rule holds however many such pairs a body has
and however many joints the child body has (PhysX leaves a pair out by SAPIEN's 32 ignore bits:
docs/mjcf_mujoco_reading.md). ``<contact><exclude>`` across top-level bodies:
test_mjcf_mujoco_reading.py."""

from __future__ import annotations

import numpy as np
import pytest
from _gaps import steps_mujocos_reading_raw

import simbridge


def _reads_mujoco(backend: str) -> bool:
    return "mujoco" in simbridge.registry.load_backend(backend).semantics


def _legs(single: int, double: int) -> str:
    """A free sphere of radius 0.3 m with ``single`` legs on one hinge and ``double`` legs on
    two hinges (one MuJoCo body with two joints), each a thin capsule from 0.27 to 0.6 m out in
    the xy-plane: every leg starts 3 cm inside its parent and clear of its siblings (3 cm
    between neighbours' surfaces at 0.27 m with 42 legs, beyond PhysX's 1 cm contact offset);
    no gravity."""
    n = single + double
    bodies = []
    for k in range(n):
        a = 2.0 * np.pi * k / n
        c, s = np.cos(a), np.sin(a)
        joints = '<joint type="hinge" axis="0 0 1"/>'
        if k >= single:
            joints += f'<joint type="hinge" axis="{-s:.6f} {c:.6f} 0"/>'
        bodies.append(
            f'<body name="leg{k}">{joints}<geom type="capsule" size="0.005" '
            f'fromto="{0.27 * c:.6f} {0.27 * s:.6f} 0 {0.6 * c:.6f} {0.6 * s:.6f} 0"/></body>'
        )
    return (
        '<mujoco><option gravity="0 0 0" timestep="0.002"/><worldbody>'
        '<body name="torso" pos="0 0 1"><freejoint/><geom type="sphere" size="0.3"/>'
        + "".join(bodies)
        + "</body></worldbody></mujoco>"
    )


@pytest.mark.parametrize(
    ("single", "double"),
    [(2, 2), (40, 2)],  # 44 parent-child pairs: more than SAPIEN's 32 bits, 2 need one
)
def test_parent_and_child_never_touch(backend: str, single: int, double: int) -> None:
    """Each leg starts 3 cm inside the torso, its parent: MuJoCo filters the pair, so nothing
    touches and, without gravity, nothing moves on any engine (the children of two joints hang
    from a massless link on PyBullet and PhysX, so PhysX's own parent-child rule does not
    reach them; measured before: with 44 pairs PhysX filtered none, the legs were thrown)."""
    if not _reads_mujoco(backend):
        pytest.skip(f"{backend!r} does not declare MuJoCo's reading of MJCF")
    with simbridge.Sim(backend) as sim:
        sim.load_mjcf(_legs(single, double), semantics="mujoco")
        sim.step(20)
        assert len(sim.contact_points()) == 0
        assert float(np.abs(sim.qvel()).max()) < 1e-6


WELDED = """<mujoco><option gravity="0 0 0" timestep="0.002"/><worldbody>
<body name="base" pos="0 0 1">{free}<geom type="box" size="0.1 0.1 0.1"/>
<body name="arm"><joint name="hinge" type="hinge" axis="0 1 0"/><joint name="roll" axis="1 0 0"/>
<geom type="capsule" fromto="0.05 0 0.08 0.4 0 0.08" size="0.03"/></body></body></worldbody>
</mujoco>"""


@pytest.mark.parametrize("free", [False, True])
def test_a_parent_welded_to_the_world_touches_its_child(backend: str, free: bool) -> None:
    """The arm's capsule starts 5 cm deep in its parent's box, under its top face. With the box
    welded to the world (no joint) MuJoCo does not filter the pair: the engine reports them
    touching after the first step; with
    a free box the pair is filtered and nothing moves (MuJoCo's ``filterparent`` applies only
    between bodies neither of which is welded to the world). The arm has two joints: on
    PyBullet and PhysX a joint's own parent and child links never touch (the next test)."""
    if not _reads_mujoco(backend):
        pytest.skip(f"{backend!r} does not declare MuJoCo's reading of MJCF")
    with simbridge.Sim(backend) as sim:
        (body,) = sim.load_mjcf(
            WELDED.format(free="<freejoint/>" if free else ""), semantics="mujoco"
        )
        sim.step(1)
        points = sim.contact_points()
        arm = sim.num_joints(body) - 1  # the arm's last row carries its geom
        sim.step(19)
        moved = float(np.abs(sim.qvel()).max())
    if free:
        assert len(points) == 0
        assert moved < 1e-6
    else:
        assert any(arm in (c.link_a, c.link_b) for c in points), points


def test_a_welded_parents_own_child_is_a_named_departure(backend: str) -> None:
    """The arm on one hinge: MuJoCo lets it touch its parent welded to the world; PyBullet and
    PhysX never let a joint's parent and child touch, a departure named with the pair."""
    if not _reads_mujoco(backend):
        pytest.skip(f"{backend!r} does not declare MuJoCo's reading of MJCF")
    text = WELDED.format(free="").replace('<joint name="roll" axis="1 0 0"/>', "")
    with simbridge.Sim(backend) as sim:
        sim.load_mjcf(text, semantics="mujoco")
        sim.step(1)
        if steps_mujocos_reading_raw(backend):
            assert len(sim.contact_points()) > 0
            return
        assert "base/arm" in sim.manifest()["departures"]["parent_child_contacts"]
