"""PyBullet's function names on a Sim: each one gets simbridge's equivalent in its
AttributeError, or a NotOfferedError saying simbridge does not offer it yet and what to use
instead; the hints name calls that exist."""

from __future__ import annotations

import re

import pytest

import simbridge
from simbridge import transforms
from simbridge.exceptions import NotOfferedError
from simbridge.sim.pybullet_names import EQUIVALENTS, NOT_OFFERED


@pytest.fixture(scope="module")
def sim():
    with simbridge.Sim("pybullet") as s:
        yield s


def _pybullet_functions() -> list[str]:
    from _engines import require_backend

    require_backend("pybullet")  # a core engine: fails where missing
    import pybullet

    return [n for n in dir(pybullet) if not n.startswith("_") and callable(getattr(pybullet, n))]


def test_every_pybullet_function_gets_an_equivalent_or_a_not_offered_error(sim):
    names = _pybullet_functions()
    assert len(names) > 100, names  # the module's functions, not an empty list
    for name in names:
        with pytest.raises(AttributeError) as err:
            getattr(sim, name)
        if name in EQUIVALENTS:
            assert f"simbridge's equivalent of PyBullet's {name} is" in str(err.value)
        else:
            assert isinstance(err.value, NotOfferedError), (name, str(err.value))
            assert f"simbridge does not offer PyBullet's {name} yet" in str(err.value)
        assert not hasattr(sim, name)


@pytest.mark.parametrize(
    "name, instead",
    [
        ("applyExternalForce", "sim.set_joint_torque"),
        ("changeDynamics", "profile entries"),
        ("getQuaternionFromEuler", "simbridge.transforms.quat_from_rpy"),
        ("getQuaternionFromEuler", "scipy.spatial.transform.Rotation"),
        ("rayTest", "no ray casts"),
        ("createConstraint", "model the joint in the URDF"),
        ("calculateInverseKinematics", "sim.set_joint_position"),
        ("getAABB", "no bounding boxes"),
        ("setRealTimeSimulation", "not supported: step yourself with sim.step()"),
        ("get_quaternion_from_euler", "quat_from_rpy"),  # snake case too
        ("apply_external_force", "sim.set_joint_torque"),
    ],
)
def test_a_function_not_offered_says_so_and_what_to_use(sim, name, instead):
    with pytest.raises(NotOfferedError) as err:
        getattr(sim, name)
    text = str(err.value)
    assert text.startswith(f"'Sim' object has no attribute {name!r}: simbridge does not offer")
    assert instead in text, text


def test_the_tables_do_not_overlap_and_their_hints_name_what_exists(sim):
    assert not set(EQUIVALENTS) & set(NOT_OFFERED)
    for hint in [*EQUIVALENTS.values(), *NOT_OFFERED.values()]:
        for attr in re.findall(r"\bsim\.(\w+)", hint):
            assert hasattr(sim, attr), (attr, hint)
        for fn in re.findall(r"simbridge\.transforms\.(\w+)", hint):
            assert callable(getattr(transforms, fn, None)), (fn, hint)


def test_a_not_offered_error_pickles_as_itself():
    import pickle

    err = NotOfferedError("rayTest", "rayTest", "no ray casts")
    back = pickle.loads(pickle.dumps(err))
    assert type(back) is NotOfferedError and str(back) == str(err)
