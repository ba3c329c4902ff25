"""An MJCF model read as MuJoCo reads it, stepped by an engine that is not MuJoCo
(``load_mjcf(source, semantics="mujoco")`` on PyBullet and PhysX).

:class:`MjcfOnEngine` is the part every such engine shares (no engine is imported here): the
engine builds the plans of :mod:`simbridge.model.mjcf_native_plan` and steps them; a
:class:`~simbridge.model.mjcf_mirror.Mirror` of the compiled model turns the engine's state
into MuJoCo's ``qpos``/``qvel`` and gives, by MuJoCo's own functions, every step's actuator,
spring and damping forces (applied as joint torques for that step) and every read (frames,
centres of mass, sites, sensors), so that a read means on every engine what it means on
MuJoCo. A subclass supplies five hooks: :meth:`engine_state`, :meth:`write_engine_state`,
:meth:`apply_forces`, :meth:`step_engine` and :meth:`close_engine`, and its departures.

No profile entry applies (no link damping, no default motors): the file's ``<option>`` gives
gravity and the time step unless the Sim was given them.
"""

from __future__ import annotations

import threading
import warnings
from abc import abstractmethod
from typing import Any, ClassVar

import numpy as np

from simbridge.backend import Backend
from simbridge.exceptions import (
    BackendUnsupportedError,
    InitialPenetrationWarning,
    SimBusyError,
    SimClosedError,
    SimulationDivergedError,
)
from simbridge.model.mjcf_mirror import Mirror, body_name, own_overlaps
from simbridge.model.mjcf_native import NativeBody, NativeMjcf, bad_coordinate
from simbridge.model.mjcf_native_plan import plan_departures, refuse_unsimulated
from simbridge.profiles import Profile
from simbridge.transforms import quat_multiply, quat_rotate
from simbridge.types import (
    ContactPoint,
    Quat,
    Vec3,
)

from . import locking
from . import mjcf_forces as forces
from .locking import exclusive, wait_for_lock
from .mjcf_reads import MjcfReads, _conj, _v, _wxyz, _xyzw

__all__ = ["PENETRATION", "MjcfOnEngine", "ball_from_inertial", "ball_to_inertial"]

# m: the overlap at load below which a pair is not named in ``initial_penetration`` (one
# number for every model: the corpus's overlaps at qpos0 are below 1e-5 m or above 0.02 m)
PENETRATION = 1e-3


def ball_from_inertial(inertial: Quat, quat: Quat, angular: Vec3) -> tuple[np.ndarray, np.ndarray]:
    """A ball joint's MuJoCo coordinates from an engine's spherical joint that turns the
    child's inertial frame (PyBullet's, and PhysX's three revolutes, ``backends/physx/ball.py``).

    MuJoCo's ball ``qpos`` turns the child body's frame (its link frame here, the body frame at
    the anchor) from its pose at ``qpos0``; with ``I`` the inertial frame in that frame, the
    engine's turn ``q`` of the inertial frame is MuJoCo's ``I q I^-1``, and its angular velocity
    (child's inertial frame) is ``R(I) w`` in the body frame.

    Args:
        inertial: ``I``, the link's inertial orientation in its link frame (x, y, z, w).
        quat: The engine's joint quaternion (x, y, z, w).
        angular: The engine's joint angular velocity (rad/s, the child's inertial frame).

    Returns:
        MuJoCo's ``qpos`` (4,) w, x, y, z and ``qvel`` (3,) (rad/s, child body frame).
    """
    turn = quat_multiply(quat_multiply(inertial, quat), _conj(inertial))
    return _wxyz(turn), np.array(quat_rotate(inertial, _v(angular)))


def ball_to_inertial(inertial: Quat, qpos: np.ndarray, qvel: np.ndarray) -> tuple[Quat, Vec3]:
    """The inverse of :func:`ball_from_inertial`.

    Args:
        inertial: ``I``, the link's inertial orientation in its link frame (x, y, z, w).
        qpos: (4,) MuJoCo's ball ``qpos``, w, x, y, z (normalised here).
        qvel: (3,) MuJoCo's ball ``qvel`` (rad/s, child body frame).

    Returns:
        The engine's joint quaternion (x, y, z, w) and angular velocity (child's inertial
        frame).
    """
    w4 = np.asarray(qpos, dtype=float) / float(np.linalg.norm(qpos))
    turn = quat_multiply(quat_multiply(_conj(inertial), _xyzw(w4)), inertial)
    return turn, quat_rotate(_conj(inertial), _v(qvel))


class MjcfOnEngine(MjcfReads, Backend):
    """The world of one MJCF model as MuJoCo compiles it, stepped by another engine.

    Args:
        profile: The Sim's profile; only its gravity and time step are read, and only where
            the Sim was given them.
        native: The compiled model.
        gravity: The gravity the caller gave the Sim (m/s², world), or None for the file's.
        timestep: The time step the caller gave the Sim (s), or None for the file's.
        gui: Whether the engine's own window shows the model (the engine opens or takes it
            over; :meth:`show_state` gives it each new state).

    Raises:
        MjcfFeatureUnsupportedError: A feature only MuJoCo simulates (tendons, equality
            constraints, flex bodies...), named with its element.
    """

    engine_version: str = ""
    contact_passes: int = 0
    """Trial steps per step that give :meth:`with_armature` the step's own constraint forces
    (each: the engine steps, the state is written back, the force is computed again with the
    constraint forces that step showed); 0: the step before's. An engine whose armature is a
    force (PyBullet) needs them where contacts change every step: measured on Gymnasium's half
    cheetah under its reference gait, 7/20 successes with the step before's, 20/20 with 2
    passes (docs/mjcf_mujoco_reading.md)."""
    soft_limits: bool = False
    """True: the engine's joints have no limits of their own and :meth:`limit_recovery` is
    every limited joint's limit, every step (MuJoCo's soft limit, acting on the inertia with
    armature); False: the engine's limits, the recovery only for a joint placed outside."""

    def __init__(
        self,
        profile: Profile,
        native: NativeMjcf,
        gravity: Vec3 | None = None,
        timestep: float | None = None,
        gui: bool = False,
    ) -> None:
        refuse_unsimulated(native, self.name)
        m = native.model
        if gravity is not None:
            m.opt.gravity[:] = gravity
        if timestep is not None:
            m.opt.timestep = timestep
        super().__init__(
            profile.with_(gravity=_v(m.opt.gravity), timestep=float(m.opt.timestep)), gui
        )
        self.native = native
        self.m = m
        self.mirror = Mirror(m)
        self.d = self.mirror.d
        self.dt = float(m.opt.timestep)
        self.ctrl = np.zeros(m.nu)
        self._bodies: dict[int, NativeBody] = dict(enumerate(native.bodies))
        self._limited = [  # hinge, slide and ball joints with a range
            j for j in range(m.njnt) if m.jnt_limited[j] and int(m.jnt_type[j]) in (1, 2, 3)
        ]
        self._recovering: set[int] = set()  # joints placed outside their range
        self._limit_tables: dict[tuple[int, ...], forces.LimitTable] = {}  # limit_recovery's
        self._armature = np.diag(m.dof_armature)  # (nv, nv), with_armature's
        self._diagonal = np.diag_indices(m.nv)
        self.ball_dofs = np.zeros(m.nv, dtype=bool)  # the ball joints' velocities
        for j in range(m.njnt):
            if int(m.jnt_type[j]) == 1:  # mjJNT_BALL
                self.ball_dofs[int(m.jnt_dofadr[j]) : int(m.jnt_dofadr[j]) + 3] = True
        # the step before's velocity, inertia, bias and applied force (with_armature)
        self._last: tuple[np.ndarray, ...] | None = None
        # armature or damping: the force depends on the constraint forces (contact_passes)
        self._passes_help = bool(m.dof_armature.any() or m.dof_damping.any())
        self._stepping = threading.RLock()
        self._in_step = False
        self._closed = False
        self._synced = False  # the mirror holds the engine's state
        self._time = 0.0
        self._diverged: SimulationDivergedError | None = None
        self._penetration = ""  # the departure initial_penetration (note_penetration)
        self._stepped = False  # a step since the last reset or restore (body_external_forces)

    reading = locking.reading

    # ---------------------------------------------------------------- the engine's hooks

    @abstractmethod
    def engine_state(self) -> tuple[np.ndarray, np.ndarray]:
        """The engine's state in MuJoCo's conventions.

        Returns:
            ``qpos`` (nq,) and ``qvel`` (nv,), MuJoCo's order (a free joint: the body frame's
            position, quaternion w, x, y, z; the origin's velocity, world; the angular
            velocity, body frame).
        """

    @abstractmethod
    def write_engine_state(self, qpos: np.ndarray, qvel: np.ndarray) -> None:
        """Put the engine in a state given in MuJoCo's conventions.

        Args:
            qpos: (nq,) MuJoCo's generalized positions.
            qvel: (nv,) MuJoCo's generalized velocities.
        """

    @abstractmethod
    def apply_forces(
        self,
        qfrc: np.ndarray,
        damping: np.ndarray,
        mass: np.ndarray,
        fc: np.ndarray | None = None,
    ) -> None:
        """Apply generalized forces for the next step.

        Args:
            qfrc: (nv,) actuator, spring, gravity compensation and fluid forces.
            damping: (nv,) MuJoCo's ``dof_damping`` (the engine applies it its own way).
            mass: (nv, nv) the joint-space inertia without armature.
            fc: (nv,) the constraint forces of this step's trial (:attr:`contact_passes`);
                None: the step before's.
        """

    def with_armature(
        self,
        qfrc: np.ndarray,
        damping: np.ndarray,
        mass: np.ndarray,
        fc: np.ndarray | None = None,
    ) -> np.ndarray:
        """The force for the next step of an engine without armature (PyBullet): the motion
        MuJoCo's Euler gives, ``(M + A + dt D)^-1 (f - c + fc - D v)`` (the damping implicit in
        every force, the armature's inertia added), with MuJoCo's soft limits; ``fc`` the
        engine's constraint forces of the step before (0 after a write of the state; without it
        a standing robot's joints get ``-A`` times their free-fall acceleration: measured, the
        ant's hips driven to their limits; with it the armature acts one step late where a
        contact changes, unless :attr:`contact_passes` give the step's own: the departure
        ``armature``). The damping implicit in the velocity
        alone, ``-D (I + dt (M + A)^-1 D)^-1 v``, left the other forces undamped within the
        step: measured, half_cheetah.xml in the air (gravity 0) under HalfCheetahGait's
        controls, 1 s: 0.13 rad from raw MuJoCo on ``fthigh``, exactly raw MuJoCo with that
        damping in place of its own.

        Args:
            qfrc: (nv,) actuator, spring, gravity compensation and fluid forces.
            damping: (nv,) MuJoCo's ``dof_damping``.
            mass: (nv, nv) the joint-space inertia without armature.
            fc: (nv,) the constraint forces of this step's trial; None: the step before's.

        Returns:
            (nv,) the force to apply for the next step.
        """
        v, c = self.d.qvel, self.d.qfrc_bias
        full = mass + self._armature
        f = np.asarray(qfrc, dtype=float)
        q = self.d.qpos
        if fc is None:  # the engine's constraint forces of the step before
            fc = np.zeros_like(f) if self._last is None else self.constraint_forces(q, v)
        # MuJoCo's Euler: (M + A + dt D) qdd = f - c + fc - D v, given through the engine's M
        # (a spinning thin body's axis has dt D / I near 10: an explicit force there is off)
        implicit = full.copy()
        implicit[self._diagonal] += self.dt * damping  # full + dt diag(D)
        acc = None  # the acceleration, solved once where no limit pushes
        if self._recovering:
            acc = np.linalg.solve(implicit, f - c + fc - damping * v)
            limit = self.limit_recovery(full, acc)
            if limit.any():
                f, acc = f + limit, None
        if not self._passes_help:  # no armature or damping: the forces as they are
            out = f  # (the same as below, less its rounding)
        else:
            if acc is None:
                acc = np.linalg.solve(implicit, f - c + fc - damping * v)
            out = mass @ acc + c - fc
        self._last = (q.copy(), v.copy(), mass.copy(), c.copy(), out)
        return out

    def constraint_forces(self, q1: np.ndarray, v1: np.ndarray) -> np.ndarray:
        """The engine's constraint forces over the step that :meth:`with_armature` last
        computed a force for, from its end state: ``M qacc - applied + c``.

        Args:
            q1: (nq,) the step's end positions (MuJoCo's conventions).
            v1: (nv,) its end velocities.

        Returns:
            (nv,) the generalized constraint forces (contacts and the engine's joints).
        """
        assert self._last is not None
        q0, v0, mass0, c0, applied0 = self._last
        return np.asarray(mass0 @ (self.velocity_change(q0, v0, q1, v1) / self.dt) - applied0 + c0)

    def velocity_change(
        self, q0: np.ndarray, v0: np.ndarray, q1: np.ndarray, v1: np.ndarray
    ) -> np.ndarray:
        """The step's change of velocity as MuJoCo's ``qacc * dt`` at the step's start, for
        the constraint forces of :meth:`with_armature`.

        Args:
            q0: (nq,) the start's positions (MuJoCo's conventions).
            v0: (nv,) the start's velocities.
            q1: (nq,) the end's positions.
            v1: (nv,) the end's velocities.

        Returns:
            (nv,) by default ``v1 - v0``; an engine that steps a free body's centre-of-mass
            velocity and world angular velocity gives that change in MuJoCo's coordinates of
            the start (:func:`~.mjcf_forces.free_velocity_change`).
        """
        return v1 - v0

    def limit_recovery(self, mass: np.ndarray, free: np.ndarray) -> np.ndarray:
        """MuJoCo's soft joint limit as a force (:func:`~.mjcf_forces.soft_limit_force`). With
        :attr:`soft_limits` (PyBullet, PhysX) every limited joint's, every step, the engine's
        limits off: measured on the ant in the air, 1 s of actuation, the joints' RMS difference
        from raw MuJoCo under Euler fell from 0.42 to 0.009 rad on PyBullet (its hard limit
        stops the joint without its armature) and from 0.11 to 0.0007 rad on PhysX. Without
        it, only a joint placed outside its range (the load, ``set_qpos_qvel``, a keyframe...)
        gets it, until it is back in its range (PyBullet's limit does not push such a joint
        back: measured, a hinge placed 0.5 rad outside its range stays there; with the
        engine's limit acting too the correction doubles and half_cheetah diverges).

        Args:
            mass: (nv, nv) the joint-space inertia, armature included.
            free: (nv,) the acceleration without the limit, ``M^-1 (f - c)``.

        Returns:
            (nv,) the force, 0 on every joint inside its range.
        """
        joints = tuple(sorted(self._recovering))
        table = self._limit_tables.get(joints)
        if table is None:
            table = self._limit_tables[joints] = forces.limit_table(self.m, joints)
        out, inside = forces.soft_limit_force(
            self.m, joints, self.d.qpos, self.d.qvel, mass, free, self.dt, table
        )
        if not self.soft_limits:  # back in its range: the engine's limit holds it now
            self._recovering -= inside
        return out

    @abstractmethod
    def step_engine(self) -> None:
        """One engine step of ``self.dt``."""

    @abstractmethod
    def close_engine(self) -> None:
        """Release the engine's world."""

    def show_state(self) -> None:
        """Show the engine's state in its window, if it has one (after a ``step`` call or a
        write): nothing by default."""

    departure_texts: ClassVar[dict[str, str]] = {}
    """What the engine does instead of MuJoCo's armature, joint damping, frictionloss and ball
    joints (keys ``"armature"``, ``"joint_damping"``, ``"frictionloss"``, ``"ball_joints"``):
    :func:`plan_departures` names those the model exercises in these words."""

    def engine_departures(self) -> dict[str, str]:
        """The engine's own departures beyond :func:`plan_departures`.

        Returns:
            Departure name -> what the engine does instead (none by default).
        """
        return {}

    def engine_overlaps(self) -> list[ContactPoint] | None:
        """The engine's own contact points of the state as it stands, found without a step
        (its collision detection alone), bodies numbered as :meth:`contact_points` numbers
        them; None where the engine has no such call (no ``initial_penetration`` is then
        measured).

        Returns:
            The points (``distance`` < 0: overlapping), or None.
        """
        return None

    def note_penetration(self, engine: str) -> None:
        """Measure, at the state just written (``qpos0`` at load), the pairs the engine's own
        collision detection finds overlapping deeper than :data:`PENETRATION` (m), with
        MuJoCo's own contact depth of the same pair at that state; where there are any, the
        departure ``initial_penetration`` names them and an
        :class:`~simbridge.exceptions.InitialPenetrationWarning` says so before the run.

        Args:
            engine: What the engine's contacts are, for the message (``"PyBullet's rigid
                contacts"``).
        """
        points = self.engine_overlaps()
        if not points:
            return
        m = self.m
        deepest: dict[tuple[int, int], float] = {}
        for c in points:
            if c.distance < -PENETRATION:
                ab = (self._mujoco_body(c.body_a, c.link_a), self._mujoco_body(c.body_b, c.link_b))
                key = (min(ab), max(ab))
                deepest[key] = min(deepest.get(key, 0.0), c.distance)
        if not deepest:
            return
        own = own_overlaps(m, self.engine_state()[0])  # MuJoCo's own at this state
        weld = m.body_weldid
        pairs = []
        for (a, b), depth in sorted(deepest.items(), key=lambda kv: kv[1]):
            theirs = own.get(frozenset((int(weld[a]), int(weld[b]))))
            mj = "no contact" if theirs is None else f"{-theirs:.4f} m"
            pairs.append(f"{body_name(m, a)!r}-{body_name(m, b)!r} {-depth:.4f} m (MuJoCo: {mj})")
        text = (
            f"at qpos0 {len(pairs)} pair{'s' * (len(pairs) > 1)} of bodies overlap in {engine}"
            ", deepest first: "
            f"{', '.join(pairs)}; the engine pushes them apart within a step where MuJoCo's soft "
            "contacts ease them out over many: the run may diverge (SimulationDivergedError)"
        )
        self._penetration = text
        warnings.warn(
            InitialPenetrationWarning(f"{self.native.display_name} on {self.name}: {text}"),
            stacklevel=2,
        )

    def _mujoco_body(self, body: int, link: int) -> int:
        """The MuJoCo body id of a contact's body and link (the world: 0)."""
        if body < 0:
            return 0
        nb = self._bodies[body]
        return nb.body_id if link < 0 else int(nb.link_bodies[link])

    # ---------------------------------------------------------------- world

    def _sync(self) -> None:
        """The mirror holds the engine's state, its frames fresh."""
        if not self._synced:
            self.mirror.set_state(*self.engine_state())
            self._synced = True
        self.mirror.refresh()

    @property
    def time(self) -> float:
        """See Backend.time: steps taken times the time step."""
        if self._closed:
            raise SimClosedError()
        return self._time

    @exclusive
    def reset(self) -> None:
        """See Backend.reset: the model's ``qpos0``, at rest (the Sim replaces this backend
        at ``reset()``)."""
        self._write(self.m.qpos0.copy(), np.zeros(self.m.nv))
        self._time = 0.0
        self._diverged = None
        self._stepped = False

    def step(self, n: int) -> None:
        """See Backend.step: each engine step applies MuJoCo's actuator, spring and damping
        forces of the state at its start; a state MuJoCo would call bad (not finite, or
        beyond 1e10: :meth:`_check`), read before each engine step and after the last, raises
        SimulationDivergedError naming the joint."""
        lock = self._stepping
        if not lock.acquire(False):
            wait_for_lock(self)
        if self._in_step:
            lock.release()
            raise SimBusyError()
        self._in_step = True
        try:
            if self._diverged is not None:
                raise self._diverged
            mirror = self.mirror
            passes = self.contact_passes if self._passes_help else 0
            for _ in range(max(n, 0)):
                q0, v0 = self.engine_state()
                self._check(q0, v0)
                mirror.set_state(q0, v0)
                qfrc, damping, mass = mirror.forces(self.ctrl)
                self.apply_forces(qfrc, damping, mass)
                for _pass in range(passes):  # the step's own constraint forces
                    self.step_engine()
                    fc = self.constraint_forces(*self.engine_state())
                    self.write_engine_state(q0, v0)
                    self.apply_forces(qfrc, damping, mass, fc)
                self.step_engine()
                self._time += self.dt
            self._synced = False
            if n > 0:
                self._stepped = True
                self._check(*self.engine_state())
                self.show_state()
        finally:
            self._in_step = False
            lock.release()

    def _check(self, qpos: np.ndarray, qvel: np.ndarray) -> None:
        """Raise SimulationDivergedError (kept: every later step raises it) where the
        engine's state is bad as MuJoCo's own ``mj_step`` judges it
        (:func:`~simbridge.model.mjcf_native.bad_coordinate`: not finite, or beyond 1e10),
        naming the first such coordinate's joint and body."""
        bad = bad_coordinate(self.m, qpos, qvel)
        if bad is not None:
            self._synced = False
            self._diverged = SimulationDivergedError(
                self.name,
                self._time,
                f"the engine's {bad}",
                why="is not finite or beyond MuJoCo's 1e10 (mjMAXVAL)",
            )
            raise self._diverged

    @exclusive
    def contact_points(self) -> list[ContactPoint]:
        """See Backend.contact_points: the engine's own points of the last step
        (:meth:`engine_contacts`), its bodies as the Sim numbers them, link ``i`` the body's
        joint row ``i``, and the file's world geoms (its floor) body -1, link -1, as on the
        MuJoCo backend."""
        if self._diverged is not None:
            raise self._diverged
        return self.engine_contacts()

    @exclusive
    def xpos(self) -> np.ndarray:
        """See Backend.xpos: the MuJoCo bodies' frames of the engine's state (no stages: the
        state after the step)."""
        self._sync()
        return np.array(self.d.xpos)

    @exclusive
    def body_external_forces(self) -> np.ndarray:
        """See Backend.body_external_forces: from the engine's contact points of the last step
        (:mod:`simbridge.wrenches`), each link's wrench on the MuJoCo body its row reads (a body
        without a joint row of its own shares its parent's link: its contacts are counted on
        that body, its own row stays zero); the torques about each tree's centre of mass
        (``subtree_com``) of the state as it stands. No torsional or rolling friction."""
        from simbridge.wrenches import external_wrenches

        out = np.zeros((self.m.nbody, 6))
        if not self._stepped:
            return out
        points = self.contact_points()
        self._sync()
        for body, b in self._bodies.items():
            rows = (b.body_id, *b.link_bodies)

            def row_of(other: int, link: int, body: int = body, rows: tuple = rows) -> int:
                return rows[link + 1] if other == body else -1

            out += external_wrenches(points, row_of, self.m.nbody, self.d.subtree_com[b.body_id])
        return out

    def engine_contacts(self) -> list[ContactPoint]:
        """The engine's contact points of the last step (see :meth:`contact_points`).

        Returns:
            The points, A and B in the engine's order, the bodies as the Sim numbers them.

        Raises:
            BackendUnsupportedError: An engine that does not give them.
        """
        raise BackendUnsupportedError(self.name, "contact points under semantics='mujoco'")

    def close(self) -> None:
        """See Backend.close."""
        if not self._closed:
            self._closed = True
            self.close_engine()

    def _write(self, qpos: np.ndarray, qvel: np.ndarray) -> None:
        """Put the engine and the mirror in this state; note the joints placed outside their
        range (:meth:`limit_recovery`)."""
        self.write_engine_state(qpos, qvel)
        self.mirror.set_state(qpos, qvel)
        self._synced = True
        self._last = None
        self.show_state()
        adr = self.m.jnt_qposadr
        self._recovering = (
            set(self._limited)
            if self.soft_limits
            else {
                j
                for j in self._limited
                if forces.violation(self.m, j, self._joint_qpos(qpos, adr[j], j))[0] < 0
            }
        )

    def _joint_qpos(self, qpos: np.ndarray, adr: int, j: int) -> float | np.ndarray:
        """Joint ``j``'s coordinates at ``adr``: a number, or a ball joint's quaternion (4,)."""
        return qpos[adr : adr + 4] if int(self.m.jnt_type[j]) == 1 else float(qpos[adr])

    # ---------------------------------------------------------------- whole state

    @exclusive
    def snapshot(self) -> Any:
        """See Backend.snapshot: time, ``qpos``, ``qvel`` and the controls."""
        q, v = self.engine_state()
        return (id(self), self._time, q, v, self.ctrl.copy())

    @exclusive
    def restore(self, native: Any) -> bool:
        """See Backend.restore: a snapshot of this world is written back (the engine's
        contact caches start afresh)."""
        self._stepped = False  # body_external_forces: zeros until the next step
        if not (isinstance(native, tuple) and len(native) == 5 and native[0] == id(self)):
            return False
        self._time = native[1]
        self.ctrl[:] = native[4]
        self._write(native[2], native[3])
        return True

    @exclusive
    def set_time(self, time: float) -> None:
        """See Backend.set_time: to the nearest whole step."""
        self._time = round(time / self.dt) * self.dt

    def manifest(self) -> dict[str, Any]:
        """See Backend.manifest: MuJoCo's reading on this engine, its departures named."""
        m = self.m
        return {
            "backend": self.name,
            "engine_version": self.engine_version,
            "semantics": "mujoco",
            "model": self.native.display_name,
            "option": {
                "timestep": float(m.opt.timestep),
                "gravity": _v(m.opt.gravity),
            },
            "sizes": {"nq": m.nq, "nv": m.nv, "nu": m.nu, "nbody": m.nbody},
            "departures": {
                "profile": "no profile entry applies under semantics='mujoco' but gravity "
                "and the time step the Sim was given: the model is MuJoCo's",
                **plan_departures(self.native, self.name, self.departure_texts),
                **self.engine_departures(),
                **({"initial_penetration": self._penetration} if self._penetration else {}),
            },
        }

    # ---------------------------------------------------------------- MuJoCo's own calls

    @exclusive
    def set_actuator_controls(self, actuators: np.ndarray, values: list[float]) -> None:
        """See Backend.set_actuator_controls: held, and clamped to ``ctrlrange`` where
        limited at each step, as MuJoCo does."""
        self.ctrl[actuators] = values

    @exclusive
    def actuator_controls(self) -> np.ndarray:
        """See Backend.actuator_controls: a copy of the controls."""
        return self.ctrl.copy()

    @exclusive
    def generalized_state(self) -> tuple[np.ndarray, np.ndarray]:
        """See Backend.generalized_state: the engine's state in MuJoCo's conventions."""
        q, v = self.engine_state()
        return q.copy(), v.copy()

    @exclusive
    def set_generalized_state(self, qpos: np.ndarray | None, qvel: np.ndarray | None) -> None:
        """See Backend.set_generalized_state."""
        q, v = self.engine_state()
        self._write(
            q if qpos is None else np.asarray(qpos), v if qvel is None else np.asarray(qvel)
        )

    @exclusive
    def reset_keyframe(self, key: int) -> None:
        """See Backend.reset_keyframe: the key's time, ``qpos``, ``qvel`` and ``ctrl``."""
        m = self.m
        self._time = float(m.key_time[key])
        if m.nu:
            self.ctrl[:] = m.key_ctrl[key]
        self._write(m.key_qpos[key].copy(), m.key_qvel[key].copy())
        self._diverged = None
        self._stepped = False

    @exclusive
    def sensor_data(self, sensor: int) -> np.ndarray:
        """See Backend.sensor_data: MuJoCo's sensor of the engine's state (contact and force
        sensors are MuJoCo's own contacts of that state, not the engine's)."""
        self._sync()
        return self.mirror.sensor(sensor, self.ctrl)

    @exclusive
    def site_pose(self, site: int) -> tuple[Vec3, Quat]:
        """See Backend.site_pose: MuJoCo's site frame of the engine's state."""
        self._sync()
        q = self.mirror.quat(self.d.site_xmat[site])
        return _v(self.d.site_xpos[site]), (float(q[0]), float(q[1]), float(q[2]), float(q[3]))
