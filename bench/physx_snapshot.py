"""What PhysX's save and restore leaves out, measured raw (no simbridge).

    python bench/physx_snapshot.py

A chain of 7 boxes (1 kg, the last 0.05 kg) on 6 revolute joints, drives off, joint friction
0, PGS, 1/240 s, in the air under gravity (no contacts), the joints started at 0.3 rad; its root
welded to the world ("fixed base") or free and thrown ("floating base"). Each experiment steps
20, ``PhysxCpuSystem.pack()``, steps 10 (the truth), ``unpack()``, steps 10 again and prints the
largest difference of the joint positions from the truth.

* Fixed base: PhysX alone continues bit for bit. Its joint accelerations (``qacc``: the last
  step's) and each link's velocities are not put back by ``unpack``: the link velocities are
  recomputed from the joint velocities, 0.095 rad/s away from those the step left (a write of
  the same joint velocities does the same). Neither is an input of PhysX's next step; but a
  force computed from the link velocities before each step (PyBullet's link damping law,
  ``-m k (1 + |v|) v``, which the backend applies so) is, and then the continuation is off
  (1.5e-4 rad after 10 steps).
  The backend's snapshot keeps the link velocities as read (backends/physx/backend.py).
* Floating base: a write of the same joint positions or of the same root pose (``unpack``
  makes both) derives every child link's pose afresh from the root pose and the joint
  positions, 1.5e-8 m from the pose PhysX's step carried forward, and the continuation is off
  by 2.1e-6 rad after 10 steps; writes of the velocities change nothing. SAPIEN 3.0.3 sets no
  pose of a child link, so no backend can put this back.
"""

from __future__ import annotations

from typing import Any

import numpy as np


def _world(floating: bool) -> tuple[Any, Any, list[Any], Any]:
    """A fresh scene with the chain: (system, articulation, links, scene)."""
    import sapien
    from sapien import physx

    cfg = physx.PhysxSceneConfig()
    cfg.enable_tgs = False
    physx.set_scene_config(cfg)
    system = physx.PhysxCpuSystem()
    scene = sapien.Scene([system])
    scene.timestep = 1 / 240
    material = physx.PhysxMaterial(0.5, 0.5, 0.0)
    parent = None
    links, entities = [], []
    for i in range(7):
        comp = physx.PhysxArticulationLinkComponent(parent)
        comp.attach(physx.PhysxCollisionShapeBox(half_size=[0.05, 0.05, 0.1], material=material))
        comp.mass = 1.0 if i < 6 else 0.05
        comp.inertia = np.array([0.01, 0.01, 0.005], dtype=np.float32)
        comp.linear_damping = comp.angular_damping = 0.0
        comp.max_linear_velocity = comp.max_angular_velocity = 1e4
        joint = comp.joint
        if i == 0:
            joint.type = "undefined" if floating else "fixed"
        else:  # alternately about x and y, 0.2 m apart
            s = float(np.sqrt(0.5))
            joint.type = "revolute_unwrapped"
            joint.limit = np.array([[-np.inf, np.inf]], dtype=np.float32)
            joint.armature = np.zeros(1, dtype=np.float32)
            joint.friction = 0.0
            joint.pose_in_parent = sapien.Pose([0, 0, 0.2], [s, s * (i % 2), s * (1 - i % 2), 0])
            joint.pose_in_child = sapien.Pose([0, 0, 0])
        entity = sapien.Entity()
        entity.add_component(comp)
        links.append(comp)
        entities.append(entity)
        parent = comp
    for entity in entities:
        scene.add_entity(entity)
    art = links[0].articulation
    art.qpos = np.full(art.dof, 0.3, dtype=np.float32)
    for j in art.active_joints:
        j.set_drive_properties(0.0, 0.0, 0.0)
    if floating:
        art.root_linear_velocity = np.array([0.3, 0.0, 1.0], dtype=np.float32)
        art.root_angular_velocity = np.array([0.5, 1.0, 2.0], dtype=np.float32)
    return system, art, links, scene


def _velocities(links: list[Any]) -> np.ndarray:
    return np.array([np.r_[link.linear_velocity, link.angular_velocity] for link in links])


def _poses(links: list[Any]) -> np.ndarray:
    return np.array([np.r_[link.entity_pose.p, link.entity_pose.q] for link in links])


def save_and_restore(floating: bool, damping: bool) -> tuple[float, float, float]:
    """(joint positions 10 steps after unpack off the truth, link velocities right after
    unpack off those at pack, link poses likewise)."""
    system, art, links, _scene = _world(floating)

    def step() -> None:
        if damping:  # PyBullet's law at k = 0.04, from the link velocities PhysX reports
            for link in links[1:]:
                v, w = link.linear_velocity, link.angular_velocity
                link.add_force_torque(
                    -0.04 * (1 + np.linalg.norm(v)) * v,
                    -0.04 * (1 + np.linalg.norm(w)) * w,
                    "acceleration",
                )
        system.step()

    for _ in range(20):
        step()
    blob = system.pack()
    velocities, poses = _velocities(links), _poses(links)
    for _ in range(10):
        step()
    truth = art.qpos.copy()
    system.unpack(blob)
    dv = float(np.abs(_velocities(links) - velocities).max())
    dp = float(np.abs(_poses(links) - poses).max())
    for _ in range(10):
        step()
    return float(np.abs(art.qpos - truth).max()), dv, dp


def same_value_write(floating: bool, what: str) -> tuple[float, float]:
    """A write of the unchanged ``what`` after 20 steps: (how far the link poses moved, the
    joint positions 10 steps later off the run without the write)."""
    runs = []
    moved = 0.0
    for write in (False, True):
        system, art, links, _scene = _world(floating)
        for _ in range(20):
            system.step()
        before = _poses(links)
        if write and what == "joint positions":
            art.qpos = art.qpos
        elif write and what == "joint velocities":
            art.qvel = art.qvel
        elif write and what == "root pose":
            art.root_pose = art.root_pose
        elif write and what == "root velocities":
            art.root_linear_velocity = art.root_linear_velocity
            art.root_angular_velocity = art.root_angular_velocity
        if write:
            moved = float(np.abs(_poses(links) - before).max())
        for _ in range(10):
            system.step()
        runs.append(art.qpos.copy())
    return moved, float(np.abs(runs[1] - runs[0]).max())


def main() -> None:
    for floating in (False, True):
        base = "floating base" if floating else "fixed base"
        for damping in (False, True):
            law = "with the link damping law" if damping else "PhysX alone"
            off, dv, dp = save_and_restore(floating, damping)
            print(
                f"{base}, {law}: pack, unpack: joint positions 10 steps later off by {off:.3g} "
                f"rad; right after unpack link velocities off by {dv:.3g}, link poses by {dp:.3g}"
            )
        for what in ("joint positions", "joint velocities", "root pose", "root velocities"):
            if what.startswith("root") and not floating:
                continue
            moved, off = same_value_write(floating, what)
            print(
                f"{base}: a write of the same {what}: link poses moved {moved:.3g}, joint "
                f"positions 10 steps later off by {off:.3g} rad"
            )


if __name__ == "__main__":
    main()
