"""The divergence rule of a model read as MuJoCo reads it (``simbridge.model.mjcf_native``'s
``bad_coordinate``): a coordinate is bad where MuJoCo's own ``mj_step`` calls it bad (not
finite, or beyond ``mjMAXVAL`` = 1e10), and it is named by its joint and body at MuJoCo's
address, as MuJoCo's own warning names it."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest

from simbridge.model.mjcf_native import BAD_VALUE, bad_coordinate, coordinate_name

# a free body, a ball joint and a hinge: qpos 7 + 4 + 1, qvel 6 + 3 + 1
XML = """<mujoco><worldbody><body name="torso"><freejoint name="root"/>
<geom type="sphere" size="0.1"/><body name="upper" pos="0 0 -0.2">
<joint name="shoulder" type="ball"/><geom type="capsule" fromto="0 0 0 0 0 -0.3" size="0.03"/>
<body name="lower" pos="0 0 -0.3"><joint name="elbow" type="hinge" axis="0 1 0"/>
<geom type="capsule" fromto="0 0 0 0 0 -0.3" size="0.03"/></body></body></body>
</worldbody></mujoco>"""


@pytest.fixture(scope="module")
def model() -> mujoco.MjModel:
    return mujoco.MjModel.from_xml_string(XML)


@pytest.mark.parametrize(
    ("vector", "index", "named"),
    [
        ("qpos", 2, "qpos[2] (joint 'root' of body 'torso')"),
        ("qpos", 9, "qpos[9] (joint 'shoulder' of body 'upper')"),
        ("qpos", 11, "qpos[11] (joint 'elbow' of body 'lower')"),
        ("qvel", 5, "qvel[5] (joint 'root' of body 'torso')"),
        ("qvel", 6, "qvel[6] (joint 'shoulder' of body 'upper')"),
        ("qvel", 9, "qvel[9] (joint 'elbow' of body 'lower')"),
    ],
)
def test_a_bad_value_is_named_as_mujocos_own_step_names_it(
    model: mujoco.MjModel, vector: str, index: int, named: str
) -> None:
    d = mujoco.MjData(model)
    getattr(d, vector)[index] = 2.0 * BAD_VALUE
    assert bad_coordinate(model, d.qpos, d.qvel) == f"{named} = 2e+10"
    warning = (
        mujoco.mjtWarning.mjWARN_BADQPOS if vector == "qpos" else mujoco.mjtWarning.mjWARN_BADQVEL
    )
    mujoco.mj_step(model, d)  # MuJoCo's own rule: it warns at that address and resets
    assert d.warning[warning].number == 1
    assert coordinate_name(model, vector, int(d.warning[warning].lastinfo)) == named


def test_the_bound_is_mujocos(model: mujoco.MjModel) -> None:
    d = mujoco.MjData(model)
    d.qvel[9] = BAD_VALUE  # at the bound: MuJoCo steps on
    assert bad_coordinate(model, d.qpos, d.qvel) is None
    mujoco.mj_step(model, d)
    assert d.warning[mujoco.mjtWarning.mjWARN_BADQVEL].number == 0


def test_non_finite_values_are_counted(model: mujoco.MjModel) -> None:
    q, v = model.qpos0.copy(), np.zeros(model.nv)
    v[[3, 9]] = np.nan
    q[0] = -np.inf
    assert bad_coordinate(model, q, v) == (
        "qpos[0] (joint 'root' of body 'torso') = -inf (and 2 more values)"
    )
