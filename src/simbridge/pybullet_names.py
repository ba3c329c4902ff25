"""PyBullet's names of the Sim's calls: ``sim.getLinkState`` (or ``sim.get_link_state``) is an
AttributeError that names simbridge's call (README's table "The interface" lists them all)."""

from __future__ import annotations

import re

__all__ = ["EQUIVALENTS", "equivalent"]

# PyBullet's function -> what a Sim offers in its place
EQUIVALENTS: dict[str, str] = {
    "loadURDF": "sim.load_urdf",
    "loadMJCF": "sim.load_mjcf",
    "loadSDF": "sim.load_sdf",
    "getNumJoints": "sim.num_joints",
    "getJointInfo": "sim.joint_info (the whole table: sim.joints)",
    "getDynamicsInfo": "sim.dynamics_info",
    "getLinkState": "sim.link_state",
    "getLinkStates": "sim.link_state, one link at a time",
    "getBasePositionAndOrientation": "sim.base_state",
    "getBaseVelocity": "sim.base_state",
    "getJointState": "sim.joint_states",
    "getJointStates": "sim.joint_states",
    "getJointStateMultiDof": "sim.joint_states_multi_dof",
    "getJointStatesMultiDof": "sim.joint_states_multi_dof",
    "resetJointStateMultiDof": "sim.reset_joint_state_multi_dof",
    "resetJointStatesMultiDof": "sim.reset_joint_state_multi_dof",
    "setJointMotorControl2": "sim.set_joint_velocity, sim.set_joint_position or "
    "sim.set_joint_torque (one per control mode)",
    "setJointMotorControlArray": "sim.set_joint_velocity, sim.set_joint_position or "
    "sim.set_joint_torque (several joints at once); every step: sim.velocity_command, "
    "sim.position_command",
    "stepSimulation": "sim.step",
    "resetJointState": "sim.reset_joint_state",
    "resetJointStates": "sim.reset_joint_state",
    "resetBasePositionAndOrientation": "sim.reset_base_state",
    "resetBaseVelocity": "sim.reset_base_state",
    "removeBody": "sim.remove",
    "resetSimulation": "sim.reset",
    "getContactPoints": "sim.contact_points",
    "saveState": "sim.get_state",
    "restoreState": "sim.set_state",
    "getCameraImage": "sim.render",
    "setGravity": "Sim(gravity=...); read it as sim.gravity",
    "setTimeStep": "Sim(timestep=...); read it as sim.timestep",
    "disconnect": "sim.close",
    "getBodyInfo": "sim.body_name",
    "getNumBodies": "sim.bodies",
    "getBodyUniqueId": "sim.bodies",
}


def _snake(name: str) -> str:
    return re.sub(r"(?<=[a-z0-9])([A-Z])", r"_\1", name).lower()


_BY_NAME: dict[str, tuple[str, str]] = {}
for _pybullet, _ours in EQUIVALENTS.items():
    _BY_NAME[_pybullet] = (_pybullet, _ours)
    _BY_NAME.setdefault(_snake(_pybullet), (_pybullet, _ours))


def equivalent(name: str) -> tuple[str, str] | None:
    """(PyBullet's name, simbridge's equivalent) for ``name`` written in PyBullet's spelling or
    in snake case (``get_link_state``), or None."""
    return _BY_NAME.get(name)
