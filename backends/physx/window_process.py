"""The window process of ``Sim(gui=True)`` on PhysX: a SAPIEN render-only scene drawing the
link poses the simulation writes into shared files (see window.py).

Run as a script (``python -P window_process.py FOLDER PARENT_PID``), never imported by the
simulation: it imports SAPIEN and NumPy alone, and its scene has no physics. ``FOLDER/header``
holds float64 values: ``[0]`` a counter the simulation raises at every new state, ``[1]`` 1.0
once the window is to close, ``[2]`` the world's generation: ``FOLDER/world.N`` (pickled) lists
the world's parts (a link, or a static body) with their shapes, ``FOLDER/poses.N`` their poses
(7 float64 each: x y z, then the quaternion w x y z). One line on standard output says
``ready`` once the first frame is drawn, or why the window could not open.

The scene is drawn with the shaders beside this file (window_shader/): SAPIEN's own lit
shaders take many times longer to compile on Mesa's lavapipe before the first frame
(docs/physx_backend.md, "The window").
The process ends with ``os._exit(0)`` without tearing the window down (the X server closes it
with the connection), as MuJoCo's window process does.
"""

from __future__ import annotations

import math
import mmap
import os
import pickle
import sys
import time
from typing import Any

FRAME_S = 1 / 30  # how often the window looks for a new state
IDLE_REDRAW_S = 0.5  # a window with nothing new is drawn again this often
HEADER = 3  # the counter, the close flag, the world's generation
SIZE = (800, 600)  # the window, pixels
NEAR_M, FAR_M = 0.02, 500.0  # the camera's clipping distances
FOV_Y = math.radians(50.0)
YAW, PITCH = math.radians(-130.0), math.radians(25.0)  # the first view: from the side, down
TURN_PER_PIXEL = 0.005  # rad of a mouse drag
MIN_DISTANCE = 1.0  # metres
DISTANCE = 1.3  # the camera's distance from the robots, times their size
GROUND_SIZE = 50.0  # a part wider than this (a ground plane) is not aimed at
SHADERS = os.path.join(os.path.dirname(os.path.abspath(__file__)), "window_shader")
_X_TO_Z = (math.sqrt(0.5), 0.0, -math.sqrt(0.5), 0.0)  # w x y z: SAPIEN's x-axis shapes onto z


def _qmul(a: tuple[float, ...], b: tuple[float, ...]) -> tuple[float, float, float, float]:
    aw, ax, ay, az = a
    bw, bx, by, bz = b
    return (
        aw * bw - ax * bx - ay * by - az * bz,
        aw * bx + ax * bw + ay * bz - az * by,
        aw * by - ax * bz + ay * bw + az * bx,
        aw * bz + ax * by - ay * bx + az * bw,
    )


class Scene:
    """The render-only scene of one generation of the world.

    Args:
        sapien: The ``sapien`` module (imported by :func:`main`).
        np: The ``numpy`` module.
        folder: The folder the simulation writes the world into.
        generation: Which world: its parts in ``world.<generation>``, poses in
            ``poses.<generation>``.
    """

    def __init__(self, sapien: Any, np: Any, folder: str, generation: int) -> None:
        with open(os.path.join(folder, f"world.{generation}"), "rb") as f:
            parts = pickle.load(f)
        with open(os.path.join(folder, f"poses.{generation}"), "r+b") as f:
            self._map = mmap.mmap(f.fileno(), 0)
        self.poses = np.frombuffer(self._map, dtype=np.float64).reshape(-1, 7)
        self.scene = sapien.Scene([sapien.render.RenderSystem()])
        self.entities = []
        self.moving: list[int] = []  # the parts the camera follows
        self.reach = 0.0  # how far their shapes reach from their origins
        render = sapien.render
        for k, part in enumerate(parts):
            body = render.RenderBodyComponent()
            for shape in part["shapes"]:
                made = _shape(render, np, shape)
                if made is not None:
                    body.attach(made)
            entity = sapien.Entity()
            entity.add_component(body)
            self.scene.add_entity(entity)
            self.entities.append(entity)
            if part["moving"]:
                self.moving.append(k)
                self.reach = max(self.reach, part["reach"])
        self.sapien = sapien
        self.place()

    def place(self) -> None:
        """Put every part at the pose the simulation last wrote, and update the render."""
        Pose = self.sapien.Pose
        rows = self.poses[: len(self.entities)].tolist()  # (a world without parts has 1 row)
        for entity, row in zip(self.entities, rows, strict=True):
            entity.set_pose(Pose(row[:3], row[3:]))
        self.scene.update_render()

    def centre(self) -> tuple[list[float], float] | None:
        """The middle of the moving parts and their size.

        Returns:
            The middle (m, world) and the size (m), or None: nothing moves (or it is past 1e6 m).
        """
        if not self.moving:
            return None
        pts = self.poses[self.moving, :3]
        lo, hi = pts.min(axis=0), pts.max(axis=0)
        if not (abs(lo).max() < 1e6 and abs(hi).max() < 1e6):
            return None
        return ((lo + hi) / 2).tolist(), float(((hi - lo) ** 2).sum() ** 0.5) + 2 * self.reach


def _shape(render: Any, np: Any, s: dict[str, Any]) -> Any:
    """A SAPIEN render shape from one visual of the plan (see window.py's ``_shapes``)."""
    kind, size = s["kind"], [max(float(v), 1e-4) for v in s["size"]]
    mat = render.RenderMaterial(base_color=list(s["rgba"]))
    turn = (1.0, 0.0, 0.0, 0.0)
    if kind == "box":
        shape = render.RenderShapeBox(np.asarray([0.5 * v for v in size], np.float32), mat)
    elif kind == "sphere":
        shape = render.RenderShapeSphere(size[0], mat)
    elif kind == "cylinder":
        shape = render.RenderShapeCylinder(size[0], 0.5 * size[1], mat)
        turn = _X_TO_Z
    elif kind == "capsule":
        shape = render.RenderShapeCapsule(size[0], 0.5 * size[1], mat)
        turn = _X_TO_Z
    elif kind == "mesh" and len(s["faces"]):
        v = np.asarray(s["vertices"], np.float32)
        f = np.asarray(s["faces"], np.uint32)
        shape = render.RenderShapeTriangleMesh(
            v, f, np.zeros_like(v), np.zeros((len(v), 2), np.float32), mat
        )
    else:
        return None
    x, y, z, w = s["orientation"]
    from sapien import Pose

    shape.local_pose = Pose(list(s["position"]), list(_qmul((w, x, y, z), turn)))
    return shape


class Camera:
    """An orbit camera: ``distance`` from ``target`` at ``yaw`` and ``pitch`` (rad, pitch down).

    The robots' motion moves the target; a drag with the left button turns the camera (SAPIEN's
    wheel delta did not reach this loop: no zoom).

    Args:
        window: The ``sapien.render.RenderWindow``.
        sapien: The ``sapien`` module.
    """

    def __init__(self, window: Any, sapien: Any) -> None:
        self.window, self.sapien = window, sapien
        self.target = [0.0, 0.0, 0.0]
        self.distance, self.yaw, self.pitch = 2.0 * DISTANCE, YAW, PITCH

    def aim(self, aimed: tuple[list[float], float] | None) -> None:
        """At the robots (after a new world), from a distance that fits them.

        Args:
            aimed: :meth:`Scene.centre`'s middle and size, or None to keep the view.
        """
        if aimed is not None:
            self.target, self.distance = aimed[0], max(MIN_DISTANCE, DISTANCE * aimed[1])
        self.place()

    def follow(self, aimed: tuple[list[float], float] | None) -> None:
        """Move the target with the robots, the distance and angles kept.

        Args:
            aimed: :meth:`Scene.centre`'s middle and size, or None to keep the view.
        """
        if aimed is not None:
            self.target = aimed[0]
            self.place()

    def mouse(self) -> bool:
        """Turn the camera by the user's drag since the last frame.

        Returns:
            Whether the view changed.
        """
        w = self.window
        dx, dy = (float(v) for v in w.mouse_delta)
        if not (w.mouse_down(0) and (dx or dy)):
            return False
        self.yaw -= TURN_PER_PIXEL * dx
        self.pitch = min(1.5, max(-1.5, self.pitch + TURN_PER_PIXEL * dy))
        self.place()
        return True

    def place(self) -> None:
        """SAPIEN's camera looks along its x axis, z up."""
        cy, sy = math.cos(self.yaw), math.sin(self.yaw)
        cp, sp = math.cos(self.pitch), math.sin(self.pitch)
        forward = (cp * cy, cp * sy, -sp)
        eye = [t - self.distance * f for t, f in zip(self.target, forward, strict=True)]
        yaw = (math.cos(self.yaw / 2), 0.0, 0.0, math.sin(self.yaw / 2))
        pitch = (math.cos(self.pitch / 2), 0.0, math.sin(self.pitch / 2), 0.0)
        self.window.set_camera_pose(self.sapien.Pose(eye, list(_qmul(yaw, pitch))))


def main() -> None:
    """Draw the world the simulation writes until the close flag, the user or the parent ends it.

    The arguments come from ``sys.argv``: the shared folder and the simulation's process id.
    """
    folder, parent = sys.argv[1], int(sys.argv[2])
    try:
        import numpy as np
        import sapien

        with open(os.path.join(folder, "header"), "r+b") as f:
            buf = mmap.mmap(f.fileno(), 0)
        header = np.frombuffer(buf, dtype=np.float64)
        generation = int(header[2])
        scene = Scene(sapien, np, folder, generation)
        window = sapien.render.RenderWindow(SIZE[0], SIZE[1], SHADERS)
        window.set_scene(scene.scene)
        window.set_camera_parameters(NEAR_M, FAR_M, FOV_Y)
        camera = Camera(window, sapien)
        camera.aim(scene.centre())
        window.render("Color", [])
    except Exception as exc:  # noqa: BLE001 - told to the simulation, which raises it
        print(f"error: {type(exc).__name__}: {exc}".replace("\n", " "), flush=True)
        os._exit(1)
    print("ready", flush=True)
    seen, drawn, busy = header[0], time.monotonic(), False
    while header[1] == 0.0 and not window.should_close and os.getppid() == parent:
        new = int(header[2])
        if new != generation:
            try:
                scene = Scene(sapien, np, folder, new)
            except FileNotFoundError:  # already replaced by a newer one: read it next time
                time.sleep(FRAME_S)
                continue
            generation = new
            window.set_scene(scene.scene)  # which resets the camera
            window.set_camera_parameters(NEAR_M, FAR_M, FOV_Y)
            camera.aim(scene.centre())
            seen = -1.0
        # the window reads its input when it draws: drawn every frame while the user acts
        if busy or header[0] != seen or time.monotonic() - drawn > IDLE_REDRAW_S:
            if header[0] != seen:
                seen = header[0]
                scene.place()
                camera.follow(scene.centre())
            window.render("Color", [])
            drawn = time.monotonic()
            busy = camera.mouse() or window.mouse_down(0)
        time.sleep(FRAME_S)
    os._exit(0)


if __name__ == "__main__":
    main()
