"""An MJCF model read as MuJoCo reads it, stepped by PyBullet (``load_mjcf(source,
semantics="mujoco")`` on ``Sim("pybullet")``).

The plans of :mod:`simbridge.model.mjcf_native_plan` become one ``p.createMultiBody`` per
top-level body (link i = MuJoCo's joint-table row i, MuJoCo's masses and inertias) and one
static body for the world body's geoms. Nothing of PyBullet's profile applies: link damping 0,
no joint-velocity clamp, the default motors released (a joint with ``frictionloss`` keeps a
velocity motor of target 0 and that force: Coulomb friction as PyBullet's motors make it).
Each step applies MuJoCo's actuator and spring forces as joint torques, the joint damping
implicit in every force (MuJoCo's Euler), the armature as a force (against the contact forces
of two trial steps of the same step, ``contact_passes``) and MuJoCo's soft joint limits
(the joints have no PyBullet limit; the shared part, ``backends/mjcf_engine.py``).

With ``gui`` the model is built in the Sim's GUI connection, handed over by the backend it
replaces (PyBullet allows one GUI per process) and reset first (``p.resetSimulation``: its
engine parameters PyBullet's defaults, as a new DIRECT connection's). The plans then carry
MuJoCo's visible geoms as visual shapes, drawn in one colour per link (the link's first
geom's: PyBullet colours a link whole); a link whose drawn geoms mix a mesh with other shapes
shows its meshes alone. The camera aims at the model and follows it, as for a URDF.
"""

from __future__ import annotations

import math
from typing import Any, ClassVar

import numpy as np

from simbridge.engine_output import captured
from simbridge.exceptions import SimulationDivergedError
from simbridge.model.mjcf_native import NativeMjcf
from simbridge.model.mjcf_native_plan import cross_excludes, ground_plan, native_plans
from simbridge.model.plan_records import BuildPlan, LinkPlan, ShapePlan
from simbridge.profiles import Profile
from simbridge.transforms import quat_multiply, quat_rotate, quat_to_matrix
from simbridge.types import ContactPoint, JointType, Quat, Vec3

from ..mjcf_engine import MjcfOnEngine, ball_from_inertial, ball_to_inertial
from ..mjcf_forces import cross3, free_velocity_change
from .contacts import contact_point
from .output import (
    _pybullet_gui_output,
    p,  # pybullet, imported with its banner captured
)
from .window import Window

__all__ = ["NativePyBullet"]

_JOINTS = {
    "revolute": p.JOINT_REVOLUTE,
    "continuous": p.JOINT_REVOLUTE,
    "prismatic": p.JOINT_PRISMATIC,
    "spherical": p.JOINT_SPHERICAL,
}


def _conj(q: Quat) -> Quat:
    return (-q[0], -q[1], -q[2], q[3])


def _shape_args(s: ShapePlan) -> dict[str, Any]:
    """``createCollisionShapeArray``'s entry of one plan shape."""
    if s.kind == "sphere":
        return {"shapeType": p.GEOM_SPHERE, "radius": s.size[0]}
    if s.kind == "capsule":
        return {"shapeType": p.GEOM_CAPSULE, "radius": s.size[0], "height": s.size[1]}
    if s.kind == "cylinder":
        return {"shapeType": p.GEOM_CYLINDER, "radius": s.size[0], "height": s.size[1]}
    if s.kind == "box":
        return {"shapeType": p.GEOM_BOX, "halfExtents": [0.5 * v for v in s.size]}
    if s.kind == "plane":
        return {"shapeType": p.GEOM_PLANE, "planeNormal": list(s.size)}
    assert s.mesh is not None
    return {"shapeType": p.GEOM_MESH, "vertices": np.asarray(s.mesh.vertices).tolist()}


def _collision(c: int, link: LinkPlan) -> int:
    """The link's compound collision shape (-1: none)."""
    if not link.collisions:
        return -1
    args = [_shape_args(s) for s in link.collisions]
    keys = ("shapeType", "radius", "halfExtents", "length", "planeNormal", "vertices")
    arrays: dict[str, list[Any]] = {k: [] for k in keys}
    for a in args:
        arrays["shapeType"].append(a["shapeType"])
        arrays["radius"].append(a.get("radius", 0.5))
        arrays["halfExtents"].append(a.get("halfExtents", [1.0, 1.0, 1.0]))
        arrays["length"].append(a.get("height", 1.0))
        arrays["planeNormal"].append(a.get("planeNormal", [0.0, 0.0, 1.0]))
    if len(args) == 1:  # one shape: createCollisionShape places it; meshes take vertices
        a = dict(args[0])
        s = link.collisions[0]
        return p.createCollisionShape(
            **a,
            collisionFramePosition=s.position,
            collisionFrameOrientation=s.orientation,
            physicsClientId=c,
        )
    if any("vertices" in a for a in args):  # several shapes with a mesh: one body link each
        raise_mesh = [s.name for s in link.collisions if s.kind == "mesh"]
        from simbridge.exceptions import BackendUnsupportedError

        raise BackendUnsupportedError(
            "pybullet",
            f"a mesh geom among several geoms of one link ({raise_mesh} of {link.name!r}) "
            "under semantics='mujoco'",
            "not yet: one mesh geom per body, or Sim('mujoco')",
        )
    return p.createCollisionShapeArray(
        shapeTypes=arrays["shapeType"],
        radii=arrays["radius"],
        halfExtents=arrays["halfExtents"],
        lengths=arrays["length"],
        planeNormals=arrays["planeNormal"],
        collisionFramePositions=[s.position for s in link.collisions],
        collisionFrameOrientations=[s.orientation for s in link.collisions],
        physicsClientId=c,
    )


def _visual(c: int, link: LinkPlan) -> int:
    """The link's visual shape (-1: none), in its first visual's colour."""
    shown = link.visuals
    if not shown:
        return -1
    rgba = list(shown[0].rgba or (1.0, 1.0, 1.0, 1.0))
    meshes = [s for s in shown if s.kind == "mesh"]
    if meshes:  # one mesh of them all, in the link frame
        vertices: list[list[float]] = []
        indices: list[int] = []
        for s in meshes:
            assert s.mesh is not None
            base = len(vertices)
            moved = np.asarray(s.mesh.vertices) @ quat_to_matrix(s.orientation).T + s.position
            vertices += moved.tolist()
            indices += [base + int(i) for i in np.asarray(s.mesh.faces).ravel()]
        return p.createVisualShape(
            p.GEOM_MESH, vertices=vertices, indices=indices, rgbaColor=rgba, physicsClientId=c
        )
    args = [_shape_args(s) for s in shown]
    return p.createVisualShapeArray(
        shapeTypes=[a["shapeType"] for a in args],
        radii=[a.get("radius", 0.5) for a in args],
        halfExtents=[a.get("halfExtents", [1.0, 1.0, 1.0]) for a in args],
        lengths=[a.get("height", 1.0) for a in args],
        visualFramePositions=[s.position for s in shown],
        visualFrameOrientations=[s.orientation for s in shown],
        physicsClientId=c,
    )


# PyBullet's joint speed clamp, above MuJoCo's bad value (1e10, mjMAXVAL): a runaway reaches
# it and raises SimulationDivergedError (MjcfOnEngine._check), where a clamp at 1e10 held it
SPEED_CAP = 1e20


class NativePyBullet(MjcfOnEngine):
    """The world of one MJCF model as MuJoCo compiles it, stepped by PyBullet.

    Args:
        profile: The Sim's profile (only gravity and the time step given to the Sim).
        native: The compiled model.
        gravity: The gravity the caller gave (m/s², world), or None for the file's.
        timestep: The time step the caller gave (s), or None for the file's.
        gui_client: The Sim's GUI connection to build the model in, now this world's (reset
            here); None: a DIRECT connection of its own.

    Raises:
        MjcfFeatureUnsupportedError: A feature only MuJoCo simulates.
    """

    name = "pybullet"
    engine_version = "3.2.7"
    departure_texts: ClassVar[dict[str, str]] = {
        "armature": "joint armature is a force each step that gives the motion "
        "(M + A + dt D)^-1 (f - c + fc - D qdot), fc the contact forces of the step's "
        "second trial (each step is tried twice, written back, then taken): exact without "
        "contact; with it two passes toward the force consistent with the step's contacts",
        "joint_damping": "joint damping is implicit in every force as MuJoCo's Euler makes it, "
        "(M + A + dt D)^-1 (f - c + fc - D qdot), given as a torque each step (fc as in "
        "armature's)",
        "frictionloss": "joint frictionloss is a velocity motor with target 0 and force "
        "frictionloss",
        "ball_joints": "a ball joint is PyBullet's spherical joint (it turns the child's "
        "inertial frame), read and written as MuJoCo's quaternion and body-frame angular "
        "velocity; its range is MuJoCo's cone computed here, its damping implicit in every "
        "force as MuJoCo's Euler makes it, its armature a force as on the hinges",
    }
    soft_limits = True  # MuJoCo's limit on M + A (PyBullet's hard limit stops M alone)
    contact_passes = 2  # the armature's force against the step's own contacts

    def __init__(
        self,
        profile: Profile,
        native: NativeMjcf,
        gravity: Vec3 | None = None,
        timestep: float | None = None,
        gui_client: int | None = None,
    ) -> None:
        super().__init__(profile, native, gravity, timestep, gui=gui_client is not None)
        self._window: Window | None = None
        if gui_client is None:
            c = self._c = p.connect(p.DIRECT)
        else:
            c = self._c = gui_client
            p.resetSimulation(physicsClientId=c)
            self._window = Window(c)
        m = self.m
        p.setGravity(*map(float, m.opt.gravity), physicsClientId=c)
        p.setPhysicsEngineParameter(fixedTimeStep=self.dt, numSubSteps=0, physicsClientId=c)
        drawn = self._window is not None
        self.plans = native_plans(native, limits=not self.soft_limits, visuals=drawn)
        ground = ground_plan(native, visuals=drawn)
        if self._window is None:
            self._ids = [self._build(plan) for plan in self.plans]
            self._ground = None if ground is None else self._build(ground)
        else:
            with self._window.paused():  # no redraw after each shape made
                self._ids = [self._build(plan) for plan in self.plans]
                self._ground = None if ground is None else self._build(ground)
        ids = {**dict(enumerate(self._ids)), -1: self._ground}
        for ka, ra, kb, rb, _ in cross_excludes(native):  # <exclude> across bodies
            if ids[ka] is not None and ids[kb] is not None:
                p.setCollisionFilterPair(ids[ka], ids[kb], ra, rb, 0, physicsClientId=c)
        self._filters()
        self._layout()
        self._write(m.qpos0.copy(), np.zeros(m.nv))
        self.note_penetration("PyBullet's rigid contacts")
        if self._window is not None:
            self._window.aim(self._shown())

    def _shown(self) -> list[tuple[int, bool]]:
        """``(PyBullet id, free base)`` of every body, for the window's camera."""
        out = [(b, not plan.fixed_base) for b, plan in zip(self._ids, self.plans, strict=True)]
        return out + ([(self._ground, False)] if self._ground is not None else [])

    def _build(self, plan: BuildPlan) -> int:
        """``p.createMultiBody`` of one plan; PyBullet's defaults undone."""
        c = self._c
        base, links = plan.links[0], plan.links[1:]
        ine = base.inertial
        body = p.createMultiBody(
            baseMass=ine.mass,
            baseCollisionShapeIndex=_collision(c, base),
            basePosition=plan.base_position,
            baseOrientation=plan.base_orientation,
            baseInertialFramePosition=ine.position,
            baseInertialFrameOrientation=ine.orientation,
            linkMasses=[lk.inertial.mass for lk in links],
            linkCollisionShapeIndices=[_collision(c, lk) for lk in links],
            baseVisualShapeIndex=_visual(c, base),
            linkVisualShapeIndices=[_visual(c, lk) for lk in links],
            linkPositions=[lk.joint.position for lk in links],  # type: ignore[union-attr]
            linkOrientations=[lk.joint.orientation for lk in links],  # type: ignore[union-attr]
            linkInertialFramePositions=[lk.inertial.position for lk in links],
            linkInertialFrameOrientations=[lk.inertial.orientation for lk in links],
            linkParentIndices=[lk.parent + 1 for lk in links],  # type: ignore[operator]
            linkJointTypes=[_JOINTS[lk.joint.type] for lk in links],  # type: ignore[union-attr]
            linkJointAxis=[lk.joint.axis for lk in links],  # type: ignore[union-attr]
            flags=p.URDF_USE_SELF_COLLISION,
            physicsClientId=c,
        )
        for lk in plan.links:
            if lk.visuals:  # the link's colour (createVisualShapeArray takes none)
                rgba = list(lk.visuals[0].rgba or (1.0, 1.0, 1.0, 1.0))
                p.changeVisualShape(body, lk.index, rgbaColor=rgba, physicsClientId=c)
            p.changeDynamics(
                body,
                lk.index,
                lateralFriction=lk.contact.lateral_friction,
                spinningFriction=lk.contact.spinning_friction,
                rollingFriction=lk.contact.rolling_friction,
                restitution=0.0,
                linearDamping=0.0,
                angularDamping=0.0,
                jointDamping=0.0,
                maxJointVelocity=SPEED_CAP,
                physicsClientId=c,
            )
            if lk.inertial.mass > 0.0 and lk.index >= 0:
                p.changeDynamics(
                    body, lk.index, localInertiaDiagonal=lk.inertial.diagonal, physicsClientId=c
                )
            p.setCollisionFilterGroupMask(
                body, lk.index, lk.filter.group, lk.filter.mask, physicsClientId=c
            )
        if plan.links[0].inertial.mass > 0.0:
            p.changeDynamics(body, -1, localInertiaDiagonal=ine.diagonal, physicsClientId=c)
        for a, b in plan.excluded_pairs:
            p.setCollisionFilterPair(body, body, a, b, 0, physicsClientId=c)
        return body

    def _filters(self) -> None:
        """No contact between bodies MuJoCo would not pair (contype/conaffinity is the plans'
        group/mask, PyBullet's rule the same OR rule)."""

    def _layout(self) -> None:
        """Each body's joints (PyBullet indices, ``qpos``/``qvel`` addresses, ``qpos0``); the
        default motors released, a ``frictionloss`` kept as a velocity motor of target 0 and
        that force; a ball joint's spherical motor a brake (kp 0, kd 1) of that force per axis,
        or released."""
        c, m = self._c, self.m
        # per body: (PyBullet id, hinge and slide joint indices, qpos addresses, qvel addresses)
        self._joints: list[tuple[int, list[int], np.ndarray, np.ndarray]] = []
        # every ball joint: (PyBullet id, joint index, qpos address, qvel address, the child's
        # inertial frame in its link frame, x, y, z, w: PyBullet's spherical joint turns it)
        self._balls: list[tuple[int, int, int, int, Quat]] = []
        for k, nb in enumerate(self.native.bodies):
            body = self._ids[k]
            rows = [(i, row) for i, row in enumerate(nb.table) if row.type != JointType.SPHERICAL]
            idx = [i for i, _ in rows]
            qa = np.array([row.q_index for _, row in rows], dtype=np.intp)
            va = np.array([row.u_index for _, row in rows], dtype=np.intp)
            self._joints.append((body, idx, qa, va))
            for i, row in enumerate(nb.table):
                j = nb.joint_ids[i]
                if row.type == JointType.SPHERICAL:
                    inertial = self.plans[k].links[i + 1].inertial.orientation
                    self._balls.append((body, i, row.q_index, row.u_index, inertial))
                    fl = float(m.dof_frictionloss[row.u_index])
                    p.setJointMotorControlMultiDof(
                        body, i, p.POSITION_CONTROL, targetPosition=[0.0, 0.0, 0.0, 1.0],
                        positionGain=[0.0] * 3, velocityGain=[1.0] * 3, force=[fl] * 3,
                        damping=[1.0] * 3, physicsClientId=c,
                    )  # fmt: skip
                elif m.jnt_limited[j] and not self.soft_limits:
                    ref = float(m.qpos0[row.q_index])  # the engine's 0 is MuJoCo's qpos0
                    p.changeDynamics(
                        body, i, jointLowerLimit=float(m.jnt_range[j][0]) - ref,
                        jointUpperLimit=float(m.jnt_range[j][1]) - ref, physicsClientId=c,
                    )  # fmt: skip
            if idx:
                p.setJointMotorControlArray(
                    body, idx, p.VELOCITY_CONTROL, targetVelocities=[0.0] * len(idx),
                    forces=m.dof_frictionloss[va].tolist(), physicsClientId=c,
                )  # fmt: skip

    # ---------------------------------------------------------------- the engine's hooks

    def engine_state(self) -> tuple[np.ndarray, np.ndarray]:
        """See MjcfOnEngine.engine_state: the free base's body frame from PyBullet's centre of
        mass; hinge and slide positions plus ``qpos0``."""
        c, m = self._c, self.m
        q, v = m.qpos0.copy(), np.zeros(m.nv)
        for k, nb in enumerate(self.native.bodies):
            if nb.free_joint < 0:
                continue
            body, ine = self._ids[k], self.plans[k].links[0].inertial
            pos, orn = p.getBasePositionAndOrientation(body, physicsClientId=c)
            lin, ang = p.getBaseVelocity(body, physicsClientId=c)
            frame = quat_multiply(orn, _conj(ine.orientation))
            off = np.array(quat_rotate(frame, ine.position))
            qa, va = int(m.jnt_qposadr[nb.free_joint]), int(m.jnt_dofadr[nb.free_joint])
            q[qa : qa + 3] = np.array(pos) - off
            q[qa + 3 : qa + 7] = (frame[3], frame[0], frame[1], frame[2])
            w = np.array(ang)
            v[va : va + 3] = np.array(lin) - cross3(w, off)
            v[va + 3 : va + 6] = quat_rotate(_conj(frame), ang)
        for body, idx, qas, vas in self._joints:
            if idx:
                states = p.getJointStates(body, idx, physicsClientId=c)
                q[qas] += [s[0] for s in states]
                v[vas] = [s[1] for s in states]
        for body, i, qa, va, inertial in self._balls:
            quat, w = p.getJointStateMultiDof(body, i, physicsClientId=c)[:2]
            q[qa : qa + 4], v[va : va + 3] = ball_from_inertial(inertial, quat, w)
        return q, v

    def write_engine_state(self, qpos: np.ndarray, qvel: np.ndarray) -> None:
        """See MjcfOnEngine.write_engine_state."""
        c, m = self._c, self.m
        for k, nb in enumerate(self.native.bodies):
            if nb.free_joint < 0:
                continue
            body, ine = self._ids[k], self.plans[k].links[0].inertial
            qa, va = int(m.jnt_qposadr[nb.free_joint]), int(m.jnt_dofadr[nb.free_joint])
            w4 = qpos[qa + 3 : qa + 7] / np.linalg.norm(qpos[qa + 3 : qa + 7])
            frame = (float(w4[1]), float(w4[2]), float(w4[3]), float(w4[0]))
            off = np.array(quat_rotate(frame, ine.position))
            orn = quat_multiply(frame, ine.orientation)
            p.resetBasePositionAndOrientation(
                body, (qpos[qa : qa + 3] + off).tolist(), orn, physicsClientId=c
            )
            ang = np.array(quat_rotate(frame, tuple(qvel[va + 3 : va + 6])))
            lin = qvel[va : va + 3] + cross3(ang, off)
            p.resetBaseVelocity(body, lin.tolist(), ang.tolist(), physicsClientId=c)
        for body, idx, qas, vas in self._joints:
            for i, a, b in zip(idx, qas.tolist(), vas.tolist(), strict=True):
                p.resetJointState(
                    body, i, float(qpos[a] - m.qpos0[a]), float(qvel[b]), physicsClientId=c
                )
        for body, i, qa, va, inertial in self._balls:
            quat, w = ball_to_inertial(inertial, qpos[qa : qa + 4], qvel[va : va + 3])
            p.resetJointStateMultiDof(body, i, quat, w, physicsClientId=c)

    def apply_forces(
        self,
        qfrc: np.ndarray,
        damping: np.ndarray,
        mass: np.ndarray,
        fc: np.ndarray | None = None,
    ) -> None:
        """See MjcfOnEngine.apply_forces: joint torques (``TORQUE_CONTROL``, one step) of
        :meth:`with_armature`; a free base's force and torque as external forces."""
        c, m = self._c, self.m
        tau = self.with_armature(qfrc, damping, mass, fc)
        for body, idx, _, vas in self._joints:
            if idx:
                p.setJointMotorControlArray(
                    body, idx, p.TORQUE_CONTROL, forces=tau[vas].tolist(), physicsClientId=c
                )
        for body, i, _, va, inertial in self._balls:  # about the child's inertial axes
            torque = quat_rotate(_conj(inertial), tuple(tau[va : va + 3]))
            p.setJointMotorControlMultiDof(
                body, i, p.TORQUE_CONTROL, force=list(torque), physicsClientId=c
            )
        for k, nb in enumerate(self.native.bodies):
            if nb.free_joint < 0:
                continue
            va = int(m.jnt_dofadr[nb.free_joint])
            f = tau[va : va + 6]
            if f.any():
                d, body = self.d, self._ids[k]
                qa = int(m.jnt_qposadr[nb.free_joint])
                w4 = d.qpos[qa + 3 : qa + 7]
                frame = (float(w4[1]), float(w4[2]), float(w4[3]), float(w4[0]))
                origin = d.qpos[qa : qa + 3].tolist()
                p.applyExternalForce(
                    body, -1, f[:3].tolist(), origin, p.WORLD_FRAME, physicsClientId=c
                )
                torque = quat_rotate(frame, tuple(f[3:]))
                p.applyExternalTorque(body, -1, list(torque), p.WORLD_FRAME, physicsClientId=c)

    def velocity_change(
        self, q0: np.ndarray, v0: np.ndarray, q1: np.ndarray, v1: np.ndarray
    ) -> np.ndarray:
        """See MjcfOnEngine.velocity_change: a free base's by
        :func:`~..mjcf_forces.free_velocity_change` (PyBullet steps its centre of mass's
        velocity and its world angular velocity)."""
        out = v1 - v0
        m = self.m
        for k, nb in enumerate(self.native.bodies):
            if nb.free_joint < 0:
                continue
            qa, va = int(m.jnt_qposadr[nb.free_joint]), int(m.jnt_dofadr[nb.free_joint])
            com = np.asarray(self.plans[k].links[0].inertial.position, dtype=np.float64)
            out[va : va + 6] = free_velocity_change(
                q0[qa : qa + 7], v0[va : va + 6], q1[qa : qa + 7], v1[va : va + 6], com, self.dt
            )
        return out

    def engine_contacts(self) -> list[ContactPoint]:
        """See MjcfOnEngine.engine_contacts: ``p.getContactPoints()``, PyBullet's rows with
        its body ids turned into the Sim's (the ground's into -1); a non-finite value raises
        SimulationDivergedError."""
        sim_id = {engine: k for k, engine in enumerate(self._ids)}
        if self._ground is not None:
            sim_id[self._ground] = -1
        out = []
        for r in p.getContactPoints(physicsClientId=self._c):
            a, b = sim_id.get(r[1]), sim_id.get(r[2])
            if a is None or b is None:
                continue
            if not all(map(math.isfinite, (*r[5], *r[6], *r[7], r[8], r[9], r[10], r[12]))):
                self._diverged = SimulationDivergedError(
                    self.name, self._time, "a contact point (non-finite)"
                )
                raise self._diverged
            out.append(contact_point((r[0], a, b, *r[3:])))
        return out

    def engine_overlaps(self) -> list[ContactPoint] | None:
        """See MjcfOnEngine.engine_overlaps: ``p.performCollisionDetection`` (no step), then
        :meth:`engine_contacts`."""
        p.performCollisionDetection(physicsClientId=self._c)
        return self.engine_contacts()

    def step_engine(self) -> None:
        """See MjcfOnEngine.step_engine: ``p.stepSimulation``."""
        p.stepSimulation(physicsClientId=self._c)

    def show_state(self) -> None:
        """See MjcfOnEngine.show_state: the window's camera follows the model (PyBullet's
        window draws the engine's state itself)."""
        if self._window is not None:
            self._window.follow(self._shown())

    def close_engine(self) -> None:
        """See MjcfOnEngine.close_engine: ``p.disconnect`` (the window with it)."""
        try:
            if self._window is not None:
                with captured(self.name, "closing the GUI", _pybullet_gui_output):
                    p.disconnect(physicsClientId=self._c)
            else:
                p.disconnect(physicsClientId=self._c)
        except p.error:
            pass

    def engine_departures(self) -> dict[str, str]:
        """See MjcfOnEngine.engine_departures."""
        out = {
            "contact_margin": "a geom's margin and gap are PyBullet's collision margin "
            "(0.04 m on primitives in its collision detection, contacts from distance 0)",
        }
        if self._window is not None:
            out["window"] = (
                "PyBullet's window draws MuJoCo's visible geoms (groups 0-2) in one colour per "
                "link (its first geom's); a link mixing a mesh with primitives shows its meshes "
                "alone; no textures, skybox or MuJoCo lights; no ellipsoid"
            )
        return out
