"""A robot's file handed to PyBullet's own loader, and the profile applied to what it built (a
part of :class:`~simbridge.backends.pybullet.backend.PyBulletBackend`): PyBullet builds its
model itself from the URDF, so this is the counterpart of the other backends' builders.

A file is given to ``loadURDF`` by the name the caller used, or, where PyBullet's cache by name
would hand back another text, through a uniquely named temporary file with its mesh paths made
absolute; the "urdf" profile's departures from PyBullet's defaults are then set with
``changeDynamics`` and the default motors (``joint_brake``, ``enforce_effort_limit``).
"""

from __future__ import annotations

import os
import tempfile
import xml.etree.ElementTree as ET
from typing import TYPE_CHECKING, ClassVar

from simbridge.engine_output import captured
from simbridge.exceptions import UrdfStructureError
from simbridge.model.urdf import UrdfModel, resolve_mesh
from simbridge.profiles import Profile
from simbridge.types import JointType, Quat, Vec3

from .commands import SPHERICAL_BRAKE_IMPULSE, SPHERICAL_BRAKE_KP
from .common import _Body, _nesting
from .output import (
    _pybullet_merge_output,
    p,  # pybullet, imported with its banner captured
)

__all__ = ["ModelLoading"]

_PYBULLET_DEFAULT_LINK_DAMPING = 0.04
_PYBULLET_DEFAULT_MAX_JOINT_VELOCITY = 100.0
_NO_CLAMP = 1e30  # "no speed clamp": PyBullet takes a number; this one is never reached
_PYBULLET_DEFAULT_FRICTION = 0.5

# PyBullet's XML reader (tinyxml2) refuses a file whose elements nest deeper than this, <robot>
# counting 1 (measured: 98 loads, 99 is XML_ELEMENT_DEPTH_EXCEEDED)
_MAX_XML_DEPTH = 98


class ModelLoading:
    """Loading a file into PyBullet and applying the profile (a part of PyBulletBackend)."""

    if TYPE_CHECKING:  # provided by PyBulletBackend and simbridge.backend.Backend
        name: ClassVar[str]
        profile: Profile
        _c: int
        _dt: float

        def _spherical_motor(
            self,
            body: int,
            joints: list[int],
            targets: list[list[float]],
            max_force: list[list[float]],
            kp: list[list[float]],
            kd: list[list[float]],
        ) -> None: ...

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
        # the files the reader found (in this same call: the working directory is the same)
        found = {
            g.mesh_uri: g.mesh_path
            for link in model.links
            for g in (*link.visuals, *link.collisions)
            if g.mesh_path is not None
        }
        for mesh in root.iter("mesh"):
            uri = mesh.get("filename")
            if uri:
                mesh_path = found.get(uri) or resolve_mesh(uri, model.source.mesh_from)[0]
                mesh.set("filename", str(mesh_path))
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
