"""Why velocity motors down a long chain miss their target on PhysX: the engine, measured raw.

    python bench/physx_chain_drives.py

A fixed-base chain of 16 revolute links (0.1 kg each, 1 cm apart, all about y: the conformance
suite's ``arms_urdf`` arm), every joint at 0.25 rad/s, every joint's drive asked for 0.5 rad/s
(stiffness 0, damping 1e11, force limit 10 N m: the backend's stand-in for PyBullet's velocity
motor), no gravity, PGS with 50 position iterations. Built with raw SAPIEN (no simbridge), it
prints the joint speeds after a few steps for several link inertias and solver settings.

MuJoCo's backend (its exact motor solve) reaches 0.5 on every joint at the first step. PyBullet's
own solver misses too on this arm, differently (through ``Sim("pybullet")``: -0.35 .. 0.60 after
one step, still -0.33 .. 0.60 after two): a single 16-link arm fits its 121-joint limit, the
conformance test's 8 arms do not. PhysX solves an articulation's
drives one joint at a time (Gauss-Seidel down the chain), and where the links' rotational
inertia is small against their mass at the joints' offsets the sweep converges slowly: at
PyBullet's inertia for a link with no collision shape (6.7e-8 kg m^2) the chain's joints read
0.19-0.5 after 2 steps, still 0.28-0.52 after 100, and more iterations do not mend it; at
1e-3 kg m^2 the same chain is within 0.002 after 100 steps.
"""

from __future__ import annotations

import numpy as np


def run(
    inertia: float,
    steps: int,
    *,
    links: int = 16,
    velocity_iterations: int = 1,
    position_iterations: int = 50,
) -> np.ndarray:
    """The chain's joint speeds after ``steps`` steps."""
    import sapien
    from sapien import physx

    cfg = physx.PhysxSceneConfig()
    cfg.gravity = np.zeros(3)
    cfg.enable_tgs = False
    physx.set_scene_config(cfg)
    scene = sapien.Scene([physx.PhysxCpuSystem()])
    scene.set_timestep(1 / 240)
    turn = [np.sqrt(0.5), 0, 0, np.sqrt(0.5)]  # the joint's x axis onto y
    parent = None
    entities, comps = [], []
    for i in range(links + 1):
        comp = physx.PhysxArticulationLinkComponent(parent)
        comp.mass = 0.1
        comp.inertia = np.full(3, inertia, dtype=np.float32)
        comp.linear_damping = comp.angular_damping = 0.0
        joint = comp.joint
        if i == 0:
            joint.type = "fixed"
        else:
            joint.type = "revolute"
            joint.pose_in_parent = sapien.Pose([0, 0, 0.01], turn)
            joint.pose_in_child = sapien.Pose([0, 0, 0], turn)
            joint.limit = np.array([[-1, 1]], dtype=np.float32)
            joint.friction = 0.0
        entity = sapien.Entity()
        entity.add_component(comp)
        entities.append(entity)
        comps.append(comp)
        parent = comp
    for entity in entities:
        scene.add_entity(entity)
    art = comps[0].articulation
    art.solver_position_iterations = position_iterations
    art.solver_velocity_iterations = velocity_iterations
    art.sleep_threshold = 0.0
    for joint in art.get_active_joints():
        joint.set_drive_properties(0.0, 1e11, 10.0, "force")
        joint.set_drive_velocity_target(0.5)
    art.qvel = np.full(links, 0.25, dtype=np.float32)
    for _ in range(steps):
        scene.step()
    return np.asarray(art.qvel, dtype=float)


def main() -> None:
    rows = [
        ("6.7e-8 (PyBullet's, no collision shape)", 6.67e-8, 2, 1),
        ("6.7e-8", 6.67e-8, 100, 1),
        ("6.7e-8, 255 velocity iterations", 6.67e-8, 2, 255),
        ("1e-5", 1e-5, 2, 1),
        ("1e-3", 1e-3, 2, 1),
        ("1e-3", 1e-3, 100, 1),
    ]
    print(f"{'link inertia (kg m^2)':42s} {'steps':>5s}  joint speeds, target 0.5 (min .. max)")
    for label, inertia, steps, vel_it in rows:
        v = run(inertia, steps, velocity_iterations=vel_it)
        worst = float(np.abs(v - 0.5).max())
        print(f"{label:42s} {steps:5d}  {v.min():.3f} .. {v.max():.3f}  (worst {worst:.3f} off)")


if __name__ == "__main__":
    main()
