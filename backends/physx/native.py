"""An MJCF model read as MuJoCo reads it, stepped by PhysX (``load_mjcf(source,
semantics="mujoco")`` on ``Sim("physx")``).

The plans of :mod:`simbridge.model.mjcf_native_plan` are built by the backend's own builder
(:func:`~.model.build_robot`: one articulation per top-level body, link i = MuJoCo's row i,
MuJoCo's masses and inertias), the world body's geoms as one static actor. MuJoCo's joint
properties PhysX has are PhysX's: ``armature`` is the joint's armature, ``damping`` a drive of
stiffness 0, that damping and target velocity 0 (implicit, as MuJoCo's Euler integrates it).
Each step applies MuJoCo's actuator and spring forces (``set_qf``), a ``frictionloss`` as the
force that stops the joint within the step, clamped to the frictionloss, and MuJoCo's soft
joint limits (the joints have no PhysX limit; the shared part, ``backends/mjcf_engine.py``).
A ball joint is the backend's spherical joint (``ball.py``: three revolutes about the child's
inertial axes, SAPIEN 3.0.3 building no spherical articulation joint), read and written in
MuJoCo's ball coordinates; its damping is a force each step, implicit in every force as
MuJoCo's Euler makes it, its armature the three revolutes' armature plus the force that makes
it MuJoCo's (:meth:`NativePhysx._armature_correction`).

With a window (``Sim("physx", gui=True)``) the plans carry MuJoCo's visible geoms as visual
shapes and the Sim's SAPIEN window (:class:`~.window.Window`, handed over by the backend the
model replaces) draws them; it takes the poses after each ``step`` call or write, and
``close()`` ends it.
"""

from __future__ import annotations

import math
from types import SimpleNamespace
from typing import Any, ClassVar

import numpy as np
import sapien
from sapien import physx

from simbridge.exceptions import MjcfFeatureUnsupportedError
from simbridge.model.mjcf_native import NativeMjcf
from simbridge.model.mjcf_native_plan import cross_excludes, ground_plan, native_plans
from simbridge.model.plan_records import BuildPlan
from simbridge.profiles import Profile
from simbridge.transforms import quat_rotate
from simbridge.types import ContactPoint, JointType, Quat, Vec3

from ..mjcf_engine import MjcfOnEngine, ball_from_inertial, ball_to_inertial
from .ball import angles_to_quat, quat_to_angles, rate_matrix
from .contacts import ContactReads
from .model import IGNORE_BITS, bits_needed, build_robot, ignore_bits, needed_pairs
from .window import Window

__all__ = ["NativePhysx"]

SOLVER_ITERATIONS = 50  # position iterations of each articulation (PyBullet's count)


def _shared_filters(
    native: NativeMjcf, plans: tuple[BuildPlan, ...], ground: BuildPlan | None
) -> tuple[dict[int, int], dict[int, dict[int, int]]]:
    """The contact-filter tags (SAPIEN's g3) and ignore bits (g2) that leave out the
    ``<contact><exclude>`` pairs between top-level bodies: the bodies an exclude joins share one
    tag, and their links' ignore bits are worked out together
    (:func:`~.model.ignore_bits`), each body's own excluded pairs and the cross pairs.

    Args:
        native: The compiled model.
        plans: Its plans (:func:`native_plans`), body k the plan k.
        ground: The world body's plan (body -1), or None.

    Returns:
        ``(tags, ignore)``: the tag of each body (-1: the ground), and the links' bits of each
        body whose filter is shared (the others: their plan's own).

    Raises:
        MjcfFeatureUnsupportedError: The pairs of one group of bodies need more than 32 bits.
    """
    tags = {k: k + 1 for k in range(len(plans))}
    tags[-1] = len(plans) + 1
    of = {k: plan for k, plan in enumerate(plans)}
    if ground is not None:
        of[-1] = ground
    cross = [c for c in cross_excludes(native) if c[0] in of and c[2] in of]
    root = {k: k for k in of}

    def find(k: int) -> int:
        while root[k] != k:
            k = root[k]
        return k

    for ka, _, kb, _, _ in cross:
        root[find(ka)] = find(kb)
    ignore: dict[int, dict[int, int]] = {}
    for top in {find(k) for k, _, _, _, _ in cross}:
        members = sorted(k for k in of if find(k) == top)
        excluded = [((k, a), (k, b)) for k in members for a, b in of[k].excluded_pairs]
        needed = [((k, a), (k, b)) for k in members for a, b in needed_pairs(of[k])]
        for ka, ra, kb, rb, _ in cross:
            if find(ka) == top:
                excluded.append(((ka, ra), (kb, rb)))
                if of[ka].link(ra).collisions and of[kb].link(rb).collisions:
                    needed.append(((ka, ra), (kb, rb)))
        bits = ignore_bits(excluded, needed)
        if bits is None:
            pair = next(c[4] for c in cross if find(c[0]) == top)
            raise _too_many_bits(native, bits_needed(excluded, needed), pair, len(needed))
        tag = min(tags[k] for k in members)
        for k in members:
            tags[k] = tag
            ignore[k] = {link.index: int(bits.get((k, link.index), 0)) for link in of[k].links}
    return tags, ignore


def _check_filters(native: NativeMjcf, plans: tuple[BuildPlan, ...], shared: set[int]) -> None:
    """Refuse a body whose filtered pairs SAPIEN's ignore bits cannot all leave out (the
    bodies of ``shared`` were checked with their cross pairs, :func:`_shared_filters`).

    Args:
        native: The compiled model.
        plans: Its plans, body k the plan k.
        shared: The bodies whose filter is worked out with others.

    Raises:
        MjcfFeatureUnsupportedError: A body's pairs need more than 32 ignore bits (PhysX's
            own parent-child rule alone would let the rest touch: ``drosophila_fused.xml``'s
            meshes, overlapping at ``qpos0``, went non-finite in the first step).
    """
    for k, plan in enumerate(plans):
        if k in shared or plan.self_collision == "off":
            continue
        needed = needed_pairs(plan)
        if len(needed) <= IGNORE_BITS:
            continue
        n = bits_needed(plan.excluded_pairs, needed)
        if n > IGNORE_BITS:
            a, b = needed[0]
            raise _too_many_bits(native, n, f"{plan.link(a).name}-{plan.link(b).name}", len(needed))


def _too_many_bits(native: NativeMjcf, n: int, pair: str, pairs: int) -> Exception:
    """The refusal of a contact filter SAPIEN cannot hold: ``n`` bits for ``pairs`` pairs."""
    return MjcfFeatureUnsupportedError(
        native.display_name,
        "physx",
        f"contact exclusions needing {n} groups; SAPIEN has {IGNORE_BITS} bits",
        pair,
        f"{pairs} pairs MuJoCo never lets touch (parent and child, <contact><exclude>) that "
        "PhysX's own parent-child rule does not leave out, one ignore bit for each group of "
        "pairwise-excluded links; left out, they would touch where MuJoCo's do not. "
        "Sim('pybullet') filters each pair itself; or give the geoms contype/conaffinity "
        "that keep them apart",
    )


def _matrix(q: Quat) -> np.ndarray:
    """The rotation matrix of a unit quaternion (x, y, z, w)."""
    x, y, z, w = q
    return np.array(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
            [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
            [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)],
        ]
    )


def _v3(a: np.ndarray) -> Vec3:
    return (float(a[0]), float(a[1]), float(a[2]))


class NativePhysx(MjcfOnEngine, ContactReads):
    """The world of one MJCF model as MuJoCo compiles it, stepped by PhysX.

    Args:
        profile: The Sim's profile (only gravity and the time step given to the Sim).
        native: The compiled model.
        gravity: The gravity the caller gave (m/s², world), or None for the file's.
        timestep: The time step the caller gave (s), or None for the file's.
        window: The SAPIEN window to draw the model in, now this world's (None: headless).

    Raises:
        MjcfFeatureUnsupportedError: A feature only MuJoCo simulates.
    """

    name = "physx"
    state_dtype = "float32"
    soft_limits = True  # MuJoCo's soft limit (docs/mjcf_mujoco_reading.md: measured closer)
    engine_version = sapien.__version__
    departure_texts: ClassVar[dict[str, str]] = {
        "armature": "joint armature is PhysX's joint armature",
        "joint_damping": "joint damping is a PhysX drive's damping (implicit, target velocity 0)",
        "frictionloss": "joint frictionloss is a PhysX drive with a force limit",
        "ball_joints": "a ball joint is three revolute joints about the child's inertial axes "
        "(SAPIEN 3.0.3 builds no spherical articulation joint), read and written as MuJoCo's "
        "quaternion and body-frame angular velocity: gimbal lock where the middle angle "
        "reaches +-90 degrees; its armature is the three revolutes' plus a force that makes "
        "it MuJoCo's (left out within 6 degrees of the lock), its damping implicit in "
        "every force as MuJoCo's Euler makes it, its range MuJoCo's cone computed here",
    }

    def __init__(
        self,
        profile: Profile,
        native: NativeMjcf,
        gravity: Vec3 | None = None,
        timestep: float | None = None,
        window: Window | None = None,
    ) -> None:
        super().__init__(profile, native, gravity, timestep, gui=window is not None)
        self._window: Window | None = None  # set once the model is built
        m = self.m
        cfg = physx.PhysxSceneConfig()
        cfg.gravity = np.asarray(m.opt.gravity, dtype=np.float32)
        cfg.enable_tgs = False
        physx.set_scene_config(cfg)
        self._scene = sapien.Scene([physx.PhysxCpuSystem()])
        self._scene.timestep = self.dt
        drawn = window is not None
        self.plans = native_plans(native, limits=not self.soft_limits, visuals=drawn)
        ground = ground_plan(native, visuals=drawn)
        tags, ignore = _shared_filters(native, self.plans, ground)
        _check_filters(native, self.plans, set(ignore))
        self._built = [
            build_robot(self._scene, plan, SOLVER_ITERATIONS, tags[k], ignore=ignore.get(k))
            for k, plan in enumerate(self.plans)
        ]
        self._ground = None
        if ground is not None:
            self._ground = build_robot(
                self._scene, ground, SOLVER_ITERATIONS, tags[-1], ignore=ignore.get(-1)
            )
        if window is not None:  # the window's parts: the built plans' visual shapes
            for b, plan in zip(self._built, self.plans, strict=True):
                b.plan = plan
            if self._ground is not None:
                self._ground.plan = ground
            shown = [*self._built, *([self._ground] if self._ground is not None else [])]
            window.show(SimpleNamespace(built=b) for b in shown)
            self._window = window
        self._dt = self.dt
        self._contacts_cache: list[ContactPoint] | None = None
        self._contacts_kept: list[ContactPoint] | None = None  # no body is ever removed
        self._layout()
        self._write(m.qpos0.copy(), np.zeros(m.nv))

    def _layout(self) -> None:
        """Each row's PhysX dof (its place in the articulation's ``qpos``; a ball joint's three
        revolutes); MuJoCo's armature and damping on the joints; PhysX's joint friction 0."""
        m = self.m
        self._rows: list[tuple[int, int, int, int]] = []  # (body, dof, qpos adr, qvel adr)
        # every ball joint: (body, its three revolutes' dofs, qpos adr, qvel adr, the child's
        # inertial frame in its link frame, x, y, z, w: the revolutes turn it)
        self._balls: list[tuple[int, tuple[int, int, int], int, int, Quat]] = []
        self._fl = np.zeros(m.nv)
        self._ball_damping = np.zeros(m.nv)  # applied as a force (apply_forces)
        for k, nb in enumerate(self.native.bodies):
            built = self._built[k]
            if built.articulation is None:
                continue
            active = built.articulation.get_active_joints()
            names = [j.name for j in active]
            for i, row in enumerate(nb.table):
                n = 3 if row.type == JointType.SPHERICAL else 1
                self._fl[row.u_index : row.u_index + n] = m.dof_frictionloss[
                    row.u_index : row.u_index + n
                ]
                if row.type == JointType.SPHERICAL:
                    dofs = tuple(names.index(f"{row.name}#{a}") for a in range(3))
                    inertial = self.plans[k].links[i + 1].inertial.orientation
                    self._balls.append((k, dofs, row.q_index, row.u_index, inertial))  # type: ignore[arg-type]
                    for a, dof in enumerate(dofs):
                        joint = active[dof]
                        joint.armature = np.array([m.dof_armature[row.u_index + a]], np.float32)
                        joint.friction = 0.0
                    self._ball_damping[row.u_index : row.u_index + 3] = m.dof_damping[
                        row.u_index : row.u_index + 3
                    ]
                    continue
                joint = built.links[i + 1].joint
                dof = names.index(joint.name)  # the plan's joint names are MuJoCo's rows'
                self._rows.append((k, dof, row.q_index, row.u_index))
                joint.armature = np.array([m.dof_armature[row.u_index]], dtype=np.float32)
                joint.friction = 0.0
                d = float(m.dof_damping[row.u_index])
                if d > 0.0:
                    joint.set_drive_properties(0.0, d, 3.0e38, "force")
                    joint.set_drive_velocity_target(0.0)
        self._rows_of = [[r for r in self._rows if r[0] == k] for k in range(len(self._built))]
        self._balls_of = [[b for b in self._balls if b[0] == k] for k in range(len(self._built))]

    # ---------------------------------------------------------------- the engine's hooks

    def engine_state(self) -> tuple[np.ndarray, np.ndarray]:
        """See MjcfOnEngine.engine_state: a free base's root link frame is MuJoCo's body frame
        (SAPIEN's pose, w, x, y, z); its velocity from the centre of mass's."""
        m = self.m
        q, v = m.qpos0.copy(), np.zeros(m.nv)
        for k, nb in enumerate(self.native.bodies):
            art = self._built[k].articulation
            if art is None:
                continue
            if nb.free_joint >= 0:
                qa, va = int(m.jnt_qposadr[nb.free_joint]), int(m.jnt_dofadr[nb.free_joint])
                root = self._built[k].links[0]
                pose = root.entity_pose
                q[qa : qa + 3] = pose.p
                q[qa + 3 : qa + 7] = pose.q
                rot = pose.to_transformation_matrix()[:3, :3]
                off = rot @ self.plans[k].links[0].inertial.position
                w = np.asarray(root.angular_velocity, dtype=float)
                v[va : va + 3] = np.asarray(root.linear_velocity, dtype=float) - np.cross(w, off)
                v[va + 3 : va + 6] = rot.T @ w
            aq, av = art.qpos, art.qvel
            for _, dof, qa, va in self._rows_of[k]:
                q[qa] = m.qpos0[qa] + float(aq[dof])
                v[va] = float(av[dof])
            for _, dofs, qa, va, inertial in self._balls_of[k]:
                a, b, c = (float(aq[d]) for d in dofs)
                w = rate_matrix(b, c) @ np.array([av[d] for d in dofs], dtype=float)
                quat = angles_to_quat(a, b, c)
                q[qa : qa + 4], v[va : va + 3] = ball_from_inertial(inertial, quat, _v3(w))
        return q, v

    def write_engine_state(self, qpos: np.ndarray, qvel: np.ndarray) -> None:
        """See MjcfOnEngine.write_engine_state."""
        m = self.m
        for k, nb in enumerate(self.native.bodies):
            art = self._built[k].articulation
            if art is None:
                continue
            if nb.free_joint >= 0:
                qa, va = int(m.jnt_qposadr[nb.free_joint]), int(m.jnt_dofadr[nb.free_joint])
                w4 = qpos[qa + 3 : qa + 7] / np.linalg.norm(qpos[qa + 3 : qa + 7])
                pose = sapien.Pose(
                    np.asarray(qpos[qa : qa + 3], np.float32), np.asarray(w4, np.float32)
                )
                art.root_pose = pose
                rot = pose.to_transformation_matrix()[:3, :3]
                off = rot @ self.plans[k].links[0].inertial.position
                w = rot @ qvel[va + 3 : va + 6]
                art.root_linear_velocity = np.asarray(
                    qvel[va : va + 3] + np.cross(w, off), np.float32
                )
                art.root_angular_velocity = np.asarray(w, np.float32)
            aq, av = art.qpos.copy(), art.qvel.copy()
            for _, dof, qa, va in self._rows_of[k]:
                aq[dof] = qpos[qa] - m.qpos0[qa]
                av[dof] = qvel[va]
            for _, dofs, qa, va, inertial in self._balls_of[k]:
                quat, w = ball_to_inertial(inertial, qpos[qa : qa + 4], qvel[va : va + 3])
                a, b, c = quat_to_angles(quat)
                rates = np.linalg.lstsq(rate_matrix(b, c), np.asarray(w), rcond=None)[0]
                for d, x, u in zip(dofs, (a, b, c), rates, strict=True):
                    aq[d], av[d] = x, u
            art.qpos = aq
            art.qvel = av

    def apply_forces(
        self,
        qfrc: np.ndarray,
        damping: np.ndarray,
        mass: np.ndarray,
        fc: np.ndarray | None = None,
    ) -> None:
        """See MjcfOnEngine.apply_forces: ``set_qf`` per articulation; damping and armature
        are the joints' own (drives, armature) but a ball joint's damping, a force implicit in
        every force (MuJoCo's Euler); frictionloss and MuJoCo's soft limits added here; a ball
        joint's three forces (child body frame) as its revolutes' ``J^T R(I)^T f``."""
        m, d = self.m, self.d
        full = mass + np.diag(m.dof_armature)
        f = qfrc.copy()
        if self._fl.any():  # the force that stops the joint within the step, clamped
            inv = np.linalg.inv(full)
            m_eff = 1.0 / np.maximum(np.diagonal(inv), 1e-12)
            f -= np.clip(m_eff * d.qvel / self.dt, -self._fl, self._fl)
        if self._balls:  # the balls' damping implicit in every force (MuJoCo's Euler)
            ball = self._ball_damping
            damping = damping - ball
            implicit = full + self.dt * np.diag(ball)
            acc = np.linalg.solve(implicit, f - (damping + ball) * d.qvel - d.qfrc_bias)
            f -= ball * (d.qvel + self.dt * acc)
            f += self._armature_correction(acc)
        if self._recovering:
            free = np.linalg.solve(full, f - damping * d.qvel - d.qfrc_bias)
            f += self.limit_recovery(full, free)
        for k, built in enumerate(self._built):
            art = built.articulation
            if art is None:
                continue
            qf = np.zeros(art.dof, dtype=np.float32)
            for _, dof, _, va in self._rows_of[k]:
                qf[dof] = f[va]
            if self._balls_of[k]:
                aq = art.qpos
                for _, dofs, _, va, inertial in self._balls_of[k]:
                    local = np.array(quat_rotate((-inertial[0], -inertial[1], -inertial[2],
                                                  inertial[3]), _v3(f[va : va + 3])))  # fmt: skip
                    jac = rate_matrix(float(aq[dofs[1]]), float(aq[dofs[2]]))
                    qf[list(dofs)] = jac.T @ local
            art.set_qf(qf)

    def _armature_correction(self, acc: np.ndarray) -> np.ndarray:
        """The force that turns the armature PhysX gives a ball's three revolutes (``A`` on
        their angle rates) into MuJoCo's (``A`` on the angular velocity): on the revolutes it
        is ``A J^-T (J^-1 w' + (J^-1)' w)`` in the child's inertial frame, MuJoCo's ``A w'``;
        the difference, in the body frame, is added (0 at the zero pose; left out where the
        middle angle is within 6° of +-90°, ``|det J| = |cos b| < 0.1``).

        Args:
            acc: (nv,) the acceleration expected this step (MuJoCo's coordinates).

        Returns:
            (nv,) the correction, 0 but on the balls' velocities.
        """
        m = self.m
        out = np.zeros(m.nv)
        for k, built in enumerate(self._built):
            art = built.articulation
            if art is None or not self._balls_of[k]:
                continue
            aq, av = art.qpos, art.qvel
            for _, dofs, _, va, inertial in self._balls_of[k]:
                arm = float(m.dof_armature[va])
                b, c = float(aq[dofs[1]]), float(aq[dofs[2]])
                if arm == 0.0 or abs(math.cos(b)) < 0.1:
                    continue
                jac = rate_matrix(b, c)
                inv = np.linalg.inv(jac)
                rates = np.array([av[i] for i in dofs], dtype=float)
                eps = 1e-6  # J's rate of change along the motion, by a difference
                ahead = rate_matrix(b + eps * rates[1], c + eps * rates[2])
                inv_rate = -inv @ ((ahead - jac) / eps) @ inv
                rot = _matrix(inertial)
                wdot = rot.T @ acc[va : va + 3]
                engine = arm * inv.T @ (inv @ wdot + inv_rate @ (jac @ rates))
                out[va : va + 3] = rot @ (engine - arm * wdot)
        return out

    def step_engine(self) -> None:
        """See MjcfOnEngine.step_engine: ``scene.step()``."""
        self._scene.step()
        self._contacts_cache = None

    def _owners(self) -> dict[int, tuple[int, int]]:
        """id of each PhysX component -> (the Sim's body, link): link ``i`` is the body's
        joint row ``i``; the file's world geoms (its floor) body -1, link -1."""
        out: dict[int, tuple[int, int]] = {}
        for body, built in enumerate(self._built):
            if built.static:
                out[id(built.actor)] = (body, -1)
            for k, comp in enumerate(built.links):
                out[id(comp)] = (body, k - 1)
        if self._ground is not None:
            out[id(self._ground.actor)] = (-1, -1)
        return out

    def engine_contacts(self) -> list[ContactPoint]:
        """See MjcfOnEngine.engine_contacts: the points SAPIEN's scene reported for the last
        step, as the PhysX backend reads them (:class:`~.contacts.ContactReads`)."""
        out = self._contacts_cache = self._last_contacts()
        return out

    def show_state(self) -> None:
        """See MjcfOnEngine.show_state: the window, if any, takes every part's pose."""
        if self._window is not None:
            self._window.sync()

    def close_engine(self) -> None:
        """See MjcfOnEngine.close_engine: the window, if any, closes; the scene is dropped."""
        window, self._window = self._window, None
        if window is not None:
            window.close()
        self._scene = None
        self._built = []

    def engine_departures(self) -> dict[str, Any]:
        """See MjcfOnEngine.engine_departures.

        Returns:
            PhysX's own: float32 state, its contact offsets; with a window, what it draws.
        """
        out = {
            "precision": "PhysX keeps poses and velocities in float32",
            "contact_margin": "a geom's margin and gap are PhysX's contact offset (0.01 m) and "
            "rest offset (0.0005 m)",
        }
        if self._window is not None:
            out["window"] = (
                "SAPIEN's window draws MuJoCo's visible geoms (groups 0-2) in their colours, "
                "flat-shaded as for a URDF: no textures, skybox or MuJoCo lights; no ellipsoid"
            )
        return out
