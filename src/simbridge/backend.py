"""The contract every backend implements.

:class:`simbridge.Sim` validates every argument and resolves every name before it calls a
backend, so a backend receives only checked values: body ids it returned, joint indices as
``np.intp`` arrays of movable joints (for commands) or of any joints (for reads; read-only,
cached by the caller: the same array object comes back for the same joints argument, so a
backend may key its own per-joint-set caches on ``id()``), links as ints (-1 = base), and
commands as lists of finite Python floats of the same length (the cheapest form to check and
to hand to an engine; copy them into your own buffers). A backend must:

* keep PyBullet's indices: joint i moves link i, the base is -1, links in the order of
  :func:`simbridge.model.urdf.parse_urdf`;
* report in PyBullet's frames and units (see :mod:`simbridge.types`), quaternions x, y, z, w;
* honour every entry of the :class:`~simbridge.profiles.Profile` it is given, and list what it
  cannot reproduce exactly in ``manifest()["departures"]``;
* keep velocity and position commands until replaced, and apply a torque command for the next
  step only (PyBullet's semantics);
* raise :class:`~simbridge.exceptions.SimulationDivergedError` from ``step`` when the state
  turns non-finite, and :class:`~simbridge.exceptions.BackendUnsupportedError` for anything it
  cannot do (never do nothing quietly).

Over 600 lines on purpose: :class:`Backend` is one contract, and its methods' docstrings (their
arguments, returns and errors) are what the author of a new engine reads, in one place.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Sequence
from contextlib import AbstractContextManager, nullcontext
from typing import TYPE_CHECKING, Any, ClassVar

import numpy as np

from simbridge.profiles import Profile
from simbridge.types import (
    LINK_STATE_WIDTH,
    BaseState,
    ContactPoint,
    DynamicsInfo,
    JointCommands,
    JointInfo,
    JointStateMultiDof,
    JointStates,
    LinkState,
    LinkStates,
    MotorMode,
    Quat,
    SphericalJointState,
    Vec3,
)

if TYPE_CHECKING:
    from simbridge.bound import BoundCommand
    from simbridge.model.load_options import LoadOptions
    from simbridge.model.mjcf_native import NativeMjcf
    from simbridge.model.scene import SceneBody
    from simbridge.model.urdf import UrdfModel

__all__ = ["NATIVE_ONLY", "Backend"]

# What a backend without MuJoCo's reading of MJCF says (BackendUnsupportedError's what, hint)
NATIVE_ONLY = (
    "MJCF read as MuJoCo reads it (load_mjcf(..., semantics='mujoco')) and its calls",
    "it runs on the 'mujoco', 'pybullet' and 'physx' backends: Sim('mujoco'); "
    "semantics='pybullet' (PyBullet's reading) runs on every backend",
)


class Backend(ABC):
    """One engine behind the :class:`simbridge.Sim` interface.

    A subclass sets :attr:`name`, implements every abstract method and overrides the optional
    ones it supports (the defaults raise
    :class:`~simbridge.exceptions.BackendUnsupportedError`). Each method's Args, Returns and
    Raises below are what a new backend must honour.

    Args:
        profile: The physics settings to reproduce (time step, gravity, solver, defaults).
        gui: Whether to open the engine's window.
    """

    name: ClassVar[str]
    state_dtype: ClassVar[str] = "float64"
    """The floating-point type the engine keeps its state in (positions, orientations,
    velocities): ``"float64"`` (PyBullet, MuJoCo: the default) or ``"float32"`` (PhysX). A
    declared fact, read without making an engine (:func:`simbridge.registry.state_dtype`).
    What compare does with it: docs/compare.md, "A float32 engine's perturbation"."""
    semantics: ClassVar[tuple[str, ...]] = ("pybullet",)
    """The readings of an MJCF file this backend runs (``Sim.load_mjcf(semantics=...)``):
    ``"pybullet"`` (PyBullet's importer, every backend) and, where :meth:`mjcf_world` is
    implemented, ``"mujoco"`` (MuJoCo's compiler). A declared fact, read before the file is."""

    def __init__(self, profile: Profile, gui: bool = False) -> None:
        self.profile = profile
        self.gui = gui

    def refuse_fixed_base_velocity(
        self, body: int, linear: Vec3 | None, angular: Vec3 | None
    ) -> None:
        """Refuse a non-zero velocity for a fixed base, which takes a pose but no velocity.

        PyBullet would carry the welded base along at it, MuJoCo has nothing to carry; both
        refuse it alike.

        Args:
            body: The body's id (for the message).
            linear: The base's linear velocity asked for (m/s, world), or None.
            angular: The base's angular velocity asked for (rad/s, world), or None.

        Raises:
            InvalidArgumentError: When a component of either velocity is not 0.
        """
        from simbridge.exceptions import InvalidArgumentError

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
        """Refuse a profile entry this engine has no switch for, before any engine resource
        exists.

        Args:
            integrators: The ``Profile.integrator`` values this engine reproduces (the
                default: what both shipped backends reproduce).
            contact_models: The ``Profile.contact_model`` values it reproduces.
            velocity_limit: Whether it can honour ``enforce_velocity_limit=True``.

        Raises:
            BackendUnsupportedError: For an integrator or contact model not listed, a
                friction or restitution combine rule other than ``"product"``, or
                ``enforce_velocity_limit`` without ``velocity_limit``.
        """
        from simbridge.exceptions import BackendUnsupportedError

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
        options: LoadOptions,
    ) -> int:
        """Add the robot to the world.

        ``model`` is already scaled by ``options.global_scaling`` and has its fixed links
        merged when ``options.merge_fixed_links``: a backend that builds its engine model from
        ``model`` uses it as it is; one whose engine reads the file itself passes both on to it
        (and its link order must then be ``model``'s). Every backend honours
        ``options.inertia_source`` and ``options.self_collision`` for this body in place of the
        profile's entries.

        Args:
            model: The parsed robot (links in PyBullet's order).
            base_position: Where the root's URDF link frame goes (m, world; not its centre of
                mass), as ``p.loadURDF`` does.
            base_orientation: The root link frame's orientation, a unit quaternion (x, y, z,
                w).
            fixed_base: Whether the base is welded to the world.
            options: ``loadURDF``'s options (:mod:`simbridge.model.load_options`).

        Returns:
            The new body's id (never one used before in this world).

        Raises:
            BackendUnsupportedError: For a joint type or option this engine cannot build.
        """

    def load_scene(self, bodies: Sequence[SceneBody], options: LoadOptions) -> list[int]:
        """Add every body of one MJCF or SDF file.

        The default loads each body through :meth:`load` (removing the ones loaded when one
        fails); a backend whose engine reads the file itself (PyBullet's
        ``loadMJCF``/``loadSDF``) overrides it, and its bodies' joint tables must then equal
        the models' (names included).

        Args:
            bodies: :func:`simbridge.model.scene_reader.parse_scene`'s bodies, in PyBullet's
                order, each with its links, joints and numbering, and with
                ``base_position``/``base_orientation`` placing its root link frame (its base
                is fixed when the root's mass is 0).
            options: The self-collision mode; the inertia source is ``"collision_aabb"``.

        Returns:
            The new bodies' ids, in ``bodies``' order.
        """
        ids: list[int] = []
        try:
            for body in bodies:
                ids.append(
                    self.load(body, body.base_position, body.base_orientation, False, options)
                )
        except BaseException:
            for body_id in reversed(ids):
                self.remove(body_id)
            raise
        return ids

    @abstractmethod
    def remove(self, body: int) -> None:
        """Remove a body; its id is not reused.

        Args:
            body: An id :meth:`load` returned, not yet removed.
        """

    @abstractmethod
    def reset(self) -> None:
        """Remove every body and set time to 0 (``p.resetSimulation``)."""

    @abstractmethod
    def step(self, n: int) -> None:
        """Advance ``n`` fixed steps of the profile's time step.

        Args:
            n: How many steps (>= 1).

        Raises:
            SimulationDivergedError: When the state turned non-finite (after the step that
                did it with ``set_divergence_check(True)``, else up to 7 steps late).
        """

    @abstractmethod
    def close(self) -> None:
        """Release the engine; must be safe to call twice."""

    # ---------------------------------------------------------------- tables

    @abstractmethod
    def joint_info(self, body: int, joint: int) -> JointInfo:
        """Row ``joint`` of the joint table.

        Args:
            body: A loaded body's id.
            joint: The joint's index (0 <= joint < :meth:`num_joints`).

        Returns:
            All 17 fields of ``getJointInfo``, equal to the model's joint table.
        """

    @abstractmethod
    def num_joints(self, body: int) -> int:
        """How many joints ``body`` has (fixed ones included; as many as it has links).

        Args:
            body: A loaded body's id.

        Returns:
            The number of joints.
        """

    @abstractmethod
    def dynamics_info(self, body: int, link: int) -> DynamicsInfo:
        """Mass, friction and inertia of one link as the engine actually simulates them.

        Args:
            body: A loaded body's id.
            link: The link's index (-1 = base).

        Returns:
            The values after the profile's inertia source and friction defaults were applied
            (kg, kg·m² in the link's inertial frame).
        """

    # ---------------------------------------------------------------- state

    @abstractmethod
    def link_state(self, body: int, link: int) -> LinkState:
        """One link's pose and velocity as they stand now.

        Args:
            body: A loaded body's id.
            link: The link's index (0 <= link < :meth:`num_joints`; the base is read with
                :meth:`base_state`).

        Returns:
            ``p.getLinkState``'s fields with link velocity and forward kinematics (world
            frame, m, m/s, rad/s, quaternions x, y, z, w).
        """

    def link_states(self, body: int, links: np.ndarray) -> LinkStates:
        """Several links' poses and velocities as they stand now, read in one pass.

        The default reads each link with :meth:`link_state`; a backend overrides it with its
        engine's batched read. Row k must hold the very floats ``link_state(body, links[k])``
        returns (the conformance suite checks it bit for bit).

        Args:
            body: A loaded body's id.
            links: ``(n,)`` ``np.intp`` link indices, -1 (the base) allowed, no index twice
                (read-only, cached by the caller: the same array object for the same links).

        Returns:
            A :class:`~simbridge.types.LinkStates` of ``(n, 3)``/``(n, 4)`` float64 arrays in
            ``links``' order (world frame, m, m/s, rad/s, quaternions x, y, z, w).

        Raises:
            SimulationDivergedError: As :meth:`link_state`.
        """
        block = np.empty((len(links), LINK_STATE_WIDTH))
        for k, link in enumerate(links.tolist()):
            s = self.link_state(body, link)
            block[k] = (*s[0], *s[1], *s[2], *s[3], *s[4], *s[5], *s[6], *s[7])
        return LinkStates.of(block)

    @abstractmethod
    def base_state(self, body: int) -> BaseState:
        """The base's centre-of-mass pose and velocity.

        Args:
            body: A loaded body's id.

        Returns:
            Position (m), orientation (x, y, z, w), linear (m/s) and angular (rad/s) velocity,
            world frame.
        """

    @abstractmethod
    def joint_states(self, body: int, joints: np.ndarray) -> JointStates:
        """Positions, velocities and last-step motor torques of ``joints``.

        Args:
            body: A loaded body's id.
            joints: (n,) ``np.intp`` joint indices, any joint types (read-only, cached by the
                caller).

        Returns:
            Three (n,) float arrays in ``joints``' order (rad or m, rad/s or m/s, N·m or N);
            fixed joints report zeros, a spherical joint its first coordinate.
        """

    @abstractmethod
    def reset_joint_state(
        self, body: int, joints: np.ndarray, positions: list[float], velocities: list[float]
    ) -> None:
        """Teleport movable joints (``p.resetJointState``); commands are kept.

        Args:
            body: A loaded body's id.
            joints: (n,) ``np.intp`` indices of movable 1-DoF joints.
            positions: n positions (rad or m).
            velocities: n velocities (rad/s or m/s).
        """

    @abstractmethod
    def reset_base_state(
        self,
        body: int,
        position: Vec3 | None,
        orientation: Quat | None,
        linear_velocity: Vec3 | None,
        angular_velocity: Vec3 | None,
    ) -> None:
        """Teleport the base, as ``p.resetBasePositionAndOrientation`` and
        ``p.resetBaseVelocity``; None keeps the current value.

        Args:
            body: A loaded body's id.
            position: The base's centre of mass (m, world), or None.
            orientation: The base's inertial frame, a unit quaternion (x, y, z, w), or None.
            linear_velocity: m/s, world, or None.
            angular_velocity: rad/s, world, or None.

        Raises:
            InvalidArgumentError: A non-zero velocity for a fixed base
                (:meth:`refuse_fixed_base_velocity`).
        """

    # ---------------------------------------------------------------- control

    @abstractmethod
    def set_joint_velocity(
        self, body: int, joints: np.ndarray, target: list[float], max_force: list[float]
    ) -> None:
        """VELOCITY_CONTROL: a motor that reaches ``target`` within one step if a force of at
        most ``max_force`` can; persists until replaced.

        Args:
            body: A loaded body's id.
            joints: (n,) ``np.intp`` indices of movable 1-DoF joints.
            target: n target velocities (rad/s or m/s).
            max_force: n force limits (N·m or N, >= 0; 0 releases the joint).
        """

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
        gain ``kd``, force clamped to ``max_force``; persists until replaced.

        Args:
            body: A loaded body's id.
            joints: (n,) ``np.intp`` indices of movable 1-DoF joints.
            target: n target positions (rad or m).
            max_force: n force limits (N·m or N, >= 0).
            kp: n position gains (PyBullet's ``positionGain``, >= 0).
            kd: n velocity gains (PyBullet's ``velocityGain``, >= 0).
        """

    @abstractmethod
    def set_joint_torque(self, body: int, joints: np.ndarray, torque: list[float]) -> None:
        """TORQUE_CONTROL: added during the next step only. As in PyBullet it does not remove
        the joint's motor: under the "pybullet" profile the default brake cancels small torques
        until ``set_joint_velocity(..., max_force=0)`` releases it.

        Args:
            body: A loaded body's id.
            joints: (n,) ``np.intp`` indices of movable 1-DoF joints.
            torque: n torques or forces (N·m or N); several in one step add up.
        """

    # ---------------------------------------------------------------- multi-DoF joints
    # Not abstract: a backend without spherical joints refuses them at load and these calls
    # (BackendUnsupportedError). The Sim checks and normalises every value (simbridge.spherical).

    def joint_states_multi_dof(self, body: int, joints: np.ndarray) -> list[JointStateMultiDof]:
        """Every coordinate of each of ``joints`` (``p.getJointStatesMultiDof``).

        Args:
            body: A loaded body's id.
            joints: (n,) ``np.intp`` joint indices, any types.

        Returns:
            n states in ``joints``' order: a spherical joint's quaternion (x, y, z, w: the
            child's inertial frame turned from its zero pose), angular velocity in the child's
            inertial frame (rad/s) and its motor's torque per axis of that frame (N·m); a
            revolute or prismatic joint's 1-tuples; a fixed joint's empty tuples.

        Raises:
            BackendUnsupportedError: The default, for a backend without spherical joints.
        """
        from simbridge.exceptions import BackendUnsupportedError

        raise BackendUnsupportedError(self.name, "multi-DoF joint states")

    def reset_joint_state_multi_dof(
        self,
        body: int,
        joints: np.ndarray,
        positions: list[list[float]],
        velocities: list[list[float]],
    ) -> None:
        """Teleport movable ``joints`` (``p.resetJointStateMultiDof``); commands are kept.

        Args:
            body: A loaded body's id.
            joints: (n,) ``np.intp`` indices of movable joints.
            positions: Per joint its coordinates: a spherical joint's unit quaternion (x, y,
                z, w), a 1-DoF joint's 1 value (rad or m).
            velocities: Per joint its velocities: a spherical joint's 3 (rad/s, child's
                inertial frame), a 1-DoF joint's 1.

        Raises:
            BackendUnsupportedError: The default, for a backend without spherical joints.
        """
        from simbridge.exceptions import BackendUnsupportedError

        raise BackendUnsupportedError(self.name, "multi-DoF joint resets")

    def set_joint_motor_multi_dof(
        self,
        body: int,
        joints: np.ndarray,
        mode: MotorMode,
        targets: list[list[float]],
        max_force: list[list[float]],
        kp: list[list[float]],
        kd: list[list[float]],
    ) -> None:
        """PyBullet's spherical joint motor on spherical ``joints``, per axis of the child's
        inertial frame (see :mod:`simbridge.spherical`). Persists until replaced.

        Args:
            body: A loaded body's id.
            joints: (n,) ``np.intp`` indices of spherical joints.
            mode: POSITION (towards ``targets``) or VELOCITY (a brake: target velocity 0, kp
                0, kd 1).
            targets: n unit quaternions (x, y, z, w); the identity, unused, for VELOCITY.
            max_force: n triples, per axis (N·m, >= 0; 0 releases an axis).
            kp: n triples of position gains.
            kd: n triples of velocity gains (PyBullet's ``damping``).

        Raises:
            BackendUnsupportedError: The default, for a backend without spherical joints.
        """
        from simbridge.exceptions import BackendUnsupportedError

        raise BackendUnsupportedError(self.name, "spherical joint motors")

    def set_joint_torque_multi_dof(
        self, body: int, joints: np.ndarray, torques: list[list[float]]
    ) -> None:
        """TORQUE_CONTROL on spherical ``joints``, added during the next step only (they add
        up, as 1-DoF torques).

        Args:
            body: A loaded body's id.
            joints: (n,) ``np.intp`` indices of spherical joints.
            torques: n triples, about the child's inertial frame axes (N·m).

        Raises:
            BackendUnsupportedError: The default, for a backend without spherical joints.
        """
        from simbridge.exceptions import BackendUnsupportedError

        raise BackendUnsupportedError(self.name, "spherical joint torques")

    def spherical_states(self, body: int) -> list[SphericalJointState]:
        """The full state and motor of every spherical joint of ``body``.

        ``joint_commands`` reports these joints' first axis only, and ``set_joint_commands``
        leaves them as they are: this and :meth:`set_spherical_states` carry them
        (``Sim.get_state``/``set_state``).

        Args:
            body: A loaded body's id.

        Returns:
            One state per spherical joint, in joint order: its coordinates, the motor in force
            (a position motor, or a brake read back as VELOCITY) and the torques pending for
            the next step.

        Raises:
            BackendUnsupportedError: The default, for a backend without spherical joints.
        """
        from simbridge.exceptions import BackendUnsupportedError

        raise BackendUnsupportedError(self.name, "the state of spherical joints (get_state)")

    def set_spherical_states(
        self, body: int, states: list[SphericalJointState], positions: bool
    ) -> None:
        """Make each of ``states`` the motor in force and the pending torques of its joint,
        replacing both.

        Args:
            body: A loaded body's id.
            states: Checked states (unit quaternions, finite values, forces and gains >= 0).
            positions: Whether to also teleport each joint to its position and velocity (False
                after a bit-exact :meth:`restore`).

        Raises:
            BackendUnsupportedError: The default, for a backend without spherical joints.
        """
        from simbridge.exceptions import BackendUnsupportedError

        raise BackendUnsupportedError(self.name, "setting the state of spherical joints")

    # ---------------------------------------------------------------- bound commands
    # Not abstract: the default (the Sim sends a bound command before every step through
    # set_joint_velocity / set_joint_position) is right for every backend; a backend whose
    # step can read the arrays itself overrides both.

    def bind_command(self, command: BoundCommand) -> bool:
        """Take a bound command (``Sim.velocity_command``/``position_command``).

        Its ``targets`` and ``max_force`` are the command of ``command.joints`` at every step,
        as if ``set_joint_velocity`` (or ``set_joint_position`` with ``command.kp``,
        ``command.kd``) were called with them just before it. The Sim has checked the joints
        and sent the first values; while bound, no other velocity or position command reaches
        these joints. The Sim calls :meth:`unbind_command` before any world change (load,
        remove, reset) and after ``close``.

        Args:
            command: The bound command; ``targets`` and ``max_force`` are (n,) float64 arrays,
                n = ``len(command.joints)``, owned by the command and written in place by the
                user.

        Returns:
            False (the default) to have the Sim call ``command.send()`` (which checks the
            values and calls ``set_joint_*``) before every ``step``; True when this backend's
            ``step`` reads the arrays itself, before it steps: a change must then give the same
            results as that call, bit for bit, and a value ``send()`` would refuse
            (non-finite, a negative force) must go through ``send()`` so that it raises before
            any step.
        """
        return False

    def unbind_command(self, command: BoundCommand) -> None:
        """Stop reading ``command``'s arrays; its joints keep the command last sent.

        Args:
            command: A command :meth:`bind_command` took.
        """
        return None  # the default binding keeps nothing: the Sim stops sending it

    def reading(self) -> AbstractContextManager[None]:
        """The context a read or a write made of several calls runs inside.

        ``Sim.get_state`` and ``Sim.set_state`` run inside it: a step that another thread
        begins meanwhile must make it raise SimBusyError, or wait for its end, never let the
        parts come from two steps (the built-in backends hold the Sim's lock). The default
        holds nothing: a backend whose step cannot run while a read does (no step releases
        the GIL) needs nothing more.

        Returns:
            A context manager guarding the read or write.
        """
        return nullcontext()

    def set_divergence_check(self, every_step: bool) -> None:
        """Set ``Sim(divergence_check=...)``; called once, before anything is loaded.

        Args:
            every_step: True for "every_step" (``step`` raises SimulationDivergedError after
                the step that left a non-finite state), False for "periodic" (every read
                checks what it returns; ``step`` may notice up to 7 steps late).

        Raises:
            BackendUnsupportedError: For True on a backend that cannot check every step (the
                default).
        """
        if every_step:
            from simbridge.exceptions import BackendUnsupportedError

            raise BackendUnsupportedError(
                self.name, 'divergence_check="every_step"', "valid here: ['periodic']"
            )

    # ---------------------------------------------------------------- description

    def manifest(self) -> dict[str, Any]:
        """What this engine is and where it departs from the profile.

        Returns:
            A JSON-serialisable dict: at least ``"backend"`` (its name), ``"engine_version"``
            and ``"departures"`` (profile entry -> what the engine does instead), plus its
            native defaults.
        """
        return {"backend": self.name, "engine_version": "unknown", "departures": {}}

    # ---------------------------------------------------------------- contacts and state
    # Not abstract: a backend without them refuses these calls (BackendUnsupportedError).

    def contact_points(self) -> list[ContactPoint]:
        """Every contact point the last step solved, each once.

        Returns:
            The points, A and B in the engine's own order (the Sim filters and orients them):
            links as PyBullet's indices (-1 = base), forces in N, and the friction fields the
            friction force on A (see :class:`~simbridge.types.ContactPoint`). Empty before
            the first step.

        Raises:
            BackendUnsupportedError: The default, for a backend without contacts.
        """
        from simbridge.exceptions import BackendUnsupportedError

        raise BackendUnsupportedError(self.name, "contact points")

    def external_forces(self, body: int) -> np.ndarray:
        """The contact wrench on each link of ``body`` in the last step (MuJoCo's
        ``cfrc_ext`` convention, :mod:`simbridge.wrenches`).

        The default derives it from :meth:`contact_points` (normal and friction forces at each
        point), the torques about :meth:`body_centre_of_mass`: a backend that reads its
        engine's own wrench (MuJoCo's ``cfrc_ext``) overrides it.

        Args:
            body: A loaded body's id.

        Returns:
            ``(links + 1, 6)`` float64, the base's row first, then link ``i`` at row ``i + 1``:
            torque (N m) then force (N), world frame, the torque about the body's centre of
            mass.

        Raises:
            BackendUnsupportedError: A backend without contact points.
        """
        from simbridge.wrenches import external_wrenches

        with self.reading():
            rows = self.num_joints(body) + 1
            centre = self.body_centre_of_mass(body)
            points = self.contact_points()

        def row_of(b: int, link: int) -> int:
            return link + 1 if b == body else -1

        return external_wrenches(points, row_of, rows, centre)

    def body_centre_of_mass(self, body: int) -> np.ndarray:
        """The centre of mass of the whole body, the point :meth:`external_forces` takes its
        torques about.

        The default: the mass-weighted mean of the base's and the links' centres of mass
        (:meth:`base_state`, :meth:`link_state`, :meth:`dynamics_info`).

        Args:
            body: A loaded body's id.

        Returns:
            ``(3,)`` (m, world); the base's centre of mass for a body without mass.
        """
        from simbridge.wrenches import centre_of_mass

        n = self.num_joints(body)
        masses = [self.dynamics_info(body, link).mass for link in range(-1, n)]
        centres = [self.base_state(body).position]
        centres += [self.link_state(body, link).com_position for link in range(n)]
        return centre_of_mass(masses, centres)

    def joint_commands(self, body: int) -> JointCommands:
        """The motor in force and the torque pending for the next step of every joint.

        Args:
            body: A loaded body's id.

        Returns:
            (n,) arrays over all n joints of ``body`` (fixed joints: mode NONE, zeros). A
            motor set by a velocity command reads back as VELOCITY with kp 0 and kd 1, one set
            by a position command as POSITION (the default brake: VELOCITY, target 0, the
            profile's brake force); ``max_force`` is the force asked for, before any effort
            limit of the profile.

        Raises:
            BackendUnsupportedError: The default, for a backend that cannot read them.
        """
        from simbridge.exceptions import BackendUnsupportedError

        raise BackendUnsupportedError(self.name, "reading the commands in force (get_state)")

    def set_joint_commands(self, body: int, commands: JointCommands) -> None:
        """Make ``commands`` the motors in force and the pending torques of ``body``,
        replacing both (a pending torque is not added to: it is set). Afterwards
        ``joint_commands(body)`` reads them back. Spherical joints' entries are left alone
        (:meth:`set_spherical_states` sets them).

        Args:
            body: A loaded body's id.
            commands: (n,) arrays over all joints, checked: modes NONE exactly on the fixed
                joints, finite values, forces and gains >= 0.

        Raises:
            BackendUnsupportedError: The default, for a backend that cannot set them.
        """
        from simbridge.exceptions import BackendUnsupportedError

        raise BackendUnsupportedError(self.name, "setting the commands in force (set_state)")

    def snapshot(self) -> Any:
        """The engine's own data that ``restore`` needs to put this world back bit-exactly.

        Returns:
            Solver warm starts, contact caches and the like, opaque to the Sim and never used
            by another backend; or None (the default) when the portable state is all there is.
        """
        return None

    def restore(self, native: Any) -> bool:
        """Put back what :meth:`snapshot` saved; called first by every ``set_state``.

        Motors and pending torques are set after it by ``set_joint_commands``.

        Args:
            native: What :meth:`snapshot` returned, or None.

        Returns:
            True when the positions, velocities, time and engine data were put back. False
            when ``native`` is None or does not fit this world as it is now (another world, a
            load, remove or reset since): the backend then drops what the engine keeps of its
            past where it can (MuJoCo: the solver's warm start), so that the portable state
            the Sim sets next means the same in any world.
        """
        return False

    def set_time(self, time: float) -> None:
        """Set the simulated time, to the nearest whole step of this world's time step.

        Args:
            time: Seconds (finite, >= 0).

        Raises:
            BackendUnsupportedError: The default, for a backend that cannot set it.
        """
        from simbridge.exceptions import BackendUnsupportedError

        raise BackendUnsupportedError(self.name, "setting the time (set_state)")

    # ---------------------------------------------------------------- MuJoCo's reading of MJCF
    # Not abstract: only a backend that declares "mujoco" in ``semantics`` implements them; the
    # Sim resolves every name and checks every value and shape first.

    def mjcf_world(
        self, native: NativeMjcf, gravity: Vec3 | None, timestep: float | None
    ) -> Backend:
        """A new backend whose world is ``native``, the model as MuJoCo compiled it.

        The Sim calls it on an empty world and uses the backend it returns in place of this
        one (it closes this one) until ``reset()``. With ``gui`` the returned backend shows
        the model in the engine's own window (this one's window may be handed over to it, or
        closed first: one window at a time); a model refused here leaves this one with a
        window drawing its own world.

        Args:
            native: The compiled model (:func:`simbridge.model.mjcf_native.compile_mjcf`).
            gravity: The gravity the caller gave the Sim (m/s², world); None: the file's.
            timestep: The time step the caller gave the Sim (s); None: the file's.

        Returns:
            The backend holding the model, stepping it as MuJoCo does.

        Raises:
            BackendUnsupportedError: The default: this backend runs PyBullet's reading only.
        """
        from simbridge.exceptions import BackendUnsupportedError

        raise BackendUnsupportedError(self.name, *NATIVE_ONLY)

    def set_actuator_controls(self, actuators: np.ndarray, values: list[float]) -> None:
        """Write MuJoCo actuator controls (``d.ctrl``); they persist until written again.

        Args:
            actuators: (n,) ``np.intp`` actuator indices.
            values: n finite controls, in the actuators' own units (clamped by MuJoCo to
                ``ctrlrange`` where it is limited).

        Raises:
            BackendUnsupportedError: The default.
        """
        from simbridge.exceptions import BackendUnsupportedError

        raise BackendUnsupportedError(self.name, *NATIVE_ONLY)

    def actuator_controls(self) -> np.ndarray:
        """The actuator controls in force.

        Returns:
            (nu,) a copy of ``d.ctrl``.

        Raises:
            BackendUnsupportedError: The default.
        """
        from simbridge.exceptions import BackendUnsupportedError

        raise BackendUnsupportedError(self.name, *NATIVE_ONLY)

    def generalized_state(self) -> tuple[np.ndarray, np.ndarray]:
        """MuJoCo's own generalized coordinates.

        Returns:
            Copies of ``qpos`` (nq,) and ``qvel`` (nv,), MuJoCo's order and conventions (a free
            joint: position, quaternion w, x, y, z; linear velocity, world, of the body frame's
            origin, angular velocity in the body frame).

        Raises:
            BackendUnsupportedError: The default.
        """
        from simbridge.exceptions import BackendUnsupportedError

        raise BackendUnsupportedError(self.name, *NATIVE_ONLY)

    def xpos(self) -> np.ndarray:
        """MuJoCo's ``d.xpos``: each MuJoCo body's frame origin.

        Returns:
            ``(nbody, 3)`` float64 (m, world), MuJoCo's body order: after a step, as the step
            left it (MuJoCo under RK4: its last stage's kinematics, which lag the final state);
            after a write, of the state written.

        Raises:
            BackendUnsupportedError: The default.
        """
        from simbridge.exceptions import BackendUnsupportedError

        raise BackendUnsupportedError(self.name, *NATIVE_ONLY)

    def body_external_forces(self) -> np.ndarray:
        """MuJoCo's ``cfrc_ext`` after the last step: the contact wrench on each MuJoCo body.

        Returns:
            ``(nbody, 6)`` float64, MuJoCo's body order (row 0: the world, zeros): torque
            (N m) then force (N), world frame, the torque about the centre of mass of the
            body's tree (``subtree_com[rootid]``); zeros before the first step after a reset
            or a restore.

        Raises:
            BackendUnsupportedError: The default.
        """
        from simbridge.exceptions import BackendUnsupportedError

        raise BackendUnsupportedError(self.name, *NATIVE_ONLY)

    def set_generalized_state(self, qpos: np.ndarray | None, qvel: np.ndarray | None) -> None:
        """Set ``qpos`` and ``qvel`` as given (MuJoCo's order; None keeps one).

        Args:
            qpos: (nq,) finite, or None.
            qvel: (nv,) finite, or None.

        Raises:
            BackendUnsupportedError: The default.
        """
        from simbridge.exceptions import BackendUnsupportedError

        raise BackendUnsupportedError(self.name, *NATIVE_ONLY)

    def reset_keyframe(self, key: int) -> None:
        """Put the world in one ``<keyframe>`` (``mj_resetDataKeyframe``).

        Args:
            key: The keyframe's index.

        Raises:
            BackendUnsupportedError: The default.
        """
        from simbridge.exceptions import BackendUnsupportedError

        raise BackendUnsupportedError(self.name, *NATIVE_ONLY)

    def sensor_data(self, sensor: int) -> np.ndarray:
        """One sensor's values for the state as it stands.

        Args:
            sensor: The sensor's index.

        Returns:
            (dim,) a copy of its part of ``d.sensordata``, in MuJoCo's units and frames.

        Raises:
            BackendUnsupportedError: The default.
        """
        from simbridge.exceptions import BackendUnsupportedError

        raise BackendUnsupportedError(self.name, *NATIVE_ONLY)

    def site_pose(self, site: int) -> tuple[Vec3, Quat]:
        """One site's pose as it stands.

        Args:
            site: The site's index.

        Returns:
            Its position (m, world) and orientation (x, y, z, w).

        Raises:
            BackendUnsupportedError: The default.
        """
        from simbridge.exceptions import BackendUnsupportedError

        raise BackendUnsupportedError(self.name, *NATIVE_ONLY)

    # ---------------------------------------------------------------- pictures

    def render(
        self,
        width: int,
        height: int,
        eye: Vec3,
        target: Vec3,
        up: Vec3,
        fov: float,
    ) -> np.ndarray:
        """A picture of the world as it stands.

        The Sim has checked the view (:meth:`simbridge.Sim.render`): finite, eye away from
        target, up not along the line of sight.

        Args:
            width: Pixels across (>= 1).
            height: Pixels down (>= 1).
            eye: The camera's position (m, world).
            target: The point it looks at (m, world).
            up: The direction that points up in the picture (world).
            fov: Vertical field of view (degrees).

        Returns:
            A (height, width, 3) uint8 RGB array.

        Raises:
            BackendUnsupportedError: The default, for a backend that cannot render.
        """
        from simbridge.exceptions import BackendUnsupportedError

        raise BackendUnsupportedError(
            self.name,
            "rendering pictures (Sim.render)",
            "render with the 'pybullet' backend, whose CPU renderer runs everywhere",
        )
