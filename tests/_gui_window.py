"""Run by tests/test_gui.py in a process of its own, under the test's Xvfb: one Sim(gui=True).

``python _gui_window.py BACKEND show OUTDIR``: r2d2 on the plane, stepped; screenshots of the X
display with the robot and after it is removed (OUTDIR/with.png, OUTDIR/without.png); prints
one JSON line with the robot-blue pixel counts, then closes the Sim.
``python _gui_window.py BACKEND close``: r2d2 alone in a window, stepped, drawn, then
``close()``; prints
``closing <time>`` just before it.
``python _gui_window.py BACKEND ant``: Gymnasium's ant.xml read as MuJoCo reads it
(``load_mjcf(..., semantics="mujoco")``) in the window, stepped under constant controls, drawn
(its tan pixels, printed as ``drawn <count> <scene> <time>``), then ``close()`` as in
``close``; before the window opens, the same run headless, and ``same <gap>`` printed: the
largest difference of the two runs' ``qpos``/``qvel``.
Either way the process then ends as Python ends it.
Where the backend cannot open a window on this machine (BackendUnsupportedError: PhysX without
a Vulkan device SAPIEN accepts), the process prints ``unsupported: <why>`` and ends with
status :data:`UNSUPPORTED`.
"""

from __future__ import annotations

import importlib.util
import json
import os
import sys
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np
from PIL import Image, ImageGrab

import simbridge
from simbridge.exceptions import BackendUnsupportedError

UNSUPPORTED = 3  # the exit status where the backend says it cannot open a window here
WAIT_S = 20.0  # the most a window gets to draw a new state (llvmpipe on loaded cores)
# Robot-blue pixels (robot_pixels) that mean r2d2 is drawn: measured with r2d2 in the window
# 5361-5553 (PyBullet), 9520-19526 (MuJoCo), 7844 (PhysX), 10 runs each of "close"; the same
# window without it, 8 s of screenshots: at most 239 (PyBullet, while its panels first draw), 0
# (MuJoCo, PhysX). 2000 lies 2.7x under the least drawn and 8x over the most without.
ROBOT_DRAWN = 2000


# Ant-tan pixels (ant_pixels) that mean Gymnasium's ant is drawn (mode "ant", 0.5 s of steps),
# measured: 4338-4990 (PyBullet, 7 runs), 8939-54076 (MuJoCo, 6 runs: the count depends on when
# its window reaches its full size), 25170 (PhysX, 6 runs); an empty window of each, 8 s of
# screenshots: 0. 1000 lies 4.3x under the least drawn.
ANT_DRAWN = 1000


def ant_xml() -> str:
    """Gymnasium's ant.xml (the package's own file)."""
    spec = importlib.util.find_spec("gymnasium")
    assert spec is not None and spec.origin is not None
    return str(Path(spec.origin).parent / "envs" / "mujoco" / "assets" / "ant.xml")


def _channels(img: Image.Image) -> list[np.ndarray]:
    a = np.asarray(img.convert("RGB"), dtype=np.int16)
    return [a[..., 0], a[..., 1], a[..., 2]]


def robot_pixels(img: Image.Image) -> int:
    """Pixels of r2d2's blue body (material "blue", rgba 0 0 0.8): blue clearly above red and
    green; the grey plane, the sky and the panels have none."""
    r, g, b = _channels(img)
    return int(((b >= 70) & (r < 40) & (g < 40)).sum())


def ant_pixels(img: Image.Image) -> int:
    """Pixels of the ant's tan (every geom of ant.xml: rgba 0.8 0.6 0.4), shaded: red over
    green over blue, red clearly above blue; grey floors and skies, PyBullet's blue-grey
    background and the viewers' panels have none."""
    r, g, b = _channels(img)
    return int(((r > g) & (g > b) & (r - b >= 40) & (r >= 60)).sum())


def scene_pixels(img: Image.Image) -> int:
    """Grey pixels (the ground plane: PyBullet's light grey, MuJoCo's dark grey), which a
    window that has not drawn its scene yet (black, or MuJoCo's "LOADING...") lacks. Counted
    with numpy: a loop over the 786,432 pixels in Python took 0.44 s of CPU a screenshot, taken
    from the window drawing beside it while grab() polled."""
    r, g, b = _channels(img)
    spread = np.maximum(np.maximum(r, g), b) - np.minimum(np.minimum(r, g), b)
    return int(((r >= 50) & (r <= 235) & (spread < 12)).sum())


def grab(
    until: Callable[[int, int], bool],
    out: str | None = None,
    robot: Callable[[Image.Image], int] = robot_pixels,
) -> tuple[int, int]:
    """Screenshots of the whole display until ``until(robot, scene)`` holds (pixel counts,
    the robot's by ``robot``) or WAIT_S pass; the last one's counts."""
    deadline = time.monotonic() + WAIT_S
    while True:
        img = ImageGrab.grab(xdisplay=os.environ["DISPLAY"])
        counts = robot(img), scene_pixels(img)
        if until(*counts) or time.monotonic() > deadline:
            if out is not None:
                img.save(out)
            return counts
        time.sleep(0.25)


def ant_run(sim: simbridge.Sim) -> np.ndarray:
    """ant.xml under MuJoCo's reading, 0.5 s under a constant 0.3 on every actuator (the ant
    falls onto its legs); its ``qpos`` and ``qvel``."""
    sim.load_mjcf(ant_xml(), semantics="mujoco")
    sim.set_actuator_controls(np.full(8, 0.3))
    sim.step(50)
    return np.concatenate([sim.qpos(), sim.qvel()])


def main() -> None:
    backend, mode = sys.argv[1], sys.argv[2]
    if mode == "ant":
        with simbridge.Sim(backend) as headless:
            alone = ant_run(headless)
    try:
        sim = simbridge.Sim(backend, gui=True)
    except BackendUnsupportedError as exc:
        print(f"unsupported: {exc}", flush=True)
        sys.exit(UNSUPPORTED)
    if mode == "ant":
        shown = ant_run(sim)
        print(f"same {float(np.abs(shown - alone).max())!r}", flush=True)
        robot, scene = grab(lambda n, _: n > ANT_DRAWN, robot=ant_pixels)
        print(f"drawn {robot} {scene} {time.time()}", flush=True)
        print(f"closing {time.time()}", flush=True)
        sim.close()
        return
    if mode == "show":
        sim.load_urdf("plane.urdf")
    body = sim.load_urdf("r2d2.urdf", base_position=(0.0, 0.0, 0.5))
    sim.step(24)
    if mode == "show":
        out = sys.argv[3]
        with_robot = grab(lambda n, _: n > ROBOT_DRAWN, os.path.join(out, "with.png"))
        sim.remove(body)
        sim.step(1)
        without = grab(
            lambda n, scene: n < 50 and scene > 100_000, os.path.join(out, "without.png")
        )
        print(json.dumps({"with": with_robot, "without": without}), flush=True)
    else:
        # the window has drawn the robot before it is closed: its pixel counts, for the test
        robot, scene = grab(lambda n, _: n > ROBOT_DRAWN)
        print(f"drawn {robot} {scene} {time.time()}", flush=True)
    print(f"closing {time.time()}", flush=True)
    sim.close()


if __name__ == "__main__":
    main()
