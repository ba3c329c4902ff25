"""The raw and layer code of every benchmark row. Each callable returns the seconds of its timed
part (set-up is excluded: loading the robot is not what a per-step figure measures)."""

from __future__ import annotations

import itertools
import time
from collections.abc import Callable
from dataclasses import dataclass
from importlib.metadata import version
from typing import Any

import numpy as np

import simbridge


def _usable(name: str) -> bool:
    from simbridge.registry import unavailable_reason

    return name in simbridge.available_backends() and unavailable_reason(name) is None


# pybullet and mujoco always (they ship with simbridge); physx where its extra is installed
BACKENDS = [b for b in ("pybullet", "mujoco") if b in simbridge.available_backends()] + [
    b for b in ("physx",) if _usable(b)
]
WHEELS = [2, 3, 6, 7]
TURN = np.array([-100.0, -100.0, 100.0, 100.0])
FORWARD = np.array([-100.0, -100.0, -100.0, -100.0])
# The drive starts with r2d2 resting on the plane (it settles at z 0.471), not from the
# tutorial's z 0.1, 0.37 m into the ground: from there MuJoCo throws the robot metres up, and a
# raw model and the layer's would spend different shares of the 980 steps in free flight,
# where a step costs a fraction of one with contacts. A per-step cost needs the same work.
START_Z = 0.5
TURN_FROM, FORWARD_FROM = 240, 480  # the tutorial's schedule: settle, turn, forward (to 980)


def drive_command(k: int) -> tuple[np.ndarray, float] | None:
    """Step k of the tutorial's drive: (wheel targets, force), or None while the robot settles
    (the timed loops below write the same schedule inline)."""
    if k < TURN_FROM:
        return None
    if k < FORWARD_FROM:
        return TURN, 50.0
    return FORWARD, 10.0


@dataclass
class Case:
    name: str
    raw: Callable[[], float]
    layer: Callable[[], float]
    target: float | None
    note: str = ""


def engine_versions() -> str:
    engines = f"pybullet {version('pybullet')}, mujoco {version('mujoco')}"
    if "physx" in BACKENDS:
        engines += f", sapien {version('sapien')}"
    return f"{engines}, simbridge {simbridge.__version__}"


# ---------------------------------------------------------------- the layer's drive


def _layer_sim(backend: str) -> tuple[simbridge.Sim, int]:
    sim = simbridge.Sim(backend)
    sim.load_urdf("plane.urdf")
    robot = sim.load_urdf("r2d2.urdf", base_position=(0, 0, START_Z))
    return sim, robot


def layer_drive(backend: str, record: bool, final: list | None = None) -> Callable[[], float]:
    """The tutorial's drive through the Sim; with ``final`` (PhysX), each run appends the
    articulation's state after it (:func:`physx_final_state`)."""
    wheels = np.array(WHEELS)

    def run() -> float:
        sim, robot = _layer_sim(backend)
        try:
            base = np.empty((980, 13))
            wheel_state = np.empty((980, 12))
            t0 = time.perf_counter()
            for k in range(980):
                if k >= TURN_FROM:
                    if k < FORWARD_FROM:
                        sim.set_joint_velocity(robot, wheels, TURN, max_force=50.0)
                    else:
                        sim.set_joint_velocity(robot, wheels, FORWARD, max_force=10.0)
                sim.step()
                if record:
                    s = sim.base_state(robot)
                    base[k, :3] = s.position
                    base[k, 3:7] = s.orientation
                    base[k, 7:10] = s.linear_velocity
                    base[k, 10:] = s.angular_velocity
                    js = sim.joint_states(robot, wheels)
                    wheel_state[k, :4] = js.positions
                    wheel_state[k, 4:8] = js.velocities
                    wheel_state[k, 8:] = js.applied_torques
            elapsed = time.perf_counter() - t0
            if final is not None:
                final.append(physx_final_state(sim, robot))
            return elapsed
        finally:
            sim.close()

    return run


def layer_bound_drive(backend: str) -> Callable[[], float]:
    """The same drive through a bound velocity command (``Sim.velocity_command``), written as
    the raw drive is: bound at the first command (once, timed; where raw code would have set
    its actuators up), its force limit written once where the schedule changes it (raw:
    ``actuator_forcerange``), its targets written in place every step after (raw:
    ``d.ctrl[:] = ...``)."""
    wheels = np.array(WHEELS)

    def run() -> float:
        sim, robot = _layer_sim(backend)
        try:
            cmd: Any = None
            t0 = time.perf_counter()
            for k in range(980):
                if k == TURN_FROM:
                    cmd = sim.velocity_command(robot, wheels, TURN, max_force=50.0)
                if k == FORWARD_FROM:
                    cmd.max_force[:] = 10.0
                if k >= TURN_FROM:
                    cmd.targets[:] = TURN if k < FORWARD_FROM else FORWARD
                sim.step()
            return time.perf_counter() - t0
        finally:
            sim.close()

    return run


# ---------------------------------------------------------------- raw PyBullet


def pybullet_raw_drive(record: bool) -> Callable[[], float]:
    import pybullet as p
    import pybullet_data

    def run() -> float:
        c = p.connect(p.DIRECT)
        try:
            p.setAdditionalSearchPath(pybullet_data.getDataPath(), physicsClientId=c)
            p.setGravity(0, 0, -9.8, physicsClientId=c)
            p.loadURDF("plane.urdf", physicsClientId=c)
            r = p.loadURDF("r2d2.urdf", [0, 0, START_Z], physicsClientId=c)
            base = np.empty((980, 13))
            wheel_state = np.empty((980, 12))
            turn, fwd = TURN.tolist(), FORWARD.tolist()
            t0 = time.perf_counter()
            for k in range(980):
                if k >= TURN_FROM:
                    if k < FORWARD_FROM:
                        p.setJointMotorControlArray(
                            r,
                            WHEELS,
                            p.VELOCITY_CONTROL,
                            targetVelocities=turn,
                            forces=[50.0] * 4,
                            physicsClientId=c,
                        )
                    else:
                        p.setJointMotorControlArray(
                            r,
                            WHEELS,
                            p.VELOCITY_CONTROL,
                            targetVelocities=fwd,
                            forces=[10.0] * 4,
                            physicsClientId=c,
                        )
                p.stepSimulation(physicsClientId=c)
                if record:  # the same quantities the layer returns
                    pos, orn = p.getBasePositionAndOrientation(r, physicsClientId=c)
                    lin, ang = p.getBaseVelocity(r, physicsClientId=c)
                    base[k, :3] = pos
                    base[k, 3:7] = orn
                    base[k, 7:10] = lin
                    base[k, 10:] = ang
                    for i, s in enumerate(p.getJointStates(r, WHEELS, physicsClientId=c)):
                        wheel_state[k, i] = s[0]
                        wheel_state[k, 4 + i] = s[1]
                        wheel_state[k, 8 + i] = s[3]
            return time.perf_counter() - t0
        finally:
            p.disconnect(c)

    return run


# ---------------------------------------------------------------- raw MuJoCo


def _mujoco_handles(sim: simbridge.Sim, robot: int) -> tuple:
    """The compiled model, data, wheel dof addresses and base body id behind a mujoco Sim."""
    from simbridge.backends.mujoco import inspect  # the raw floor: the model the layer built

    r = inspect.robot(sim, robot)
    m, d = inspect.model_and_data(sim)
    return m, d, r.dofadr[WHEELS].copy(), int(r.body_ids[0])


def _mujoco_raw_model(sim: simbridge.Sim, robot: int) -> tuple:
    """What a user of raw MuJoCo drives: the layer's world (the same bodies, geoms and contact
    pairs) without the layer's motors, brakes and damping and with MuJoCo's default joint-limit
    parameters (the layer's margin keeps r2d2's grippers' limit rows active: a raw model would
    not have them), plus one velocity actuator per wheel
    (``kv`` 5, force range +-50 N·m), driven by ``d.ctrl``, under the ``implicitfast``
    integrator, as MuJoCo's documentation advises for velocity actuators. Under Euler, kv 5
    is far above the wheels' I/dt: measured, the wheels chatter at +-200 rad/s with ctrl 0 and
    r2d2 never comes to rest (nefc 2 per step while settling against the layer's 37), so a raw
    step would cost half of a resting one for a reason that has nothing to do with the layer."""
    import mujoco

    from simbridge.backends.mujoco import inspect  # the raw floor: the model the layer built

    r = inspect.robot(sim, robot)
    spec = inspect.world_spec(sim).copy()
    for jnt in spec.joints:  # MuJoCo's own joint limits (the layer gives them PyBullet's law)
        jnt.solref_limit = [0.02, 1.0]
        jnt.solimp_limit = [0.9, 0.95, 0.001, 0.5, 2.0]
        jnt.margin = 0.0
    for j in WHEELS:
        act = spec.add_actuator(
            name=f"raw/{j}", target=r.spec.joint_names[j], trntype=mujoco.mjtTrn.mjTRN_JOINT
        )
        act.set_to_velocity(kv=5.0)
        act.forcelimited = mujoco.mjtLimited.mjLIMITED_TRUE
        act.forcerange = [-50.0, 50.0]
    spec.option.integrator = mujoco.mjtIntegrator.mjINT_IMPLICITFAST
    m = spec.compile()
    d = mujoco.MjData(m)
    d.qpos[:] = inspect.model_and_data(sim)[1].qpos  # the same start
    dofs = np.array(
        [
            m.jnt_dofadr[mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_JOINT, r.spec.joint_names[j])]
            for j in WHEELS
        ]
    )
    body = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, r.spec.body_names[0])
    return m, d, dofs, body


def mujoco_raw_drive(record: bool) -> Callable[[], float]:
    """Raw MuJoCo, written the fast idiomatic way: ``d.ctrl[:] = array`` and ``mj_step``,
    on the layer's world with velocity actuators on the wheels (:func:`_mujoco_raw_model`)."""
    import mujoco

    def run() -> float:
        sim, robot = _layer_sim("mujoco")
        try:
            m, d, dofs, base_body = _mujoco_raw_model(sim, robot)
            base = np.empty((980, 13))
            wheel_state = np.empty((980, 12))
            qadr = m.jnt_qposadr[m.dof_jntid[dofs]]
            t0 = time.perf_counter()
            for k in range(980):
                if k == FORWARD_FROM:
                    m.actuator_forcerange[:] = [-10.0, 10.0]
                if k >= TURN_FROM:
                    d.ctrl[:] = TURN if k < FORWARD_FROM else FORWARD
                mujoco.mj_step(m, d)
                if record:
                    mujoco.mj_kinematics(m, d)  # poses after the step, not before it
                    base[k, :3] = d.xipos[base_body]
                    base[k, 3:7] = d.xquat[base_body]
                    base[k, 7:13] = d.qvel[:6]
                    wheel_state[k, :4] = d.qpos[qadr]
                    wheel_state[k, 4:8] = d.qvel[dofs]
                    wheel_state[k, 8:] = d.actuator_force
            return time.perf_counter() - t0
        finally:
            sim.close()

    return run


# ---------------------------------------------------------------- raw PhysX (SAPIEN)


def physx_drive_damping() -> float:
    """PhysX's drive damping of a velocity command, from backends/physx/commands.py, or from
    motors.py in a tree from before the backends' one-name-per-part rename (issue 32): bench/ab.py
    runs this tree's benchmarks in an older tree too."""
    try:
        from simbridge.backends.physx.commands import DRIVE_DAMPING
    except ModuleNotFoundError:
        from simbridge.backends.physx.motors import DRIVE_DAMPING  # type: ignore[no-redef]
    return float(DRIVE_DAMPING)


def _physx_raw_world(sim: simbridge.Sim, robot: int, native_damping: bool = True) -> tuple:
    """What a user of raw SAPIEN drives: the layer's world (the same articulation, shapes,
    materials and solver settings, built from the same model) with PhysX's own link damping
    (the profile's 0.04) in place of the layer's per-step PyBullet law, the wheels' drives set
    the idiomatic way (stiffness 0, the layer's damping, the force limit set where the schedule
    changes it, targets every step) and the other joints' brakes left as the layer set them."""
    from simbridge.backends.physx import inspect

    DRIVE_DAMPING = physx_drive_damping()
    r = inspect.robot(sim, robot)
    if native_damping:
        for link in r.moving_links:
            link.linear_damping = sim.profile.linear_damping
            link.angular_damping = sim.profile.angular_damping
    joints = [r.joints[j] for j in WHEELS]
    return inspect.scene(sim), r, joints, DRIVE_DAMPING


def physx_final_state(sim: simbridge.Sim, robot: int) -> tuple[np.ndarray, ...]:
    """The robot's articulation state as PhysX holds it (float32): joint positions and
    velocities, the root link's pose and velocities."""
    from simbridge.backends.physx import inspect

    r = inspect.robot(sim, robot)
    art, root = r.built.articulation, r.built.links[0]
    pose = root.entity_pose
    return (art.qpos, art.qvel, pose.p, pose.q, root.linear_velocity, root.angular_velocity)


def physx_raw_stepper(
    sim: simbridge.Sim, robot: int, pybullet_damping: bool, speed_clamp: bool
) -> tuple[Callable[[int], None], Any]:
    """Raw SAPIEN's step ``k`` of the drive on ``robot``'s articulation, written the fast
    idiomatic way (``set_drive_velocity_target`` per wheel, ``scene.step()``), and the robot's
    ``inspect.robot`` record: PyBullet's link damping law applied by hand with
    ``pybullet_damping``, its speed clamp with ``speed_clamp`` (see :func:`physx_raw_drive`).
    Also the raw side of ``bench/physx_drive_pairs.py``."""
    scene, r, joints, damping = _physx_raw_world(sim, robot, not pybullet_damping)
    getters = []
    for link in r.moving_links:
        getters += [link.get_linear_velocity, link.get_angular_velocity]
    p = sim.profile
    n = len(r.moving_links)
    damp = np.tile(np.array([-p.linear_damping, -p.angular_damping], dtype=np.float32), n)
    buf = np.empty((2 * n, 3), dtype=np.float32)
    adds = [
        (link.add_force_torque, buf[2 * i], buf[2 * i + 1]) for i, link in enumerate(r.moving_links)
    ]
    art = r.built.articulation
    turn, forward = TURN.tolist(), FORWARD.tolist()
    cap = p.max_joint_velocity
    assert cap is not None and float(np.float32(cap)) == cap  # clamps in plain floats

    def step(k: int) -> None:
        nonlocal buf  # written in place: the views in ``adds`` stay on it
        if k in (TURN_FROM, FORWARD_FROM):
            force = 50.0 if k == TURN_FROM else 10.0
            for j in joints:
                j.set_drive_properties(0.0, damping, force, "force")
        if k >= TURN_FROM:
            for j, v in zip(joints, turn if k < FORWARD_FROM else forward, strict=True):
                j.set_drive_velocity_target(v)
        if pybullet_damping:
            buf[:] = [f() for f in getters]
            buf *= (damp * (1.0 + np.sqrt((buf * buf).sum(axis=1))))[:, None]
            for add, a, b in adds:
                add(a, b, "acceleration")
        scene.step()
        if speed_clamp:
            speeds = art.qvel.tolist()
            if max(map(abs, speeds)) > cap:
                clipped = [-cap if x < -cap else cap if x > cap else x for x in speeds]
                art.qvel = np.array(clipped, dtype=np.float32)

    return step, r


def physx_raw_drive(
    record: bool,
    pybullet_damping: bool = False,
    speed_clamp: bool = False,
    final: list | None = None,
) -> Callable[[], float]:
    """Raw SAPIEN, written the fast idiomatic way: ``set_drive_velocity_target`` per wheel and
    ``scene.step()`` (:func:`_physx_raw_world`). With ``pybullet_damping``, PhysX's own link
    damping is off and the raw code applies PyBullet's law itself, as few engine calls as it
    takes (each moving link's two velocities read, one ``add_force_torque``, per step): the
    floor of any layer that gives PhysX PyBullet's link damping. With ``speed_clamp`` too, it
    clamps the joint speeds after each step to the profile's 100 rad/s as PyBullet does (PhysX
    lets r2d2's driven wheels end a step a little past it: 212 of the drive's 980 steps), one
    ``qvel`` read per step and a write where a speed is past the cap: the same trajectory as
    the layer's, bit for bit (:func:`physx_floor_matches_layer`)."""

    def run() -> float:
        sim, robot = _layer_sim("physx")
        try:
            step, r = physx_raw_stepper(sim, robot, pybullet_damping, speed_clamp)
            art = r.built.articulation
            root = r.built.links[0]
            dofs = r.dof[WHEELS]
            wheel_links = [r.built.links[j + 1].index for j in WHEELS]  # PhysX's link order
            base = np.empty((980, 13))
            wheel_state = np.empty((980, 12))
            t0 = time.perf_counter()
            for k in range(980):
                step(k)
                if record:
                    pose = root.entity_pose * root.cmass_local_pose
                    base[k, :3] = pose.p
                    base[k, 3:7] = pose.q
                    base[k, 7:10] = root.linear_velocity
                    base[k, 10:] = root.angular_velocity
                    wheel_state[k, :4] = art.qpos[dofs]
                    wheel_state[k, 4:8] = art.qvel[dofs]
                    wheel_state[k, 8:] = art.get_link_incoming_joint_forces()[wheel_links, 3]
            elapsed = time.perf_counter() - t0
            if final is not None:
                final.append(physx_final_state(sim, robot))
            return elapsed
        finally:
            sim.close()

    return run


def physx_floor_matches_layer(speed_clamp: bool = True) -> bool:
    """Whether raw SAPIEN applying PyBullet's link damping (and, with ``speed_clamp``, its
    speed clamp) ends the drive in the layer's state, bit for bit."""
    raw: list = []
    lay: list = []
    physx_raw_drive(False, pybullet_damping=True, speed_clamp=speed_clamp, final=raw)()
    layer_drive("physx", False, final=lay)()
    return all(np.array_equal(a, b) for a, b in zip(raw[0], lay[0], strict=True))


# the layer's PhysX drive against raw SAPIEN that applies PyBullet's link damping itself, and
# against raw SAPIEN that does all the layer's per-step PyBullet work (damping and speed clamp)
DAMPED_FLOOR: Case | None = (
    Case(
        "drive vs raw with PyBullet's damping law",
        physx_raw_drive(False, pybullet_damping=True),
        layer_drive("physx", False),
        None,
    )
    if "physx" in BACKENDS
    else None
)
CLAMPED_FLOOR: Case | None = (
    Case(
        "drive vs raw with PyBullet's damping law and speed clamp",
        physx_raw_drive(False, pybullet_damping=True, speed_clamp=True),
        layer_drive("physx", False),
        1.10,
    )
    if "physx" in BACKENDS
    else None
)
DRIVES: dict[str, Case] = {}
BOUND_DRIVES: dict[str, Case] = {}
RECORDED_DRIVES: dict[str, Case] = {}
for _b, _raw, _t, _tr in (
    ("pybullet", pybullet_raw_drive, 1.03, 1.10),
    ("mujoco", mujoco_raw_drive, 1.15, 1.20),
    ("physx", physx_raw_drive, 1.10, 1.20),
):
    if _b in BACKENDS:
        DRIVES[_b] = Case("drive", _raw(False), layer_drive(_b, False), _t)
        BOUND_DRIVES[_b] = Case("bound drive", _raw(False), layer_bound_drive(_b), _t)
        RECORDED_DRIVES[_b] = Case("drive+record", _raw(True), layer_drive(_b, True), _tr)


# ---------------------------------------------------------------- single calls


def single_calls(backend: str, n: int) -> list[Case]:
    sim, robot = _layer_sim(backend)
    sim.step(10)
    wheels = np.array(WHEELS)
    out: list[Case] = []
    # set_joint_velocity alternates two targets, raw and layer alike: each call is a new
    # command (a repeated one is cheaper on both backends; the drive rows repeat theirs)
    raw_targets = itertools.cycle([TURN.tolist(), FORWARD.tolist()]).__next__
    layer_targets = itertools.cycle([TURN, FORWARD]).__next__

    def per_call(fn: Callable[[], object]) -> Callable[[], float]:
        def run() -> float:
            t0 = time.perf_counter()
            for _ in range(n):
                fn()
            return (time.perf_counter() - t0) / n

        return run

    if backend == "pybullet":
        import pybullet as p

        from simbridge.backends.pybullet.inspect import client_id

        c = client_id(sim)  # the same client, called raw

        def raw_link() -> object:
            return p.getLinkState(
                robot, 2, computeLinkVelocity=1, computeForwardKinematics=1, physicsClientId=c
            )

        def raw_js() -> object:
            return p.getJointStates(robot, WHEELS, physicsClientId=c)

        def raw_set() -> None:
            p.setJointMotorControlArray(
                robot,
                WHEELS,
                p.VELOCITY_CONTROL,
                targetVelocities=raw_targets(),
                forces=[50.0] * 4,
                physicsClientId=c,
            )
    elif backend == "physx":
        from simbridge.backends.physx import inspect as physx_inspect

        r = physx_inspect.robot(sim, robot)
        link2 = r.built.links[3]  # link 2
        art = r.built.articulation
        dofs = r.dof[WHEELS]
        wheel_joints = [r.joints[j] for j in WHEELS]

        def raw_link() -> object:
            return link2.entity_pose, link2.linear_velocity, link2.angular_velocity

        def raw_js() -> object:
            return art.qpos[dofs], art.qvel[dofs]

        def raw_set() -> None:
            for j, v in zip(wheel_joints, raw_targets(), strict=True):
                j.set_drive_velocity_target(v)
    else:
        import mujoco

        m, d, dofs, _ = _mujoco_handles(sim, robot)
        from simbridge.backends.mujoco import inspect

        body = int(inspect.robot(sim, robot).body_ids[3])  # link 2
        qadr = m.jnt_qposadr[m.dof_jntid[dofs]]

        def raw_link() -> object:
            return d.xipos[body].copy(), d.xquat[body].copy(), d.cvel[body].copy()

        def raw_js() -> object:
            return d.qpos[qadr].copy(), d.qvel[dofs].copy()

        def raw_set() -> None:
            d.qfrc_applied[dofs] = raw_targets()

        _ = mujoco
    out.append(
        Case(
            "single call: link_state(link 2)",
            per_call(raw_link),
            per_call(lambda: sim.link_state(robot, 2)),
            None,
            "velocity + fresh pose",
        )
    )
    out.append(
        Case(
            "single call: joint_states(4 wheels)",
            per_call(raw_js),
            per_call(lambda: sim.joint_states(robot, wheels)),
            None,
        )
    )
    out.append(
        Case(
            "single call: set_joint_velocity(4 wheels)",
            per_call(raw_set),
            per_call(
                lambda: sim.set_joint_velocity(robot, wheels, layer_targets(), max_force=50.0)
            ),
            None,
            "a new target each call",
        )
    )
    return out


# ---------------------------------------------------------------- compare end to end


def compare_end_to_end() -> Case | None:
    """``simbridge.compare`` on r2d2 against a plain script doing the same two runs and a diff."""
    if len(BACKENDS) < 2:
        return None
    try:
        from simbridge import compare
    except ImportError:
        return None
    if not hasattr(compare, "run") or not hasattr(compare, "diff"):
        return None

    def plain() -> float:
        # Timed whole, set-up included, like the layer's side: raw PyBullet, raw MuJoCo stepping
        # (on the model the layer compiles, whose build is timed too), numpy diff.
        t0 = time.perf_counter()
        a = pybullet_raw_positions()
        b = mujoco_raw_positions()
        np.linalg.norm(a - b, axis=1).max()
        return time.perf_counter() - t0

    def layer() -> float:
        t0 = time.perf_counter()
        ta = compare.run("r2d2", "pybullet")
        tb = compare.run("r2d2", "mujoco")
        compare.diff(ta, tb)
        return time.perf_counter() - t0

    return Case("compare", plain, layer, None, "runs + diff, no report files")


def pybullet_raw_positions() -> np.ndarray:
    import pybullet as p
    import pybullet_data

    c = p.connect(p.DIRECT)
    try:
        p.setAdditionalSearchPath(pybullet_data.getDataPath(), physicsClientId=c)
        p.setGravity(0, 0, -9.8, physicsClientId=c)
        p.loadURDF("plane.urdf", physicsClientId=c)
        r = p.loadURDF("r2d2.urdf", [0, 0, START_Z], physicsClientId=c)
        out = np.empty((980, 3))
        for k in range(980):
            if k >= TURN_FROM:
                tv = TURN if k < FORWARD_FROM else FORWARD
                p.setJointMotorControlArray(
                    r,
                    WHEELS,
                    p.VELOCITY_CONTROL,
                    targetVelocities=tv.tolist(),
                    forces=[50.0 if k < FORWARD_FROM else 10.0] * 4,
                    physicsClientId=c,
                )
            p.stepSimulation(physicsClientId=c)
            out[k] = p.getBasePositionAndOrientation(r, physicsClientId=c)[0]
        return out
    finally:
        p.disconnect(c)


def mujoco_raw_positions() -> np.ndarray:
    import mujoco

    sim, robot = _layer_sim("mujoco")
    try:
        m, d, _, base_body = _mujoco_raw_model(sim, robot)
        out = np.empty((980, 3))
        for k in range(980):
            if k == FORWARD_FROM:
                m.actuator_forcerange[:] = [-10.0, 10.0]
            if k >= TURN_FROM:
                d.ctrl[:] = TURN if k < FORWARD_FROM else FORWARD
            mujoco.mj_step(m, d)
            mujoco.mj_kinematics(m, d)
            out[k] = d.xipos[base_body]
        return out
    finally:
        sim.close()


def layer_positions(backend: str) -> np.ndarray:
    sim, robot = _layer_sim(backend)
    try:
        out = np.empty((980, 3))
        wheels = np.array(WHEELS)
        for k in range(980):
            if k >= TURN_FROM:
                sim.set_joint_velocity(
                    robot,
                    wheels,
                    TURN if k < FORWARD_FROM else FORWARD,
                    max_force=50.0 if k < FORWARD_FROM else 10.0,
                )
            sim.step()
            out[k] = sim.base_state(robot).position
        return out
    finally:
        sim.close()
