"""PyBullet's names of the Sim's calls: ``sim.getLinkState`` (or ``sim.get_link_state``) is an
AttributeError that names simbridge's call (the table "The interface" in docs/sim.md lists them
all); a PyBullet function simbridge does not offer (``sim.applyExternalForce``) is a
:class:`~simbridge.exceptions.NotOfferedError` that says so and what to use instead, where
something exists. Every function of PyBullet's module is in one table or the other."""

from __future__ import annotations

import re

__all__ = ["EQUIVALENTS", "NOT_OFFERED", "equivalent", "not_offered"]

# PyBullet's function -> what a Sim offers in its place
EQUIVALENTS: dict[str, str] = {
    "loadURDF": "sim.load_urdf",
    "loadMJCF": "sim.load_mjcf",
    "loadSDF": "sim.load_sdf",
    "getNumJoints": "sim.num_joints",
    "getJointInfo": "sim.joint_info (the whole table: sim.joints)",
    "getDynamicsInfo": "sim.dynamics_info",
    "getLinkState": "sim.link_state",
    "getLinkStates": "sim.link_states",
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

_ROTATION = "scipy.spatial.transform.Rotation"
_TRANSFORMS = "simbridge.transforms"
_DEBUG_GUI = (
    "simbridge draws no debug items; Sim(backend, gui=True) opens the engine's viewer, "
    "sim.render(eye=..., target=...) draws a picture"
)
_USER_DATA = "simbridge keeps no user data on bodies: keep it in your own dict by body id"
_SHAPES = (
    "simbridge builds bodies from files only: write a URDF (or MJCF/SDF) and load it "
    "(sim.load_urdf, which also takes URDF text)"
)
_CONSTRAINTS = "simbridge has no constraints beyond a file's joints: model the joint in the URDF"
_DYNAMICS = (
    "profile entries (lateral_friction, restitution, linear_damping...: "
    "Sim(profile='pybullet+lateral_friction=0.9')) and engine settings "
    "(Sim(engine_settings={...}); `simbridge settings` lists them), for the whole world"
)
_QUERIES = "sim.contact_points lists the contacts of the last step"
_LOGGING = (
    "record what you need from sim.joint_states / sim.link_state / sim.base_state "
    "after each sim.step; simbridge compare writes whole trajectories"
)
_CAMERA = "sim.render(width, height, eye=..., target=..., up=..., fov=...) takes the camera itself"
_PLUGINS = "simbridge loads no engine plugins"
_NONE = ""  # nothing in simbridge does this

# PyBullet's functions simbridge does not offer (yet) -> what to use instead ("" for nothing)
NOT_OFFERED: dict[str, str] = {
    # forces and dynamics
    "applyExternalForce": "sim.set_joint_torque for a joint's force or torque; no force on a "
    "link yet",
    "applyExternalTorque": "sim.set_joint_torque for a joint's torque; no torque on a link yet",
    "changeDynamics": _DYNAMICS + "; a link's own values from its URDF <inertial> and <contact>",
    "setPhysicsEngineParameter": "Sim(timestep=..., profile=..., engine_settings={...}) "
    "(`simbridge settings pybullet` lists PyBullet's parameters there)",
    "getPhysicsEngineParameters": "sim.timestep, sim.gravity, sim.profile and "
    "sim.manifest()['engine_settings']",
    "setDefaultContactERP": "engine settings: Sim(engine_settings={'contactERP': ...}) "
    "(`simbridge settings pybullet`)",
    "setRealTimeSimulation": "not supported: step yourself with sim.step(), and "
    "sim.step(n, realtime=True) to pace the steps to the wall clock",
    "setTimeOut": _NONE,
    "setInternalSimFlags": _NONE,
    "enableJointForceTorqueSensor": "sim.joint_states reports each joint's applied torque",
    "calculateInverseDynamics": _NONE,
    "calculateInverseKinematics": "not yet: solve it outside (ikpy, pinocchio) from "
    "sim.joints and sim.link_state, then sim.set_joint_position",
    "calculateInverseKinematics2": "not yet: solve it outside (ikpy, pinocchio) from "
    "sim.joints and sim.link_state, then sim.set_joint_position",
    "calculateJacobian": "not yet: sim.link_state gives link poses and velocities",
    "calculateMassMatrix": "not yet: sim.dynamics_info gives each link's mass and inertia",
    "computeDofCount": "sim.joints (each joint's type) and sim.num_joints",
    # constraints
    "createConstraint": _CONSTRAINTS,
    "changeConstraint": _CONSTRAINTS,
    "removeConstraint": _CONSTRAINTS,
    "getConstraintInfo": _CONSTRAINTS,
    "getConstraintState": _CONSTRAINTS,
    "getConstraintUniqueId": _CONSTRAINTS,
    "getNumConstraints": _CONSTRAINTS,
    # collision queries
    "rayTest": "not yet: no ray casts; " + _QUERIES,
    "rayTestBatch": "not yet: no ray casts; " + _QUERIES,
    "getClosestPoints": "not yet: " + _QUERIES,
    "getOverlappingObjects": "not yet: " + _QUERIES,
    "getAABB": "not yet: no bounding boxes; sim.link_state gives link positions",
    "performCollisionDetection": "sim.step makes the contacts; " + _QUERIES,
    "setCollisionFilterGroupMask": "load_urdf(self_collision=...) for a body's own links; "
    "no collision filters between bodies",
    "setCollisionFilterPair": "load_urdf(self_collision=...) for a body's own links; "
    "no collision filters between bodies",
    # quaternions and transforms (no engine needed)
    "getQuaternionFromEuler": f"{_TRANSFORMS}.quat_from_rpy (x, y, z, w), or "
    f"{_ROTATION}.from_euler('xyz', rpy).as_quat()",
    "getEulerFromQuaternion": f"{_TRANSFORMS}.rpy_from_quat, or "
    f"{_ROTATION}.from_quat(q).as_euler('xyz')",
    "getMatrixFromQuaternion": f"{_TRANSFORMS}.matrix_from_quat_bullet (PyBullet's 3x3) or "
    f"{_TRANSFORMS}.quat_to_matrix",
    "getQuaternionFromAxisAngle": f"{_ROTATION}.from_rotvec(angle * axis).as_quat()",
    "getAxisAngleFromQuaternion": f"{_ROTATION}.from_quat(q).as_rotvec()",
    "getDifferenceQuaternion": f"{_TRANSFORMS}.quat_multiply and {_TRANSFORMS}.quat_conjugate",
    "getAxisDifferenceQuaternion": f"{_ROTATION}: (Rotation.from_quat(b) * "
    "Rotation.from_quat(a).inv()).as_rotvec()",
    "calculateVelocityQuaternion": f"{_ROTATION}.from_quat(q).as_rotvec() / dt",
    "getQuaternionSlerp": "scipy.spatial.transform.Slerp",
    "multiplyTransforms": f"{_TRANSFORMS}.transform_multiply",
    "invertTransform": f"{_TRANSFORMS}.transform_inverse",
    "rotateVector": f"{_TRANSFORMS}.quat_rotate",
    # building bodies
    "createCollisionShape": _SHAPES,
    "createCollisionShapeArray": _SHAPES,
    "createVisualShape": _SHAPES,
    "createVisualShapeArray": _SHAPES,
    "createMultiBody": _SHAPES,
    "removeCollisionShape": _SHAPES,
    "getCollisionShapeData": "not yet: a body's shapes are its file's <collision> elements",
    "getVisualShapeData": "not yet: a body's shapes are its file's <visual> elements",
    "changeVisualShape": _NONE,
    "resetVisualShapeData": _NONE,
    "changeTexture": _NONE,
    "loadTexture": _NONE,
    "unsupportedChangeScaling": "load_urdf(global_scaling=...) at load",
    "vhacd": "convex-decompose meshes outside simbridge (the vhacd or coacd tools)",
    "getMeshData": _NONE,
    "resetMeshData": _NONE,
    "getTetraMeshData": _NONE,
    "loadSoftBody": "simbridge simulates rigid bodies only",
    "createSoftBodyAnchor": "simbridge simulates rigid bodies only",
    "loadBullet": "sim.get_state / sim.set_state (a WorldState, which pickles)",
    "saveBullet": "sim.get_state / sim.set_state (a WorldState, which pickles)",
    "saveWorld": "sim.get_state / sim.set_state (a WorldState, which pickles)",
    "removeState": "drop the WorldState sim.get_state returned",
    "syncBodyInfo": "sim.bodies",
    "setAdditionalSearchPath": "pass a path to load_urdf, or a name on its search path "
    "(pybullet_data's files are found without it)",
    # joints
    "setJointMotorControl": "sim.set_joint_velocity, sim.set_joint_position or "
    "sim.set_joint_torque",
    "setJointMotorControlMultiDof": "sim.set_joint_velocity, sim.set_joint_position or "
    "sim.set_joint_torque (they take spherical joints)",
    "setJointMotorControlMultiDofArray": "sim.set_joint_velocity, sim.set_joint_position or "
    "sim.set_joint_torque (they take spherical joints)",
    # camera and debug GUI
    "computeViewMatrix": _CAMERA,
    "computeViewMatrixFromYawPitchRoll": _CAMERA,
    "computeProjectionMatrix": _CAMERA,
    "computeProjectionMatrixFOV": _CAMERA,
    "renderImage": _CAMERA,
    "getDebugVisualizerCamera": _DEBUG_GUI,
    "resetDebugVisualizerCamera": _DEBUG_GUI,
    "configureDebugVisualizer": _DEBUG_GUI,
    "addUserDebugLine": _DEBUG_GUI,
    "addUserDebugPoints": _DEBUG_GUI,
    "addUserDebugText": _DEBUG_GUI,
    "addUserDebugParameter": _DEBUG_GUI,
    "readUserDebugParameter": _DEBUG_GUI,
    "removeUserDebugItem": _DEBUG_GUI,
    "removeAllUserDebugItems": _DEBUG_GUI,
    "removeAllUserParameters": _DEBUG_GUI,
    "setDebugObjectColor": _DEBUG_GUI,
    "getKeyboardEvents": _DEBUG_GUI,
    "getMouseEvents": _DEBUG_GUI,
    "getVREvents": _DEBUG_GUI,
    "setVRCameraState": _DEBUG_GUI,
    # user data
    "addUserData": _USER_DATA,
    "getUserData": _USER_DATA,
    "getUserDataId": _USER_DATA,
    "getUserDataInfo": _USER_DATA,
    "getNumUserData": _USER_DATA,
    "removeUserData": _USER_DATA,
    "syncUserData": _USER_DATA,
    # the connection
    "connect": "simbridge.Sim(backend) is the connection (Sim('pybullet', gui=True) for p.GUI)",
    "isConnected": "not sim.closed",
    "getConnectionInfo": "sim.backend and sim.manifest()",
    "getAPIVersion": "simbridge.__version__ and sim.manifest()",
    "isNumpyEnabled": "simbridge returns numpy arrays where PyBullet returns tuples",
    "error": "simbridge raises its own errors: simbridge.exceptions",
    "startStateLogging": _LOGGING,
    "stopStateLogging": _LOGGING,
    "submitProfileTiming": "time the calls yourself (bench/calls.py times every call)",
    "executePluginCommand": _PLUGINS,
    "loadPlugin": _PLUGINS,
    "unloadPlugin": _PLUGINS,
}


def _snake(name: str) -> str:
    return re.sub(r"(?<=[a-z0-9])([A-Z])", r"_\1", name).lower()


_BY_NAME: dict[str, tuple[str, str]] = {}
for _pybullet, _ours in EQUIVALENTS.items():
    _BY_NAME[_pybullet] = (_pybullet, _ours)
    _BY_NAME.setdefault(_snake(_pybullet), (_pybullet, _ours))


_NOT_BY_NAME: dict[str, tuple[str, str]] = {}
for _pybullet, _instead in NOT_OFFERED.items():
    _NOT_BY_NAME[_pybullet] = (_pybullet, _instead)
    _NOT_BY_NAME.setdefault(_snake(_pybullet), (_pybullet, _instead))


def not_offered(name: str) -> tuple[str, str] | None:
    """What to say of a PyBullet function simbridge does not offer.

    Args:
        name: the name asked for, in PyBullet's spelling or in snake case.

    Returns:
        (PyBullet's name, what to use instead or ""), or None when ``name`` is no such
        function.
    """
    return _NOT_BY_NAME.get(name)


def equivalent(name: str) -> tuple[str, str] | None:
    """simbridge's equivalent of a PyBullet function.

    Args:
        name: the name asked for, in PyBullet's spelling or in snake case
            (``get_link_state``).

    Returns:
        (PyBullet's name, simbridge's equivalent), or None when ``name`` has none.
    """
    return _BY_NAME.get(name)
