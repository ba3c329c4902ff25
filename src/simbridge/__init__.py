"""simbridge: write a robot simulation once, run it on PyBullet or MuJoCo, and measure where the
engines disagree.

``import simbridge`` imports no engine: backends load on first use.
"""

from __future__ import annotations

from simbridge import _moved, engine_settings, exceptions
from simbridge._version import __version__
from simbridge.exceptions import SimbridgeError
from simbridge.profiles import PROFILES, Profile, get_profile
from simbridge.registry import available_backends, register
from simbridge.sim import Sim
from simbridge.types import (
    ActuatorInfo,
    BaseState,
    BodyState,
    ContactPoint,
    DynamicsInfo,
    JointInfo,
    JointStateMultiDof,
    JointStates,
    JointType,
    LinkState,
    LinkStates,
    MotorMode,
    SiteState,
    WorldState,
)

__all__ = [
    "__version__",
    "Sim",
    "JointType",
    "JointInfo",
    "DynamicsInfo",
    "LinkState",
    "LinkStates",
    "BaseState",
    "JointStates",
    "JointStateMultiDof",
    "ContactPoint",
    "WorldState",
    "BodyState",
    "MotorMode",
    "ActuatorInfo",
    "SiteState",
    "Profile",
    "PROFILES",
    "get_profile",
    "available_backends",
    "register",
    "exceptions",
    "engine_settings",
    "SimbridgeError",
]

_moved.install()  # old module paths (simbridge.urdf...) still import, with a warning
