"""The contract every backend implements.

:class:`simbridge.Sim` validates every argument and resolves every name before it calls a
backend, so a backend receives only checked values: body ids it returned, joint indices as
``np.intp`` arrays of movable joints (for commands) or of any joints (for reads; read-only,
cached by the caller: the same array object comes back for the same joints argument, so a
backend may key its own per-joint-set caches on ``id()``), links as ints (-1 = base), and
commands as lists of finite Python floats of the same length (the cheapest form to check and
to hand to an engine; copy them into your own buffers). A backend must:

* keep PyBullet's indices: joint i moves link i, the base is -1, links in the order of
  :func:`simbridge.urdf.parse_urdf`;
* report in PyBullet's frames and units (see :mod:`simbridge.types`), quaternions x, y, z, w;
* honour every entry of the :class:`~simbridge.profiles.Profile` it is given, and list what it
  cannot reproduce exactly in ``manifest()["departures"]``;
* keep velocity and position commands until replaced, and apply a torque command for the next
  step only (PyBullet's semantics);
* raise :class:`~simbridge.exceptions.SimulationDivergedError` from ``step`` when the state
  turns non-finite, and :class:`~simbridge.exceptions.BackendUnsupportedError` for anything it
  cannot do (never do nothing quietly).
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from typing import TYPE_CHECKING, Any, ClassVar

import numpy as np

from .profiles import Profile
from .types import BaseState, DynamicsInfo, JointInfo, JointStates, LinkState, Quat, Vec3

if TYPE_CHECKING:
    from .urdf import UrdfModel

__all__ = ["Backend"]


class Backend(ABC):
    """One engine behind the :class:`simbridge.Sim` interface."""

    name: ClassVar[str]

    def __init__(self, profile: Profile, gui: bool = False) -> None:
        self.profile = profile
        self.gui = gui

    def refuse_fixed_base_velocity(
        self, body: int, linear: Vec3 | None, angular: Vec3 | None
    ) -> None:
        """A fixed base takes a pose but no velocity: PyBullet would carry the welded base
        along at it, MuJoCo has nothing to carry; both refuse it alike."""
        from .exceptions import InvalidArgumentError

        if any(v != 0.0 for v in (*(linear or ()), *(angular or ()))):
            raise InvalidArgumentError(
                "linear_velocity/angular_velocity",
                f"body {body} has a fixed base, which takes no velocity on backend "
                f"{self.name!r} (PyBullet would move the welded base along; MuJoCo cannot): "
                "pass zeros or None",
            )

    def refuse_unsupported(
        self,
        integrators: tuple[str, ...] = ("semi-implicit Euler",),
        contact_models: tuple[str, ...] = ("stiff",),
        velocity_limit: bool = False,
    ) -> None:
        """Raise BackendUnsupportedError for a profile entry this engine has no switch for (the
        defaults: what both shipped backends reproduce), before any engine resource exists."""
        from .exceptions import BackendUnsupportedError

        p = self.profile
        if p.integrator not in integrators:
            raise BackendUnsupportedError(
                self.name, f"integrator {p.integrator!r}", f"valid: {list(integrators)}"
            )
        if p.contact_model not in contact_models:
            raise BackendUnsupportedError(
                self.name, f"contact_model {p.contact_model!r}", f"valid: {list(contact_models)}"
            )
        if p.friction_combine != "product" or p.restitution_combine != "product":
            raise BackendUnsupportedError(
                self.name, "friction/restitution combine rules other than 'product'"
            )
        if p.enforce_velocity_limit and not velocity_limit:
            raise BackendUnsupportedError(
                self.name,
                "enforce_velocity_limit=True",
                "PyBullet never clamps to <limit velocity>; use max_joint_velocity",
            )

    # ---------------------------------------------------------------- world

    @property
    @abstractmethod
    def time(self) -> float:
        """Simulated time in seconds since creation or the last reset."""

    @abstractmethod
    def load(
        self,
        model: UrdfModel,
        base_position: Vec3,
        base_orientation: Quat,
        fixed_base: bool,
    ) -> int:
        """Add the robot to the world; return its body id.

        ``base_position``/``base_orientation`` place the root's URDF link frame (not its centre
        of mass), as ``p.loadURDF`` does.
        """

    @abstractmethod
    def remove(self, body: int) -> None:
        """Remove a body; its id is not reused."""

    @abstractmethod
    def reset(self) -> None:
        """Remove every body and set time to 0 (``p.resetSimulation``)."""

    @abstractmethod
    def step(self, n: int) -> None:
        """Advance ``n`` fixed steps."""

    @abstractmethod
    def close(self) -> None:
        """Release the engine; must be safe to call twice."""

    # ---------------------------------------------------------------- tables

    @abstractmethod
    def joint_info(self, body: int, joint: int) -> JointInfo:
        """Row ``joint`` of the joint table (all 17 fields of ``getJointInfo``)."""

    @abstractmethod
    def num_joints(self, body: int) -> int: ...

    @abstractmethod
    def dynamics_info(self, body: int, link: int) -> DynamicsInfo:
        """Mass, friction and inertia as the engine actually simulates them (after the
        profile's inertia source and friction defaults were applied)."""

    # ---------------------------------------------------------------- state

    @abstractmethod
    def link_state(self, body: int, link: int) -> LinkState: ...

    @abstractmethod
    def base_state(self, body: int) -> BaseState: ...

    @abstractmethod
    def joint_states(self, body: int, joints: np.ndarray) -> JointStates:
        """``joints`` is an ``np.intp`` array (any joint types; fixed joints report zeros)."""

    @abstractmethod
    def reset_joint_state(
        self, body: int, joints: np.ndarray, positions: list[float], velocities: list[float]
    ) -> None:
        """Teleport movable joints (``p.resetJointState``); commands are kept."""

    @abstractmethod
    def reset_base_state(
        self,
        body: int,
        position: Vec3 | None,
        orientation: Quat | None,
        linear_velocity: Vec3 | None,
        angular_velocity: Vec3 | None,
    ) -> None:
        """Teleport the base; position/orientation are the base's centre-of-mass frame, as in
        ``p.resetBasePositionAndOrientation``; None keeps the current value."""

    # ---------------------------------------------------------------- control

    @abstractmethod
    def set_joint_velocity(
        self, body: int, joints: np.ndarray, target: list[float], max_force: list[float]
    ) -> None:
        """VELOCITY_CONTROL: a motor that reaches ``target`` within one step if a force of at
        most ``max_force`` can; persists until replaced."""

    @abstractmethod
    def set_joint_position(
        self,
        body: int,
        joints: np.ndarray,
        target: list[float],
        max_force: list[float],
        kp: list[float],
        kd: list[float],
    ) -> None:
        """POSITION_CONTROL: PyBullet's law, target velocity ``kp (q* - q) / dt`` with velocity
        gain ``kd``, force clamped to ``max_force``; persists until replaced."""

    @abstractmethod
    def set_joint_torque(self, body: int, joints: np.ndarray, torque: list[float]) -> None:
        """TORQUE_CONTROL: added during the next step only. As in PyBullet it does not remove
        the joint's motor: under the "pybullet" profile the default brake cancels small torques
        until ``set_joint_velocity(..., max_force=0)`` releases it."""

    # ---------------------------------------------------------------- description

    def manifest(self) -> dict[str, Any]:
        """Engine name and version, native defaults, and departures from the profile."""
        return {"backend": self.name, "engine_version": "unknown", "departures": {}}
