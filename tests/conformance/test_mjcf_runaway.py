"""A model read as MuJoCo reads it never runs away without a word, on every engine: a state
MuJoCo would call bad (not finite, or beyond 1e10: ``mjMAXVAL``) raises
SimulationDivergedError naming the joint and the body, here and at every later step; geoms
that overlap at ``qpos0`` in an engine with rigid contacts are named at load with their depth
against MuJoCo's own (the departure ``initial_penetration`` and an
InitialPenetrationWarning: dm_control's ``robot_arm.xml`` folded into itself); a contact
filter the engine cannot hold is refused by name at load (``drosophila_fused.xml``'s 55
groups on PhysX), never a non-finite state; ``<flag contact="disable"/>`` makes no contact.
"""

from __future__ import annotations

import importlib.util
import re
import warnings
from pathlib import Path

import mujoco
import numpy as np
import pytest
from _gaps import gap

import simbridge
from simbridge.exceptions import (
    BackendUnsupportedError,
    InitialPenetrationWarning,
    MjcfFeatureUnsupportedError,
    SimulationDivergedError,
)

# a pendulum under a position servo far too stiff for its time step: the explicit force
# overshoots 1e5-fold each step, on every engine (MuJoCo's kp is explicit too)
SERVO = """<mujoco><option timestep="0.01"/><worldbody>
<body name="pole" pos="0 0 1"><joint name="swing" type="hinge" axis="0 1 0"/>
<geom type="capsule" fromto="0 0 0 0 0 -0.5" size="0.05" mass="1"/></body></worldbody>
<actuator><position name="servo" joint="swing" kp="1e7"/></actuator></mujoco>"""
NAMED = re.escape("[0] (joint 'swing' of body 'pole')")


def _reads_mujoco(backend: str) -> None:
    if "mujoco" not in simbridge.registry.load_backend(backend).semantics:
        pytest.skip(f"{backend} does not read MJCF as MuJoCo does")


def _dm_control(relative: str) -> str:
    spec = importlib.util.find_spec("dm_control")
    if spec is None or spec.origin is None:
        pytest.skip("dm_control is not installed: pip install 'simbridge[mjcf-corpus]'")
    return str(Path(spec.origin).parent / relative)


def test_a_runaway_names_its_joint_and_stays_diverged(backend: str) -> None:
    _reads_mujoco(backend)
    with simbridge.Sim(backend) as sim:
        sim.load_mjcf(SERVO, semantics="mujoco")
        sim.set_actuator_controls([1.0])
        with pytest.raises(SimulationDivergedError, match=r"q(pos|vel|acc)" + NAMED) as caught:
            sim.step(20)
        at = float(re.search(r"diverged at t=([\d.]+) s", str(caught.value)).group(1))  # type: ignore[union-attr]
        assert at <= 0.05 + 1e-9  # within a few steps, not at the end of the call
        with pytest.raises(SimulationDivergedError) as again:
            sim.step(1)
        assert str(again.value) == str(caught.value)


def test_a_velocity_beyond_mujocos_bound_raises(backend: str) -> None:
    _reads_mujoco(backend)
    with simbridge.Sim(backend) as sim:
        sim.load_mjcf(SERVO, semantics="mujoco")
        sim.set_qpos_qvel(qvel=[1.5 * mujoco.mjMAXVAL])
        with pytest.raises(SimulationDivergedError, match=r"qvel" + NAMED + r".*1e10"):
            sim.step(1)
    with simbridge.Sim(backend) as sim:  # just inside MuJoCo's bound: a step, no error
        sim.load_mjcf(SERVO, semantics="mujoco")
        sim.set_qpos_qvel(qvel=[1e3])
        sim.step(1)
        assert np.isfinite(sim.qvel()).all()


def test_overlaps_at_load_are_named(backend: str) -> None:
    _reads_mujoco(backend)
    path = _dm_control("mjcf/test_assets/robot_arm.xml")
    with warnings.catch_warnings(record=True) as caught, simbridge.Sim(backend) as sim:
        warnings.simplefilter("always")
        sim.load_mjcf(path, semantics="mujoco")
        text = sim.manifest()["departures"].get("initial_penetration")
    warned = [w for w in caught if issubclass(w.category, InitialPenetrationWarning)]
    bound = gap(backend, "mjcf_initial_penetration")
    if bound is None:  # MuJoCo's own contacts, or an engine that cannot measure them
        assert text is None and not warned
        return
    assert text is not None and len(warned) == 1 and text in str(warned[0].message)
    # MuJoCo's own contacts at qpos0: 11, up to 6.07 cm deep ('b_base' in 'b_4')
    pairs = re.findall(r"'(\w+)'-'(\w+)' ([\d.]+) m \(MuJoCo: ([\d.]+) m\)", text)
    assert pairs[0][:2] == ("b_base", "b_4")
    m = mujoco.MjModel.from_xml_path(path)
    d = mujoco.MjData(m)
    mujoco.mj_forward(m, d)
    assert abs(float(pairs[0][2]) + d.contact.dist[: d.ncon].min()) < bound
    for _, _, engine, own in pairs:
        assert abs(float(engine) - float(own)) < bound


def test_a_model_clear_at_load_carries_no_overlap(backend: str) -> None:
    _reads_mujoco(backend)
    spec = importlib.util.find_spec("gymnasium")
    assert spec is not None and spec.origin is not None
    ant = Path(spec.origin).parent / "envs/mujoco/assets/ant.xml"
    with warnings.catch_warnings():
        warnings.simplefilter("error", InitialPenetrationWarning)
        with simbridge.Sim(backend) as sim:
            sim.load_mjcf(ant, semantics="mujoco")
            assert "initial_penetration" not in sim.manifest()["departures"]


def _chain(n: int) -> str:
    """A chain of ``n`` capsules below a body welded to the world, each a body of two hinges
    whose capsule starts inside its parent's end: MuJoCo filters each parent-child pair but
    the first (its parent is welded to the world), no two pairs in one group (``n - 1``
    groups). No gravity."""
    body = ""
    for k in reversed(range(n)):
        body = (
            f'<body name="link{k}" pos="0 0 -0.1"><joint type="hinge" axis="1 0 0"/>'
            '<joint type="hinge" axis="0 1 0"/><geom type="capsule" size="0.02" '
            f'fromto="0 0 0.01 0 0 -0.1"/>{body}</body>'
        )
    return (
        '<mujoco><option gravity="0 0 0"/><worldbody><body name="top" pos="0 0 4">'
        f'<geom type="sphere" size="0.02"/>{body}</body></worldbody></mujoco>'
    )


def _refused_or_finite(backend: str, source: str, groups: int) -> None:
    with simbridge.Sim(backend) as sim:
        try:
            sim.load_mjcf(source, semantics="mujoco")
        except BackendUnsupportedError as exc:
            if "groups" not in str(exc):  # another feature, refused by its name
                return
            assert isinstance(exc, MjcfFeatureUnsupportedError)
            needing = rf"contact exclusions needing {groups} groups; \w+ has 32 bits"
            assert re.search(needing, str(exc)) and "contype/conaffinity" in str(exc)
            return
        sim.step(5)
        assert np.isfinite(sim.qpos()).all() and np.isfinite(sim.qvel()).all()


@pytest.mark.parametrize("n", [33, 35])
def test_a_filter_the_engine_cannot_hold_is_refused_or_runs_finite(backend: str, n: int) -> None:
    """Each engine leaves out every pair MuJoCo filters, or refuses the model at load naming
    the groups it would need: 32 fit SAPIEN's ignore bits, 34 do not."""
    _reads_mujoco(backend)
    _refused_or_finite(backend, _chain(n), n - 1)
    if n == 33:  # every engine runs it
        with simbridge.Sim(backend) as sim:
            sim.load_mjcf(_chain(n), semantics="mujoco")


@pytest.mark.slow
def test_drosophila_is_refused_or_runs_finite(backend: str) -> None:
    """drosophila_fused.xml: 55 filtered pairs between bodies of two and three hinges, each
    its own group, whose meshes overlap at qpos0 (up to 0.2 units; 4-11 s to load)."""
    _reads_mujoco(backend)
    path = _dm_control("locomotion/walkers/assets/build_fruitfly/assets/drosophila_fused.xml")
    _refused_or_finite(backend, path, 55)


def test_contacts_disabled_by_the_file_make_none(backend: str) -> None:
    """dm_control's suite cartpole turns MuJoCo's contacts off (``<flag contact="disable"/>``):
    its rails run through the cart, 10 cm deep."""
    _reads_mujoco(backend)
    with warnings.catch_warnings():
        warnings.simplefilter("error", InitialPenetrationWarning)
        with simbridge.Sim(backend) as sim:
            sim.load_mjcf(_dm_control("suite/cartpole.xml"), semantics="mujoco")
            sim.set_actuator_controls([1.0])
            sim.step(20)
            assert len(sim.contact_points()) == 0
            assert abs(sim.qpos()[0]) > 1e-3  # the cart slides, rails or not
