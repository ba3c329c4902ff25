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
A ball joint is refused (backends/mjcf_engine.py).
"""

from __future__ import annotations

from typing import Any

import numpy as np
import sapien
from sapien import physx

from simbridge.exceptions import MjcfFeatureUnsupportedError
from simbridge.model.mjcf_native import NativeMjcf
from simbridge.model.mjcf_native_plan import cross_excludes, ground_plan, native_plans
from simbridge.model.plan_records import BuildPlan
from simbridge.profiles import Profile
from simbridge.types import ContactPoint, Vec3

from ..mjcf_engine import MjcfOnEngine
from .contacts import ContactReads
from .model import build_robot, ignore_bits, needed_pairs

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
            raise MjcfFeatureUnsupportedError(
                native.display_name,
                "physx",
                "<contact><exclude> between two top-level bodies",
                pair,
                "its bodies' excluded pairs need more than SAPIEN's 32 ignore bits",
            )
        tag = min(tags[k] for k in members)
        for k in members:
            tags[k] = tag
            ignore[k] = {link.index: int(bits.get((k, link.index), 0)) for link in of[k].links}
    return tags, ignore


class NativePhysx(MjcfOnEngine, ContactReads):
    """The world of one MJCF model as MuJoCo compiles it, stepped by PhysX.

    Args:
        profile: The Sim's profile (only gravity and the time step given to the Sim).
        native: The compiled model.
        gravity: The gravity the caller gave (m/s², world), or None for the file's.
        timestep: The time step the caller gave (s), or None for the file's.

    Raises:
        MjcfFeatureUnsupportedError: A feature only MuJoCo simulates, or a ball joint.
    """

    name = "physx"
    state_dtype = "float32"
    soft_limits = True  # MuJoCo's soft limit (docs/mjcf_mujoco_reading.md: measured closer)
    engine_version = sapien.__version__

    def __init__(
        self,
        profile: Profile,
        native: NativeMjcf,
        gravity: Vec3 | None = None,
        timestep: float | None = None,
    ) -> None:
        super().__init__(profile, native, gravity, timestep)
        m = self.m
        cfg = physx.PhysxSceneConfig()
        cfg.gravity = np.asarray(m.opt.gravity, dtype=np.float32)
        cfg.enable_tgs = False
        physx.set_scene_config(cfg)
        self._scene = sapien.Scene([physx.PhysxCpuSystem()])
        self._scene.timestep = self.dt
        self.plans = native_plans(native, limits=not self.soft_limits)
        ground = ground_plan(native)
        tags, ignore = _shared_filters(native, self.plans, ground)
        self._built = [
            build_robot(self._scene, plan, SOLVER_ITERATIONS, tags[k], ignore=ignore.get(k))
            for k, plan in enumerate(self.plans)
        ]
        self._ground = None
        if ground is not None:
            self._ground = build_robot(
                self._scene, ground, SOLVER_ITERATIONS, tags[-1], ignore=ignore.get(-1)
            )
        self._dt = self.dt
        self._contacts_cache: list[ContactPoint] | None = None
        self._contacts_kept: list[ContactPoint] | None = None  # no body is ever removed
        self._layout()
        self._write(m.qpos0.copy(), np.zeros(m.nv))

    def _layout(self) -> None:
        """Each row's PhysX dof (its place in the articulation's ``qpos``); MuJoCo's armature
        and damping on the joints; PhysX's joint friction 0."""
        m = self.m
        self._rows: list[tuple[int, int, int, int]] = []  # (body, dof, qpos adr, qvel adr)
        self._fl = np.zeros(m.nv)
        for k, nb in enumerate(self.native.bodies):
            built = self._built[k]
            if built.articulation is None:
                continue
            active = [j.name for j in built.articulation.get_active_joints()]
            for i, row in enumerate(nb.table):
                joint = built.links[i + 1].joint
                dof = active.index(joint.name)  # the plan's joint names are MuJoCo's rows'
                self._rows.append((k, dof, row.q_index, row.u_index))
                joint.armature = np.array([m.dof_armature[row.u_index]], dtype=np.float32)
                joint.friction = 0.0
                d = float(m.dof_damping[row.u_index])
                if d > 0.0:
                    joint.set_drive_properties(0.0, d, 3.0e38, "force")
                    joint.set_drive_velocity_target(0.0)
                self._fl[row.u_index] = float(m.dof_frictionloss[row.u_index])
        self._rows_of = [[r for r in self._rows if r[0] == k] for k in range(len(self._built))]

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
            art.qpos = aq
            art.qvel = av

    def apply_forces(self, qfrc: np.ndarray, damping: np.ndarray, mass: np.ndarray) -> None:
        """See MjcfOnEngine.apply_forces: ``set_qf`` per articulation; damping and armature
        are the joints' own (drives, armature); frictionloss and the recovery of a joint placed
        outside its range added here."""
        m, d = self.m, self.d
        full = mass + np.diag(m.dof_armature)
        f = qfrc.copy()
        if self._fl.any():  # the force that stops the joint within the step, clamped
            inv = np.linalg.inv(full)
            m_eff = 1.0 / np.maximum(np.diagonal(inv), 1e-12)
            f -= np.clip(m_eff * d.qvel / self.dt, -self._fl, self._fl)
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
            art.set_qf(qf)

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

    def close_engine(self) -> None:
        """See MjcfOnEngine.close_engine: the scene is dropped."""
        self._scene = None
        self._built = []

    def engine_departures(self) -> dict[str, Any]:
        """See MjcfOnEngine.engine_departures.

        Returns:
            PhysX's own: float32 state, its contact offsets.
        """
        out = {
            "precision": "PhysX keeps poses and velocities in float32",
            "contact_margin": "a geom's margin and gap are PhysX's contact offset (0.01 m) and "
            "rest offset (0.0005 m)",
        }
        loose = [self.plans[k].name for k, b in enumerate(self._built) if not b.filtered_exactly]
        if loose:
            out["excluded_pairs"] = (
                "the excluded pairs (parent and child, <contact><exclude>) of these bodies need "
                f"more than SAPIEN's 32 ignore bits; only PhysX's own rule applies: {loose}"
            )
        return out
