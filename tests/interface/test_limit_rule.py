"""The joint-limit rule as an engine setting (``physx.limit_rule``, ``mujoco.limit_rule``):
PyBullet's rule on PhysX, PhysX's hard limit on MuJoCo, each default unchanged.

Known answers (slider.urdf under the "urdf" profile: no gravity along the rail, no damping, its
motor off; 1/240 s): the carriage reset at 0.38 m moving at 1 m/s reaches its 0.4 m limit in the
5th step. PyBullet's limit row exists only once a step starts at or past the limit, so that step
carries it to 0.38 + 5/240 = 0.400833 m (one step's travel ends 8.3e-4 m past the limit), and
the next steps push it back at 0.2 of that depth per step: -0.2 x 8.33e-4 x 240 = -0.04 m/s,
which it keeps. A hard limit ends the 5th step on the limit, 0.4 m, and holds it there.
``python bench/limit_rule.py`` measures the same on a KUKA (bench's figures in its output).
"""

from __future__ import annotations

import importlib.util

import numpy as np
import pytest

import simbridge
from simbridge import engine_settings as es
from simbridge.exceptions import InvalidEngineSettingError, InvalidProfileError

needs_sapien = pytest.mark.skipif(
    importlib.util.find_spec("sapien") is None, reason="the physx extra is not installed"
)
PHYSX = pytest.param("physx", marks=needs_sapien)
DT = 1.0 / 240.0
UPPER = 0.4
ARRIVAL = 0.38 + 5 * DT  # where one step's travel carries the carriage, 8.3e-4 m past
PUSH_BACK = -0.2 * (ARRIVAL - UPPER) / DT  # PyBullet's row: -0.04 m/s


def _slider(backend: str, rule: str | None = None, steps: int = 30) -> np.ndarray:
    """(position, speed) after each step; ``rule`` the backend's limit_rule (None: unset)."""
    profile = simbridge.get_profile("urdf")
    if rule is not None:
        profile = profile.with_engine(backend, limit_rule=rule)
    with simbridge.Sim(backend, profile=profile) as sim:
        body = sim.load_urdf("slider.urdf", fixed_base=True)
        sim.set_joint_velocity(body, 0, 0.0, max_force=0.0)
        sim.reset_joint_state(body, 0, 0.38, 1.0)
        out = np.empty((steps, 2))
        for k in range(steps):
            sim.step()
            js = sim.joint_states(body, [0])
            out[k] = js.positions[0], js.velocities[0]
        return out


def _passes_and_returns(run: np.ndarray, tol: float) -> None:
    """PyBullet's rule, the known answer above."""
    q, v = run[:, 0], run[:, 1]
    assert q[3] < UPPER  # step 4: short of the limit
    assert q[4] == pytest.approx(ARRIVAL, abs=tol)  # step 5: one step's travel past it
    assert 0.0 < q.max() - UPPER <= DT * 1.0 + tol  # never more than a step's travel
    assert v[5:] == pytest.approx(PUSH_BACK, abs=1e3 * tol)  # pushed back, and keeps going
    assert q[-1] == pytest.approx(ARRIVAL + PUSH_BACK * DT * (len(q) - 5), abs=10 * tol)


def _stops_on_the_limit(run: np.ndarray, tol: float) -> None:
    q, v = run[:, 0], run[:, 1]
    assert q.max() <= UPPER + tol  # never past
    assert q[4:] == pytest.approx(UPPER, abs=tol)  # on the limit from step 5 on
    assert v[5:] == pytest.approx(0.0, abs=1e3 * tol)


def test_pybullet_itself_passes_by_one_step_and_returns():
    _passes_and_returns(_slider("pybullet"), 1e-9)


@needs_sapien
def test_physx_pybullet_rule_passes_by_one_step_and_returns_as_pybullet():
    """PhysX's default stops the carriage on the limit; limit_rule "pybullet" gives the known
    answer, within float32 of PyBullet's run (measured 5.8e-7 m)."""
    _stops_on_the_limit(_slider("physx"), 1e-6)
    run = _slider("physx", "pybullet")
    _passes_and_returns(run, 2e-6)
    ref = _slider("pybullet")
    assert np.abs(run[:, 0] - ref[:, 0]).max() < 2e-6


def test_mujoco_hard_rule_stops_on_the_limit():
    """MuJoCo's default is PyBullet's rule (measured 1e-6 m from PyBullet); limit_rule "hard"
    stops the carriage on the limit, as PhysX's default does (within 2e-8 m: its rows are
    hardened, not polished)."""
    _passes_and_returns(_slider("mujoco"), 2e-6)
    _stops_on_the_limit(_slider("mujoco", "hard"), 1e-7)


@pytest.mark.parametrize("backend", ["mujoco", PHYSX])
def test_the_default_rule_given_explicitly_changes_nothing(backend):
    default = es.settings_for(backend)["limit_rule"].default
    np.testing.assert_array_equal(_slider(backend, default), _slider(backend))


@pytest.mark.parametrize(
    ("backend", "choices"), [("mujoco", "['pybullet', 'hard']"), ("physx", "['hard', 'pybullet']")]
)
def test_a_bad_limit_rule_names_the_valid_choices(backend, choices):
    with pytest.raises(InvalidEngineSettingError) as err:
        simbridge.get_profile("pybullet").with_engine(backend, limit_rule="soft")
    assert isinstance(err.value, InvalidProfileError)
    msg = str(err.value)
    assert f"{backend}.limit_rule" in msg and choices in msg and "'soft'" in msg
    with pytest.raises(InvalidEngineSettingError, match="limit_rule"):
        es.validate(backend, {"limit_rule": True})


def _kuka_falls(backend: str, rule: str | None) -> tuple[np.ndarray, float]:
    """KUKA's joint 2 released 0.3 rad from upright, the other joints held: gravity swings it
    into its upper limit in the 169th step (tests/compare/data/kuka-falls.toml)."""
    profile = simbridge.get_profile("pybullet")
    if rule is not None:
        profile = profile.with_engine(backend, limit_rule=rule)
    with simbridge.Sim(backend, profile=profile) as sim:
        body = sim.load_urdf("kuka_iiwa/model.urdf", fixed_base=True)
        others = [0, 2, 3, 4, 5, 6]
        sim.set_joint_position(body, others, [0.0] * 6, max_force=300.0)
        sim.set_joint_velocity(body, 1, 0.0, max_force=0.0)
        sim.reset_joint_state(body, 1, 0.3, 0.0)
        q = np.empty(200)
        for k in range(len(q)):
            sim.step()
            q[k] = sim.joint_states(body, [1]).positions[0]
        return q, sim.joint_info(body, 1).upper_limit


@pytest.mark.parametrize("backend", ["mujoco", PHYSX])
def test_a_chain_falling_into_a_limit_follows_the_rule(backend):
    """A joint of a chain arriving at its limit: PyBullet's joint passes it by 2.67e-2 rad (one
    step's travel at 6.4 rad/s) and is pushed back; under PyBullet's rule the engine does too
    (measured: PhysX 2.672e-2, within 5.8e-3 rad of PyBullet over the run; MuJoCo 7.5e-5);
    under the hard rule it stops on the limit (PhysX's float32 limit 5.8e-8 past)."""
    ref, upper = _kuka_falls("pybullet", None)
    assert ref.max() - upper == pytest.approx(2.673e-2, abs=1e-4)
    rules = {"physx": ("pybullet", "hard"), "mujoco": ("pybullet", "hard")}[backend]
    pyb, hard = (_kuka_falls(backend, r)[0] for r in rules)
    assert pyb.max() - upper == pytest.approx(ref.max() - upper, abs=1e-4)
    assert np.argmax(pyb) == np.argmax(ref) == 168  # the step it arrives in
    assert np.abs(pyb - ref).max() < 1e-2
    assert hard.max() - upper < 1e-7
    assert np.abs(hard - ref).max() > 3e-2  # the rule is what parts them
