"""Every call of the `Sim` interface, PyBullet, MuJoCo and PhysX side by side, with the raw
engine call.

    python bench/calls.py                        # full run (a few minutes)
    python bench/calls.py --quick --repeats 1    # smoke run
    python bench/calls.py --backends mujoco --stat min   # one engine; the least of the repeats
    python bench/calls.py --backends pybullet,physx      # PhysX against PyBullet
    python bench/calls.py --stat min --clock cpu         # a machine busier than its cores
    python bench/calls.py --only link_state      # the rows whose name holds the text, alone
    python bench/ab.py BEFORE_TREE AFTER_TREE    # two source trees' runs in turn, compared

Two robots: r2d2 resting on plane.urdf (4 wheels commanded, link 2 read) and a fixed-base KUKA
iiwa (7 joints commanded, link 6 read); and for the reads a legged observation makes
(``A1_ROWS``: link and base states, joint states, contacts) a Unitree A1 standing on the plane,
its 12 joints held in a1_stand's default pose by position motors (33.5 N m), link 5 (the front
right toe) read. Every call is timed per call over a loop of ``--calls`` calls (a command
alternates two targets, so every call is a new command; a step row times single ``sim.step()``
calls, contact-free: r2d2 reset into the air before each repeat, the KUKA in free space; the
``contact_points`` row reads r2d2 resting on the plane (the A1 standing), put back and settled
before each timing, every call converting the step's points afresh: the number of points each
engine reports is said under the table). Each repeat times every row once, in turn (PyBullet
layer, MuJoCo layer, PhysX layer, then the raw calls), and the table gives the medians
(``--stat min``: the least) over ``--repeats`` repeats, less the loop's own cost (a call of an
empty lambda, measured the same way). Each ratio is an engine's layer call over PyBullet's
layer call, the target (../shared/PERFORMANCE.md, issues 11 and 21) at most 1.5x for every
engine.

Raw calls: PyBullet's own function on the same client (``setJointMotorControlArray``,
``getLinkState(computeLinkVelocity=1, computeForwardKinematics=1)``...); for MuJoCo, what a raw
user writes: a ``d.ctrl[:] = array`` write (a model with one actuator per commanded joint),
copies out of ``MjData`` for reads, ``mj_step`` on the same world without the layer's motors,
brakes and damping. For PhysX, raw SAPIEN 3 written the fast idiomatic way on a second world
built by the layer from the same model (its own scene: the raw code changes it), with PhysX's
own link damping (the profile's k) in place of the layer's per-step PyBullet law: joint
handles, dof indices, links and poses looked up once; a drive target per joint
(``set_drive_velocity_target``, ``set_drive_target``: SAPIEN's CPU articulation has no batched
drive target), the force limit left as set (the layer, too, sets ``set_drive_properties`` only
when it changes); ``art.qf``/``art.qpos``/``art.qvel`` array writes; ``entity_pose``,
``cmass_local_pose``, ``linear_velocity``/``angular_velocity`` reads; ``scene.step()``.
"-" where there is no raw counterpart.

A second table: the position-controlled KUKA, a new target every step: the command and the
step against the step alone (the target: within 1.3x), through ``set_joint_position`` and
through a bound command (``sim.position_command``), and the r2d2 drive through a bound
velocity command against each raw engine (for PhysX also against raw SAPIEN that applies
PyBullet's link damping law itself, the floor of any layer that gives PhysX that law).

A last table (PhysX): where its layer call costs more than raw SAPIEN's, the raw call, the raw
call plus what the layer must do that idiomatic SAPIEN does not, and the layer's call.

The machine is shared: compare ratios measured in one run, not absolute times across runs.
Where it runs more work than it has cores, ``--clock cpu`` times this process's CPU time.
"""

from __future__ import annotations

import argparse
import platform
import statistics
import sys
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from types import SimpleNamespace
from typing import Any

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))

import cases  # noqa: E402  (bench/cases.py: the r2d2 world and the raw drives)

import simbridge  # noqa: E402

KUKA = "kuka_iiwa/model.urdf"
A1 = "a1/a1.urdf"
# the A1's default pose (envs/tasks/a1_stand.toml): joint name -> rad; its base's start height
A1_POSE = {
    "FR_hip_joint": -0.1,
    "FR_upper_joint": 0.8,
    "FR_lower_joint": -1.5,
    "FL_hip_joint": 0.1,
    "FL_upper_joint": 0.8,
    "FL_lower_joint": -1.5,
    "RR_hip_joint": -0.1,
    "RR_upper_joint": 1.0,
    "RR_lower_joint": -1.5,
    "RL_hip_joint": 0.1,
    "RL_upper_joint": 1.0,
    "RL_lower_joint": -1.5,
}
A1_Z = 0.32
A1_FORCE = 33.5  # N m, the stand task's torque limit
# the rows timed on the standing A1: a legged observation's reads
A1_ROWS = (
    "link_state(link)",
    "link_states(every link)",
    "base_state",
    "joint_states(commanded joints)",
    "contact_points",
)
ROBOTS = ("r2d2", "kuka", "a1")
TARGET = 1.5  # no MuJoCo or PhysX call more than 1.5x the same call on PyBullet


@dataclass
class Row:
    """One call: a callable per column, taking 0 or 1 (which of two alternating arguments)."""

    name: str
    columns: dict[str, Callable[[int], object]]
    note: str = ""
    times: dict[str, list[float]] = field(default_factory=dict)


COLUMNS = ("pybullet", "mujoco", "physx", "raw pybullet", "raw mujoco", "raw physx")
# every engine installed (PhysX where its extra is: cases.BACKENDS)
CALL_BACKENDS = list(cases.BACKENDS)
LABEL = {"pybullet": "PyBullet", "mujoco": "MuJoCo", "physx": "PhysX"}


# ---------------------------------------------------------------- worlds


class World:
    """One robot on one backend: the Sim, the body, the joints commanded, the link read."""

    def __init__(self, backend: str, robot: str) -> None:
        self.backend = backend
        self.robot = robot
        self.sim = simbridge.Sim(backend)
        if robot == "r2d2":
            self.sim.load_urdf("plane.urdf")
            self.body = self.sim.load_urdf("r2d2.urdf", base_position=(0, 0, cases.START_Z))
            self.joints = list(cases.WHEELS)
            self.link = 2
        elif robot == "a1":
            self.sim.load_urdf("plane.urdf")
            self.body = self.sim.load_urdf(A1, base_position=(0, 0, A1_Z))
            every = range(self.sim.num_joints(self.body))
            names = [self.sim.joint_info(self.body, j).name for j in every]
            self.joints = [names.index(name) for name in A1_POSE]
            self.link = 5
            _stand(self)
        else:
            self.body = self.sim.load_urdf(KUKA, fixed_base=True)
            self.joints = list(range(7))
            self.link = 6
        self.sim.step(10)
        self.np_joints = np.array(self.joints)


def _pybullet_raw(w: World) -> dict[str, Callable[[Any], object]]:
    import pybullet as p

    from simbridge.backends.pybullet.inspect import client_id

    c = client_id(w.sim)  # the same client, called raw
    b, j, link, n = w.body, w.joints, w.link, len(w.joints)
    forces = [50.0] * n
    gains = ([0.1] * n, [1.0] * n)
    every = list(range(p.getNumJoints(b, physicsClientId=c)))  # every link

    def reset_joints(q: list[float]) -> None:
        for i, v in zip(j, q, strict=True):
            p.resetJointState(b, i, v, 0.0, physicsClientId=c)

    return {
        "set_joint_velocity": lambda t: p.setJointMotorControlArray(
            b, j, p.VELOCITY_CONTROL, targetVelocities=t, forces=forces, physicsClientId=c
        ),
        "set_joint_position": lambda t: p.setJointMotorControlArray(
            b,
            j,
            p.POSITION_CONTROL,
            targetPositions=t,
            forces=forces,
            positionGains=gains[0],
            velocityGains=gains[1],
            physicsClientId=c,
        ),
        "set_joint_torque": lambda t: p.setJointMotorControlArray(
            b, j, p.TORQUE_CONTROL, forces=t, physicsClientId=c
        ),
        "link_state": lambda _: p.getLinkState(
            b, link, computeLinkVelocity=1, computeForwardKinematics=1, physicsClientId=c
        ),
        "base_state": lambda _: (
            p.getBasePositionAndOrientation(b, physicsClientId=c),
            p.getBaseVelocity(b, physicsClientId=c),
        ),
        "link_states": lambda _: (
            p.getBasePositionAndOrientation(b, physicsClientId=c),
            p.getBaseVelocity(b, physicsClientId=c),
            p.getLinkStates(
                b,
                every,
                computeLinkVelocity=1,
                computeForwardKinematics=1,
                physicsClientId=c,
            ),
        ),
        "joint_states": lambda _: p.getJointStates(b, j, physicsClientId=c),
        "joint_info": lambda _: p.getJointInfo(b, link, physicsClientId=c),
        "dynamics_info": lambda _: p.getDynamicsInfo(b, link, physicsClientId=c),
        "num_joints": lambda _: p.getNumJoints(b, physicsClientId=c),
        "reset_joint_state": reset_joints,
        "reset_base_state": lambda pose: p.resetBasePositionAndOrientation(
            b, pose[0], pose[1], physicsClientId=c
        ),
        "step": lambda _: p.stepSimulation(physicsClientId=c),
        "contact_points": lambda _: p.getContactPoints(physicsClientId=c),
        "two groups": lambda i: p.setJointMotorControlArray(
            b,
            _groups(w)[i],
            p.VELOCITY_CONTROL,
            targetVelocities=[1.0 + i] * len(_groups(w)[i]),
            forces=[50.0] * len(_groups(w)[i]),
            physicsClientId=c,
        ),
        "mode change": lambda i: (
            p.setJointMotorControlArray(
                b,
                j,
                p.VELOCITY_CONTROL,
                targetVelocities=[0.5] * n,
                forces=forces,
                physicsClientId=c,
            )
            if i
            else p.setJointMotorControlArray(
                b,
                j,
                p.POSITION_CONTROL,
                targetPositions=[0.2] * n,
                forces=forces,
                positionGains=gains[0],
                velocityGains=gains[1],
                physicsClientId=c,
            )
        ),
    }


def _mujoco_raw(w: World) -> dict[str, Callable[[Any], object]]:
    """Raw MuJoCo on the layer's world: a copy of its spec with MuJoCo's own joint-limit
    parameters, none of the layer's motors, brakes and damping, and one velocity actuator per
    commanded joint (for the ``d.ctrl`` writes; ctrl 0 and kv 0 while stepping)."""
    import mujoco

    from simbridge.backends.mujoco import inspect

    r = inspect.robot(w.sim, w.body)
    spec = inspect.world_spec(w.sim).copy()
    for jnt in spec.joints:
        jnt.solref_limit = [0.02, 1.0]
        jnt.solimp_limit = [0.9, 0.95, 0.001, 0.5, 2.0]
        jnt.margin = 0.0
    for j in w.joints:
        act = spec.add_actuator(
            name=f"raw/{j}", target=r.spec.joint_names[j], trntype=mujoco.mjtTrn.mjTRN_JOINT
        )
        act.set_to_velocity(kv=0.0)
    m = spec.compile()
    d = mujoco.MjData(m)
    d.qpos[:] = inspect.model_and_data(w.sim)[1].qpos
    mujoco.mj_forward(m, d)
    jid = [mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_JOINT, r.spec.joint_names[j]) for j in w.joints]
    qadr = m.jnt_qposadr[jid].copy()
    dofs = m.jnt_dofadr[jid].copy()
    link = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, r.spec.body_names[w.link + 1])
    bodies = np.array(  # every link's body, the base first
        [mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, name) for name in r.spec.body_names]
    )
    base = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, r.spec.body_names[0])
    free = m.body_jntadr[base] >= 0 and m.jnt_type[m.body_jntadr[base]] == 0
    a = m.jnt_qposadr[m.body_jntadr[base]] if free else -1
    v = m.jnt_dofadr[m.body_jntadr[base]] if free else -1

    def ctrl(t: np.ndarray) -> None:
        d.ctrl[:] = t

    def link_state(_: object) -> object:
        return d.xipos[link].copy(), d.xquat[link].copy(), d.xpos[link].copy(), d.cvel[link].copy()

    def link_states(_: object) -> object:
        return d.xipos[bodies], d.xquat[bodies], d.xpos[bodies], d.cvel[bodies]

    def base_state(_: object) -> object:
        if free:
            return d.xipos[base].copy(), d.xquat[base].copy(), d.qvel[v : v + 6].copy()
        return d.xipos[base].copy(), d.xquat[base].copy()

    def dynamics(_: object) -> object:
        return (
            float(m.body_mass[link]),
            m.body_inertia[link].copy(),
            m.body_ipos[link].copy(),
            m.body_iquat[link].copy(),
        )

    def reset_joints(q: np.ndarray) -> None:
        d.qpos[qadr] = q
        d.qvel[dofs] = 0.0

    def reset_base(pose: tuple[np.ndarray, np.ndarray]) -> None:
        if free:
            d.qpos[a : a + 3] = pose[0]
            d.qpos[a + 3 : a + 7] = pose[1]
        else:
            m.body_pos[base] = pose[0]
            m.body_quat[base] = pose[1]

    lm, ld = inspect.model_and_data(w.sim)  # the layer's own world: its contacts

    def contacts(_: object) -> object:
        n = ld.ncon
        con = ld.contact
        force = np.zeros((n, 6))
        for i in range(n):
            mujoco.mj_contactForce(lm, ld, i, force[i])
        return con.geom[:n].copy(), con.pos[:n].copy(), con.frame[:n].copy(), force

    return {
        "set_joint_velocity": ctrl,
        "set_joint_position": ctrl,
        "set_joint_torque": ctrl,
        "link_state": link_state,
        "link_states": link_states,
        "base_state": base_state,
        "joint_states": lambda _: (d.qpos[qadr].copy(), d.qvel[dofs].copy()),
        "dynamics_info": dynamics,
        "num_joints": lambda _: int(m.njnt),
        "reset_joint_state": reset_joints,
        "reset_base_state": reset_base,
        "step": lambda _: mujoco.mj_step(m, d),
        "contact_points": contacts,
    }


def _physx_raw(w: World) -> dict[str, Callable[[Any], object]]:
    """Raw SAPIEN 3 on a world of its own (``w``: built by the layer from the same model, never
    stepped by it), PhysX's own link damping in place of the layer's per-step law
    (as cases._physx_raw_world); every handle looked up once."""
    import sapien

    from simbridge.backends.physx import inspect

    DRIVE_DAMPING = cases.physx_drive_damping()

    scene, r = inspect.scene(w.sim), inspect.robot(w.sim, w.body)
    for moving in r.moving_links:  # PhysX's own link damping, the profile's k
        moving.linear_damping = w.sim.profile.linear_damping
        moving.angular_damping = w.sim.profile.angular_damping
    joints = [r.joints[j] for j in w.joints]
    art = r.built.articulation
    link = r.built.links[w.link + 1]
    root = r.built.links[0]
    link_cm, root_cm = link.cmass_local_pose, root.cmass_local_pose  # fixed at load
    every = [(k, k.cmass_local_pose) for k in r.built.links]  # every link, the base first
    dofs = r.dof[w.joints]
    qf = np.zeros(art.dof, dtype=np.float32)
    groups = tuple([r.joints[j] for j in g] for g in _groups(w))

    def velocity(t: np.ndarray) -> None:
        for j, v in zip(joints, t.tolist(), strict=True):
            j.set_drive_velocity_target(v)

    def position(t: np.ndarray) -> None:
        for j, v in zip(joints, t.tolist(), strict=True):
            j.set_drive_target(v)

    def torque(t: np.ndarray) -> None:
        qf[dofs] = t
        art.qf = qf

    def link_state(_: object) -> object:
        pose = link.entity_pose
        return pose * link_cm, pose, link.linear_velocity, link.angular_velocity

    def base_state(_: object) -> object:
        return root.entity_pose * root_cm, root.linear_velocity, root.angular_velocity

    def link_states(_: object) -> object:
        return [
            (k.entity_pose * cm, k.entity_pose, k.linear_velocity, k.angular_velocity)
            for k, cm in every
        ]

    def reset_joints(q: np.ndarray) -> None:
        qpos = art.qpos
        qvel = art.qvel
        qpos[dofs] = q
        qvel[dofs] = 0.0
        art.qpos = qpos
        art.qvel = qvel

    def reset_base(pose: tuple[np.ndarray, np.ndarray]) -> None:
        art.root_pose = sapien.Pose(pose[0], pose[1])

    def contacts(_: object) -> object:
        return [
            (c.bodies, [(q.position, q.normal, q.impulse, q.separation) for q in c.points])
            for c in scene.get_contacts()
        ]

    def two_groups(i: int) -> None:
        for j in groups[i]:
            j.set_drive_velocity_target(1.0 + i)

    def mode_change(i: int) -> None:
        # PhysX's own modes: a velocity drive (stiffness 0) or a position drive (stiffness kp)
        for j in joints:
            if i:
                j.set_drive_properties(0.0, DRIVE_DAMPING, 50.0, "force")
                j.set_drive_velocity_target(0.5)
            else:
                j.set_drive_properties(1e4, 1e2, 50.0, "force")
                j.set_drive_target(0.2)

    return {
        "set_joint_velocity": velocity,
        "set_joint_position": position,
        "set_joint_torque": torque,
        "link_state": link_state,
        "link_states": link_states,
        "base_state": base_state,
        "joint_states": lambda _: (art.qpos[dofs], art.qvel[dofs]),
        "dynamics_info": lambda _: (link.mass, link.inertia, link_cm),
        "num_joints": lambda _: len(art.joints),
        "reset_joint_state": reset_joints,
        "reset_base_state": reset_base,
        "step": lambda _: scene.step(),
        "contact_points": contacts,
        "two groups": two_groups,
        "mode change": mode_change,
    }


def _groups(w: World) -> tuple[list[int], list[int]]:
    """The commanded joints in two halves (r2d2's right and left wheels)."""
    half = len(w.joints) // 2
    return w.joints[:half], w.joints[half:]


def _targets(w: World, kind: str) -> tuple[Any, Any]:
    n = len(w.joints)
    base = np.linspace(0.1, 0.7, n)
    if kind == "velocity":
        return base * 10.0, base * -10.0
    if kind == "position":
        return base, base * -0.5
    return base * 2.0, base * -2.0


def rows_for(
    robot: str, worlds: dict[str, World], raw_worlds: dict[str, World] | None = None
) -> list[Row]:
    """The rows of one robot: each call on every backend present, and its raw counterparts
    (raw PhysX on its own world, ``raw_worlds["physx"]``)."""
    layer: dict[str, dict[str, Callable[[Any], object]]] = {}
    raw: dict[str, dict[str, Callable[[Any], object]]] = {}
    for backend, w in worlds.items():
        s, b, link = w.sim, w.body, w.link
        groups = _groups(w)
        fresh = _fresh_contacts(w)
        every = range(-1, s.num_joints(b))  # the base and every link
        layer[backend] = {
            "set_joint_velocity": lambda t, s=s, b=b, j=w.joints: s.set_joint_velocity(
                b, j, t, max_force=50.0
            ),
            "set_joint_velocity np": lambda t, s=s, b=b, j=w.np_joints: s.set_joint_velocity(
                b, j, t, max_force=50.0
            ),
            "set_joint_position": lambda t, s=s, b=b, j=w.joints: s.set_joint_position(
                b, j, t, max_force=50.0
            ),
            "set_joint_position np": lambda t, s=s, b=b, j=w.np_joints: s.set_joint_position(
                b, j, t, max_force=50.0
            ),
            "set_joint_torque": lambda t, s=s, b=b, j=w.joints: s.set_joint_torque(b, j, t),
            "set_joint_torque np": lambda t, s=s, b=b, j=w.np_joints: s.set_joint_torque(b, j, t),
            "link_state": lambda _, s=s, b=b, lk=link: s.link_state(b, lk),
            "link_state(-1)": lambda _, s=s, b=b: s.link_state(b, -1),
            "link_states": lambda _, s=s, b=b: s.link_states(b),
            "link_state each": lambda _, s=s, b=b, ls=every: [s.link_state(b, k) for k in ls],
            "base_state": lambda _, s=s, b=b: s.base_state(b),
            "joint_states": lambda _, s=s, b=b, j=w.np_joints: s.joint_states(b, j),
            "joint_states(all)": lambda _, s=s, b=b: s.joint_states(b),
            "joint_info": lambda _, s=s, b=b, lk=link: s.joint_info(b, lk),
            "dynamics_info": lambda _, s=s, b=b, lk=link: s.dynamics_info(b, lk),
            "num_joints": lambda _, s=s, b=b: s.num_joints(b),
            "reset_joint_state": lambda q, s=s, b=b, j=w.np_joints: s.reset_joint_state(b, j, q),
            "reset_base_state": lambda pose, s=s, b=b: s.reset_base_state(b, pose[0], pose[1]),
            "step": lambda _, s=s: s.step(),
            "contact_points": lambda _, s=s, f=fresh: (f(), s.contact_points()),
            "two groups": lambda i, s=s, b=b, g=groups: s.set_joint_velocity(
                b, g[i], 1.0 + i, max_force=50.0
            ),
            "mode change": lambda i, s=s, b=b, j=w.joints: (
                s.set_joint_velocity(b, j, 0.5, max_force=50.0)
                if i
                else s.set_joint_position(b, j, 0.2, max_force=50.0)
            ),
        }
        if backend == "pybullet":
            raw[backend] = _pybullet_raw(w)
        elif backend == "physx":
            raw[backend] = _physx_raw((raw_worlds or {}).get("physx") or World("physx", robot))
        else:
            raw[backend] = _mujoco_raw(w)
    w0 = next(iter(worlds.values()))
    vel = _targets(w0, "velocity")
    pos = _targets(w0, "position")
    tq = _targets(w0, "torque")
    here = (0.0, 0.0, 1.0) if robot == "r2d2" else (0.0, 0.0, 0.0)
    there = (0.01, 0.0, 1.0) if robot == "r2d2" else (0.01, 0.0, 0.0)
    q0 = (0.0, 0.0, 0.0, 1.0)
    poses = ((here, q0), (there, q0))
    raw_poses = tuple((np.array(p), np.array([1.0, 0.0, 0.0, 0.0])) for p, _ in poses)
    spec: list[tuple[str, str, tuple[Any, Any], tuple[Any, Any], str]] = [
        # (row name, raw key, layer args, raw args, note)
        ("set_joint_velocity (list)", "set_joint_velocity", _lists(vel), vel, "new target"),
        ("set_joint_velocity (numpy)", "set_joint_velocity", vel, vel, "new target"),
        ("set_joint_position (list)", "set_joint_position", _lists(pos), pos, "new target"),
        ("set_joint_position (numpy)", "set_joint_position", pos, pos, "new target"),
        ("set_joint_torque (list)", "set_joint_torque", _lists(tq), tq, ""),
        ("set_joint_torque (numpy)", "set_joint_torque", tq, tq, ""),
        ("link_state(link)", "link_state", (0, 0), (0, 0), "velocity + fresh pose"),
        ("link_state(-1)", "", (0, 0), (0, 0), "the base as a link"),
        ("link_states(every link)", "link_states", (0, 0), (0, 0), "the base and every link"),
        ("link_state of every link, a call each", "", (0, 0), (0, 0), "what link_states saves"),
        ("base_state", "base_state", (0, 0), (0, 0), ""),
        ("joint_states(commanded joints)", "joint_states", (0, 0), (0, 0), ""),
        ("joint_states(all)", "", (0, 0), (0, 0), ""),
        ("joint_info", "joint_info", (0, 0), (0, 0), ""),
        ("dynamics_info", "dynamics_info", (0, 0), (0, 0), ""),
        ("num_joints", "num_joints", (0, 0), (0, 0), ""),
        ("reset_joint_state(commanded joints)", "reset_joint_state", pos, pos, ""),
        ("reset_base_state(pose)", "reset_base_state", poses, poses, ""),
        ("step, contact-free", "step", (0, 0), (0, 0), ""),
        ("contact_points", "contact_points", (0, 0), (0, 0), _points_note(worlds)),  # r2d2 rests
        (
            "set_joint_velocity, two joint groups in turn",
            "two groups",
            (0, 1),
            (0, 1),
            "each group's command repeated",
        ),
        (
            "velocity <-> position command in turn",
            "mode change",
            (0, 1),
            (0, 1),
            "the motor set changes each call",
        ),
    ]
    layer_key = {
        "set_joint_velocity (list)": "set_joint_velocity",
        "set_joint_velocity (numpy)": "set_joint_velocity np",
        "set_joint_position (list)": "set_joint_position",
        "set_joint_position (numpy)": "set_joint_position np",
        "set_joint_torque (list)": "set_joint_torque",
        "set_joint_torque (numpy)": "set_joint_torque np",
        "link_state(link)": "link_state",
        "link_state(-1)": "link_state(-1)",
        "link_states(every link)": "link_states",
        "link_state of every link, a call each": "link_state each",
        "base_state": "base_state",
        "joint_states(commanded joints)": "joint_states",
        "joint_states(all)": "joint_states(all)",
        "joint_info": "joint_info",
        "dynamics_info": "dynamics_info",
        "num_joints": "num_joints",
        "reset_joint_state(commanded joints)": "reset_joint_state",
        "reset_base_state(pose)": "reset_base_state",
        "step, contact-free": "step",
        "contact_points": "contact_points",
        "set_joint_velocity, two joint groups in turn": "two groups",
        "velocity <-> position command in turn": "mode change",
    }
    out: list[Row] = []
    for name, raw_key, args, raw_args, note in spec:
        cols: dict[str, Callable[[int], object]] = {}
        for backend in worlds:
            cols[backend] = _alternating(layer[backend][layer_key[name]], args)
        for backend in worlds:
            fn = raw[backend].get(raw_key)
            if fn is None:
                continue
            if backend in ("mujoco", "physx") and raw_key == "reset_base_state":
                cols[f"raw {backend}"] = _alternating(fn, raw_poses)
            elif backend == "pybullet" and raw_key.startswith(("set_joint", "reset_joint")):
                cols["raw pybullet"] = _alternating(fn, _lists(raw_args))
            else:
                cols[f"raw {backend}"] = _alternating(fn, raw_args)
        out.append(Row(f"{robot}: {name}", cols, note))
    return out


def _alternating(fn: Callable[[Any], object], args: tuple[Any, Any]) -> Callable[[int], object]:
    """``fn`` called with ``args[i]`` for i = 0, 1, 0, 1 ... (the timed loop passes i)."""
    return lambda i: fn(args[i])


def _lists(pair: tuple[Any, Any]) -> tuple[Any, Any]:
    return tuple(v.tolist() if isinstance(v, np.ndarray) else v for v in pair)  # type: ignore[return-value]


def _fresh_contacts(w: World) -> Callable[[], None]:
    """What makes each timed ``contact_points`` call convert the step's points: PhysX's layer
    keeps the points it gave until the next step (a second read of one step is a lookup), so
    its cache is emptied first; the other engines read theirs afresh at every call."""
    if w.backend != "physx":
        return lambda: None
    from simbridge.backends.physx import inspect

    backend = inspect.backend_of(w.sim)

    def empty() -> None:
        backend._contacts_cache = None

    return empty


def _settle(worlds: list[World]) -> None:
    """r2d2 back on the plane at rest, wheels stopped, and 240 steps: resting on its contacts;
    the A1 stood up again (:func:`_stand`)."""
    for w in worlds:
        if w.robot == "a1":
            _stand(w)
            continue
        w.sim.set_joint_velocity(w.body, w.joints, 0.0, max_force=50.0)
        w.sim.reset_base_state(w.body, (0, 0, cases.START_Z), (0, 0, 0, 1), (0, 0, 0), (0, 0, 0))
        w.sim.step(240)


def _stand(w: World) -> None:
    """The A1 put back at its start height in its default pose at rest, position motors
    holding the pose, and 480 steps (2 s): standing on its four feet."""
    pose = list(A1_POSE.values())
    w.sim.reset_base_state(w.body, (0, 0, A1_Z), (0, 0, 0, 1), (0, 0, 0), (0, 0, 0))
    w.sim.reset_joint_state(w.body, w.joints, pose)
    w.sim.set_joint_position(w.body, w.joints, pose, max_force=A1_FORCE)
    w.sim.step(480)


def _points_note(worlds: dict[str, World]) -> str:
    """How many points each engine reports (r2d2 resting on the plane, the A1 standing; none
    for the KUKA)."""
    if any(w.robot == "kuka" for w in worlds.values()):  # in free space
        return "no contact: the call's own cost"
    _settle(list(worlds.values()))
    counts = ", ".join(f"{b} {len(w.sim.contact_points())}" for b, w in worlds.items())
    return f"points: {counts}"


def _prepare_step(worlds: list[World]) -> Callable[[], None]:
    """Before each timing of r2d2's step row: r2d2 back into the air at rest (no contact)."""

    def prepare() -> None:
        for w in worlds:
            w.sim.reset_base_state(w.body, (0, 0, 1.0), (0, 0, 0, 1), (0, 0, 0), (0, 0, 0))

    return prepare


def time_row(row: Row, n: int, reps: int, prepare: Callable[[], None] | None) -> None:
    """Time every column of ``row`` ``reps`` times, the columns interleaved (so that they are
    measured side by side, within a second of each other, on a machine shared with other
    work), appending seconds per call less the loop's own cost."""

    def loop(fn: Callable[[int], object]) -> float:
        t0 = CLOCK()
        for i in range(n):
            fn(i & 1)
        return (CLOCK() - t0) / n

    empty = _alternating(lambda _: None, (0, 0))
    raw: dict[str, list[float]] = {}
    overheads = []
    for _ in range(reps):
        overhead = loop(empty)
        overheads.append(overhead)
        for col in COLUMNS:
            fn = row.columns.get(col)
            if fn is None:
                continue
            if prepare is not None:
                prepare()
            took = loop(fn)
            raw.setdefault(col, []).append(took)
            row.times.setdefault(col, []).append(max(took - overhead, 1e-9))
    if STAT is min:  # the least loop less the least empty loop (the least of the differences
        # would pair an undisturbed call loop with a disturbed empty one)
        for col, took_all in raw.items():
            row.times[col] = [max(min(took_all) - min(overheads), 1e-9)]


# ---------------------------------------------------------------- command + step


def kuka_position_loop(backend: str, how: str, steps: int) -> Callable[[], float]:
    """A fixed KUKA following a new position target every step: ``how`` is "step alone" (the
    command in force, not renewed), "set_joint_position" (numpy targets) or "bound command"
    (``sim.position_command``, its targets written in place each step)."""
    sim = simbridge.Sim(backend)
    arm = sim.load_urdf(KUKA, fixed_base=True)
    joints = np.arange(7)
    path = 0.5 * np.sin(0.02 * np.arange(steps)[:, None] + joints[None, :])
    sim.set_joint_position(arm, joints, path[0], max_force=300.0)
    cmd = sim.position_command(arm, joints, path[0], max_force=300.0) if how == "bound" else None
    sim.step(10)

    def run() -> float:
        t0 = CLOCK()
        if how == "step alone":
            for _ in range(steps):
                sim.step()
        elif how == "set_joint_position":
            for k in range(steps):
                sim.set_joint_position(arm, joints, path[k], max_force=300.0)
                sim.step()
        else:
            assert cmd is not None
            targets = cmd.targets
            for k in range(steps):
                targets[:] = path[k]
                sim.step()
        return (CLOCK() - t0) / steps

    return run


# ---------------------------------------------------------------- main


# the clock of every timing: wall time (default), or with --clock cpu this process's CPU time
# (on a machine shared with more runnable work than cores, a wall-clock loop mostly measures
# the time the process waits for a core: r2d2's 300 steps on PhysX took 0.49 s of wall time
# and 0.07 s of CPU time at load 12 on 2 cores; every engine here steps on the calling thread)
CLOCK: Callable[[], float] = time.perf_counter


def use_clock(name: str) -> None:
    """Time with ``name`` ("wall" or "cpu"), here and in bench/cases.py's loops (which read
    ``time.perf_counter``)."""
    global CLOCK
    CLOCK = time.process_time if name == "cpu" else time.perf_counter
    cases.time = SimpleNamespace(perf_counter=CLOCK)  # type: ignore[assignment]


# each timing's summary over the repeats: the median, or with --stat min the least (on a machine
# busy with other work the least is the run that was least disturbed)
STAT: Callable[[list[float]], float] = statistics.median

# a median under this is within the noise of the loop's own cost (it is subtracted): printed as
# "<0.01" with no ratio (a ratio over a value at the resolution says nothing)
RESOLUTION_S = 0.005e-6


def fmt_us(values: list[float] | None) -> str:
    if not values:
        return "-"
    med = STAT(values)
    return "<0.01" if med < RESOLUTION_S else f"{med * 1e6:.2f}"


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--repeats", type=int, default=9, help="repeats per row (default 9)")
    parser.add_argument("--calls", type=int, default=2000, help="calls per timing (default 2000)")
    parser.add_argument("--quick", action="store_true", help="200 calls, 240 steps (smoke run)")
    parser.add_argument(
        "--backends",
        default=",".join(CALL_BACKENDS),
        help="comma-separated backends to time (default: %(default)s)",
    )
    parser.add_argument(
        "--stat",
        choices=("median", "min"),
        default="median",
        help="summary of the repeats: median (default) or min (a machine busy with other work)",
    )
    parser.add_argument(
        "--clock",
        choices=("wall", "cpu"),
        default="wall",
        help="wall time (default) or this process's CPU time (a machine with more runnable "
        "work than cores)",
    )
    parser.add_argument(
        "--only",
        metavar="TEXT",
        help="time only the calls table's rows whose name holds TEXT (link_state), no other table",
    )
    args = parser.parse_args(argv)
    use_clock(args.clock)
    reps, n = max(1, args.repeats), 200 if args.quick else max(10, args.calls)
    backends = [b for b in CALL_BACKENDS if b in args.backends.split(",")]
    if not backends:
        parser.error(f"--backends: none of {CALL_BACKENDS}")
    global STAT
    STAT = min if args.stat == "min" else statistics.median

    print(
        f"# simbridge calls: {platform.node()} | {platform.processor() or platform.machine()}"
        f" | Python {platform.python_version()} | {cases.engine_versions()}"
        f" | {args.stat}s of {reps} repeats of {n} calls, {args.clock} clock"
    )
    print()
    missed = calls_table(backends, reps, n, args.only)
    if args.only is None:
        position_table(backends, reps, 240 if args.quick else 1000)
        drive_table(backends, reps)
        if "physx" in backends:
            physx_bounds(reps, n)
    print()
    for b, count in missed.items():
        print(f"{LABEL[b]} calls over {TARGET}x PyBullet's: {count}")
    return 0


def calls_table(backends: list[str], reps: int, n: int, only: str | None = None) -> dict[str, int]:
    """The table of single calls (only the rows whose name holds ``only``, where given);
    returns per engine how many of its calls miss the 1.5x target (PyBullet's layer call being
    the reference)."""
    others = [b for b in backends if b != "pybullet"] if "pybullet" in backends else []
    head = [f"{LABEL[b]} µs" for b in backends]
    head += [f"{LABEL[b]}/PyBullet" for b in others]
    head += [f"raw {LABEL[b]} µs" for b in backends]
    print(f"| call | {' | '.join(head)} |")
    print("|------" * (len(head) + 1) + "|")
    missed = dict.fromkeys(others, 0)
    notes: list[str] = []  # said under the table
    for robot in ROBOTS:
        if only is not None and robot == "a1" and not any(only in f"a1: {r}" for r in A1_ROWS):
            continue
        worlds = {b: World(b, robot) for b in backends}
        raw_worlds = {"physx": World("physx", robot)} if "physx" in backends else {}
        rows = rows_for(robot, worlds, raw_worlds)
        for row in rows:
            if only is not None and only not in row.name:
                continue
            if robot == "a1" and row.name.split(": ", 1)[1] not in A1_ROWS:
                continue
            for col in row.columns.values():  # warm up: caches, first compile of a path
                col(0)
                col(1)
            prepare = None
            if row.name == "r2d2: step, contact-free":
                prepare = _prepare_step([*worlds.values(), *raw_worlds.values()])
            elif row.name in ("r2d2: contact_points", "a1: contact_points"):
                both = [*worlds.values(), *raw_worlds.values()]
                prepare = lambda both=both: _settle(both)  # noqa: E731
            time_row(row, n, reps, prepare)
            pb = row.times.get("pybullet")
            ratios = []
            for b in others:
                t = row.times.get(b)
                ratio = ""
                if pb and t and min(STAT(pb), STAT(t)) >= RESOLUTION_S:
                    r = STAT(t) / STAT(pb)
                    ok = r <= TARGET
                    missed[b] += not ok
                    ratio = f"{r:.2f}" + ("" if ok else " MISSED")
                ratios.append(ratio)
            cells = [fmt_us(row.times.get(b)) for b in backends] + ratios
            cells += [fmt_us(row.times.get(f"raw {b}")) for b in backends]
            print(f"| {row.name} | {' | '.join(cells)} |")
            if row.name in ("r2d2: contact_points", "a1: contact_points"):
                notes.append(f"{row.name}: {row.note} (one call reads them all)")
        for w in [*worlds.values(), *raw_worlds.values()]:
            w.sim.close()
    print()
    for note in notes:
        print(note)
    return missed


def position_table(backends: list[str], reps: int, steps: int) -> None:
    """The position-controlled KUKA: command + step against the step alone."""
    print()
    head = " | ".join(f"{LABEL[b]} µs | ratio" for b in backends)
    print(f"| per step | {head} | target |")
    print("|------" * (2 * len(backends) + 2) + "|")
    loops = {
        how: {b: kuka_position_loop(b, how, steps) for b in backends}
        for how in ("step alone", "set_joint_position", "bound")
    }
    times: dict[str, dict[str, list[float]]] = {h: {b: [] for b in backends} for h in loops}
    for _ in range(reps):
        for how, per in loops.items():
            for b, fn in per.items():
                times[how][b].append(fn())
    for how, label in (
        ("step alone", "KUKA, position motors in force: step alone"),
        ("set_joint_position", "KUKA: set_joint_position(numpy) + step"),
        ("bound", "KUKA: position_command targets[:] = q + step"),
    ):
        cells = []
        for b in backends:
            med = STAT(times[how][b])
            base = STAT(times["step alone"][b])
            cells += [f"{med * 1e6:.2f}", f"{med / base:.2f}"]
        print(f"| {label} | {' | '.join(cells)} | {'-' if how == 'step alone' else '1.30x'} |")


def drive_table(backends: list[str], reps: int) -> None:
    """The r2d2 drive: raw, plain set_joint_velocity, a bound velocity command; for MuJoCo
    also the stepping alone (the schedule in three step(n) calls, one command at each change:
    no Python per step), the floor under any per-step loop; for PhysX also the layer against
    raw SAPIEN that applies PyBullet's link damping law itself (cases.DAMPED_FLOOR)."""
    drives: dict[str, list[Callable[[], float]]] = {
        b: [cases.DRIVES[b].raw, cases.DRIVES[b].layer, cases.BOUND_DRIVES[b].layer]
        for b in backends
    }
    if "mujoco" in drives:
        drives["mujoco"] += [_mujoco_raw_chunks, _layer_chunks]
    floor = "physx, raw with PyBullet's damping law"
    if "physx" in drives and cases.DAMPED_FLOOR is not None:
        drives[floor] = [cases.DAMPED_FLOOR.raw]  # against the physx row's plain and bound
    dtimes: dict[str, list[list[float]]] = {b: [[] for _ in fns] for b, fns in drives.items()}
    for _ in range(reps):
        for b, fns in drives.items():
            for i, fn in enumerate(fns):
                dtimes[b][i].append(fn() / 980)
    print()
    head = "| raw µs | plain µs | ratio | bound µs | ratio | target |"
    print(f"| r2d2 drive, 980 steps, per step {head} stepping alone: raw, layer µs |")
    print("|------|------|------|------|------|------|------|------|")
    for b in drives:
        med = [STAT(x) for x in dtimes[b]]
        if b == floor:  # the physx layer's figures over this raw floor; no target
            raw_m = med[0]
            plain_m, bound_m = (STAT(x) for x in dtimes["physx"][1:3])
            target = "-"
        else:
            raw_m, plain_m, bound_m = med[:3]
            target = f"{cases.DRIVES[b].target:.2f}x"
        alone = "-"
        if len(med) == 5:
            alone = f"{med[3] * 1e6:.2f}, {med[4] * 1e6:.2f} ({med[4] / med[3]:.3f})"
        print(
            f"| {b} | {raw_m * 1e6:.2f} | {plain_m * 1e6:.2f} | {plain_m / raw_m:.3f} "
            f"| {bound_m * 1e6:.2f} | {bound_m / raw_m:.3f} | {target} | {alone} |"
        )


def physx_bounds(reps: int, n: int) -> None:
    """Where a PhysX layer call costs more than the raw SAPIEN call: the raw call, the raw
    call plus what the layer must do that idiomatic SAPIEN does not (written raw, as fast as
    SAPIEN allows), and the layer's call, timed side by side in the same way as the calls
    table. Steps: r2d2 in the air, the KUKA in free space (as the step rows)."""
    print()
    print("| PhysX, per call | raw µs | raw + the layer's work µs | layer µs | the layer's work |")
    print("|------|------|------|------|------|")
    for robot in ("r2d2", "kuka"):
        worlds = [World("physx", robot) for _ in range(3)]  # layer, raw, raw + the layer's work
        for name, columns, what, step in _physx_bound_rows(robot, *worlds):
            row = Row(f"{robot}: {name}", columns)
            for col in row.columns.values():
                col(0)
                col(1)
            prepare = _prepare_step(worlds) if step and robot == "r2d2" else None
            time_row(row, n, reps, prepare)
            t = row.times
            print(
                f"| {row.name} | {fmt_us(t.get('raw pybullet'))} | {fmt_us(t.get('raw mujoco'))} "
                f"| {fmt_us(t.get('physx'))} | {what} |"
            )
        for w in worlds:
            w.sim.close()


def _physx_bound_rows(
    robot: str, layer: World, native: World, law: World
) -> list[tuple[str, dict[str, Callable[[int], object]], str, bool]]:
    """The rows of :func:`physx_bounds` (name, columns, the layer's work, a step row): the
    columns in the slots of :data:`COLUMNS` that :func:`time_row` times, "raw pybullet" for
    the raw call, "raw mujoco" for raw + the layer's work, "physx" for the layer's call."""
    import sapien

    from simbridge.backends.physx import inspect
    from simbridge.transforms import transform_multiply

    raw = _physx_raw(native)  # PhysX's own link damping
    r = inspect.robot(law.sim, law.body)  # law: the layer's world, stepped raw
    scene, art = inspect.scene(law.sim), r.built.articulation
    link = r.built.links[law.link + 1]
    ine = r.built.inertials[law.link + 1]
    local = (ine.position, ine.orientation)
    dofs = r.dof[law.joints]
    forces_at = (
        np.array([r.built.links[j + 1].index for j in law.joints]),
        np.array([0 if r.model.joints[j].type == "prismatic" else 3 for j in law.joints]),
    )
    pre = _physx_damping_law(law.sim, law.body)

    def law_step(_: object) -> None:
        after = pre()
        scene.step()
        after()

    pose_floats = sapien.Pose.__getstate__

    def js_forces(_: object) -> object:
        return art.qpos[dofs], art.qvel[dofs], art.get_link_incoming_joint_forces()[forces_at]

    def link_f64(_: object) -> object:
        # the pose's 7 floats in one call (its pickling state; p.tolist() and q.tolist() give
        # the same values through two arrays, 1.3 µs more)
        x, y, z, qw, qx, qy, qz = pose_floats(link.entity_pose)
        frame = ((x, y, z), (qx, qy, qz, qw))
        lin, ang = link.linear_velocity.tolist(), link.angular_velocity.tolist()
        return transform_multiply(frame, local), frame, lin, ang

    def root_rewrite(pose: tuple[np.ndarray, np.ndarray]) -> None:
        art.root_pose = sapien.Pose(pose[0], pose[1])
        art.qpos = art.qpos
        art.qvel = art.qvel

    s, b = layer.sim, layer.body
    here = (0.0, 0.0, 1.0) if robot == "r2d2" else (0.0, 0.0, 0.0)
    there = (here[0] + 0.01, here[1], here[2])
    q0 = (0.0, 0.0, 0.0, 1.0)
    raw_poses = tuple((np.array(p_), np.array([1.0, 0.0, 0.0, 0.0])) for p_ in (here, there))
    damping = "PyBullet's link damping law (2 velocity reads + 1 force per moving link)"
    if r.damping is not None:
        damping += " and the file's joint damping as joint forces"

    def cols(
        raw_fn: Callable[[Any], object],
        work_fn: Callable[[Any], object],
        layer_fn: Callable[[Any], object],
        args: tuple[Any, Any] = (0, 0),
        layer_args: tuple[Any, Any] = (0, 0),
    ) -> dict[str, Callable[[int], object]]:
        return {
            "raw pybullet": _alternating(raw_fn, args),
            "raw mujoco": _alternating(work_fn, args),
            "physx": _alternating(layer_fn, layer_args),
        }

    return [
        ("step, contact-free", cols(raw["step"], law_step, lambda _: s.step()), damping, True),
        (
            "joint_states(commanded joints)",
            cols(raw["joint_states"], js_forces, lambda _: s.joint_states(b, layer.np_joints)),
            "the applied torque: the joints' incoming forces read",
            False,
        ),
        (
            "link_state(link)",
            cols(raw["link_state"], link_f64, lambda _: s.link_state(b, layer.link)),
            "PyBullet's float64 centre-of-mass frame (SAPIEN's Pose product is float32)",
            False,
        ),
        (
            "reset_base_state(pose)",
            cols(
                raw["reset_base_state"],
                root_rewrite,
                lambda pose: s.reset_base_state(b, pose[0], pose[1]),
                raw_poses,
                ((here, q0), (there, q0)),
            ),
            "the joint state rewritten so that reads see the teleport whole",
            False,
        ),
    ]


def _physx_damping_law(sim: simbridge.Sim, body: int) -> Callable[[], Callable[[], None]]:
    """Raw SAPIEN giving PhysX PyBullet's link damping (and the file's joint damping) on the
    layer's world: called before ``scene.step()``, returns what to call after it."""
    from simbridge.backends.physx import inspect

    r = inspect.robot(sim, body)
    p = sim.profile
    links = r.moving_links
    getters = []
    for link in links:
        getters += [link.get_linear_velocity, link.get_angular_velocity]
    k = np.tile(np.array([-p.linear_damping, -p.angular_damping], dtype=np.float32), len(links))
    buf = np.empty((2 * len(links), 3), dtype=np.float32)
    adds = [(lk.add_force_torque, buf[2 * i], buf[2 * i + 1]) for i, lk in enumerate(links)]
    art = r.built.articulation
    joint_damping = r.damping
    zeros = np.zeros(art.dof, dtype=np.float32)

    def after() -> None:
        art.qf = zeros

    def nothing() -> None:
        pass

    def pre() -> Callable[[], None]:
        buf[:] = [f() for f in getters]
        np.multiply(buf, (k * (1.0 + np.sqrt((buf * buf).sum(axis=1))))[:, None], out=buf)
        for add, a, b in adds:
            add(a, b, "acceleration")
        if joint_damping is None:
            return nothing
        art.qf = (-joint_damping * art.qvel).astype(np.float32)
        return after

    return pre


def _mujoco_raw_chunks() -> float:
    """Raw MuJoCo's drive stepped in three ``mj_step(m, d, n)`` calls."""
    import mujoco

    sim, robot = cases._layer_sim("mujoco")  # noqa: SLF001
    try:
        m, d, _, _ = cases._mujoco_raw_model(sim, robot)  # noqa: SLF001
        t0 = CLOCK()
        mujoco.mj_step(m, d, cases.TURN_FROM)
        d.ctrl[:] = cases.TURN
        mujoco.mj_step(m, d, cases.FORWARD_FROM - cases.TURN_FROM)
        m.actuator_forcerange[:] = [-10.0, 10.0]
        d.ctrl[:] = cases.FORWARD
        mujoco.mj_step(m, d, 980 - cases.FORWARD_FROM)
        return CLOCK() - t0
    finally:
        sim.close()


def _layer_chunks() -> float:
    """The layer's drive stepped in three ``Sim.step(n)`` calls."""
    sim, robot = cases._layer_sim("mujoco")  # noqa: SLF001
    try:
        wheels = np.array(cases.WHEELS)
        t0 = CLOCK()
        sim.step(cases.TURN_FROM)
        sim.set_joint_velocity(robot, wheels, cases.TURN, max_force=50.0)
        sim.step(cases.FORWARD_FROM - cases.TURN_FROM)
        sim.set_joint_velocity(robot, wheels, cases.FORWARD, max_force=10.0)
        sim.step(980 - cases.FORWARD_FROM)
        return CLOCK() - t0
    finally:
        sim.close()


if __name__ == "__main__":
    sys.exit(main())
