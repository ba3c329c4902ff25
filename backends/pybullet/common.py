"""What the PyBullet backend's modules share: the record kept per body (:class:`_Body`), the
guard of every call that touches the world (:func:`_exclusive`), the reads' tests for
non-finite values, and the checks made before PyBullet is given a file or a display (names
PyBullet can hold, XML nesting depth, the X display)."""

from __future__ import annotations

import math
import os
import time
import xml.etree.ElementTree as ET
from typing import Any

from simbridge.exceptions import UrdfStructureError
from simbridge.model.urdf import UrdfModel
from simbridge.types import JointInfo, JointType, Quat, Vec3

from ..locking import WAIT_LIMIT_S, WAIT_SLICE_S, exclusive, wait_for_lock

__all__ = [
    "MAX_NAME_BYTES",
    "WAIT_LIMIT_S",
    "WAIT_SLICE_S",
    "_Body",
    "_all_finite",
    "_exclusive",
    "_finite_base",
    "_nesting",
    "_refuse_long_names",
    "_x_display_problem",
    "wait_for_lock",
]

# Every call that touches the world holds the Sim's lock (PyBullet's client is one state
# machine): the rules (a call waits for another thread's call, a step is refused, never
# waited for) are backends/locking.py's, shared with the MuJoCo backend.
_exclusive = exclusive


def _finite_base(pos: Vec3, orn: Quat, lin: Vec3, ang: Vec3) -> bool:
    """The reads' quick test of a base state: its sum is finite only if every number is (or
    the sum overflowed: _all_finite tells). Explicit additions, not sum(), which takes twice
    as long (bench/divergence.py's docstring)."""
    return math.isfinite(
        pos[0] + pos[1] + pos[2] + orn[0] + orn[1] + orn[2] + orn[3]
        + lin[0] + lin[1] + lin[2] + ang[0] + ang[1] + ang[2]
    )  # fmt: skip


def _all_finite(*groups: Any) -> bool:
    """Whether every number in ``groups`` (sequences of floats) is finite: the exact test
    behind the reads' quick one (a sum overflows where no value is infinite)."""
    return all(math.isfinite(v) for g in groups for v in g)


class _Body:
    __slots__ = ("table", "movable", "probe_joints", "free", "base_inertial", "n", "effort")

    def __init__(self, table: list[JointInfo], free: bool, base_inertial: Any) -> None:
        self.table = table
        self.n = len(table)
        self.movable = [i for i, j in enumerate(table) if j.type != JointType.FIXED]
        self.free = free
        # a fixed base's probe: its movable leaves (no movable joint below them). A NaN in a
        # joint reaches every joint below it within the step (the articulated-body algorithm's
        # outward pass), so some leaf shows it; a free base shows any joint's NaN in its pose.
        above: set[int] = set()
        for i in self.movable:
            k = table[i].parent_index
            while k >= 0:
                above.add(k)
                k = table[k].parent_index
        self.probe_joints = [] if free else [i for i in self.movable if i not in above]
        self.base_inertial = base_inertial  # (pos, orn) of the COM in the base link frame
        # <limit effort> per joint, the clamp on motor force and torque when the profile
        # enforces it (None: not enforced)
        self.effort: list[float] | None = None


# PyBullet keeps names in 1024-byte buffers (1023 bytes and a NUL) and ends the process
# (SIGSEGV, measured on 3.2.7) on a joint name over 1263 bytes or a link name over 2287:
# longer names are refused before PyBullet reads the file.
MAX_NAME_BYTES = 1023


def _refuse_long_names(model: UrdfModel) -> None:
    """UrdfStructureError for a robot, link or joint name PyBullet cannot hold."""
    named: list[tuple[str, str, int | None]] = [("robot", model.name, None)]
    named += [("link", link.name, link.line or None) for link in model.links]
    named += [("joint", joint.name, joint.line or None) for joint in model.joints]
    for element, name, line in named:
        size = len(name.encode("utf-8"))
        if size > MAX_NAME_BYTES:
            raise UrdfStructureError(
                model.source.display_name,
                f"<{element} name={name[:20] + '...'!r}>",
                f"a name of {size} bytes: PyBullet holds at most {MAX_NAME_BYTES} (longer "
                "ones crash it); shorten it, or use the 'mujoco' backend",
                line,
            )


def _nesting(root: ET.Element) -> int:
    """How deep the elements under ``root`` nest (``root`` alone: 1), without recursion."""
    deepest = 0
    stack = [(root, 1)]
    while stack:
        element, depth = stack.pop()
        deepest = max(deepest, depth)
        stack.extend((child, depth + 1) for child in element)
    return deepest


X_TRIES = 3  # connections to the X server tried before it is called unreachable


def _x_display_problem() -> str | None:
    """Why the X display cannot be opened, or None. PyBullet's GUI ends the whole process when
    it cannot connect to the X server (measured: DISPLAY=:77, exit code 1, no exception), so
    the display is tried here first with Xlib's own XOpenDisplay."""
    import ctypes
    import ctypes.util

    name = ctypes.util.find_library("X11")
    if name is None:
        return "libX11 is not installed (PyBullet's GUI needs an X server)"
    try:
        xlib = ctypes.CDLL(name)
    except OSError as exc:
        return f"libX11 cannot be loaded: {exc}"
    xlib.XOpenDisplay.restype = ctypes.c_void_p
    xlib.XOpenDisplay.argtypes = [ctypes.c_char_p]
    xlib.XCloseDisplay.argtypes = [ctypes.c_void_p]
    # a busy Xvfb refuses a connection now and then (docs/pybullet_backend.md, "The window")
    for attempt in range(X_TRIES):
        display = xlib.XOpenDisplay(None)
        if display:
            xlib.XCloseDisplay(display)
            return None
        time.sleep(0.1 * (attempt + 1))
    return f"cannot connect to the X server at DISPLAY={os.environ.get('DISPLAY')!r}"
