"""PyBullet's own ``loadMJCF`` and ``loadSDF`` for :meth:`PyBulletBackend.load_scene`.

PyBullet stays the reference: the file is handed to its importer as a user would, and the
bodies it creates are checked against simbridge's reading of the same file
(:mod:`simbridge.model.scene`): the body count, and per body the joint count, every joint's type and
every link's name. Joint names PyBullet makes up itself (``jointfix_<n>_<k>``, ``joint<n>_...``)
carry a counter that lives as long as the process; the table reports the model's names, which
are the ones a first load in a fresh process gets.
"""

from __future__ import annotations

import os
import tempfile
import xml.etree.ElementTree as ET
from collections.abc import Sequence
from typing import ClassVar, Protocol

from simbridge.engine_output import captured
from simbridge.exceptions import UrdfStructureError
from simbridge.model.scene import SceneBody, find_mesh
from simbridge.types import JointInfo

from .output import p  # pybullet, imported with its banner captured


class PyBulletBackend(Protocol):
    """What this module uses of :class:`~simbridge.backends.pybullet.backend.PyBulletBackend`
    (named here, not imported: that module imports this one)."""

    name: ClassVar[str]
    _c: int  # the client id
    _file_texts: dict[str, str]  # files PyBullet has read, by path: the text it read


__all__ = ["Pending", "load_file", "named_table"]


class Pending:
    """One file's bodies while :meth:`PyBulletBackend.load_scene` loads them one by one.

    They go through ``load``: the first body's load hands the file to PyBullet, which makes every
    body at once; each load then claims its own id. Ids nobody claimed (a later body refused) are
    removed.

    Args:
        bodies: The file's bodies, in PyBullet's order.
        flags: ``p.loadMJCF``'s flags (the self-collision mode).
    """

    def __init__(self, bodies: Sequence[SceneBody], flags: int) -> None:
        self.bodies = list(bodies)
        self.flags = flags
        self.ids: list[int] | None = None
        self.claimed: set[int] = set()

    def body(self, backend: PyBulletBackend, model: SceneBody) -> int:
        """The id PyBullet gave one body of the file, claimed; the first call loads the file.

        Args:
            backend: The backend loading it.
            model: The body, one of the file's.

        Returns:
            Its body id.
        """
        if self.ids is None:
            self.ids = load_file(backend, self.bodies, self.flags)
        body = self.ids[model.body_index]
        self.claimed.add(body)
        return body

    def discard_unclaimed(self, backend: PyBulletBackend) -> None:
        """Remove the bodies of the file that no load claimed.

        Args:
            backend: The backend that loaded them.
        """
        for body in self.ids or []:
            if body not in self.claimed:
                p.removeBody(body, physicsClientId=backend._c)


def _rewritten(bodies: Sequence[SceneBody]) -> bytes:
    """The file's text with every mesh made an absolute path (for a copy PyBullet reads from a
    temporary file elsewhere)."""
    src = bodies[0].source
    root = ET.fromstring(src.text.encode("utf-8", errors="surrogateescape"))
    if bodies[0].file_format == "mjcf":
        mesh_dir = ""
        for compiler in root.iter("compiler"):
            mesh_dir = compiler.attrib.pop("meshdir", mesh_dir)
        for mesh in root.iter("mesh"):
            if mesh.get("file"):
                path = find_mesh(mesh_dir + mesh.get("file", ""), src.mesh_from)[0]
                mesh.set("file", str(path))
    else:
        for uri in root.iter("uri"):
            if uri.text and uri.text.strip():
                uri.text = str(find_mesh(uri.text.strip(), src.mesh_from)[0])
    return ET.tostring(root, encoding="utf-8")


def load_file(backend: PyBulletBackend, bodies: Sequence[SceneBody], flags: int) -> list[int]:
    """``p.loadMJCF(path, flags)`` or ``p.loadSDF(path)`` on the bodies' file.

    Through a temporary copy for text, or for a file whose text changed since PyBullet first read
    it: PyBullet caches files by name.

    Args:
        backend: The backend to load into.
        bodies: The file's bodies as simbridge read them, in PyBullet's order.
        flags: ``p.loadMJCF``'s flags.

    Returns:
        The ids PyBullet returns, one per body.

    Raises:
        UrdfStructureError: PyBullet refused the file, or read other bodies, joints or links than
            simbridge did (the bodies it made are removed).
    """
    first = bodies[0]
    src = first.source
    kind = first.file_format
    c = backend._c
    temp = None
    path = str(src.path) if src.path is not None else None
    if path is None or backend._file_texts.setdefault(path, src.text) != src.text:
        suffix = ".xml" if kind == "mjcf" else ".sdf"
        fd, temp = tempfile.mkstemp(prefix="simbridge_", suffix=suffix)
        with os.fdopen(fd, "wb") as f:
            f.write(_rewritten(bodies))
        path = temp
    try:
        with captured(backend.name, f"loading {src.display_name}"):
            if kind == "mjcf":
                ids = p.loadMJCF(path, flags=flags, physicsClientId=c)
            else:
                ids = p.loadSDF(path, physicsClientId=c)
    except p.error as exc:
        raise UrdfStructureError(
            src.display_name, f"<{'mujoco' if kind == 'mjcf' else 'sdf'}>", f"PyBullet: {exc}"
        ) from None
    finally:
        if temp is not None:
            os.unlink(temp)
    ids = [int(b) for b in ids]
    why = None
    if len(ids) != len(bodies):
        why = f"PyBullet made {len(ids)} bodies, simbridge's reading {len(bodies)}"
    else:
        for body, model in zip(ids, bodies, strict=True):
            why = _structure_difference(backend, body, model)
            if why:
                break
    if why:
        for body in ids:
            p.removeBody(body, physicsClientId=c)
        raise UrdfStructureError(src.display_name, "<file>", f"read differently: {why}")
    return ids


def _structure_difference(backend: PyBulletBackend, body: int, model: SceneBody) -> str | None:
    c = backend._c
    n = p.getNumJoints(body, physicsClientId=c)
    if n != len(model.joints):
        return f"body {model.body_index}: {n} joints, simbridge's reading {len(model.joints)}"
    base = p.getBodyInfo(body, physicsClientId=c)[0].decode("utf-8", errors="replace")
    if base != model.base.name:
        return f"body {model.body_index}: base {base!r}, simbridge's reading {model.base.name!r}"
    for i, joint in enumerate(model.joints):
        info = p.getJointInfo(body, i, physicsClientId=c)
        link = info[12].decode("utf-8", errors="replace")
        if link != joint.child:
            return f"body {model.body_index} link {i}: {link!r}, simbridge's {joint.child!r}"
    return None


def named_table(table: list[JointInfo], model: SceneBody) -> list[JointInfo]:
    """PyBullet's rows with the model's joint names (see the module docstring).

    Args:
        table: PyBullet's joint table of the body.
        model: The body as simbridge read it.

    Returns:
        The table, each row named as the model names its joint.
    """
    return [row._replace(name=j.name) for row, j in zip(table, model.joints, strict=True)]
