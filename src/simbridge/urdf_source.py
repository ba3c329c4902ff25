"""Where a URDF comes from: a file, a name on the search path, or URDF text; and where its
meshes are.

A source is read as text (UTF-8) once; what PyBullet makes of that text (its line reader, its
lenient XML parser) is :mod:`simbridge.urdf_xml`'s part.
"""

from __future__ import annotations

import importlib.util
import os
import stat
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

from .exceptions import UrdfNotFoundError, UrdfParseError

__all__ = ["UrdfSource", "resolve_source", "resolve_mesh", "search_path", "not_a_regular_file"]


@dataclass(frozen=True)
class UrdfSource:
    """Where a URDF came from: its text, its file (None for text) and the folder that relative
    mesh paths resolve against. A file's bytes that are not UTF-8 are in ``text`` as
    surrogate escapes (``errors="surrogateescape"``) until the parser reads them."""

    text: str
    path: Path | None
    base_dir: Path
    display_name: str


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
    found = found.resolve()
    try:
        data = found.read_bytes()
    except OSError as exc:
        raise UrdfParseError(str(found), f"cannot read the file: {exc}") from exc
    # bytes that are not UTF-8 are kept (as surrogates) for the reader to judge: PyBullet's
    # parser takes them (a Latin-1 comment, say)
    text = data.decode("utf-8", errors="surrogateescape")
    return UrdfSource(text, found, found.parent, str(found))


def _mesh_candidates(uri: str, base_dir: Path) -> Iterator[str]:
    """Where :func:`resolve_mesh` looks, in order."""
    join = os.path.join
    folders = [str(base_dir), *map(str, base_dir.parents)]
    if uri.startswith("package://"):
        rest = uri[len("package://") :]
        package, _, sub = rest.partition("/")
        for ancestor in folders:
            if os.path.basename(ancestor) == package:
                yield join(ancestor, sub)
            yield join(ancestor, package, sub)
        yield join(folders[0], sub)
        yield join(folders[0], rest)
        return
    path = uri
    for prefix in ("file://", "model://"):
        if path.startswith(prefix):
            path = path[len(prefix) :]
    if os.path.isabs(path):
        yield path
        return
    cwd = os.getcwd()
    yield join(cwd, path)
    for folder in folders:
        yield join(folder, path)
    for up in (".", "..", join("..", "..")):
        yield join(cwd, up, path)


def resolve_mesh(uri: str, base_dir: Path) -> tuple[Path, list[Path]]:
    """Resolve a mesh filename as PyBullet does (bullet3 ``UrdfFindMeshFile.h``).

    ``file://`` and ``model://`` are dropped; a relative path is then tried as it stands (from
    the working directory), then in ``base_dir`` (the URDF's folder) and each of its ancestors,
    nearest first, then as ``./``, ``../`` and ``../../`` of it. ``package://NAME/rest`` is
    looked up in every ancestor of ``base_dir`` (a folder that is, or contains, NAME), then as
    ``rest`` and ``NAME/rest`` relative to ``base_dir``. Returns the first existing candidate
    and the candidates tried so far; when none exists, the one in ``base_dir`` (the first for
    ``package://`` and absolute paths) and every candidate, that one first.
    """
    tried: list[Path] = []
    for candidate in _mesh_candidates(uri, base_dir):
        tried.append(Path(candidate))
        if os.path.isfile(candidate):
            return Path(os.path.realpath(candidate)), tried
    path = uri.split("://", 1)[1] if uri.startswith(("file://", "model://")) else uri
    relative = not uri.startswith("package://") and not os.path.isabs(path)
    primary = base_dir / path if relative else tried[0]
    return primary, [primary, *(c for c in tried if c != primary)]


_KINDS = (
    (stat.S_ISDIR, "a directory"),
    (stat.S_ISFIFO, "a FIFO"),
    (stat.S_ISCHR, "a character device"),
    (stat.S_ISBLK, "a block device"),
    (stat.S_ISSOCK, "a socket"),
)


def not_a_regular_file(tried: list[Path]) -> str | None:
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
