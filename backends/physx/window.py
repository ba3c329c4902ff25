"""SAPIEN's window for ``Sim(gui=True)`` on PhysX: opened with the world, kept in step, closed.

The physics scene has no render system and no visual shapes (nothing of this costs a headless
Sim anything). The window lives in a process of its own (window_process.py) with a render-only
scene made from the plan's visual shapes (primitives, meshes, colours: what the PyBullet and
MuJoCo backends draw); the simulation writes every part's pose into a shared file and the
window draws it, its camera following the robots. ``close()`` asks the window to go, waits
:data:`CLOSE_WAIT_S` and kills it if it is still there: whatever SAPIEN's window does at exit,
the simulation's process goes on and exits cleanly (MuJoCo's window process is built the same
way).

SAPIEN draws through Vulkan: the window needs a Vulkan device that SAPIEN accepts (it asks for
VK_KHR_external_semaphore_fd, which Debian 12's lavapipe, Mesa 22.3.6, lacks; Mesa 25's from
bookworm-backports has it). Without one, opening raises BackendUnsupportedError saying so.
"""

from __future__ import annotations

import math
import mmap
import os
import pickle
import select
import shutil
import subprocess
import sys
import tempfile
import time
import weakref
from collections.abc import Iterable
from typing import Any

import numpy as np

from simbridge.exceptions import BackendUnsupportedError, DisplayError
from simbridge.model.build_plan import BuildPlan, ShapePlan
from simbridge.transforms import transform_multiply

from .model import _link_frame_in_base

__all__ = ["Window", "VULKAN_NEEDED"]

OPEN_WAIT_S = 60.0  # the window's first frame: seconds on a loaded 2-core machine under Mesa
CLOSE_WAIT_S = 3.0  # then the window's process is killed
# a window whose process fails to open it is started again, twice: under a busy Xvfb SAPIEN
# now and then finds no device where the openings around it do (docs/physx_backend.md, "The
# window")
OPEN_RETRIES = 2
RETRY_PAUSE_S = 1.0  # before the first retry; twice that before the second
HEADER = 3  # the counter, the close flag, the world's generation (window_process.py)
DEFAULT_RGBA = (1.0, 1.0, 1.0, 1.0)  # a visual without a colour (as the MuJoCo backend's)
_SCRIPT = os.path.join(os.path.dirname(os.path.abspath(__file__)), "window_process.py")
VULKAN_NEEDED = (
    "SAPIEN's window needs a Vulkan device with VK_KHR_external_semaphore_fd: Debian 12's "
    "lavapipe (mesa-vulkan-drivers 22.3.6) lacks it; Mesa 25's (apt-get install -t "
    "bookworm-backports mesa-vulkan-drivers) has it. Watch a run with gui=True on 'pybullet' "
    "or 'mujoco' meanwhile"
)
# what SAPIEN says when it finds no Vulkan device it can use (SAPIEN 3.0.3)
_NO_DEVICE = ("rendering device", "vulkan", "vk_")


def _end(proc: subprocess.Popen[bytes], header: mmap.mmap, folder: str) -> None:
    """Ask the window to close, wait for it, kill it if it stays; remove the shared files."""
    try:
        header[8:16] = np.float64(1.0).tobytes()  # the close flag
    except ValueError:  # the map is already closed
        pass
    try:
        proc.wait(CLOSE_WAIT_S)
    except subprocess.TimeoutExpired:
        proc.kill()
        proc.wait()
    if proc.stdout is not None:
        proc.stdout.close()
    shutil.rmtree(folder, ignore_errors=True)


def _shapes(link_frame: tuple[Any, Any] | None, visuals: Iterable[ShapePlan]) -> list[dict]:
    """The plan's visual shapes as the window process makes them, placed in the part's frame
    (``link_frame``: the link in the part, for a static body's links; None: the part is the
    link)."""
    out = []
    for s in visuals:
        position, orientation = s.position, s.orientation
        if link_frame is not None:
            position, orientation = transform_multiply(link_frame, (position, orientation))
        mesh = s.mesh
        out.append(
            {
                "kind": s.kind,
                "size": tuple(s.size),
                "position": tuple(position),
                "orientation": tuple(orientation),
                "rgba": tuple(s.rgba or DEFAULT_RGBA),
                "vertices": None if mesh is None else np.asarray(mesh.vertices, np.float32),
                "faces": None if mesh is None else np.asarray(mesh.faces, np.uint32),
            }
        )
    return out


def _reach(shapes: list[dict]) -> float:
    """How far the shapes reach from their part's origin (m)."""
    reach = 0.0
    for s in shapes:
        size = [abs(float(v)) for v in s["size"]]
        if s["vertices"] is not None and len(s["vertices"]):
            extent = float(np.linalg.norm(s["vertices"], axis=1).max())
        elif s["kind"] == "box":
            extent = 0.5 * math.hypot(*size)
        elif s["kind"] in ("cylinder", "capsule"):
            extent = math.hypot(size[0], 0.5 * size[1]) + (size[0] if s["kind"] == "capsule" else 0)
        else:
            extent = size[0] if size else 0.0
        reach = max(reach, math.hypot(*s["position"]) + extent)
    return reach


def world_parts(robots: Iterable[Any]) -> tuple[list[dict], list[Any]]:
    """The world's parts for the window and, per part, what gives its pose.

    Args:
        robots: The backend's Robot records.

    Returns:
        The parts (each a dict: its ``shapes``, whether it is ``moving``, its ``reach`` in
        metres) and, per part, what gives its pose: a moving link's component, or a static body's
        entity.
    """
    parts: list[dict] = []
    posers: list[Any] = []
    for robot in robots:
        built = robot.built
        plan: BuildPlan = built.plan
        if built.static:
            shapes: list[dict] = []
            for link in plan.links:
                shapes += _shapes(_link_frame_in_base(plan, link.index), link.visuals)
            parts.append({"shapes": shapes, "moving": False, "reach": _reach(shapes)})
            posers.append(built.entities[0])
            continue
        for link, comp in zip(plan.links, built.links, strict=True):
            if not link.visuals:
                continue
            shapes = _shapes(None, link.visuals)
            parts.append({"shapes": shapes, "moving": not link.static, "reach": _reach(shapes)})
            posers.append(comp.entity)
    return parts, posers


class Window:
    """A window on the world, in a process of its own (window_process.py).

    Args:
        backend: The backend's name, for the errors.

    Raises:
        DisplayError: On Linux with neither DISPLAY nor WAYLAND_DISPLAY set, or when the window did
            not open.
        BackendUnsupportedError: SAPIEN found no Vulkan device to draw with.
    """

    def __init__(self, backend: str) -> None:
        if sys.platform.startswith("linux") and not (
            os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY")
        ):
            raise DisplayError(backend, "neither DISPLAY nor WAYLAND_DISPLAY is set")
        self._backend = backend
        self._folder = tempfile.mkdtemp(prefix="simbridge-physx-view-")
        path = os.path.join(self._folder, "header")
        with open(path, "w+b") as f:
            f.truncate(8 * HEADER)
            self._header_map = mmap.mmap(f.fileno(), 0)
        self._header = np.frombuffer(self._header_map, dtype=np.float64)
        self._generation = 0
        self._posers: list[Any] = []
        self._poses: np.ndarray | None = None
        self._pose_map: mmap.mmap | None = None
        self.show([])
        for attempt in range(1 + OPEN_RETRIES):
            if attempt:  # after a pause: the failures seen came in spells under load
                time.sleep(RETRY_PAUSE_S * attempt)
            detail = self._start()
            if detail is None:
                break
        if detail is not None:
            shutil.rmtree(self._folder, ignore_errors=True)
            del self._poses, self._header
            if self._pose_map is not None:
                self._pose_map.close()
            self._header_map.close()
            if any(word in detail.lower() for word in _NO_DEVICE):
                raise BackendUnsupportedError(
                    backend, "gui=True here", f"{VULKAN_NEEDED} (SAPIEN: {detail})"
                )
            raise DisplayError(backend, detail)

    def _start(self) -> str | None:
        """Start the window's process; None once it has drawn, else why it failed (the
        process ended)."""
        with tempfile.TemporaryFile() as err:  # the window's messages, told if it fails
            self._proc = subprocess.Popen(
                [sys.executable, "-P", _SCRIPT, self._folder, str(os.getpid())],
                stdin=subprocess.DEVNULL,
                stdout=subprocess.PIPE,
                stderr=err,
            )
            self._closer = weakref.finalize(self, _end, self._proc, self._header_map, self._folder)
            problem = self._handshake()
            if problem is None:
                return None
            self._closer.detach()
            self._proc.kill()
            self._proc.wait()
            if self._proc.stdout is not None:
                self._proc.stdout.close()
            err.seek(0)
            tail = err.read().decode(errors="replace").strip().splitlines()[-3:]
            return "; ".join([problem, *tail])

    def _handshake(self) -> str | None:
        """Wait for the window's first line; None once it has drawn its first frame."""
        out = self._proc.stdout
        assert out is not None
        deadline = time.monotonic() + OPEN_WAIT_S
        while time.monotonic() < deadline:
            ready, _, _ = select.select([out], [], [], 0.1)
            if ready:
                line = out.readline().decode(errors="replace").strip()
                if line == "ready":
                    return None
                return f"SAPIEN's window failed: {line or 'no answer'}"
        return f"SAPIEN's window did not open within {OPEN_WAIT_S:g} s"

    def show(self, robots: Iterable[Any]) -> None:
        """A new world (a load, a removal, a reset): its parts and their poses.

        Args:
            robots: The backend's Robot records.
        """
        parts, posers = world_parts(robots)
        generation = self._generation + 1
        folder = self._folder
        with open(os.path.join(folder, f"world.{generation}.tmp"), "wb") as f:
            pickle.dump(parts, f, protocol=pickle.HIGHEST_PROTOCOL)
        with open(os.path.join(folder, f"poses.{generation}"), "w+b") as f:
            f.truncate(8 * 7 * max(len(parts), 1))
            pose_map = mmap.mmap(f.fileno(), 0)
        os.replace(
            os.path.join(folder, f"world.{generation}.tmp"),
            os.path.join(folder, f"world.{generation}"),
        )
        old, self._pose_map = self._pose_map, pose_map
        self._poses = np.frombuffer(pose_map, dtype=np.float64).reshape(-1, 7)
        self._posers = posers
        self._write()
        self._header[2] = generation  # the window reads the new world from here on
        if old is not None:
            for name in (f"world.{self._generation}", f"poses.{self._generation}"):
                try:
                    os.unlink(os.path.join(folder, name))
                except OSError:
                    pass
            old.close()
        self._generation = generation

    def _write(self) -> None:
        poses = self._poses
        assert poses is not None
        for row, poser in zip(poses, self._posers, strict=False):
            p = poser.pose
            row[:3] = p.p
            row[3:] = p.q
        self._header[0] += 1.0

    def sync(self) -> None:
        """Show the current poses (nothing once the window is closed)."""
        if self._closer.alive and self._posers:
            self._write()

    def close(self) -> None:
        """Close the window: it goes within CLOSE_WAIT_S, killed if need be."""
        if self._closer.alive:
            self._closer()
            del self._poses, self._header  # the maps' last views, so that they can close
            if self._pose_map is not None:
                self._pose_map.close()
            self._header_map.close()
