"""The window process of ``Sim(gui=True)`` on MuJoCo: MuJoCo's passive viewer on a copy of the
model, drawing the poses the simulation writes into a shared file (see window.py).

Run as a script (``python -P window_process.py SHARED PARENT_PID``), never imported by the
simulation: it imports MuJoCo and NumPy alone. The pickled ``MjModel`` comes on standard input;
one line on standard output says ``ready`` or why the window could not open. The shared file
holds float64 values: ``[0]`` a counter the simulation raises at every new state, ``[1]`` 1.0
once the window is to close, then ``qpos``, ``mocap_pos`` and ``mocap_quat``.

The process ends with ``os._exit(0)`` without tearing the viewer down (the viewer's own close
can hang or crash its process: docs/mujoco_backend.md, "The window"); the X server closes the
window with the connection.
"""

from __future__ import annotations

import mmap
import os
import pickle
import sys
import time
from typing import Any

FRAME_S = 1 / 60  # how often the window looks for a new state
HEADER = 2  # the counter and the close flag
NEAR_M = 0.05  # the camera's near clipping distance, metres at most


def _camera(mujoco: Any, m: Any, d: Any, cam: Any) -> None:
    """Point the viewer's camera at the robots: at the centre of mass of the world's moving
    bodies, from a distance that fits their geoms; a world without one is seen from 5 m."""
    moving = [b for b in range(1, m.nbody) if m.body_weldid[b] != 0]
    cam.type = mujoco.mjtCamera.mjCAMERA_FREE
    if not moving:
        cam.lookat[:] = (0.0, 0.0, 0.0)
        cam.distance, cam.elevation, cam.azimuth = 5.0, -30.0, 135.0
        return
    centre = d.subtree_com[0]
    cam.lookat[:] = centre
    reach = 0.0
    for g in range(m.ngeom):
        if m.body_weldid[m.geom_bodyid[g]] != 0:
            dist = float(((d.geom_xpos[g] - centre) ** 2).sum() ** 0.5)
            reach = max(reach, dist + float(m.geom_rbound[g]))
    cam.distance = max(1.0, 4.0 * reach)
    cam.elevation, cam.azimuth = -20.0, 135.0


def main() -> None:
    """Show the model read from standard input until the close flag, the user or the parent
    ends it.

    The arguments come from ``sys.argv``: the shared file's path and the simulation's process id.
    """
    shared, parent = sys.argv[1], int(sys.argv[2])
    try:
        import mujoco
        import mujoco.viewer
        import numpy as np

        m = pickle.load(sys.stdin.buffer)
        # the near clipping plane is a fraction of the model's extent, which a ground plane
        # makes large (plane.urdf: 283 m, so 2.8 m): a robot nearer the camera was not drawn
        m.vis.map.znear = min(float(m.vis.map.znear), NEAR_M / max(float(m.stat.extent), 1e-9))
        d = mujoco.MjData(m)
        with open(shared, "r+b") as f:
            buf = mmap.mmap(f.fileno(), 0)
        values = np.frombuffer(buf, dtype=np.float64)
        nq, nmocap = m.nq, m.nmocap
        qpos = values[HEADER : HEADER + nq]
        mpos = values[HEADER + nq : HEADER + nq + 3 * nmocap].reshape(nmocap, 3)
        mquat = values[HEADER + nq + 3 * nmocap :].reshape(nmocap, 4)

        def show() -> None:
            d.qpos[:] = qpos
            if nmocap:
                d.mocap_pos[:] = mpos
                d.mocap_quat[:] = mquat
            mujoco.mj_kinematics(m, d)
            mujoco.mj_comPos(m, d)  # subtree_com, which the tracking camera follows

        show()
        handle = mujoco.viewer.launch_passive(m, d, show_left_ui=False, show_right_ui=False)
        with handle.lock():
            _camera(mujoco, m, d, handle.cam)
        handle.sync()
    except Exception as exc:  # noqa: BLE001 - told to the simulation, which raises it
        print(f"error: {type(exc).__name__}: {exc}".replace("\n", " "), flush=True)
        os._exit(1)
    print("ready", flush=True)
    seen = values[0]
    while values[1] == 0.0 and handle.is_running() and os.getppid() == parent:
        if values[0] != seen:
            seen = values[0]
            with handle.lock():
                before = d.subtree_com[0].copy()
                show()
                handle.cam.lookat[:] += d.subtree_com[0] - before  # follow the robots
            handle.sync()
        time.sleep(FRAME_S)
    os._exit(0)


if __name__ == "__main__":
    main()
