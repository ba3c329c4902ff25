"""Where a URDF comes from: a file, a name on the search path, or URDF text; and where its
meshes are.

A source is read as text (UTF-8) once; what PyBullet makes of that text (its line reader, its
lenient XML parser) is :mod:`simbridge.model.urdf_xml`'s part.
"""

from __future__ import annotations

import importlib.util
import os
import stat
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

from simbridge.exceptions import UrdfNotFoundError, UrdfParseError

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

    Returns:
        The folders, in the order searched.

    Raises:
        RuntimeError: The package's robots folder is missing (a broken installation).
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


NAME_MAX = 255
"""Characters: the longest name of one file or folder that file systems take (Linux's
``NAME_MAX``); a longer part is no name of a file."""
SHOWN_LENGTH = 240
"""Characters: a path up to this long is shown whole in a message."""
_LISTED = 10000
"""Entries: the most of one folder read for a "did you mean" (a larger folder gives none)."""


def shown_path(text: str) -> str:
    """A path (or what was given as one) as a message shows it.

    Args:
        text: The path as given.

    Returns:
        ``text`` whole where it is at most :data:`SHOWN_LENGTH` characters; longer, the middle
        of its folders that exist cut (``/a/b/.../y/z/wrong/name.urdf``), never the first part
        that does not exist nor any after it; for a text with a part no file system takes as a
        name (over :data:`NAME_MAX` characters), its first 100 characters and its length.
    """
    parts = text.split("/")
    if any(len(p) > NAME_MAX for p in parts):
        return f"{text[:100]}... ({len(text)} characters)"
    if len(text) <= SHOWN_LENGTH:
        return text
    exists = 0  # the leading parts that name folders which exist
    for k in range(1, len(parts)):
        folder = "/".join(parts[:k]) or "/"
        try:
            if not os.path.isdir(folder):
                break
        except (OSError, ValueError):
            break
        exists = k
    over = len(text) - SHOWN_LENGTH + len("/...")
    head = 2 if parts[0] == "" else 1  # "/work" or "work" stays
    # the folders cut: those after the head, never the last one that exists nor what follows
    cut, dropped = 0, 0
    while head + dropped < exists - 1 and cut < over:
        cut += len(parts[head + dropped]) + 1
        dropped += 1
    if dropped < 2:  # "..." for one folder saves nothing worth the loss
        return text
    return "/".join([*parts[:head], "...", *parts[head + dropped :]])


def _entries(folder: Path) -> list[str]:
    """The names in ``folder`` (none where it cannot be read or holds more than
    :data:`_LISTED`)."""
    try:
        with os.scandir(folder) as it:
            names = []
            for entry in it:
                names.append(entry.name)
                if len(names) > _LISTED:
                    return []
            return names
    except (OSError, ValueError):
        return []


def _likeness(typed: str, name: str) -> float:
    """How alike two names are, 0 to 1: case aside, the stems compared where both have the same
    extension (``fooo.urdf`` is not like ``door.urdf``), letters swapped counting as alike."""
    a, b = typed.lower(), name.lower()
    ext_a, ext_b = os.path.splitext(a)[1], os.path.splitext(b)[1]
    if ext_a and ext_a == ext_b:
        a, b = a[: -len(ext_a)], b[: -len(ext_b)]
    if sorted(a) == sorted(b):
        return 1.0 if a == b else 0.9
    import difflib

    return difflib.SequenceMatcher(None, a, b).ratio()


def _closest(name: str, names: list[str], suffixes: Sequence[str]) -> str | None:
    """The name of ``names`` most like ``name`` (or ``name`` with one of ``suffixes``), None
    where none is alike enough."""
    best, score = None, 0.7  # "r2d3" and "r2d2" are 0.75 alike
    for typed in (name, *(name + s for s in suffixes if s and not name.endswith(s))):
        for other in names:
            alike = _likeness(typed, other)
            if alike > score:
                best, score = other, alike
    return best


def near_file(text: str, folders: Sequence[Path], suffixes: Sequence[str] = ("",)) -> str | None:
    """The path ``text`` with the parts that are not there replaced by the nearest names beside
    them (``robots/pandaa.urdf`` -> ``robots/panda.urdf``), where that makes a file's path.

    Args:
        text: The path given.
        folders: Where a relative path starts, tried in turn (an absolute one starts at ``/``).
        suffixes: What the search also adds to the name (``.urdf``).

    Returns:
        The near path, or None where no such file is near.
    """
    path = Path(text)
    parts = list(path.parts)
    if not parts:
        return None
    starts = [Path(parts.pop(0))] if path.is_absolute() else list(folders)
    for base in starts:
        here, new, changed = base, [], False
        for k, part in enumerate(parts):
            last = k == len(parts) - 1
            try:
                there = (here / part).is_file() if last else (here / part).is_dir()
            except (OSError, ValueError):
                there = False
            if not there:
                near = _closest(part, _entries(here), suffixes if last else ())
                if near is None:
                    break
                part, changed = near, True
            here = here / part
            new.append(part)
        else:
            if changed and _is_file(here):
                return str(Path(*path.parts[:1], *new)) if path.is_absolute() else str(Path(*new))
    return None


def not_found(
    source: str,
    tried: Sequence[str],
    kind: str,
    folders: Sequence[Path] = (),
    suffixes: Sequence[str] = ("",),
) -> UrdfNotFoundError:
    """The error for ``source`` found nowhere.

    Args:
        source: What was asked for (shown as :func:`shown_path` shows a path).
        tried: Every place tried, in order (each listed once).
        kind: The file's kind in the message (``"URDF"``).
        folders: Where a relative path's "did you mean" starts (:func:`near_file`).
        suffixes: What the search also added to the name.

    Returns:
        The error, with "did you mean" a file whose path is near, to raise.
    """
    near = None
    if "\0" not in source and all(len(p) <= NAME_MAX for p in source.split("/")):
        near = near_file(source, folders, suffixes)
    hint = f" (did you mean {shown_path(near)!r}?)" if near else ""
    searched = [shown_path(t) for t in dict.fromkeys(tried)]
    return UrdfNotFoundError(shown_path(source), searched, kind, hint)


PACKAGE_SCHEME = "package://"
"""A file in an installed Python package: ``package://gymnasium/envs/mujoco/assets/ant.xml``
(ROS's scheme, its package a Python one), as a scenario names a model a package ships."""


def _in_python_package(text: str, kind: str) -> Path:
    """The file a ``package://NAME/PATH`` names: PATH under the installed Python package NAME.

    Raises:
        UrdfNotFoundError: NAME is not installed (saying so), or has no file PATH.
    """
    name, _, rest = text[len(PACKAGE_SCHEME) :].partition("/")
    spec = importlib.util.find_spec(name) if name.isidentifier() else None
    if spec is None or not spec.submodule_search_locations:
        raise UrdfNotFoundError(
            text,
            ["the installed Python packages"],
            kind,
            f" (no Python package {name!r} is installed here; it ships this file)",
        )
    path = Path(next(iter(spec.submodule_search_locations))) / rest
    if not rest or not _is_file(path):
        raise UrdfNotFoundError(text, [str(path)], kind)
    return path


def locate(
    source: str | os.PathLike[str],
    *,
    near: Path | None = None,
    suffixes: Sequence[str] = ("",),
    kind: str = "URDF",
) -> tuple[Path, bool]:
    """Where the file ``source`` names is.

    ``source`` itself (from the working directory, ``~`` expanded); else, for a relative path,
    the path under ``near``, then under each folder of :func:`search_path` (the name, then with
    each of ``suffixes``).

    Args:
        source: A path or a name.
        near: A folder searched first for a relative path (a scenario's folder: the name
            alone).
        suffixes: What the search path's lookups add to the name, in order.
        kind: The file's kind in the message.

    Returns:
        The file, and whether it was ``source`` itself.

    Raises:
        UrdfNotFoundError: found nowhere (:func:`not_found`: every place searched, in order).
    """
    text = os.fspath(source)
    if text.startswith(PACKAGE_SCHEME):
        return _in_python_package(text, kind), False
    try:
        candidate = Path(text).expanduser()
    except (RuntimeError, ValueError):  # "~nosuchuser/..."
        candidate = Path(text)
    relative = not candidate.is_absolute() and len(text) <= NAME_MAX and "\0" not in text
    tried: list[str] = []
    folders: list[Path] = []
    if relative and near is not None:  # a scenario's folder first, as Scenario.resolve_urdf
        folders.append(near)
        if _is_file(near / candidate):
            return near / candidate, False
        tried.append(str((near / candidate).absolute()))
    if _is_file(candidate):
        return candidate, True
    tried.append(str(candidate.absolute()))
    folders.insert(0, Path.cwd())
    if relative:
        for folder in search_path():
            folders.append(folder)
            for ending in suffixes:
                path = folder / f"{candidate}{ending}"
                if _is_file(path):
                    return path, False
                tried.append(str(path.absolute()))
    raise not_found(text, tried, kind, folders, suffixes)


def resolve_source(source: str | os.PathLike[str], *, near: Path | None = None) -> UrdfSource:
    """Turn a path, a name on the search path, or URDF XML text into a :class:`UrdfSource`.

    Args:
        source: A path, a name (``"r2d2"`` or ``"r2d2.urdf"``), or text starting with ``<``.
        near: A folder searched for a relative path before the search path (a scenario's).

    Returns:
        The source: its text read as UTF-8 (other bytes kept as surrogate escapes), its file
        and folder.

    Raises:
        UrdfNotFoundError: neither a path, a name nor text, or found nowhere.
        UrdfParseError: the file cannot be read.
    """
    if isinstance(source, str) and source.lstrip("\ufeff \t\r\n").startswith("<"):
        return UrdfSource(source.lstrip("\ufeff"), None, Path.cwd(), "<urdf text>")
    if not isinstance(source, (str, os.PathLike)):
        raise UrdfNotFoundError(repr(source), ["a path, a name or URDF text was expected"])
    found, itself = locate(source, near=near, suffixes=("", ".urdf"))
    # the path as PyBullet would be given it: the caller's text, or the search folder's file
    as_given = os.path.expanduser(os.fspath(source)) if itself else str(found)
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
    """What :func:`resolve_mesh` takes for a file read from ``path``.

    Args:
        path: The file's path as written.

    Returns:
        Its folder part, up to and with its last separator (``""`` for a bare name).
    """
    text = os.fspath(path)
    cut = max(text.rfind("/"), text.rfind("\\"))
    return text[: cut + 1]


def resolve_mesh(uri: str, folder: str | Path) -> tuple[Path, list[str]]:
    """Resolve a mesh filename where PyBullet does (bullet3 ``UrdfFindMeshFile.h``, measured on
    PyBullet 3.2.7 with strace).

    ``file://`` is dropped, then ``package://`` or ``model://`` (the package's name stays:
    ``package://pkg/m.stl`` is looked for as ``pkg/m.stl``). The name is tried as written (from
    the working directory), then after every leading part of the URDF's path up to a separator,
    longest first (its own folder, then each folder above it that the path names: all of them
    for an absolute path, only those written for a relative one), then after ``./``, ``../``
    and ``../../`` (from the working directory). Each attempt is a prefix and the name joined
    as strings, so ``/meshes/m.stl`` is also found as ``meshes/m.stl`` beside the file.
    PyBullet's additional search path is not searched (it finds the URDF, whose path then gives
    the folders).

    Args:
        uri: The mesh's filename as written in the file.
        folder: The URDF's folder as PyBullet is given it (:func:`mesh_folder` of its path, a
            relative one included), or a folder as a Path (treated as absolute).

    Returns:
        The first regular file found (its real path) and the attempts made so far, each made
        absolute from the working directory; where none is found, the first attempt and every
        attempt.
    """
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
    """Why a mesh path that exists is not read.

    Raw PyBullet 3.2.7 waits forever on a FIFO, ends the process on a directory
    (std::bad_alloc) and reads a device such as /dev/zero as a link without a shape (measured):
    such a path is refused.

    Args:
        tried: The paths, as :func:`resolve_mesh` lists them.

    Returns:
        "PATH is a directory, not a regular file" (or a FIFO, a device...) for the first of
        ``tried`` that exists, when it is not a regular file (symbolic links followed); None
        when it is one or none exists.
    """
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
