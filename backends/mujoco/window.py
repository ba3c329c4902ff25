"""MuJoCo's passive viewer for ``Sim(gui=True)``: opened on a world, kept in step, closed.

The window lives in a process of its own (window_process.py) with a copy of the model: the
simulation writes each new state into a shared file and the window draws it: MuJoCo's passive
viewer in the simulation's own process could hang or crash it at ``close()``, and its own camera
framed the whole world (the runs: docs/mujoco_backend.md, "The window"). Here ``close()`` asks
the window to go, waits :data:`CLOSE_WAIT_S` and kills it if it is still there: whatever the
viewer does, the simulation's process goes on and exits cleanly. The camera tracks the robots.
"""

from __future__ import annotations

import mmap
import os
import pickle
import select
import shutil
import struct
import subprocess
import sys
import tempfile
import time
import weakref
from typing import Any

import numpy as np

from simbridge.exceptions import DisplayError

__all__ = ["Viewer", "check_display"]

OPEN_WAIT_S = 60.0  # the window's first frame: seconds on a loaded 2-core machine under Mesa
CLOSE_WAIT_S = 3.0  # then the window's process is killed
_WINDOW = os.path.join(os.path.dirname(os.path.abspath(__file__)), "window_process.py")
_HEADER = 2  # the counter and the close flag (window_process.py)


def check_display(backend: str) -> None:
    """Refuse a window where none can open (Linux without DISPLAY or WAYLAND_DISPLAY).

    Args:
        backend: The backend's name, for the message.

    Raises:
        DisplayError: On Linux with neither DISPLAY nor WAYLAND_DISPLAY set.
    """
    if sys.platform.startswith("linux") and not (
        os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY")
    ):
        raise DisplayError(backend, "neither DISPLAY nor WAYLAND_DISPLAY is set")


def _end(proc: subprocess.Popen[bytes], shared: mmap.mmap, path: str, cwd: str) -> None:
    """Ask the window to close, wait for it, kill it if it stays; remove the shared file and
    the window's working folder (where MuJoCo writes MUJOCO_LOG.TXT when GLFW fails)."""
    try:
        shared[8:16] = struct.pack("d", 1.0)  # the close flag
    except ValueError:  # the map is already closed
        pass
    try:
        proc.wait(CLOSE_WAIT_S)
    except subprocess.TimeoutExpired:
        proc.kill()
        proc.wait()
    for stream in (proc.stdin, proc.stdout):
        if stream is not None:
            stream.close()
    try:
        os.unlink(path)
    except OSError:
        pass
    shutil.rmtree(cwd, ignore_errors=True)


class Viewer:
    """A passive viewer window on one model and data (a new model needs a new window).

    The window runs in a process of its own (window_process.py), reading the poses from a shared
    file.

    Args:
        backend: The backend's name, for the error.
        m: The ``mujoco.MjModel`` to show (pickled to the window's process).
        d: The ``mujoco.MjData`` whose ``qpos`` and mocap poses it shows.

    Raises:
        DisplayError: The window's process did not open the viewer within ``OPEN_WAIT_S``.
    """

    def __init__(self, backend: str, m: Any, d: Any) -> None:
        self._d = d
        self._nq, self._nmocap = m.nq, m.nmocap
        size = 8 * (_HEADER + m.nq + 7 * m.nmocap)
        fd, self._path = tempfile.mkstemp(prefix="simbridge-mujoco-view-")
        try:
            os.ftruncate(fd, size)
            self._map = mmap.mmap(fd, size)
        finally:
            os.close(fd)
        self._values = np.frombuffer(self._map, dtype=np.float64)
        self._write()
        # the window runs in a folder of its own: MuJoCo writes MUJOCO_LOG.TXT into the working
        # folder when GLFW cannot start, which would be left in the user's
        cwd = tempfile.mkdtemp(prefix="simbridge-mujoco-window-")
        with tempfile.TemporaryFile() as err:  # the window's messages, told if it fails
            self._proc = subprocess.Popen(
                [sys.executable, "-P", _WINDOW, self._path, str(os.getpid())],
                stdin=subprocess.PIPE,
                stdout=subprocess.PIPE,
                stderr=err,
                cwd=cwd,
            )
            self._closer = weakref.finalize(self, _end, self._proc, self._map, self._path, cwd)
            problem = self._handshake(m)
            if problem is not None:
                self.close()
                err.seek(0)
                tail = err.read().decode(errors="replace").strip().splitlines()[-3:]
                raise DisplayError(backend, "; ".join([problem, *tail]))

    def _handshake(self, m: Any) -> str | None:
        """Send the model, wait for the window's first line; None once it is open."""
        proc = self._proc
        assert proc.stdin is not None and proc.stdout is not None
        try:
            proc.stdin.write(pickle.dumps(m))
            proc.stdin.close()
        except OSError as exc:
            return f"MuJoCo's viewer process stopped before it read the model ({exc})"
        deadline = time.monotonic() + OPEN_WAIT_S
        while time.monotonic() < deadline:
            ready, _, _ = select.select([proc.stdout], [], [], 0.1)
            if ready:
                line = proc.stdout.readline().decode(errors="replace").strip()
                if line == "ready":
                    return None
                return f"mujoco.viewer.launch_passive failed: {line or 'no answer'}"
        return f"MuJoCo's viewer did not open within {OPEN_WAIT_S:g} s"

    def _write(self) -> None:
        v, nq, nm = self._values, self._nq, self._nmocap
        d = self._d
        v[_HEADER : _HEADER + nq] = d.qpos
        if nm:
            v[_HEADER + nq : _HEADER + nq + 3 * nm] = d.mocap_pos.ravel()
            v[_HEADER + nq + 3 * nm :] = d.mocap_quat.ravel()
        v[0] += 1.0

    def sync(self) -> None:
        """Show the current state (nothing once the user has closed the window)."""
        if self._closer.alive:
            self._write()

    def close(self) -> None:
        """Close the window: it goes within CLOSE_WAIT_S, killed if need be."""
        if self._closer.alive:
            self._closer()
            del self._values  # the map's last view, so that it can close
            self._map.close()
