"""A joint reset past its limit on PhysX: raw SAPIEN's own ways against PyBullet's limit row.

    python bench/physx_limit_reset.py

slider.urdf's carriage (0.5 kg, prismatic along x, limits +-0.4 m, no gravity along it, no
motor) is reset past its limit and stepped 60 times at 1/240 s. PyBullet's limit row
(btMultiBodyJointLimitConstraint, measured on raw PyBullet here) only pushes the joint back
in, asks for zero speed along it and, under 0.04 of penetration d, a push-back at 0.2 d / dt:
0.41 leaves at -0.48 m/s and keeps it; 0.441 and 0.7 stay where they are.

Part 1 builds the slider with raw SAPIEN (no simbridge: PGS, 50 position iterations as the
backend sets them) and prints, per PhysX setting, where the carriage is and how fast it moves
after 1 and 60 steps, and the largest difference from raw PyBullet's run over the 60 steps
(PyBullet's link damping off, as under the "urdf" profile). PhysX's own limit puts the joint
back on the limit within a step and keeps 0.8 d / dt as speed (the carriage reset at 0.7 crosses
to -0.4); the links' max depenetration velocity changes nothing (it bounds contacts, not an
articulation's limits); the joint's max velocity only caps the speed; TGS stops the joint near
the limit with no speed; fewer position iterations keep 0.64 d / dt (one iteration).

Part 2 is the backend's stand-in (backends/physx/limits.py), written raw: before each step,
PhysX's limit on the violated side of a joint past its limit is moved to q + vt dt (vt = -0.2 d /
dt, or 0 deeper than 0.04); after it, where that limit held the joint, the joint is put on the
bound at speed vt; the limit is put back once the joint is in range.

Part 3 runs the conformance test's cases through ``simbridge.Sim("physx")`` against
``Sim("pybullet")``, both profiles: the largest position and speed difference over 60 steps.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

DT = 1.0 / 240.0
STEPS = 60
CASES = [(0.4, 1.0), (0.41, 0.0), (0.439, 0.0), (0.441, 0.0), (0.7, 0.0), (0.7, -0.5), (-0.45, 2.0)]
SLIDER = str(Path(__file__).resolve().parent.parent / "robots" / "slider.urdf")


def pybullet_run(start: float, speed: float, damping: bool = False) -> np.ndarray:
    """Raw PyBullet's (position, speed) after each step (link damping off unless asked)."""
    import pybullet as p

    c = p.connect(p.DIRECT)
    try:
        p.setTimeStep(DT, physicsClientId=c)
        p.setGravity(0, 0, -9.81, physicsClientId=c)
        body = p.loadURDF(SLIDER, useFixedBase=True, physicsClientId=c)
        if not damping:
            for link in (-1, 0):
                p.changeDynamics(body, link, linearDamping=0, angularDamping=0, physicsClientId=c)
        p.setJointMotorControl2(body, 0, p.VELOCITY_CONTROL, force=0, physicsClientId=c)
        p.resetJointState(body, 0, start, speed, physicsClientId=c)
        out = np.empty((STEPS, 2))
        for k in range(STEPS):
            p.stepSimulation(physicsClientId=c)
            out[k] = p.getJointState(body, 0, physicsClientId=c)[:2]
        return out
    finally:
        p.disconnect(c)


def sapien_slider(
    tgs: bool = False, iterations: int = 50, depenetration: float = 1e32, max_velocity: float = 1e6
):
    """slider.urdf built with raw SAPIEN: (scene, articulation, carriage joint)."""
    import sapien
    from sapien import physx

    cfg = physx.PhysxSceneConfig()
    cfg.gravity = np.array([0, 0, -9.81], dtype=np.float32)
    cfg.bounce_threshold = 2.0
    cfg.enable_tgs = tgs
    physx.set_scene_config(cfg)
    scene = sapien.Scene([physx.PhysxCpuSystem()])
    scene.timestep = DT
    rail = physx.PhysxArticulationLinkComponent(None)
    rail.mass = 2.0
    rail.inertia = np.array([0.0020833, 0.1670833, 0.1683333], dtype=np.float32)
    rail.joint.type = "fixed"
    car = physx.PhysxArticulationLinkComponent(rail)
    car.mass = 0.5
    car.inertia = np.full(3, 0.00083333, dtype=np.float32)
    joint = car.joint
    joint.type = "prismatic"
    joint.pose_in_parent = sapien.Pose([0, 0, 0.1])
    joint.pose_in_child = sapien.Pose()
    joint.limit = np.array([[-0.4, 0.4]], dtype=np.float32)
    joint.friction = 0.0
    joint.armature = np.zeros(1, dtype=np.float32)
    for link in (rail, car):
        link.max_linear_velocity = 1e6
        link.max_angular_velocity = 1e6
        link.max_depenetration_velocity = depenetration
        link.linear_damping = 0.0
        link.angular_damping = 0.0
        entity = sapien.Entity()
        entity.add_component(link)
        scene.add_entity(entity)
    art = car.articulation
    art.solver_position_iterations = iterations
    art.solver_velocity_iterations = 1
    art.sleep_threshold = 0.0
    joint.max_velocity = max_velocity
    return scene, art, joint


def sapien_run(start: float, speed: float, stand_in: bool = False, **settings) -> np.ndarray:
    """Raw SAPIEN's (position, speed) after each step; ``stand_in``: the backend's law."""
    scene, art, joint = sapien_slider(**settings)
    art.qpos = np.array([start], dtype=np.float32)
    art.qvel = np.array([speed], dtype=np.float32)
    lo, hi = (float(x) for x in joint.limit[0])
    out = np.empty((STEPS, 2))
    for k in range(STEPS):
        held = None
        if stand_in:
            q = float(art.qpos[0])
            if q > hi or q < lo:
                side = 1.0 if q > hi else -1.0
                depth = side * (q - (hi if q > hi else lo))
                vt = -side * 0.2 * depth / DT if depth < 0.04 else 0.0
                bound = float(np.float32(q + vt * DT))
                joint.limit = np.array([[lo, bound] if q > hi else [bound, hi]], np.float32)
                held = (bound, vt, side)
            else:
                joint.limit = np.array([[lo, hi]], dtype=np.float32)
        scene.step()
        if held is not None:
            bound, vt, side = held
            if side * (float(art.qpos[0]) - bound) >= -2.0 * float(np.spacing(np.float32(bound))):
                art.qpos = np.array([bound], dtype=np.float32)  # held by the moved limit
                art.qvel = np.array([vt], dtype=np.float32)
        out[k] = float(art.qpos[0]), float(art.qvel[0])
    return out


SETTINGS: list[tuple[str, dict]] = [
    ("PhysX's limit (the backend's settings)", {}),
    ("max_depenetration_velocity 0.48", {"depenetration": 0.48}),
    ("max_depenetration_velocity 0", {"depenetration": 0.0}),
    ("joint max_velocity 0.48", {"max_velocity": 0.48}),
    ("TGS", {"tgs": True}),
    ("1 position iteration", {"iterations": 1}),
    ("the stand-in (limits.py)", {"stand_in": True}),
]


def raw_table() -> list[str]:
    lines = [
        "| PhysX, raw SAPIEN | start m, speed m/s | after 1 step | after 60 | max |dq|, |dv| |",
        "|---|---|---|---|---|",
    ]
    reference = {case: pybullet_run(*case) for case in CASES}
    for label, settings in SETTINGS:
        for case in CASES:
            got = sapien_run(*case, **settings)
            diff = np.abs(got - reference[case]).max(axis=0)
            lines.append(
                f"| {label} | {case[0]:g}, {case[1]:g} | {got[0, 0]:.5f}, {got[0, 1]:.4g} | "
                f"{got[-1, 0]:.5f}, {got[-1, 1]:.4g} | {diff[0]:.2e}, {diff[1]:.2e} |"
            )
    lines.append("")
    lines.append(
        "raw PyBullet (link damping off): "
        + ", ".join(
            f"{c[0]:g} -> {reference[c][-1, 0]:.5f} at {reference[c][-1, 1]:.4g}" for c in CASES
        )
    )
    return lines


def layer_table() -> list[str]:
    import simbridge

    lines = ['| Sim("physx") against Sim("pybullet") | profile | max |dq| m | max |dv| m/s |']
    lines.append("|---|---|---|---|")
    for profile in ("pybullet", "urdf"):
        for start, speed in CASES:
            runs = []
            for name in ("pybullet", "physx"):
                with simbridge.Sim(name, profile=profile) as sim:
                    body = sim.load_urdf("slider.urdf", fixed_base=True)
                    sim.set_joint_velocity(body, 0, 0.0, max_force=0.0)
                    sim.reset_joint_state(body, 0, start, speed)
                    out = np.empty((STEPS, 2))
                    for k in range(STEPS):
                        sim.step()
                        js = sim.joint_states(body, [0])
                        out[k] = js.positions[0], js.velocities[0]
                    runs.append(out)
            diff = np.abs(runs[0] - runs[1]).max(axis=0)
            lines.append(f"| {start:g}, {speed:g} | {profile} | {diff[0]:.2e} | {diff[1]:.2e} |")
    return lines


# two hinges about y, the first free, the second limited to +-0.4 rad; no gravity
CHAIN = """<robot name="chain">
<link name="base"><inertial><mass value="1"/>
<inertia ixx="0.01" ixy="0" ixz="0" iyy="0.01" iyz="0" izz="0.01"/></inertial></link>
<link name="upper"><inertial><origin xyz="0.2 0 0"/><mass value="1"/>
<inertia ixx="0.001" ixy="0" ixz="0" iyy="0.004" iyz="0" izz="0.004"/></inertial></link>
<link name="lower"><inertial><origin xyz="0.2 0 0"/><mass value="0.5"/>
<inertia ixx="0.001" ixy="0" ixz="0" iyy="0.002" iyz="0" izz="0.002"/></inertial></link>
<joint name="shoulder" type="continuous"><parent link="base"/><child link="upper"/>
<axis xyz="0 1 0"/></joint>
<joint name="elbow" type="revolute"><parent link="upper"/><child link="lower"/>
<origin xyz="0.4 0 0"/><axis xyz="0 1 0"/><limit lower="-0.4" upper="0.4" effort="1" velocity="5"/>
</joint></robot>"""


def chain_table() -> list[str]:
    """The elbow of a free two-hinge chain reset past its limit: the push-back moves the
    shoulder too on PyBullet (its row impulse through the mass matrix)."""
    import simbridge

    lines = ["| chain, elbow reset at (rad) | max |dq| shoulder, elbow | max |dv| the same |"]
    lines.append("|---|---|---|")
    for start in (0.41, 0.439, 0.7):
        runs = []
        for name in ("pybullet", "physx"):
            with simbridge.Sim(name, profile="urdf", gravity=(0, 0, 0)) as sim:
                body = sim.load_urdf(CHAIN, fixed_base=True)
                sim.set_joint_velocity(body, [0, 1], 0.0, max_force=0.0)
                sim.reset_joint_state(body, 1, start, 0.0)
                out = np.empty((STEPS, 4))
                for k in range(STEPS):
                    sim.step()
                    js = sim.joint_states(body, [0, 1])
                    out[k] = *js.positions, *js.velocities
                runs.append(out)
        d = np.abs(runs[0] - runs[1]).max(axis=0)
        lines.append(f"| {start:g} | {d[0]:.2e}, {d[1]:.2e} | {d[2]:.2e}, {d[3]:.2e} |")
    return lines


def main(argv: list[str]) -> int:
    print("\n".join(raw_table()))
    print()
    print("\n".join(layer_table()))
    print()
    print("\n".join(chain_table()))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
