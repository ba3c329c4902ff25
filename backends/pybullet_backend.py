"""The PyBullet backend: the reference semantics, one physics client per `Sim`.

Under the "pybullet" profile this backend adds nothing: each call maps onto the PyBullet call a
tutorial user would write (``loadURDF``, ``getJointInfo``, ``setJointMotorControlArray``,
``stepSimulation``...), so a drive written against `Sim` is bit for bit the raw drive. The
"urdf" profile is reached with PyBullet's own switches (``URDF_USE_INERTIA_FROM_FILE``,
``changeDynamics``, the default motor's force set to the file's friction).
"""

from __future__ import annotations

import functools
import logging
import math
import os
import re
import sys
import tempfile
import threading
import xml.etree.ElementTree as ET
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager
from importlib.metadata import PackageNotFoundError, version
from typing import Any, TypeVar

import numpy as np

from simbridge.backend import Backend
from simbridge.engine_output import Record, captured, register_classifier
from simbridge.exceptions import (
    BackendUnsupportedError,
    DisplayError,
    SimBusyError,
    SimulationDivergedError,
    UrdfStructureError,
)
from simbridge.load_options import LoadOptions
from simbridge.profiles import Profile
from simbridge.scene import SceneBody
from simbridge.types import (
    BaseState,
    ContactPoint,
    DynamicsInfo,
    JointCommands,
    JointInfo,
    JointStateMultiDof,
    JointStates,
    JointType,
    LinkState,
    MotorMode,
    Quat,
    SphericalJointState,
    Vec3,
)
from simbridge.urdf import UrdfModel, resolve_mesh

from .pybullet_scene import Pending, named_table
from .pybullet_state import Records, Saved, contact_point

__all__ = ["PyBulletBackend"]

_PYBULLET_DEFAULT_LINK_DAMPING = 0.04
_PYBULLET_DEFAULT_MAX_JOINT_VELOCITY = 100.0
_NO_CLAMP = 1e30  # "no speed clamp": PyBullet takes a number; this one is never reached
_PYBULLET_DEFAULT_FRICTION = 0.5
# Divergence: every state read checks the values it returns (a few float additions), so no
# read ever hands out a NaN or an infinity. Besides, every body is probed (one engine call each:
# its base pose, or its leaf joints for a fixed base) after the first step following a load or
# a teleport, and after every _CHECK_EVERY-th step: a probe costs 0.6-1.5 µs per body, 5-10 % of
# a fixed KUKA's 11-16 µs step if taken at every step; one in 8 steps is under 2 % (measured:
# python bench/divergence.py). A divergence nobody reads is raised by step at most 7 steps late.
_CHECK_EVERY = 8
# What PyBullet 3.2.7 can read and set of one body (measured on chains and trees, fixed or free
# base): its state reads (getJointState(s), getLinkState, getBasePositionAndOrientation,
# getBaseVelocity) fail with "getJointState failed" & co. for every joint of a body with more
# than 127 joints (fixed ones included); and its state arrays hold 128 coordinates, the 7 of
# the base first (a fixed base too), so a movable joint past the 121st reads position and
# velocity 0 and takes no reset or motor, silently. Such bodies are refused when loaded.
MAX_BODY_JOINTS = 127
MAX_BODY_MOVABLE_JOINTS = 121
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


# PyBullet's spherical joint motor at load (PhysicsServerCommandProcessor::createJointMotors): a
# btMultiBodySphericalJointMotor holding the identity with kp 0.2 and an impulse of 1000 N·m·s
# per step per axis (the MuJoCo backend's motors.py reproduces it)
SPHERICAL_BRAKE_KP = 0.2
SPHERICAL_BRAKE_IMPULSE = 1000.0

# PyBullet's removeBody keeps the body's collision shapes until the world is reset (r2d2: 0.6 MB
# per load/step/remove cycle, raw PyBullet alike; resetSimulation frees them, 0.5 ms on an empty
# world; python bench/soak.py). When remove() empties the world after this many removals since
# the engine's world was new, and the ids PyBullet would hand out next are a new world's (0, 1,
# 2, ...: the bodies were removed last-loaded first), the engine's world is made new: nothing
# the Sim shows changes (ids, time, settings), and the memory stays bounded (r2d2 loaded and
# removed 1000 times: 20 MB over the first cycles, then flat).
RECYCLE_AFTER_REMOVALS = 32

# PyBullet's XML reader (tinyxml2) refuses a file whose elements nest deeper than this, <robot>
# counting 1 (measured: 98 loads, 99 is XML_ELEMENT_DEPTH_EXCEEDED)
_MAX_XML_DEPTH = 98

_F = TypeVar("_F", bound=Callable[..., Any])


def _nesting(root: ET.Element) -> int:
    """How deep the elements under ``root`` nest (``root`` alone: 1), without recursion."""
    deepest = 0
    stack = [(root, 1)]
    while stack:
        element, depth = stack.pop()
        deepest = max(deepest, depth)
        stack.extend((child, depth + 1) for child in element)
    return deepest


def _exclusive(method: _F) -> _F:
    """A call that touches the world: refused with SimBusyError while another thread steps
    it (the stepping lock is re-entrant: the stepping thread's own nested calls pass)."""

    @functools.wraps(method)
    def call(self: PyBulletBackend, *args: Any, **kwargs: Any) -> Any:
        lock = self._stepping
        if not lock.acquire(False):
            raise SimBusyError()
        try:
            return method(self, *args, **kwargs)
        finally:
            lock.release()

    return call  # type: ignore[return-value]


def _finite_base(pos: Vec3, orn: Quat, lin: Vec3, ang: Vec3) -> bool:
    """The reads' quick test of a base state: its sum is finite only if every number is (or
    the sum overflowed: _all_finite tells). Explicit additions: 0.15 µs, sum() takes 0.3."""
    return math.isfinite(
        pos[0] + pos[1] + pos[2] + orn[0] + orn[1] + orn[2] + orn[3]
        + lin[0] + lin[1] + lin[2] + ang[0] + ang[1] + ang[2]
    )  # fmt: skip


def _all_finite(*groups: Any) -> bool:
    """Whether every number in ``groups`` (sequences of floats) is finite: the exact test
    behind the reads' quick one (a sum overflows where no value is infinite)."""
    return all(math.isfinite(v) for g in groups for v in g)


# What PyBullet writes from C: ``b3Warning[file,line]:\n`` (b3Error, b3Printf alike) and the
# message, often without a newline before the next marker; the banner on import.
_B3_MARKER = re.compile(r"b3(Warning|Error|Printf)\[[^\]\n]*\]:\n?")
_B3_LEVEL = {"Warning": logging.WARNING, "Error": logging.ERROR, "Printf": logging.INFO}
_BANNER = re.compile(r"^pybullet build time: [^\n]*\n?", re.MULTILINE)


def _pybullet_output(text: str) -> tuple[list[Record], str]:
    """PyBullet's own lines in ``text`` as log records (the banner at DEBUG, b3Warning at
    WARNING, b3Error at ERROR, b3Printf at INFO; a message is the text after its marker up to
    the next marker or the end of its line; a one-word message after the same marker names the
    subject of the one before, and joins it), and the rest of ``text``, which is not PyBullet's
    (whitespace alone left between PyBullet's lines is dropped)."""
    records: list[Record] = []
    rest: list[str] = []
    at = 0
    markers = list(_B3_MARKER.finditer(text))
    for k, m in enumerate(markers):
        rest.append(text[at : m.start()])
        end = markers[k + 1].start() if k + 1 < len(markers) else len(text)
        newline = text.find("\n", m.end(), end)
        at = end if newline < 0 else newline + 1
        level, message = _B3_LEVEL[m.group(1)], text[m.end() : at].strip()
        if (
            records
            and message
            and not any(c.isspace() for c in message)
            and records[-1][0] == level
            and k > 0
            and markers[k - 1].group() == m.group()
        ):
            # Bullet reports a link's problem in two calls, the sentence and then the link's
            # name ("No inertial data for link, ...", "base_footprint"): one record
            records[-1] = (level, f"{records[-1][1].rstrip(':')}: {message}")
        else:
            records.append((level, message))
    rest.append(text[at:])
    left = "".join(rest)
    for m in _BANNER.finditer(left):
        records.insert(0, (logging.DEBUG, m.group().strip()))
    left = _BANNER.sub("", left)
    return records, left if left.strip() else ""


# URDF_MERGE_FIXED_LINKS makes Bullet print the link tree as it merges (printf, no b3 marker)
_MERGE_TREE = re.compile(r"^\t*(?:processing \S.*|merge \S.* into \S.*!|relink \S.*!)\n?", re.M)


def _pybullet_merge_output(text: str) -> tuple[list[Record], str]:
    """A load with merged fixed links: Bullet's printout of the merge at DEBUG, the rest as
    :func:`_pybullet_output` classifies it."""
    merged: list[Record] = [(logging.DEBUG, m.group().strip()) for m in _MERGE_TREE.finditer(text)]
    records, rest = _pybullet_output(_MERGE_TREE.sub("", text))
    return merged + records, rest


def _pybullet_gui_output(text: str) -> tuple[list[Record], str]:
    """Opening and closing the GUI prints lines of its own (threads, OpenGL versions), all
    PyBullet's: every line is claimed, those without a b3 marker at DEBUG."""
    records, rest = _pybullet_output(text)
    records += [(logging.DEBUG, line.strip()) for line in rest.splitlines() if line.strip()]
    return records, ""


register_classifier("pybullet", _pybullet_output)
with captured("pybullet", "importing"):  # its banner, also where this module is imported first
    import pybullet as p  # noqa: E402

# the probe's engine calls (bound once: a module attribute lookup less per call)
_base_pose = p.getBasePositionAndOrientation
_joint_state = p.getJointState
_joint_states = p.getJointStates

# Sim.load_urdf's self_collision -> loadURDF's flags (URDF_USE_SELF_COLLISION_EXCLUDE_PARENT
# is not read by PyBullet 3.2.7: excluding the parent is what URDF_USE_SELF_COLLISION does)
_SELF_COLLISION_FLAGS = {
    "off": 0,
    "exclude_parent": p.URDF_USE_SELF_COLLISION,
    "exclude_all_parents": (
        p.URDF_USE_SELF_COLLISION | p.URDF_USE_SELF_COLLISION_EXCLUDE_ALL_PARENTS
    ),
    "include_parent": p.URDF_USE_SELF_COLLISION | p.URDF_USE_SELF_COLLISION_INCLUDE_PARENT,
}


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
    display = xlib.XOpenDisplay(None)
    if not display:
        return f"cannot connect to the X server at DISPLAY={os.environ.get('DISPLAY')!r}"
    xlib.XCloseDisplay(display)
    return None


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


class PyBulletBackend(Backend):
    """`Sim` on PyBullet (DIRECT, or GUI when asked)."""

    name = "pybullet"
    _scene: Pending | None = None  # the MJCF/SDF file load_scene is loading

    NATIVE_DEFAULTS = {
        "gravity": (0.0, 0.0, 0.0),
        "timestep": 1.0 / 240.0,
        "solver_iterations": 50,
        "joint_brake": "velocity motor, target 0, max impulse 1 N·s per step",
        "inertia_source": "collision_aabb",
        "linear_damping": 0.04,
        "angular_damping": 0.04,
        "max_joint_velocity": 100.0,
        "lateral_friction": 0.5,
        "friction_combine": "product",
        "self_collision": False,
    }

    def __init__(self, profile: Profile, gui: bool = False) -> None:
        super().__init__(profile, gui)
        self._c = -1
        # held by step() and by every call that touches the world (re-entrant: a call's own
        # nested calls pass); a call from another thread meanwhile raises SimBusyError
        self._stepping = threading.RLock()
        self._file_texts: dict[str, str] = {}  # URDF files loaded by path: their first text
        self._diverged: SimulationDivergedError | None = None  # raised again until reset()
        self._checked_at = 0.0  # the time of the last probe that found every body finite
        self.refuse_unsupported()
        if gui:
            if sys.platform.startswith("linux"):
                if not os.environ.get("DISPLAY"):
                    raise DisplayError(self.name, "DISPLAY is not set")
                problem = _x_display_problem()
                if problem:
                    raise DisplayError(self.name, problem)
            with captured(self.name, "opening the GUI", _pybullet_gui_output):
                self._c = p.connect(p.GUI)
            if self._c < 0:
                raise DisplayError(
                    self.name, "p.connect(p.GUI) failed (PyBullet allows one GUI per process)"
                )
        else:
            with captured(self.name, "connecting"):
                self._c = p.connect(p.DIRECT)
        self._dt = profile.timestep
        self._steps = 0
        self._check_every = _CHECK_EVERY  # bench/divergence.py times other cadences
        self._next_check = _CHECK_EVERY
        self._bodies: dict[int, _Body] = {}
        # the last velocity command sent: (joints, body, target, max_force). PyBullet's motor
        # keeps a command until another replaces it, so the same command again is not re-sent
        # (a control loop repeating it every step pays 1.4 us less); any other motor command,
        # load, remove or reset forgets it.
        self._last_velocity: tuple[Any, ...] | None = None
        self._records = Records()  # the commands given and saved states (pybullet_state.py)
        # PyBullet's pool of body ids: the freed ones (a stack: the last freed is handed out
        # first), ids below _fresh handed out since the world was new, removals since then
        self._freed: list[int] = []
        self._fresh = 0
        self._removed = 0
        self._configure()

    def _configure(self) -> None:
        c = self._c
        p.setGravity(*self.profile.gravity, physicsClientId=c)
        p.setTimeStep(self._dt, physicsClientId=c)
        p.setPhysicsEngineParameter(
            numSolverIterations=self.profile.solver_iterations, physicsClientId=c
        )

    # ---------------------------------------------------------------- world

    @property
    def time(self) -> float:
        return self._steps * self._dt

    def load(
        self,
        model: UrdfModel,
        base_position: Vec3,
        base_orientation: Quat,
        fixed_base: bool,
        options: LoadOptions,
    ) -> int:
        movable = sum(j.type != "fixed" for j in model.joints)
        # the last movable joint's first position coordinate (its qIndex, after the base's 7)
        # must be under 128: measured, 121 one-coordinate joints load, 31 spherical ones (4
        # coordinates each: the 32nd's qIndex is 131 and reads nothing)
        sizes = [4 if j.type == "spherical" else 1 for j in model.joints if j.type != "fixed"]
        last_q = 7 + sum(sizes[:-1]) if sizes else 0
        if len(model.joints) > MAX_BODY_JOINTS or last_q > MAX_BODY_MOVABLE_JOINTS + 6:
            raise BackendUnsupportedError(
                self.name,
                f"{model.source.display_name}: a body with {len(model.joints)} joints "
                f"({movable} movable)",
                f"PyBullet reads no state of a body with more than {MAX_BODY_JOINTS} joints "
                "(getJointState, getLinkState and getBasePositionAndOrientation fail for every "
                f"joint of it), and no more than {MAX_BODY_MOVABLE_JOINTS} movable ones (its "
                "state arrays hold 128 coordinates, 7 of them the base's: past them a joint "
                "reads 0 and takes no reset or motor); merge fixed links "
                "(merge_fixed_links=True), split the robot, or use the 'mujoco' backend",
            )
        _refuse_long_names(model)
        with self._idle():
            body = self._load(model, base_position, base_orientation, fixed_base, options)
            if body in self._freed:  # PyBullet's pool: the last freed id, or a fresh one
                self._freed.remove(body)
            self._fresh = max(self._fresh, body + 1)
            self._next_check = self._steps + 1  # a new model: probed after its first step
            return body

    def _load(
        self,
        model: UrdfModel,
        base_position: Vec3,
        base_orientation: Quat,
        fixed_base: bool,
        options: LoadOptions,
    ) -> int:
        self._last_velocity = None
        prof = self.profile
        # loadURDF's own options: PyBullet scales and merges the file it reads itself
        flags = _SELF_COLLISION_FLAGS[options.self_collision]
        if options.inertia_source == "file":
            flags |= p.URDF_USE_INERTIA_FROM_FILE
        if options.merge_fixed_links:
            flags |= p.URDF_MERGE_FIXED_LINKS
        scale = options.global_scaling
        src = model.source
        needs_rewrite = (
            src.path is None
            or any(
                g.mesh_uri.startswith(("package://", "file://"))
                for link in model.links
                for g in (*link.visuals, *link.collisions)
            )
            # PyBullet caches a file's contents by name for the connection's life: a file
            # edited since it was first loaded here goes through a fresh temporary name
            or self._file_texts.setdefault(str(src.path), src.text) != src.text
        )
        if isinstance(model, SceneBody):  # a body of an MJCF/SDF file: PyBullet's own importer
            assert self._scene is not None, "a SceneBody loads through load_scene"
            body = self._scene.body(self, model)
        elif not needs_rewrite:
            body = self._load_file(
                str(src.path),
                src.display_name,
                base_position,
                base_orientation,
                fixed_base,
                flags,
                scale,
            )
        else:
            body = self._load_text(model, base_position, base_orientation, fixed_base, flags, scale)
        self._apply_profile(body, model)
        table = [
            self._read_joint_info(body, i)
            for i in range(p.getNumJoints(body, physicsClientId=self._c))
        ]
        if isinstance(model, SceneBody):
            table = named_table(table, model)
        dyn = p.getDynamicsInfo(body, -1, physicsClientId=self._c)
        base_mass = dyn[0]
        free = not fixed_base and base_mass > 0
        info = self._bodies[body] = _Body(table, free, (dyn[3], dyn[4]))
        self._records.loaded(body)
        if prof.enforce_effort_limit:
            info.effort = [j.max_force if j.max_force > 0 else math.inf for j in table]
            self._clamp_brake(body, info, model)
        return body

    def load_scene(self, bodies: Sequence[SceneBody], options: LoadOptions) -> list[int]:
        """``p.loadMJCF``/``p.loadSDF`` on the file itself (backends/pybullet_scene.py); each
        body then goes through ``load`` as a URDF's does."""
        self._scene = Pending(bodies, _SELF_COLLISION_FLAGS[options.self_collision])
        try:
            return super().load_scene(bodies, options)
        finally:
            self._scene.discard_unclaimed(self)
            self._scene = None

    def _clamp_brake(self, body: int, info: _Body, model: UrdfModel) -> None:
        """Under enforce_effort_limit, the default brake too stays within <limit effort>."""
        assert info.effort is not None
        if self.profile.joint_brake == "pybullet":
            brake = {i: 1.0 / self._dt for i in info.movable}
        else:
            brake = {j.index: j.friction for j in model.joints if j.type != "fixed"}
        balls = {i for i in info.movable if info.table[i].type == JointType.SPHERICAL}
        if self.profile.joint_brake == "pybullet":  # PyBullet's spherical motor at load
            brake.update({i: SPHERICAL_BRAKE_IMPULSE / self._dt for i in balls})
        weak = [i for i in info.movable if info.effort[i] < brake[i] and i not in balls]
        weak_balls = [i for i in info.movable if info.effort[i] < brake[i] and i in balls]
        if weak_balls:  # the same motor (kp 0.2 or the friction brake), within the effort
            kp = SPHERICAL_BRAKE_KP if self.profile.joint_brake == "pybullet" else 0.0
            self._spherical_motor(
                body,
                weak_balls,
                [[0.0, 0.0, 0.0, 1.0]] * len(weak_balls),
                [[info.effort[i]] * 3 for i in weak_balls],
                [[kp] * 3] * len(weak_balls),
                [[1.0] * 3] * len(weak_balls),
            )
        if weak:
            p.setJointMotorControlArray(
                body,
                weak,
                p.VELOCITY_CONTROL,
                targetVelocities=[0.0] * len(weak),
                forces=[info.effort[i] for i in weak],
                physicsClientId=self._c,
            )

    def _within_effort(self, body: int, joints: np.ndarray, force: list[float]) -> list[float]:
        effort = self._bodies[body].effort
        if effort is None:
            return force
        return [min(f, effort[i]) for f, i in zip(force, joints.tolist(), strict=True)]

    def _load_file(
        self,
        path: str,
        display: str,
        pos: Vec3,
        orn: Quat,
        fixed: bool,
        flags: int,
        scale: float = 1.0,
    ) -> int:
        # globalScaling only when asked: PyBullet's default call stays the tutorial's call
        scaling = {} if scale == 1.0 else {"globalScaling": scale}
        merging = _pybullet_merge_output if flags & p.URDF_MERGE_FIXED_LINKS else None
        try:
            with captured(self.name, f"loading {display}", merging):
                return int(
                    p.loadURDF(
                        path,
                        basePosition=pos,
                        baseOrientation=orn,
                        useFixedBase=fixed,
                        flags=flags,
                        physicsClientId=self._c,
                        **scaling,
                    )
                )
        except p.error as exc:
            raise UrdfStructureError(
                display, "<robot>", f"PyBullet cannot load it: {exc}"
            ) from None

    def _load_text(
        self, model: UrdfModel, pos: Vec3, orn: Quat, fixed: bool, flags: int, scale: float = 1.0
    ) -> int:
        """Load through a uniquely named temporary file that is always removed (PyBullet reads
        files only, and caches their contents by name). Mesh paths are made absolute."""
        root = ET.fromstring(model.source.text)
        depth = _nesting(root)
        if depth > _MAX_XML_DEPTH:  # ET.tostring would recurse past Python's limit first
            raise UrdfStructureError(
                model.source.display_name,
                "<robot>",
                f"elements nested {depth} deep: PyBullet's XML reader refuses more than "
                f"{_MAX_XML_DEPTH} (XML_ELEMENT_DEPTH_EXCEEDED)",
            )
        for mesh in root.iter("mesh"):
            uri = mesh.get("filename")
            if uri:
                mesh.set("filename", str(resolve_mesh(uri, model.source.base_dir)[0]))
        fd, path = tempfile.mkstemp(prefix="simbridge_", suffix=".urdf")
        try:
            with os.fdopen(fd, "wb") as f:
                f.write(ET.tostring(root, encoding="utf-8"))
            return self._load_file(path, model.source.display_name, pos, orn, fixed, flags, scale)
        finally:
            os.unlink(path)

    def _apply_profile(self, body: int, model: UrdfModel) -> None:
        prof, c = self.profile, self._c
        changes: dict[str, float] = {}
        if prof.linear_damping != _PYBULLET_DEFAULT_LINK_DAMPING:
            changes["linearDamping"] = prof.linear_damping
        if prof.angular_damping != _PYBULLET_DEFAULT_LINK_DAMPING:
            changes["angularDamping"] = prof.angular_damping
        max_vel = prof.max_joint_velocity
        if max_vel != _PYBULLET_DEFAULT_MAX_JOINT_VELOCITY:
            changes["maxJointVelocity"] = _NO_CLAMP if max_vel is None else max_vel
        if changes:
            p.changeDynamics(body, -1, physicsClientId=c, **changes)
        for link in model.links:
            ct = link.contact
            dyn: dict[str, float] = {}
            if ct.lateral_friction is None or not prof.read_urdf_contact:
                if prof.lateral_friction != _PYBULLET_DEFAULT_FRICTION:
                    dyn["lateralFriction"] = prof.lateral_friction
            if ct.rolling_friction is None or not prof.read_urdf_contact:
                if prof.rolling_friction != 0.0:
                    dyn["rollingFriction"] = prof.rolling_friction
            if ct.spinning_friction is None or not prof.read_urdf_contact:
                if prof.spinning_friction != 0.0:
                    dyn["spinningFriction"] = prof.spinning_friction
            if ct.restitution is None or not prof.read_urdf_contact:
                if prof.restitution != 0.0:
                    dyn["restitution"] = prof.restitution
            if dyn:
                p.changeDynamics(body, link.index, physicsClientId=c, **dyn)
        if not prof.apply_joint_damping:  # PyBullet applies <dynamics damping> unless told
            for j in model.joints:
                if j.damping != 0.0:
                    p.changeDynamics(body, j.index, jointDamping=0.0, physicsClientId=c)
        if prof.joint_brake == "urdf_friction":
            balls = [j for j in model.joints if j.type == "spherical"]
            if balls:  # PyBullet's spherical motor, made a brake with the file's friction
                self._spherical_motor(
                    body,
                    [j.index for j in balls],
                    [[0.0, 0.0, 0.0, 1.0]] * len(balls),
                    [[j.friction] * 3 for j in balls],
                    [[0.0] * 3] * len(balls),
                    [[1.0] * 3] * len(balls),
                )
            movable = [j for j in model.joints if j.type not in ("fixed", "spherical")]
            if movable:
                p.setJointMotorControlArray(
                    body,
                    [j.index for j in movable],
                    p.VELOCITY_CONTROL,
                    targetVelocities=[0.0] * len(movable),
                    forces=[j.friction for j in movable],
                    physicsClientId=c,
                )

    @contextmanager
    def _idle(self) -> Iterator[None]:
        """Changing the world while another thread steps it would end that thread's loop with
        a raw pybullet.error (measured: close() from another thread mid-step): the change
        holds the stepping lock, or is refused."""
        if not self._stepping.acquire(blocking=False):
            raise SimBusyError()
        try:
            yield
        finally:
            self._stepping.release()

    def remove(self, body: int) -> None:
        with self._idle():
            self._last_velocity = None
            p.removeBody(body, physicsClientId=self._c)
            del self._bodies[body]
            self._records.removed(body)
            self._freed.append(body)
            self._removed += 1
            if (
                not self._bodies
                and self._removed >= RECYCLE_AFTER_REMOVALS
                and self._freed == list(range(self._fresh - 1, -1, -1))
            ):
                self._renew_world()

    def _renew_world(self) -> None:
        """An empty world made new (resetSimulation frees what removeBody keeps), with the
        same settings, time and next body ids; saved states of the old one are dropped."""
        self._last_velocity = None
        p.resetSimulation(physicsClientId=self._c)
        self._configure()
        self._records.reset()
        self._freed.clear()
        self._fresh = 0
        self._removed = 0

    def reset(self) -> None:
        with self._idle():
            self._reset()

    def _reset(self) -> None:
        self._last_velocity = None
        p.resetSimulation(physicsClientId=self._c)
        self._diverged = None
        self._configure()
        self._bodies.clear()
        self._records.reset()
        self._freed.clear()
        self._fresh = 0
        self._removed = 0
        self._steps = 0
        self._next_check = _CHECK_EVERY
        self._checked_at = 0.0

    def step(self, n: int) -> None:
        if self._diverged is not None:  # the state is NaN: no step makes it a simulation
            raise self._diverged
        lock = self._stepping
        if not lock.acquire(False):
            raise SimBusyError()
        try:
            if n == 1:
                p.stepSimulation(physicsClientId=self._c)
                self._steps += 1
            else:
                c = self._c
                done = 0
                try:
                    for _ in range(n):
                        p.stepSimulation(physicsClientId=c)
                        done += 1
                finally:  # Ctrl-C between two steps: the time counts the steps done
                    self._steps += done
            if self._steps >= self._next_check:
                self._probe()  # under the lock: no other thread steps between its calls
        finally:
            lock.release()

    def _probe(self) -> None:
        """Probe every body for a non-finite state (one engine call per body that can move:
        a free base's pose; a fixed base's movable leaf joints, see _Body). The hot path of
        the check (0.9 µs for one body, measured): a sum of the numbers, which is finite only
        if each one is; the exact test in _probe_failed."""
        self._next_check = self._steps + self._check_every
        c = self._c
        isfinite = math.isfinite
        for body, info in self._bodies.items():
            if info.free:
                pos, orn = _base_pose(body, c)
                if not isfinite(pos[0] + pos[1] + pos[2] + orn[0] + orn[1] + orn[2] + orn[3]):
                    self._probe_failed(body, info)
            elif len(info.probe_joints) == 1:
                r = _joint_state(body, info.probe_joints[0], c)
                if not isfinite(r[0] + r[1] + r[3]):
                    self._probe_failed(body, info)
            elif info.probe_joints:
                for r in _joint_states(body, info.probe_joints, c):
                    if not isfinite(r[0] + r[1] + r[3]):
                        self._probe_failed(body, info)
        self._checked_at = self._steps * self._dt

    def _probe_failed(self, body: int, info: _Body) -> None:
        """A probe's sum was not finite: diverged, unless every number is finite (a sum of
        large finite numbers may overflow)."""
        c = self._c
        if info.free:
            pos, orn = _base_pose(body, c)
            if not _all_finite(pos, orn):
                self._diverge(f"body {body} base pose")
            return
        for j, r in zip(info.probe_joints, _joint_states(body, info.probe_joints, c), strict=True):
            if not _all_finite(r[:2], r[3:]):
                self._diverge(f"body {body} joint {j} state")

    def _diverge(self, where: str) -> None:
        """The world holds a non-finite value (``where``): it is refused from now on, by every
        step and state read, with this error, until reset()."""
        if self._diverged is None:
            if self.time > self._checked_at:
                where += f" (finite at the last check, t={self._checked_at:.6f} s)"
            self._diverged = SimulationDivergedError(self.name, self.time, where)
        raise self._diverged

    def close(self) -> None:
        with self._idle():
            if self._c >= 0:
                try:
                    if self.gui:
                        with captured(self.name, "closing the GUI", _pybullet_gui_output):
                            p.disconnect(physicsClientId=self._c)
                    else:
                        p.disconnect(physicsClientId=self._c)
                except p.error:  # already disconnected (e.g. the GUI window was closed)
                    pass
                self._c = -1

    # ---------------------------------------------------------------- tables

    def _read_joint_info(self, body: int, joint: int) -> JointInfo:
        r = p.getJointInfo(body, joint, physicsClientId=self._c)
        return JointInfo(
            r[0],
            r[1].decode("utf-8"),
            JointType(r[2]),
            r[3],
            r[4],
            r[5],
            r[6],
            r[7],
            r[8],
            r[9],
            r[10],
            r[11],
            r[12].decode("utf-8"),
            r[13],
            r[14],
            r[15],
            r[16],
        )

    def joint_info(self, body: int, joint: int) -> JointInfo:
        return self._bodies[body].table[joint]

    def num_joints(self, body: int) -> int:
        return self._bodies[body].n

    @_exclusive
    def dynamics_info(self, body: int, link: int) -> DynamicsInfo:
        r = p.getDynamicsInfo(body, link, physicsClientId=self._c)
        return DynamicsInfo(r[0], r[1], r[2], r[3], r[4], r[5], r[6], r[7])

    # ---------------------------------------------------------------- state

    def link_state(self, body: int, link: int) -> LinkState:
        if self._diverged is not None:
            raise self._diverged
        lock = self._stepping
        if not lock.acquire(False):
            raise SimBusyError()
        try:
            c = self._c
            if link >= 0:
                r = p.getLinkState(
                    body, link, computeLinkVelocity=1, computeForwardKinematics=1, physicsClientId=c
                )
                p0, o0, p4, o5, v6, w7 = r[0], r[1], r[4], r[5], r[6], r[7]
                if not math.isfinite(  # explicit sums: 0.2 µs (sum() 0.4)
                    p0[0] + p0[1] + p0[2] + o0[0] + o0[1] + o0[2] + o0[3]
                    + p4[0] + p4[1] + p4[2] + o5[0] + o5[1] + o5[2] + o5[3]
                    + v6[0] + v6[1] + v6[2] + w7[0] + w7[1] + w7[2]
                ) and not _all_finite(p0, o0, p4, o5, v6, w7):  # fmt: skip
                    self._diverge(f"body {body} link {link} state")
                return LinkState(r[0], r[1], r[2], r[3], r[4], r[5], r[6], r[7])
            pos, orn = p.getBasePositionAndOrientation(body, physicsClientId=c)
            lin, ang = p.getBaseVelocity(body, physicsClientId=c)
        finally:
            lock.release()
        if not _finite_base(pos, orn, lin, ang) and not _all_finite(pos, orn, lin, ang):
            self._diverge(f"body {body} base state")
        lp, lo = self._bodies[body].base_inertial
        inv_pos, inv_orn = p.invertTransform(lp, lo)
        fpos, forn = p.multiplyTransforms(pos, orn, inv_pos, inv_orn)
        return LinkState(pos, orn, lp, lo, fpos, forn, lin, ang)

    def base_state(self, body: int) -> BaseState:
        if self._diverged is not None:
            raise self._diverged
        lock = self._stepping
        if not lock.acquire(False):
            raise SimBusyError()
        try:
            c = self._c
            pos, orn = p.getBasePositionAndOrientation(body, physicsClientId=c)
            lin, ang = p.getBaseVelocity(body, physicsClientId=c)
        finally:
            lock.release()
        if not _finite_base(pos, orn, lin, ang) and not _all_finite(pos, orn, lin, ang):
            self._diverge(f"body {body} base state")
        return BaseState(pos, orn, lin, ang)

    def joint_states(self, body: int, joints: np.ndarray) -> JointStates:
        if self._diverged is not None:
            raise self._diverged
        lock = self._stepping
        if not lock.acquire(False):
            raise SimBusyError()
        try:
            rows = p.getJointStates(body, joints.tolist(), physicsClientId=self._c)
        finally:
            lock.release()
        if not rows:
            return JointStates(np.zeros(0), np.zeros(0), np.zeros(0))
        pos, vel, _, torque = zip(*rows, strict=True)  # position, velocity, reaction, torque
        if not math.isfinite(sum(pos) + sum(vel) + sum(torque)) and not _all_finite(
            pos, vel, torque
        ):
            self._diverge(f"body {body} joint states")
        return JointStates(np.array(pos), np.array(vel), np.array(torque))

    @_exclusive
    def reset_joint_state(
        self, body: int, joints: np.ndarray, positions: list[float], velocities: list[float]
    ) -> None:
        c = self._c
        for j, q, v in zip(joints.tolist(), positions, velocities, strict=True):
            p.resetJointState(body, j, q, v, physicsClientId=c)
        self._next_check = self._steps + 1  # a teleport: probed after the next step

    @_exclusive
    def reset_base_state(
        self,
        body: int,
        position: Vec3 | None,
        orientation: Quat | None,
        linear_velocity: Vec3 | None,
        angular_velocity: Vec3 | None,
    ) -> None:
        if self._diverged is not None:  # it reads the state it keeps
            raise self._diverged
        self._next_check = self._steps + 1  # a teleport: probed after the next step
        c = self._c
        if not self._bodies[body].free:
            self.refuse_fixed_base_velocity(body, linear_velocity, angular_velocity)
        cur_lin, cur_ang = p.getBaseVelocity(body, physicsClientId=c)
        if position is not None or orientation is not None:
            cur_pos, cur_orn = p.getBasePositionAndOrientation(body, physicsClientId=c)
            p.resetBasePositionAndOrientation(
                body,
                cur_pos if position is None else position,
                cur_orn if orientation is None else orientation,
                physicsClientId=c,
            )
            # PyBullet's pose reset also zeroes the base velocity; the contract keeps it
            if linear_velocity is None:
                linear_velocity = cur_lin
            if angular_velocity is None:
                angular_velocity = cur_ang
        if linear_velocity is not None or angular_velocity is not None:
            p.resetBaseVelocity(
                body,
                cur_lin if linear_velocity is None else linear_velocity,
                cur_ang if angular_velocity is None else angular_velocity,
                physicsClientId=c,
            )

    # ---------------------------------------------------------------- control

    def set_joint_velocity(
        self, body: int, joints: np.ndarray, target: list[float], max_force: list[float]
    ) -> None:
        lock = self._stepping
        if not lock.acquire(False):
            raise SimBusyError()
        try:
            last = self._last_velocity
            # joints: Sim's cached read-only index array: the same object, the same joints
            if (
                last is not None
                and last[0] is joints
                and last[1] == body
                and last[2] == target
                and last[3] == max_force
            ):
                return  # the command in force already
            p.setJointMotorControlArray(
                body,
                joints.tolist(),
                p.VELOCITY_CONTROL,
                targetVelocities=target,
                forces=self._within_effort(body, joints, max_force),
                physicsClientId=self._c,
            )
            self._last_velocity = (joints, body, target, max_force)
            self._records.motor(body, joints, 0, target, max_force, None, None)
        finally:
            lock.release()

    @_exclusive
    def set_joint_position(
        self,
        body: int,
        joints: np.ndarray,
        target: list[float],
        max_force: list[float],
        kp: list[float],
        kd: list[float],
    ) -> None:
        self._last_velocity = None
        p.setJointMotorControlArray(
            body,
            joints.tolist(),
            p.POSITION_CONTROL,
            targetPositions=target,
            forces=self._within_effort(body, joints, max_force),
            positionGains=kp,
            velocityGains=kd,
            physicsClientId=self._c,
        )
        self._records.motor(body, joints, 2, target, max_force, kp, kd)

    @_exclusive
    def set_joint_torque(self, body: int, joints: np.ndarray, torque: list[float]) -> None:
        self._last_velocity = None
        effort = self._bodies[body].effort
        if effort is not None:  # each command within the effort, as on MuJoCo
            torque = [
                max(-effort[i], min(t, effort[i]))
                for t, i in zip(torque, joints.tolist(), strict=True)
            ]
        p.setJointMotorControlArray(
            body, joints.tolist(), p.TORQUE_CONTROL, forces=torque, physicsClientId=self._c
        )
        self._records.torque(self._steps, body, joints, torque)

    # ---------------------------------------------------------------- spherical joints

    def joint_states_multi_dof(self, body: int, joints: np.ndarray) -> list[JointStateMultiDof]:
        if self._diverged is not None:
            raise self._diverged
        lock = self._stepping
        if not lock.acquire(False):
            raise SimBusyError()
        try:
            rows = p.getJointStatesMultiDof(body, joints.tolist(), physicsClientId=self._c)
        finally:
            lock.release()
        out = [JointStateMultiDof(tuple(r[0]), tuple(r[1]), tuple(r[3])) for r in rows]
        if not _all_finite(*(x for r in out for x in r)):
            self._diverge(f"body {body} joint states")
        return out

    @_exclusive
    def reset_joint_state_multi_dof(
        self,
        body: int,
        joints: np.ndarray,
        positions: list[list[float]],
        velocities: list[list[float]],
    ) -> None:
        c = self._c
        for j, q, v in zip(joints.tolist(), positions, velocities, strict=True):
            p.resetJointStateMultiDof(body, j, q, v, physicsClientId=c)
        self._next_check = self._steps + 1  # a teleport: probed after the next step

    @_exclusive
    def set_joint_motor_multi_dof(
        self,
        body: int,
        joints: np.ndarray,
        mode: MotorMode,
        targets: list[list[float]],
        max_force: list[list[float]],
        kp: list[list[float]],
        kd: list[list[float]],
    ) -> None:
        self._last_velocity = None
        self._spherical_motor(body, joints.tolist(), targets, max_force, kp, kd)
        for j, q, f, a, b in zip(joints.tolist(), targets, max_force, kp, kd, strict=True):
            self._records.spherical_motor(body, j, (int(mode), q, f, a, b))

    def _spherical_motor(
        self,
        body: int,
        joints: list[int],
        targets: list[list[float]],
        max_force: list[list[float]],
        kp: list[list[float]],
        kd: list[list[float]],
    ) -> None:
        """setJointMotorControlMultiDof's POSITION_CONTROL with every gain and force a list of
        3 (PyBullet takes them per axis only then: a single kp makes force[0] every axis's);
        ``damping`` is the velocity term the motor reads (velocityGain is read by nothing)."""
        info = self._bodies.get(body)  # None while loading (the profile's brake)
        effort = info.effort if info is not None else None
        for j, q, f, a, b in zip(joints, targets, max_force, kp, kd, strict=True):
            if effort is not None:
                f = [min(x, effort[j]) for x in f]
            p.setJointMotorControlMultiDof(
                body,
                j,
                p.POSITION_CONTROL,
                targetPosition=q,
                positionGain=a,
                velocityGain=[1.0, 1.0, 1.0],
                force=f,
                damping=b,
                physicsClientId=self._c,
            )

    @_exclusive
    def set_joint_torque_multi_dof(
        self, body: int, joints: np.ndarray, torques: list[list[float]]
    ) -> None:
        self._last_velocity = None
        effort = self._bodies[body].effort
        for j, t in zip(joints.tolist(), torques, strict=True):
            if effort is not None:  # each command within the effort, as on MuJoCo
                t = [max(-effort[j], min(x, effort[j])) for x in t]
            p.setJointMotorControlMultiDof(
                body, j, p.TORQUE_CONTROL, force=t, physicsClientId=self._c
            )
            self._records.spherical_torque(self._steps, body, j, t)

    def _spherical_default(self, body: int, joint: int) -> tuple[Any, ...]:
        """The motor PyBullet gives a spherical joint at load, under this profile: (mode,
        target, max_force, kp, kd), the force as asked (before an effort limit)."""
        if self.profile.joint_brake == "pybullet":
            force = SPHERICAL_BRAKE_IMPULSE / self._dt
            return (MotorMode.POSITION, (0.0, 0.0, 0.0, 1.0), [force] * 3, [0.2] * 3, [1.0] * 3)
        friction = self._bodies[body].table[joint].friction
        return (MotorMode.VELOCITY, (0.0, 0.0, 0.0, 1.0), [friction] * 3, [0.0] * 3, [1.0] * 3)

    @_exclusive
    def spherical_states(self, body: int) -> list[SphericalJointState]:
        info = self._bodies[body]
        balls = [i for i in info.movable if info.table[i].type == JointType.SPHERICAL]
        rows = p.getJointStatesMultiDof(body, balls, physicsClientId=self._c)
        records = self._records.spherical.get(body, {})
        out = []
        for j, r in zip(balls, rows, strict=True):
            mode, target, force, kp, kd = records.get(j) or self._spherical_default(body, j)
            out.append(
                SphericalJointState(
                    j,
                    tuple(r[0]),
                    tuple(r[1]),
                    int(mode),
                    tuple(target),
                    tuple(force),
                    tuple(kp),
                    tuple(kd),
                    tuple(self._records.spherical_pending(self._steps, body, j)),  # type: ignore[arg-type]
                )
            )
        return out

    @_exclusive
    def set_spherical_states(
        self, body: int, states: list[SphericalJointState], positions: bool
    ) -> None:
        """Positions (unless a bit-exact restore put them back), the motors, and the pending
        torques: those in force cancelled exactly (x + (-x) is 0), the new ones given."""
        self._last_velocity = None
        c = self._c
        records = self._records
        for e in states:
            if positions:
                p.resetJointStateMultiDof(body, e.joint, e.position, e.velocity, physicsClientId=c)
            motor = (e.motor_mode, e.motor_target, e.motor_max_force, e.motor_kp, e.motor_kd)
            self._spherical_motor(
                body,
                [e.joint],
                [list(e.motor_target)],
                [list(e.motor_max_force)],
                [list(e.motor_kp)],
                [list(e.motor_kd)],
            )
            records.spherical_motor(body, e.joint, motor)
            now = records.spherical_pending(self._steps, body, e.joint)
            for torque in ([-x for x in now], list(e.pending_torque)):
                if any(torque):
                    p.setJointMotorControlMultiDof(
                        body, e.joint, p.TORQUE_CONTROL, force=torque, physicsClientId=c
                    )
            records.spherical_set_pending(self._steps, body, e.joint, list(e.pending_torque))
        if positions:
            self._next_check = self._steps + 1  # a teleport: probed after the next step

    # ---------------------------------------------------------------- description

    def manifest(self) -> dict[str, Any]:
        try:
            engine_version = version("pybullet")
        except PackageNotFoundError:  # pragma: no cover
            engine_version = f"api {p.getAPIVersion()}"
        return {
            "backend": self.name,
            "engine": "PyBullet (Bullet Physics, Featherstone multibody, sequential impulse)",
            "engine_version": engine_version,
            "native_defaults": self.NATIVE_DEFAULTS,
            "departures": {},
        }

    # ---------------------------------------------------------------- contacts and state

    @_exclusive
    def contact_points(self) -> list[ContactPoint]:
        if self._diverged is not None:
            raise self._diverged
        # unfiltered: PyBullet keeps the friction fields in its own order of A and B when it
        # swaps them to answer a filtered query (Sim.contact_points orients them itself)
        rows = p.getContactPoints(physicsClientId=self._c)
        for r in rows:  # positions, normal, distance, forces and friction directions
            values = (*r[5], *r[6], *r[7], r[8], r[9], r[10], *r[11], r[12], *r[13])
            if not math.isfinite(sum(values)) and not _all_finite(values):
                self._diverge(f"a contact point of bodies {r[1]} and {r[2]}")
        return [contact_point(r) for r in rows]

    @_exclusive
    def joint_commands(self, body: int) -> JointCommands:
        return self._records.commands(
            body, self._bodies[body].table, self.profile.joint_brake, self._dt, self._steps
        )

    @_exclusive
    def set_joint_commands(self, body: int, commands: JointCommands) -> None:
        """Re-issue the motors that differ from those in force (a restore into the same world
        sends none), then cancel the pending torques and give the new ones."""
        c = self._c
        now = self.joint_commands(body)
        info = self._bodies[body]
        movable = np.asarray(  # spherical joints: set_spherical_states
            [i for i in info.movable if info.table[i].type != JointType.SPHERICAL], dtype=np.intp
        )
        differ = np.zeros(len(now.mode), dtype=bool)
        for field in range(5):
            differ |= now[field] != commands[field]
        for mode in (MotorMode.VELOCITY, MotorMode.POSITION):
            joints = movable[differ[movable] & (commands.mode[movable] == mode)]
            if not len(joints):
                continue
            force = self._within_effort(body, joints, commands.max_force[joints].tolist())
            target = commands.target[joints].tolist()
            if mode == MotorMode.VELOCITY:
                p.setJointMotorControlArray(
                    body,
                    joints.tolist(),
                    p.VELOCITY_CONTROL,
                    targetVelocities=target,
                    forces=force,
                    physicsClientId=c,
                )
            else:
                p.setJointMotorControlArray(
                    body,
                    joints.tolist(),
                    p.POSITION_CONTROL,
                    targetPositions=target,
                    forces=force,
                    positionGains=commands.kp[joints].tolist(),
                    velocityGains=commands.kd[joints].tolist(),
                    physicsClientId=c,
                )
        self._last_velocity = None
        if (now.pending_torque != commands.pending_torque).any():
            for torque in (-now.pending_torque[movable], commands.pending_torque[movable]):
                if torque.any():  # x + (-x) is exactly 0: the engine's sum starts afresh
                    p.setJointMotorControlArray(
                        body,
                        movable.tolist(),
                        p.TORQUE_CONTROL,
                        forces=torque.tolist(),
                        physicsClientId=c,
                    )
        self._records.set(body, commands, self._steps, movable)

    def _world_key(self) -> tuple[Any, ...]:
        return tuple(self._bodies.items())

    def _free_dead_states(self) -> None:
        records = self._records
        while records.dead:
            generation, state_id = records.dead.pop()
            if generation == records.generation:
                p.removeState(state_id, physicsClientId=self._c)

    def snapshot(self) -> Any:
        if self._diverged is not None:
            raise self._diverged
        with self._idle():
            self._free_dead_states()
            state_id = p.saveState(physicsClientId=self._c)
            return Saved(self._c, self._records, self._world_key(), state_id, self._steps)

    def restore(self, native: Any) -> bool:
        if self._diverged is not None:
            raise self._diverged
        with self._idle():
            self._free_dead_states()
            if not (
                isinstance(native, Saved) and native.fits(self._c, self._records, self._world_key())
            ):
                return False  # PyBullet's contact caches cannot be dropped: they stay
            with captured(self.name, "restoring a state"):
                p.restoreState(native.state_id, physicsClientId=self._c)
            self.set_time(native.steps * self._dt)
            return True

    @_exclusive
    def set_time(self, time: float) -> None:
        steps = round(time / self._dt)
        if steps != self._steps:
            self._records.restamp(self._steps, steps)
            self._steps = steps
            self._next_check = steps + 1  # a restored state: probed after the next step
