"""Where a URDF comes from: a file, a name on the search path, or URDF text; and where its
meshes are.

A source is read as text (UTF-8) once; what PyBullet makes of that text (its line reader, its
lenient XML parser) is :mod:`simbridge.urdf_xml`'s part.
"""

from __future__ import annotations

import importlib.util
import os
import stat
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

from .exceptions import UrdfNotFoundError, UrdfParseError

__all__ = [
    "UrdfSource",
    "resolve_source",
    "resolve_mesh",
    "mesh_folder",
    "search_path",
    "not_a_regular_file",
]


@dataclass(frozen=True)
class UrdfSource:
    """Where a URDF came from: its text, its file (None for text) and the folder that relative
    mesh paths resolve against. A file's bytes that are not UTF-8 are in ``text`` as
    surrogate escapes (``errors="surrogateescape"``) until the parser reads them."""

    text: str
    path: Path | None
    base_dir: Path
    display_name: str
    given: str | None = None
    """The file's path as raw PyBullet would be given it (the caller's path, relative where
    it was, symbolic links kept; a search folder's file), None for text: meshes are looked up
    from its folders, as PyBullet looks them up."""

    @property
    def mesh_from(self) -> str | Path:
        """What :func:`resolve_mesh` takes for this file's meshes."""
        return self.base_dir if self.given is None else mesh_folder(self.given)


def _robots_dir() -> Path:
    spec = importlib.util.find_spec("simbridge.robots")
    if spec is None or not spec.submodule_search_locations:  # pragma: no cover - broken install
        raise RuntimeError("simbridge.robots package data is missing from this installation")
    return Path(next(iter(spec.submodule_search_locations)))


def search_path() -> list[Path]:
    """Folders searched for a URDF given by name: the package's robots, then pybullet_data.

    ``SIMBRIDGE_URDF_PATH`` (os.pathsep-separated) is searched first when set.
    """
    paths = [Path(p) for p in os.environ.get("SIMBRIDGE_URDF_PATH", "").split(os.pathsep) if p]
    paths.append(_robots_dir())
    spec = importlib.util.find_spec("pybullet_data")
    if spec is not None and spec.submodule_search_locations:
        paths.append(Path(next(iter(spec.submodule_search_locations))))
    return paths


def _is_file(path: Path) -> bool:
    """Path.is_file, False for names no file system takes (too long, a NUL byte)."""
    try:
        return path.is_file()
    except (OSError, ValueError):
        return False


def resolve_source(source: str | os.PathLike[str]) -> UrdfSource:
    """Turn a path, a name on the search path, or URDF XML text into a :class:`UrdfSource`."""
    if isinstance(source, str) and source.lstrip("\ufeff \t\r\n").startswith("<"):
        return UrdfSource(source.lstrip("\ufeff"), None, Path.cwd(), "<urdf text>")
    if not isinstance(source, (str, os.PathLike)):
        raise UrdfNotFoundError(repr(source), ["a path, a name or URDF text was expected"])
    shown = (
        str(source)
        if len(str(source)) <= 120
        else f"{str(source)[:100]}... ({len(str(source))} characters)"
    )
    try:
        candidate = Path(source).expanduser()
    except (RuntimeError, ValueError):  # "~nosuchuser/..."
        candidate = Path(source)
    tried: list[str] = []
    if _is_file(candidate):
        found: Path | None = candidate
    else:
        tried.append(shown if len(str(candidate)) > 120 else str(candidate.absolute()))
        found = None
        if not candidate.is_absolute() and len(str(candidate)) <= 255 and "\0" not in str(source):
            for folder in search_path():
                for name in (candidate, Path(f"{candidate}.urdf")):
                    path = folder / name
                    if _is_file(path):
                        found = path
                        break
                    tried.append(str(path))
                if found:
                    break
    if found is None:
        raise UrdfNotFoundError(shown, tried)
    # the path as PyBullet would be given it: the caller's text, or the search folder's file
    as_given = os.path.expanduser(os.fspath(source)) if found is candidate else str(found)
    found = found.resolve()
    try:
        data = found.read_bytes()
    except OSError as exc:
        raise UrdfParseError(str(found), f"cannot read the file: {exc}") from exc
    # bytes that are not UTF-8 are kept (as surrogates) for the reader to judge: PyBullet's
    # parser takes them (a Latin-1 comment, say)
    text = data.decode("utf-8", errors="surrogateescape")
    return UrdfSource(text, found, found.parent, str(found), as_given)


def _mesh_candidates(uri: str, folder: str) -> list[str]:
    """Where :func:`resolve_mesh` looks, in order: bullet3 ``UrdfFindMeshFile.h``'s
    attempts, each a prefix joined to the name as strings."""
    name = uri
    if name.startswith("file://"):
        name = name[len("file://") :]
    if name.startswith("package://"):
        name = name[len("package://") :]
    elif name.startswith("model://"):
        name = name[len("model://") :]
    # every leading part of the URDF's path that ends at a separator, longest first
    leading = [folder[:i] + "/" for i, ch in enumerate(folder) if ch in "/\\"]
    return [prefix + name for prefix in ("", *reversed(leading), "./", "../", "../../")]


def mesh_folder(path: str | os.PathLike[str]) -> str:
    """The folder part of a file's path as written (up to and with its last separator; ""
    for a bare name): what :func:`resolve_mesh` takes for a file read from ``path``."""
    text = os.fspath(path)
    cut = max(text.rfind("/"), text.rfind("\\"))
    return text[: cut + 1]


def resolve_mesh(uri: str, folder: str | Path) -> tuple[Path, list[str]]:
    """Resolve a mesh filename where PyBullet does (bullet3 ``UrdfFindMeshFile.h``, measured
    on PyBullet 3.2.7 with strace).

    ``file://`` is dropped, then ``package://`` or ``model://`` (the package's name stays:
    ``package://pkg/m.stl`` is looked for as ``pkg/m.stl``). The name is tried as written
    (from the working directory), then after every leading part of the URDF's path up to a
    separator, longest first (its own folder, then each folder above it that the path names:
    all of them for an absolute path, only those written for a relative one), then after
    ``./``, ``../`` and ``../../`` (from the working directory). Each attempt is a prefix and
    the name joined as strings, so ``/meshes/m.stl`` is also found as ``meshes/m.stl`` beside
    the file. PyBullet's additional search path is not searched (it finds the URDF, whose path
    then gives the folders).

    ``folder``: the URDF's folder as PyBullet is given it (:func:`mesh_folder` of its path, a
    relative one included), or a folder as a Path (treated as absolute). Returns the first
    regular file found (its real path) and the attempts made so far, each made absolute from
    the working directory; where none is found, the first attempt and every attempt."""
    base = folder if isinstance(folder, str) else os.path.join(os.path.abspath(folder), "")
    cwd = os.getcwd()
    tried: list[str] = []
    for candidate in _mesh_candidates(uri, base):
        tried.append(candidate if os.path.isabs(candidate) else os.path.join(cwd, candidate))
        if os.path.isfile(candidate):  # False for a name no file system takes
            return Path(os.path.realpath(candidate)), tried
    return Path(tried[0]), tried


_KINDS = (
    (stat.S_ISDIR, "a directory"),
    (stat.S_ISFIFO, "a FIFO"),
    (stat.S_ISCHR, "a character device"),
    (stat.S_ISBLK, "a block device"),
    (stat.S_ISSOCK, "a socket"),
)


def not_a_regular_file(tried: Sequence[str | Path]) -> str | None:
    """Why a mesh path that exists is not read: "PATH is a directory (not a regular file)"
    for the first of ``tried`` (as :func:`resolve_mesh` lists them) that exists but is not a
    regular file (symbolic links followed); None when none exists. Raw PyBullet 3.2.7 waits
    forever on a FIFO, ends the process on a directory (std::bad_alloc) and reads a device
    such as /dev/zero as a link without a shape (measured): such a path is refused."""
    for path in tried:
        try:
            mode = os.stat(path).st_mode
        except (OSError, ValueError):
            continue
        if stat.S_ISREG(mode):
            return None
        kind = next((what for test, what in _KINDS if test(mode)), "no regular file")
        return f"{str(path)!r} is {kind}, not a regular file"
    return None
